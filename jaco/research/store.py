"""The sweep store: finished chunks of :func:`jaco.sweep` in an SQLite file, so that a sweep that
was killed resumes where it stopped (``jaco.sweep(..., store="sweep.db")``).

Why SQLite: it is in Python's standard library (no new dependency), a transaction is atomic and
durable (a chunk is in the file completely or not at all, whatever kills the process, so nothing
half-written is ever read back), and one file holds any number of sweeps. Parquet (pyarrow) would
need a file per chunk, or rewriting the file per chunk, to stay safe against a kill.

Layout: table ``sweeps`` has one row per sweep, found by a fingerprint (sha256) of everything that
decides its results (planner, maps, queries, every configuration's values, seeds, sizes,
connectivity) and the call in readable JSON; table ``chunks`` one row per finished chunk: the
rows it ran and its result arrays (little-endian bytes, queries × rows). A sweep's rows do not
depend on the chunk they ran in, so a resumed sweep may cut its chunks differently.

Locking: a store is used by one process at a time. :class:`SweepStore` holds an exclusive
``flock`` on the file while a sweep runs (released by the kernel when the process dies, even by
SIGKILL); a second process gets a one-line :class:`~jaco.errors.JacoError` naming the lock.
"""

from __future__ import annotations

import contextlib
import errno
import fcntl
import hashlib
import json
import os
import sqlite3
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import JacoError
from ..outputs import as_path, check_output

SCHEMA_VERSION = 1
FIELDS = ("cost", "length", "best_iteration", "covered")  # the chunk program's outputs, in order
_DTYPES = {"cost": "<f4", "length": "<f4", "best_iteration": "<i4", "covered": "<i4"}


class StoreError(JacoError):
    """A sweep store that cannot be used: locked by another process, or not a jaco store."""


#: The open :func:`counting` ledgers.
_LEDGERS: list[dict] = []


@contextlib.contextmanager
def counting(ledger: dict | None = None):
    """While open, fills a ledger (``ledger``, or a new dict) ``{store path: {sweep fingerprint:
    runs stored}}`` of every sweep that used a store: the runs it found there, plus each chunk it
    appended once committed. What an interrupted ``jaco sweep --store`` reports as kept."""
    ledger = {} if ledger is None else ledger
    _LEDGERS.append(ledger)
    try:
        yield ledger
    finally:
        _LEDGERS.remove(ledger)


def _count(path: Path, key: str, runs: int, add: bool) -> None:
    for ledger in _LEDGERS:
        sweeps = ledger.setdefault(str(path), {})
        sweeps[key] = sweeps.get(key, 0) + runs if add else runs


def check_store_path(path: Any, what: str = "store") -> Path:
    """``path`` checked like every output (not a folder, its folder writable) before anything
    runs, and a database file (not standard output, a device or a FIFO); the file itself is
    created when the work starts."""
    from ..outputs import target

    path = check_output(path, what)
    if target(path, what).kind != "file":
        raise StoreError(f"{what} {str(path)!r}: a database is a file; not standard output, a device or a pipe")
    return path


def _sha(x: np.ndarray) -> str:
    return hashlib.sha256(np.ascontiguousarray(x).tobytes()).hexdigest()


class exclusive_lock:
    """An exclusive ``flock`` on ``path`` (created if missing) for as long as the object is open:
    a second process gets a one-line :class:`StoreError` naming the file. The kernel releases it
    when the process ends, however it ends, so a killed run never leaves a stale lock."""

    def __init__(self, path, what: str):
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self.fd: int | None = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o666)
        try:
            fcntl.flock(self.fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as e:
            os.close(self.fd)
            self.fd = None
            if e.errno in (errno.EWOULDBLOCK, errno.EAGAIN, errno.EACCES):
                raise StoreError(
                    f"{what} {str(self.path)!r} is in use by another process (an exclusive flock on the file): "
                    "wait for it to finish, or use another file"
                ) from None
            raise

    def close(self) -> None:
        if self.fd is not None:
            os.close(self.fd)  # releases the flock
            self.fd = None


class SweepStore:
    """An open, locked sweep store (a context manager): :meth:`fingerprint`, :meth:`load`,
    :meth:`append`."""

    def __init__(self, path):
        self.path = as_path(path, "store")
        self._lock = exclusive_lock(self.path, "store")
        try:
            self.db = sqlite3.connect(self.path, isolation_level=None, timeout=30)
            tables = {r[0] for r in self.db.execute("SELECT name FROM sqlite_master WHERE type='table'")}
            if tables and "jaco_sweep_store" not in tables:
                raise StoreError(
                    f"{str(self.path)!r} is an SQLite file but not a jaco sweep store (tables {sorted(tables)})"
                )
            self.db.executescript(
                """
                CREATE TABLE IF NOT EXISTS jaco_sweep_store (schema_version INTEGER NOT NULL);
                CREATE TABLE IF NOT EXISTS sweeps (fingerprint TEXT PRIMARY KEY, planner TEXT, call TEXT);
                CREATE TABLE IF NOT EXISTS chunks (fingerprint TEXT NOT NULL, rows BLOB NOT NULL, cost BLOB,
                    length BLOB, best_iteration BLOB, covered BLOB);
                CREATE INDEX IF NOT EXISTS chunks_by_sweep ON chunks (fingerprint);
                """
            )
            version = self.db.execute("SELECT schema_version FROM jaco_sweep_store").fetchone()
            if version is None:
                self.db.execute("INSERT INTO jaco_sweep_store VALUES (?)", (SCHEMA_VERSION,))
            elif version[0] > SCHEMA_VERSION:
                raise StoreError(
                    f"store {str(self.path)!r} has schema version {version[0]}, newer than this jaco reads"
                )
        except sqlite3.DatabaseError as e:
            self.close()
            raise StoreError(f"{str(self.path)!r} is not a jaco sweep store ({e})") from None
        except BaseException:
            self.close()
            raise

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
        return False

    def close(self) -> None:
        db = self.__dict__.pop("db", None)
        if db is not None:
            db.close()
        self._lock.close()

    def fingerprint(self, variant: Any, queries: Any, values: Any, config: Any, seeds: Any, **sizes: Any) -> str:
        """The sweep's key: sha256 of what decides its runs; registers the sweep on first use."""
        from .record_format import map_hash

        call = {
            "planner": variant.name,
            "queries": [[map_hash(g), list(s), list(t)] for g, s, t in queries],
            "parameters": {k: _sha(np.asarray(v, np.float64)) for k, v in sorted(values.items())},
            "config": _sha(np.asarray(config, np.int64)),
            "seeds": _sha(np.asarray(seeds, np.uint32)),
            **{k: int(v) for k, v in sorted(sizes.items())},
            "rows": int(len(seeds)),
        }
        key = hashlib.sha256(json.dumps(call, sort_keys=True).encode()).hexdigest()
        self.db.execute("INSERT OR IGNORE INTO sweeps VALUES (?, ?, ?)", (key, variant.name, json.dumps(call)))
        return key

    def load(self, key: str, outs: Any) -> np.ndarray:
        """Fill ``outs`` (arrays ``(queries, rows)`` in :data:`FIELDS` order) with the stored runs
        of sweep ``key``; returns which rows were stored."""
        n_q, n_rows = outs[0].shape
        done = np.zeros(n_rows, bool)
        for row in self.db.execute(f"SELECT rows, {', '.join(FIELDS)} FROM chunks WHERE fingerprint = ?", (key,)):
            rows = np.frombuffer(row[0], "<i8")
            if rows.size and (rows.min() < 0 or rows.max() >= n_rows):
                raise StoreError(f"store {str(self.path)!r}: a chunk of this sweep names rows outside it")
            for dst, name, blob in zip(outs, FIELDS, row[1:]):
                dst[:, rows] = np.frombuffer(blob, _DTYPES[name]).reshape(n_q, len(rows))
            done[rows] = True
        _count(self.path, key, int(done.sum()) * n_q, add=False)
        return done

    def append(self, key: str, rows: Any, outputs: Any) -> None:
        """Store one finished chunk (one transaction: all of it or nothing)."""
        blobs = [np.ascontiguousarray(o, _DTYPES[name]).tobytes() for name, o in zip(FIELDS, outputs)]
        self.db.execute("BEGIN IMMEDIATE")
        try:
            self.db.execute(
                "INSERT INTO chunks VALUES (?, ?, ?, ?, ?, ?)", (key, np.asarray(rows, "<i8").tobytes(), *blobs)
            )
            self.db.execute("COMMIT")
        except BaseException:
            self.db.execute("ROLLBACK")
            raise
        _count(self.path, key, int(np.size(outputs[0])), add=True)  # queries x rows

    def stored_runs(self, key: str) -> int:
        """How many rows of sweep ``key`` are stored."""
        return sum(len(r[0]) // 8 for r in self.db.execute("SELECT rows FROM chunks WHERE fingerprint = ?", (key,)))
