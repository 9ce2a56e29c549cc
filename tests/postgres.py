"""A real PostgreSQL server for tests (never a mock): :func:`postgres_server` starts one in a
temporary folder, as the unprivileged ``postgres`` user (the server refuses root), listening only on
127.0.0.1 on a free port with trust authentication, and stops and removes it at the end.

Use the session fixture ``postgres_url`` (import it into a test module) or the context manager.
Either skips, saying why, when the server binaries, the ``postgres`` user or psycopg are missing.
"""

from __future__ import annotations

import contextlib
import os
import pwd
import shutil
import socket
import subprocess
import tempfile
import time
from pathlib import Path

import pytest

#: Where Debian and Ubuntu put the server binaries (``JACO_PG_BIN`` overrides).
PG_BIN = os.environ.get("JACO_PG_BIN", "/usr/lib/postgresql/15/bin")
PG_USER = "postgres"


def missing() -> str | None:
    """Why no server can start here (None: it can)."""
    if not all((Path(PG_BIN) / b).is_file() for b in ("initdb", "pg_ctl", "postgres")):
        return f"no PostgreSQL server binaries in {PG_BIN} (set JACO_PG_BIN)"
    try:
        pwd.getpwnam(PG_USER)
    except KeyError:
        return f"no {PG_USER!r} user to run the PostgreSQL server as"
    try:
        import psycopg  # noqa: F401
    except ImportError:
        return "psycopg is not installed (pip install 'psycopg[binary]')"
    return None


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _as_postgres(*args: str, **kw) -> subprocess.CompletedProcess:
    user = None if os.geteuid() != 0 else PG_USER  # as root: the server's own user
    return subprocess.run(list(args), user=user, check=True, capture_output=True, text=True, **kw)


@contextlib.contextmanager
def postgres_server(database: str = "jaco"):
    """A running server; yields its SQLAlchemy URL (``postgresql+psycopg://...``) to ``database``."""
    why = missing()
    if why:
        pytest.skip(why)
    folder = Path(tempfile.mkdtemp(prefix="jaco-pg-"))
    data, port = folder / "data", _free_port()
    info = pwd.getpwnam(PG_USER)
    os.chmod(folder, 0o755)
    if os.geteuid() == 0:
        os.chown(folder, info.pw_uid, info.pw_gid)
    bin_ = Path(PG_BIN)
    try:
        _as_postgres(str(bin_ / "initdb"), "-D", str(data), "-U", PG_USER, "--auth=trust", "-E", "UTF8")
        options = f"-h 127.0.0.1 -p {port} -k {folder} -c fsync=off -c max_connections=100"
        _as_postgres(str(bin_ / "pg_ctl"), "-D", str(data), "-o", options, "-l", str(folder / "log"), "-w", "start")
        url = f"postgresql+psycopg://{PG_USER}@127.0.0.1:{port}/{database}"
        _create_database(port, database)
        yield url
    finally:
        if (data / "postmaster.pid").exists():
            with contextlib.suppress(subprocess.CalledProcessError):
                _as_postgres(str(bin_ / "pg_ctl"), "-D", str(data), "-m", "immediate", "stop")
        shutil.rmtree(folder, ignore_errors=True)


def _create_database(port: int, name: str) -> None:
    import psycopg

    deadline = time.time() + 30
    while True:
        try:
            with psycopg.connect(f"host=127.0.0.1 port={port} user={PG_USER} dbname=postgres", autocommit=True) as c:
                c.execute(f'CREATE DATABASE "{name}"')
                return
        except psycopg.OperationalError:
            if time.time() > deadline:
                raise
            time.sleep(0.2)


@pytest.fixture(scope="session")
def postgres_url():
    """The URL of a PostgreSQL server started once for the test session."""
    with postgres_server() as url:
        yield url
