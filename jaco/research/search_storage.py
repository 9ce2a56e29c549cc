"""Where a search's study lives (:func:`jaco.search` ``storage=``): Optuna's in-memory storage,
SQLite (a ``sqlite:///`` URL or a ``.db`` path) in write-ahead-log mode, Optuna's journal file (a
``journal:`` URL or a ``.journal`` path) or any other SQLAlchemy URL (PostgreSQL), opened so that
several workers share it (:func:`opened`); the lock that serialises claims on a journal file
(:func:`claim_lock`); and Optuna's log lines and warnings kept quiet (:func:`quiet`)."""

from __future__ import annotations

import gc
import time
import traceback
import warnings
from contextlib import contextmanager, suppress
from pathlib import Path
from typing import Any, NamedTuple

from .search_checks import SearchError


class StorageTarget(NamedTuple):
    """A checked ``storage=``: ``storage`` (an Optuna storage object, a URL, or ``"journal"``),
    ``path`` (the file to lock and check, or None) and ``text`` (for messages)."""

    storage: Any
    path: Path | None
    text: str


def storage_target(storage) -> StorageTarget:
    """What ``storage=`` names (None: in memory), before anything is opened."""
    import optuna

    if storage is None:
        return StorageTarget(optuna.storages.InMemoryStorage(), None, "memory")
    if isinstance(storage, optuna.storages.BaseStorage):
        return StorageTarget(storage, None, type(storage).__name__)
    if isinstance(storage, Path):
        storage = str(storage)
    if not isinstance(storage, str) or not storage.strip():
        raise SearchError(
            f"storage must be a URL (sqlite:///study.db), a .db or .journal path, or an Optuna storage, got {storage!r}"
        )
    if storage.startswith("journal:") or storage.endswith((".journal", ".log")):
        path = Path(storage.removeprefix("journal:"))
        return StorageTarget("journal", path, f"journal {path}")
    if storage.startswith("sqlite:///"):
        return StorageTarget(storage, Path(storage.removeprefix("sqlite:///")), storage)
    if "://" in storage:
        return StorageTarget(storage, None, storage.split("://")[0])
    return StorageTarget(f"sqlite:///{storage}", Path(storage), f"sqlite:///{storage}")


def check_storage_path(path: Path | None) -> None:
    if path is not None:
        from .store import check_store_path

        check_store_path(path, "storage")


@contextmanager
def opened(storage, path):
    """The storage object (no lock: several workers share a study, :class:`jaco.research.search_workers.Workers`)."""
    import optuna

    engine = None
    try:
        if storage == "journal":
            storage = journal_storage(path)
        elif isinstance(storage, str) and storage.startswith("sqlite:///"):
            storage = _created(lambda url=storage: sqlite_storage(url, path))
            engine = storage.engine
        elif isinstance(storage, str):  # any other SQLAlchemy URL (postgresql+psycopg://...)
            storage = _created(
                lambda url=storage: optuna.storages.RDBStorage(url, engine_kwargs={"pool_pre_ping": True})
            )
        yield storage
    finally:
        if engine is not None:
            engine.dispose()  # closes the connections: SQLite folds its write-ahead log back into the file
            _rollback_journal(path)


def _created(make, tries: int = 8):
    """``make()``, again after a moment when it fails the first times: workers that open a new
    database at the same moment race to create Optuna's tables (one wins; the others, a moment
    later, find them)."""
    import random

    for k in range(tries):
        try:
            return make()
        except Exception:  # noqa: BLE001 - a duplicate table or version row, a busy file: retried, then raised
            if k == tries - 1:
                raise
            time.sleep(0.2 + random.random() * 0.5)


def _rollback_journal(path) -> None:
    """Back to SQLite's default journal: readers after the search (``jaco.load_study``, Optuna's
    dashboard) then open the file without making ``-wal``/``-shm`` files beside it."""
    import sqlite3

    con = sqlite3.connect(str(path), timeout=2)
    try:
        con.execute("PRAGMA journal_mode=DELETE")
    except sqlite3.OperationalError:  # another reader holds the file (a dashboard): it stays in WAL mode
        pass
    finally:
        con.close()


def journal_storage(path):
    """Optuna's journal storage on the file ``path``, with Optuna's open-lock beside it."""
    import optuna

    j = optuna.storages.journal
    return optuna.storages.JournalStorage(j.JournalFileBackend(str(path), lock_obj=j.JournalFileOpenLock(str(path))))


def sqlite_storage(url: str, path):
    """Optuna's RDB storage on SQLite in write-ahead-log mode with ``synchronous=NORMAL``: a commit
    no longer waits for the disk (measured here: 128 trials asked and told in 6 s instead of 17 s),
    and a committed trial still survives a killed process (only a power cut or an OS crash could
    lose the last commits). Several workers share the file: every transaction begins IMMEDIATE
    (it takes the write lock at once, so two workers never both read a trial RUNNING and then
    both write it: the second waits, up to a 60 s busy timeout, and reads the first's write).
    SQLite keeps ``FILE-wal`` and ``FILE-shm`` beside the file while workers run (after a kill
    they hold committed trials: the next open folds them back); at the end the file returns to
    SQLite's default journal when no other worker has it open (:func:`opened`)."""
    import sqlite3

    import optuna
    from sqlalchemy import event

    def connect():
        con = sqlite3.connect(str(path), timeout=60, check_same_thread=False, isolation_level=None)
        con.execute("PRAGMA busy_timeout=60000")
        con.execute("PRAGMA journal_mode=WAL")
        con.execute("PRAGMA synchronous=NORMAL")
        return con

    storage = optuna.storages.RDBStorage(url, engine_kwargs={"creator": connect})
    event.listen(storage.engine, "begin", lambda conn: conn.exec_driver_sql("BEGIN IMMEDIATE"))
    return storage


def end_session(storage, stopped_by: BaseException | None = None) -> None:
    """Roll back and close this thread's database session of an RDB ``storage`` (SQLite,
    PostgreSQL; nothing for a journal file). An interrupt (Ctrl-C, the parent's SIGINT to a worker)
    that lands inside one of Optuna's storage calls can leave its transaction open: with SQLite it
    holds the file's write lock, and the heartbeat thread (and every other worker) would wait for
    it up to the 60 s busy timeout. Optuna opens a new session at the next call.

    ``stopped_by``: the exception that stopped the storage's user. An interrupt (not an error)
    also has the locals of its frames dropped: one inside SQLAlchemy's own execution of a call
    leaves the call's connection out of the session's reach, checked out of the pool or closed
    with the call's statement still in progress (SQLite keeps a closed connection's transaction
    and write lock until that statement is finalized), and only those frames hold it (measured:
    of about 300 interrupts at random moments of reads, 9 left the lock held for 60 s before,
    none now)."""
    scoped = getattr(getattr(storage, "_backend", storage), "scoped_session", None)
    if scoped is not None:
        with suppress(Exception):  # closing a broken connection failed: the stop goes on regardless
            scoped.remove()
    if stopped_by is not None and not isinstance(stopped_by, Exception):  # an interrupt, not an error
        stop: BaseException | None = stopped_by
        while stop is not None:
            traceback.clear_frames(stop.__traceback__)
            stop = stop.__context__
        gc.collect()  # (the connection, its cursor and their result may hold each other)


@contextmanager
def _no_lock():
    yield


def claim_lock(store, path):
    """What serialises the claims of a journal file (its appends are atomic, but a journal's
    state change is not a compare-and-set): Optuna's own open-lock beside it. SQLite's IMMEDIATE
    transactions and PostgreSQL's row locks make the claim atomic by themselves."""
    if store.__class__.__name__ != "JournalStorage" or path is None:
        return _no_lock
    from optuna.storages.journal import JournalFileOpenLock

    lock = JournalFileOpenLock(f"{path}.claim")

    @contextmanager
    def held():
        lock.acquire()
        try:
            yield
        finally:
            lock.release()

    return held


@contextmanager
def quiet():
    """Optuna's INFO lines ("Trial 3 finished ...") and experimental-feature warnings off."""
    import optuna

    level = optuna.logging.get_verbosity()
    optuna.logging.set_verbosity(optuna.logging.WARNING)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", optuna.exceptions.ExperimentalWarning)
            yield
    finally:
        optuna.logging.set_verbosity(level)
