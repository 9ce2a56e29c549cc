"""The sweep store: finished chunks of :func:`jaco.sweep` in an SQLite file, so that a sweep that
was killed resumes where it stopped, and several processes (on one machine, or on hosts sharing a
filesystem) fill one sweep together (``jaco.sweep(..., store="sweep.db")`` in each).

Why SQLite: it is in Python's standard library (no new dependency), a transaction is atomic and
durable (a chunk is in the file completely or not at all, whatever kills the process, so nothing
half-written is ever read back), and one file holds any number of sweeps. Parquet (pyarrow) would
need a file per chunk, or rewriting the file per chunk, to stay safe against a kill.

Layout: table ``sweeps`` has one row per sweep, found by a fingerprint (sha256) of everything that
decides its results (planner, maps, queries, every configuration's values, seeds, sizes,
connectivity) and the call in readable JSON; table ``chunks`` one row per finished chunk: the
rows it ran, its result arrays (little-endian bytes, queries × rows), the worker that ran it and
the attempt (1, or more when it was taken over from a worker that stopped beating). A sweep's rows
do not depend on the chunk they ran in, so a resumed sweep may cut its chunks differently.

Sharing: a worker *claims* a unit of rows before it runs it (table ``claims``: the rows, the
worker's id ``host/pid/token`` and a heartbeat time that a background thread refreshes every
``heartbeat_interval`` seconds, also while a long chunk runs). A unit is claimable when some of its
rows are not stored and no live claim overlaps it; a claim is expired when its
heartbeat is older than ``grace_period`` seconds, or at once when its worker is a process of this
host that no longer exists. Claiming and committing are each one ``BEGIN IMMEDIATE`` transaction
(SQLite's write lock), so a unit is claimed, taken over and stored exactly once; a worker whose
claim was taken over while it ran discards its results. Heartbeats compare wall clocks: hosts must
agree on the time to well within the grace period (NTP).

Journal: SQLite's rollback journal (``journal_mode=DELETE``) on every filesystem, with a busy
timeout (a transaction waits for another worker's). WAL would let readers go on while a worker
writes, but a store sees a few short transactions per chunk, WAL's index lives in shared memory
that other hosts of a network filesystem cannot see (a store shared over NFS would be corrupted,
and telling a network filesystem apart fails for a worker on the file server's own disk), and it
leaves ``-wal`` and ``-shm`` files beside the store. Either journal needs working POSIX locks on
the file: on NFS, locking (``lockd``, or NFS v4), never a ``nolock`` mount.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import secrets
import socket
import sqlite3
import threading
import time
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from ..errors import JacoError
from ..outputs import as_path, check_output

SCHEMA_VERSION = 2  # 2: chunks name their worker and attempt; claims
FIELDS = ("cost", "length", "best_iteration", "covered")  # the chunk program's outputs, in order
_DTYPES = {"cost": "<f4", "length": "<f4", "best_iteration": "<i4", "covered": "<i4"}
BUSY_TIMEOUT = 120.0  # seconds a transaction waits for another worker's
#: SQLite's journal: the rollback journal, on every filesystem (the module's docstring says why).
JOURNAL_MODE = "delete"


class StoreError(JacoError):
    """A sweep store that cannot be used: not a jaco store, or written by a newer jaco."""


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


# -- workers and transactions ----------------------------------------------------------------
_OPEN_WORKERS: set[str] = set()  # the ids of this process's open stores
HOST = socket.gethostname()  # the host part of this process's worker ids


def worker_id() -> str:
    """A new worker's id: ``host/pid/token`` (the token tells two calls of one process apart)."""
    return f"{HOST}/{os.getpid()}/{secrets.token_hex(4)}"


def process_exists(pid: int) -> bool:
    """Whether process ``pid`` of this host exists (another user's counts)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # exists, another user's
        return True
    return True


def _gone(worker: str) -> bool:
    """Whether ``worker`` was a process of this host that no longer exists (its claims are dead)."""
    host, _, rest = worker.partition("/")
    pid = rest.partition("/")[0]
    if host != HOST or not pid.isdigit():
        return False
    if int(pid) == os.getpid():  # an earlier call of this process, ended
        return worker not in _OPEN_WORKERS
    return not process_exists(int(pid))


def _connect(path: Path) -> sqlite3.Connection:
    return sqlite3.connect(path, isolation_level=None, timeout=BUSY_TIMEOUT, check_same_thread=False)


@contextlib.contextmanager
def _transaction(db: sqlite3.Connection):
    """``BEGIN IMMEDIATE`` (the write lock, waiting up to the busy timeout) ... ``COMMIT``."""
    db.execute("BEGIN IMMEDIATE")
    try:
        yield db
    except BaseException:
        db.execute("ROLLBACK")
        raise
    db.execute("COMMIT")


# -- claims ------------------------------------------------------------------------------------
class Claim(NamedTuple):
    """A unit of rows ``lo:hi`` claimed by this worker: ``rows``, those not stored yet; ``attempt``
    1, or more when it was taken over from a worker whose claim expired; ``done``, the sweep's
    rows stored when it was claimed."""

    lo: int
    hi: int
    rows: np.ndarray
    attempt: int
    done: int


class Waiting(NamedTuple):
    """Nothing to claim now: ``held`` units are claimed live by ``workers``; ``done`` rows stored."""

    held: int
    workers: tuple
    done: int


_SCHEMA = (
    "CREATE TABLE IF NOT EXISTS jaco_sweep_store (schema_version INTEGER NOT NULL)",
    "CREATE TABLE IF NOT EXISTS sweeps (fingerprint TEXT PRIMARY KEY, planner TEXT, call TEXT)",
    "CREATE TABLE IF NOT EXISTS chunks (fingerprint TEXT NOT NULL, rows BLOB NOT NULL, cost BLOB, length BLOB, "
    "best_iteration BLOB, covered BLOB, worker TEXT, attempt INTEGER)",
    "CREATE INDEX IF NOT EXISTS chunks_by_sweep ON chunks (fingerprint)",
    "CREATE TABLE IF NOT EXISTS claims (fingerprint TEXT NOT NULL, lo INTEGER NOT NULL, hi INTEGER NOT NULL, "
    "worker TEXT NOT NULL, heartbeat REAL NOT NULL, attempt INTEGER NOT NULL, PRIMARY KEY (fingerprint, lo, hi))",
)


class SweepStore:
    """An open sweep store (a context manager), shareable by any number of processes:
    :meth:`fingerprint`, :meth:`load`, :meth:`claim`, :meth:`commit`, :meth:`heartbeat`."""

    def __init__(self, path, grace_period: float = 60.0):
        self.path = as_path(path, "store")
        self.grace_period = float(grace_period)
        self.worker = worker_id()
        self._seen: dict = {}  # fingerprint -> (last chunk rowid read, done rows)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        try:
            self.db = _connect(self.path)
            self._open()
        except sqlite3.DatabaseError as e:
            self.close()
            raise StoreError(f"{str(self.path)!r} is not a jaco sweep store ({e})") from None
        except BaseException:
            self.close()
            raise
        _OPEN_WORKERS.add(self.worker)

    def _open(self) -> None:
        tables = {r[0] for r in self.db.execute("SELECT name FROM sqlite_master WHERE type='table'")}
        if tables and "jaco_sweep_store" not in tables:
            raise StoreError(
                f"{str(self.path)!r} is an SQLite file but not a jaco sweep store (tables {sorted(tables)})"
            )
        self.db.execute(f"PRAGMA journal_mode={JOURNAL_MODE}")
        with _transaction(self.db):
            for statement in _SCHEMA:
                self.db.execute(statement)
            version = self.db.execute("SELECT schema_version FROM jaco_sweep_store").fetchone()
            if version is None:
                self.db.execute("INSERT INTO jaco_sweep_store VALUES (?)", (SCHEMA_VERSION,))
            elif version[0] > SCHEMA_VERSION:
                raise StoreError(
                    f"store {str(self.path)!r} has schema version {version[0]}, newer than this jaco reads"
                )
            elif version[0] < SCHEMA_VERSION:  # 1: chunks without worker and attempt
                for column in ("worker TEXT", "attempt INTEGER"):
                    self.db.execute(f"ALTER TABLE chunks ADD COLUMN {column}")
                self.db.execute("UPDATE jaco_sweep_store SET schema_version = ?", (SCHEMA_VERSION,))

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
        return False

    def close(self) -> None:
        """Release this worker's claims (the others take them at once) and close the file."""
        _OPEN_WORKERS.discard(self.worker)
        db = self.__dict__.pop("db", None)
        if db is not None:
            with contextlib.suppress(sqlite3.Error):
                db.execute("DELETE FROM claims WHERE worker = ?", (self.worker,))
            db.close()

    def fingerprint(self, planner: Any, queries: Any, values: Any, config: Any, seeds: Any, **sizes: Any) -> str:
        """The sweep's key: sha256 of what decides its runs; registers the sweep on first use."""
        from .record_format import map_hash

        call = {
            "planner": planner.name,
            "queries": [[map_hash(g), list(s), list(t)] for g, s, t in queries],
            "parameters": {k: _sha(np.asarray(v, np.float64)) for k, v in sorted(values.items())},
            "config": _sha(np.asarray(config, np.int64)),
            "seeds": _sha(np.asarray(seeds, np.uint32)),
            **{k: int(v) for k, v in sorted(sizes.items())},
            "rows": int(len(seeds)),
        }
        key = hashlib.sha256(json.dumps(call, sort_keys=True).encode()).hexdigest()
        self.db.execute("INSERT OR IGNORE INTO sweeps VALUES (?, ?, ?)", (key, planner.name, json.dumps(call)))
        return key

    def load(self, key: str, outs: Any) -> np.ndarray:
        """Fill ``outs`` (arrays ``(queries, rows)`` in :data:`FIELDS` order) with the stored runs
        of sweep ``key``; returns which rows were stored."""
        n_q, n_rows = outs[0].shape
        done = np.zeros(n_rows, bool)
        for row in self.db.execute(f"SELECT rows, {', '.join(FIELDS)} FROM chunks WHERE fingerprint = ?", (key,)):
            rows = self._rows(row[0], n_rows)
            for dst, name, blob in zip(outs, FIELDS, row[1:]):
                dst[:, rows] = np.frombuffer(blob, _DTYPES[name]).reshape(n_q, len(rows))
            done[rows] = True
        _count(self.path, key, int(done.sum()) * n_q, add=False)
        return done

    def _rows(self, blob: bytes, n_rows: int) -> np.ndarray:
        rows = np.frombuffer(blob, "<i8")
        if rows.size and (rows.min() < 0 or rows.max() >= n_rows):
            raise StoreError(f"store {str(self.path)!r}: a chunk of this sweep names rows outside it")
        return rows

    def _done(self, key: str, n_rows: int) -> np.ndarray:
        """The stored rows of sweep ``key`` (reading only the chunks added since the last call)."""
        last, done = self._seen.get(key, (0, np.zeros(n_rows, bool)))
        for rowid, blob in self.db.execute(
            "SELECT rowid, rows FROM chunks WHERE fingerprint = ? AND rowid > ? ORDER BY rowid", (key, last)
        ):
            done[self._rows(blob, n_rows)] = True
            last = rowid
        self._seen[key] = (last, done)
        return done

    def _expired(self, worker: str, beat: float, now: float) -> bool:
        return worker != self.worker and (now - beat > self.grace_period or _gone(worker))

    def claim(self, key: str, n_rows: int, unit: int) -> Claim | Waiting | None:
        """Claim the first unit (rows ``k·unit … (k+1)·unit − 1``) with rows not stored that no
        live claim overlaps; taking over an expired claim exactly once (one
        ``BEGIN IMMEDIATE`` transaction). None when every row is stored."""
        with _transaction(self.db):
            done = self._done(key, n_rows)
            now = time.time()
            claims = self.db.execute(
                "SELECT lo, hi, worker, heartbeat, attempt FROM claims WHERE fingerprint = ?", (key,)
            ).fetchall()
            live = [c for c in claims if not self._expired(c[2], c[3], now)]  # this worker's own too
            for lo in range(0, n_rows, unit):
                hi = min(n_rows, lo + unit)
                if done[lo:hi].all() or any(c[0] < hi and lo < c[1] for c in live):
                    continue
                attempt = self._take(key, lo, hi, [c for c in claims if c[0] < hi and lo < c[1]], now)
                return Claim(lo, hi, lo + np.flatnonzero(~done[lo:hi]), attempt, int(done.sum()))
            if done.all():
                return None
            others = [c for c in live if c[2] != self.worker]
            return Waiting(len(others), tuple(sorted({c[2] for c in others})), int(done.sum()))

    def _take(self, key: str, lo: int, hi: int, overlapping: list, now: float) -> int:
        """Claim ``lo:hi`` (inside the claim's transaction): an expired claim of the same rows is
        taken over (its attempt + 1), expired claims of other rows that overlap are dropped."""
        attempt = 1
        for c_lo, c_hi, worker, beat, c_attempt in overlapping:
            if (c_lo, c_hi) == (lo, hi):
                attempt = c_attempt + 1
            self.db.execute(
                "DELETE FROM claims WHERE fingerprint = ? AND lo = ? AND hi = ? AND worker = ? AND heartbeat = ?",
                (key, c_lo, c_hi, worker, beat),
            )
        self.db.execute("INSERT INTO claims VALUES (?, ?, ?, ?, ?, ?)", (key, lo, hi, self.worker, now, attempt))
        return attempt

    def commit(self, key: str, claim: Claim, outputs: Any) -> bool:
        """Store a claimed unit's results and end the claim (one transaction: all of it or
        nothing). False, storing nothing, when another worker took the claim over meanwhile."""
        blobs = [np.ascontiguousarray(o, _DTYPES[name]).tobytes() for name, o in zip(FIELDS, outputs)]
        with _transaction(self.db):
            held = self.db.execute(
                "SELECT worker FROM claims WHERE fingerprint = ? AND lo = ? AND hi = ?", (key, claim.lo, claim.hi)
            ).fetchone()
            if held is None or held[0] != self.worker:
                return False
            self.db.execute(
                "INSERT INTO chunks VALUES (?, ?, ?, ?, ?, ?, ?, ?)",
                (key, np.asarray(claim.rows, "<i8").tobytes(), *blobs, self.worker, claim.attempt),
            )
            self.db.execute("DELETE FROM claims WHERE fingerprint = ? AND lo = ? AND hi = ?", (key, claim.lo, claim.hi))
        _count(self.path, key, int(np.size(outputs[0])), add=True)  # queries x rows
        return True

    def heartbeat(self, interval: float) -> Heartbeat:
        """A context manager: while open, a thread refreshes this worker's claims every ``interval`` s."""
        return Heartbeat(self.path, self.worker, interval)

    def stored_runs(self, key: str) -> int:
        """How many rows of sweep ``key`` are stored."""
        return sum(len(r[0]) // 8 for r in self.db.execute("SELECT rows FROM chunks WHERE fingerprint = ?", (key,)))


class Heartbeat:
    """A daemon thread, with its own connection, that sets the heartbeat of ``worker``'s claims to
    now every ``interval`` seconds (also while the main thread waits inside a long chunk). A beat
    that finds the file busy is skipped; the next one comes ``interval`` later."""

    def __init__(self, path: Path, worker: str, interval: float):
        self.path, self.worker, self.interval = path, worker, interval
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="jaco-heartbeat", daemon=True)

    def __enter__(self):
        self._thread.start()
        return self

    def __exit__(self, *exc):
        self._stop.set()
        self._thread.join(timeout=5.0)
        return False

    def _run(self) -> None:
        db = sqlite3.connect(self.path, isolation_level=None, timeout=self.interval)
        try:
            while not self._stop.wait(self.interval):
                with contextlib.suppress(sqlite3.OperationalError):  # busy: the next beat
                    db.execute("UPDATE claims SET heartbeat = ? WHERE worker = ?", (time.time(), self.worker))
        finally:
            db.close()
