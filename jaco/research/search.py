"""Adaptive batched search (``jaco.search``): a sampler proposes a batch of trials, the batch runs
as one compiled call, the results go back to the sampler, and every trial is stored as its batch
finishes (docs/search.md).

>>> import jaco
>>> grid = jaco.maps.named("demo")
>>> study = jaco.search(grid, grid.meta["start"], grid.meta["goal"], {"beta": (1.0, 8.0), "rho": (0.05, 0.5)},
...                     trials=8, batch=4, seeds=2, n_ants=8, n_iters=10, sampler="random", progress=False)
>>> len(study.trials), sorted(study.best_params)
(8, ['beta', 'planner', 'rho'])

**Evaluation.** A generation's trials are grouped by planner and sizes; each group runs
trials × seeds × queries through one planner's compiled chunk program (:class:`jaco.research.sweeps.Runner`,
the one :func:`jaco.sweep` uses), so every run equals :func:`jaco.solve` with its parameters and
seed. Chunks hold a power of two of trials (at most ``batch``), so a study compiles at most
log2(batch) + 1 programs per planner and size, each once, and never recompiles per generation.
Every trial runs the same seeds (common random numbers).

**Objectives** (``objective``, one name or several): ``"gap"`` (default) the mean over runs of the
relative gap to the exact optimum; ``"length"`` the mean path length; ``"turns"`` the mean number of
heading changes of the best path; ``"success"`` the success rate (maximised); ``"budget"`` ants ×
iterations (with the sizes in the space: the cost of a configuration). A failed run counts as a
*penalty*, never NaN: by default the worst value a successful run could have — the length of a
path of ``steplimit`` diagonal steps, √2·steplimit, its gap, and ``steplimit`` turns (the largest
step limit of the planners searched) — so a failure is never better than a success; ``penalty=`` sets it (a number, or a dict by objective). With
several objectives the study's ``best_trials`` is the Pareto front.

**Multi-fidelity** (``fidelity=Halving(...)``): successive halving over the iteration budget
(Jamieson & Talwalkar 2016; Hyperband, Li et al. 2018, with ``hyperband=True``). A bracket asks
``batch`` trials, runs them all at the smallest budget, keeps the best 1/η, runs those at η times
the budget, and so on up to ``n_iters``; every rung is one batch. A promoted trial is *re-run* at
the larger budget, not continued: the planners' schedules depend on the total number of
iterations (IDACA's α, β and ρ schedules, IAACO's q0 and ρ, chaos ACO's perturbation), so the
first 25 iterations of a 100-iteration run are not a 25-iteration run, and a continued run could
not equal any run :func:`jaco.solve` gives. Re-running keeps every reported value reproducible by
``jaco solve`` (and costs at most 1/(η − 1) more work). Each rung's value is reported to Optuna as
an intermediate value (step = iterations); trials that are not promoted end PRUNED, the others
COMPLETE with their value at ``n_iters``.

**Durable.** With ``storage=`` the study lives in Optuna's storage — ``"sqlite:///study.db"``
(or a path ending in ``.db``: SQLite), ``"journal:path"`` or a path ending in ``.journal`` (Optuna's
journal file), any other SQLAlchemy URL, or a storage object. Every trial is written when it is
asked (RUNNING) and again when its batch finishes (COMPLETE or PRUNED, with its seeds, per-run
lengths and success and what reruns it). Killed at any moment, the same call again resumes: a
trial left RUNNING is marked FAIL and evaluated again, once, as a new trial with its stored
parameters (it never finished, so nothing is counted twice) and the search goes on until
``trials`` trials are finished (or its ``timeout`` passes: no new batch starts after it, the
running one is stored). ``optuna-dashboard sqlite:///study.db`` shows it.

**Workers.** Several processes (on one machine or several hosts) may search one study at once:
each asks its own batch, runs it and tells it, until ``trials`` trials are finished by all of them
together (at most one batch more per other worker). Each writes a heartbeat every
``heartbeat_interval`` seconds; a RUNNING trial whose worker's heartbeat is older than
``grace_period`` (or whose worker stopped, or was a process of this host that is gone) is claimed
by exactly one other worker through an atomic RUNNING → FAIL transition and evaluated again
(:class:`_Workers`). ``worker`` (an index per process) offsets the sampler's seed (docs/search.md).
"""

from __future__ import annotations

import math
import time
import warnings
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import numpy as np
import pandas as pd

from .. import progress as _progress
from ..errors import JacoError, accepts_aliases
from .samplers import EVOSAX_PREFIX, EvosaxProposer, check_sampler, optuna_sampler, require, suggest
from .space import SIZES, VARIANT, Space, parse_space

FORMAT = "jaco-search"
FORMAT_VERSION = 1
OBJECTIVES: dict[str, Literal["minimize", "maximize"]] = {
    "gap": "minimize",
    "length": "minimize",
    "turns": "minimize",
    "success": "maximize",
    "budget": "minimize",
}
PENALIZED = ("gap", "length", "turns")


def objective_column(name: str) -> str:
    """The column of :attr:`Study.trials` that holds objective ``name``: a penalised objective
    (``gap``, ``length``, ``turns``: the mean over runs, a failed run counted as its penalty) is
    ``gap_penalised_mean`` ..., so that it never reads as the ``gap_median`` and ``length_mean``
    beside it (over the successful runs only); ``success`` and ``budget`` keep their names."""
    return f"{name}_penalised_mean" if name in PENALIZED else name


class BestParams(dict):
    """:attr:`Study.best_params`: a dict with the key ``planner``; ``["variant"]`` (its former
    name) still reads it, with a DeprecationWarning."""

    def __missing__(self, key):
        if key == VARIANT and "planner" in self:
            warnings.warn(
                "best_params['variant'] is the former name of best_params['planner']", DeprecationWarning, stacklevel=2
            )
            return self["planner"]
        raise KeyError(key)


ATTR = "jaco"  # the study's user attribute with everything jaco needs to rerun and resume it
STOPPED = "jaco_stopped"  # the study's user attribute: why the last search call stopped (None: it did not end)
_clock = time.monotonic  # the timeout's clock (a module name, so tests can replace it)


class SearchError(JacoError):
    """A search that cannot run or resume (one line, before anything compiles)."""


@dataclass(frozen=True)
class Halving:
    """Successive halving over the iteration budget (see the module): rungs at
    ``n_iters / eta**k`` iterations down to ``min_iters`` (default ``n_iters / eta**2``, at least
    1); each rung keeps the best ``1/eta`` of the trials (at least one). ``hyperband``: the
    brackets cycle through the rungs they start at (Hyperband's brackets, each with ``batch``
    trials), the first starting at the smallest budget."""

    min_iters: int | None = None
    eta: int = 3
    hyperband: bool = False

    def rungs(self, n_iters: int) -> list[int]:
        if isinstance(self.eta, bool) or not isinstance(self.eta, (int, np.integer)) or self.eta < 2:
            raise SearchError(f"Halving: eta must be an integer >= 2, got {self.eta!r}")
        low = self.min_iters if self.min_iters is not None else max(1, n_iters // self.eta**2)
        if isinstance(low, bool) or not isinstance(low, (int, np.integer)) or not 1 <= low <= n_iters:
            raise SearchError(f"Halving: min_iters must be an integer in [1, n_iters = {n_iters}], got {low!r}")
        rungs = [int(n_iters)]
        while rungs[0] // self.eta >= low:
            rungs.insert(0, rungs[0] // self.eta)
        return rungs

    def brackets(self, n_iters: int) -> list[list[int]]:
        """The rungs of each bracket, cycled through in order."""
        rungs = self.rungs(n_iters)
        return [rungs[s:] for s in range(len(rungs) if self.hyperband else 1)]

    def describe(self) -> dict:
        return {"min_iters": self.min_iters, "eta": int(self.eta), "hyperband": bool(self.hyperband)}


def _fidelity(fidelity) -> Halving | None:
    if fidelity is None or isinstance(fidelity, Halving):
        return fidelity
    if fidelity in ("halving", "hyperband"):
        return Halving(hyperband=fidelity == "hyperband")
    raise SearchError(
        f"fidelity must be None, 'halving', 'hyperband' or a jaco.research.search.Halving, got {fidelity!r}"
    )


def _objectives(objective) -> tuple[str, ...]:
    names = (
        (objective,) if isinstance(objective, str) else tuple(objective) if isinstance(objective, (list, tuple)) else ()
    )
    if not names or not all(isinstance(n, str) for n in names):
        raise SearchError(f"objective must be a name or a list of names ({', '.join(OBJECTIVES)}), got {objective!r}")
    for n in names:
        if n not in OBJECTIVES:
            raise SearchError(f"unknown objective {n!r}; valid: {', '.join(OBJECTIVES)}")
    if len(set(names)) != len(names):
        raise SearchError(f"objective: {names} names one twice")
    return names


def _positive_int(name, v, limit=2**31 - 1) -> int:
    if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or not 1 <= v <= limit:
        raise SearchError(f"{name} must be a positive integer, got {v!r}")
    return int(v)


def _positive_seconds(name, v) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)) or not 0 < v < math.inf:
        raise SearchError(f"{name} must be a positive finite number of seconds, got {v!r}")
    return float(v)


def _penalties(penalty, objectives) -> dict:
    """User penalties by objective (None: the default bound, per query)."""
    out: dict[str, float | None] = {n: None for n in objectives if n in PENALIZED}
    if penalty is None:
        return out
    given = penalty if isinstance(penalty, dict) else {n: penalty for n in out}
    for n, v in given.items():
        if n not in out:
            raise SearchError(f"penalty for {n!r}: only {', '.join(out) or 'no objective'} of this search take one")
        try:
            x = float(v)
        except (TypeError, ValueError):
            raise SearchError(f"penalty for {n!r} must be a number, got {v!r}") from None
        if not (math.isfinite(x) and x >= 0):
            raise SearchError(f"penalty for {n!r} must be a finite number >= 0, got {v!r}")
        out[n] = x
    return out


# -- storage ------------------------------------------------------------------------------------
def _storage(storage):
    """``(optuna storage or URL, file to lock or None, description)``."""
    import optuna

    if storage is None:
        return optuna.storages.InMemoryStorage(), None, "memory"
    if isinstance(storage, optuna.storages.BaseStorage):
        return storage, None, type(storage).__name__
    if isinstance(storage, Path):
        storage = str(storage)
    if not isinstance(storage, str) or not storage.strip():
        raise SearchError(
            f"storage must be a URL (sqlite:///study.db), a .db or .journal path, or an Optuna storage, got {storage!r}"
        )
    if storage.startswith("journal:") or storage.endswith((".journal", ".log")):
        path = Path(storage.removeprefix("journal:"))
        return "journal", path, f"journal {path}"
    if storage.startswith("sqlite:///"):
        return storage, Path(storage.removeprefix("sqlite:///")), storage
    if "://" in storage:
        return storage, None, storage.split("://")[0]
    return f"sqlite:///{storage}", Path(storage), f"sqlite:///{storage}"


def _check_storage_path(path: Path | None) -> None:
    if path is not None:
        from .store import check_store_path

        check_store_path(path, "storage")


@contextmanager
def _opened(storage, path):
    """The storage object (no lock: several workers share a study, :class:`_Workers`)."""
    import optuna

    engine = None
    try:
        if storage == "journal":
            storage = _journal(path)
        elif isinstance(storage, str) and storage.startswith("sqlite:///"):
            storage = _created(lambda url=storage: _sqlite(url, path))
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


def _journal(path):
    import optuna

    j = optuna.storages.journal
    return optuna.storages.JournalStorage(j.JournalFileBackend(str(path), lock_obj=j.JournalFileOpenLock(str(path))))


def _sqlite(url: str, path):
    """Optuna's RDB storage on SQLite in write-ahead-log mode with ``synchronous=NORMAL``: a commit
    no longer waits for the disk (measured here: 128 trials asked and told in 6 s instead of 17 s),
    and a committed trial still survives a killed process (only a power cut or an OS crash could
    lose the last commits). Several workers share the file: every transaction begins IMMEDIATE
    (it takes the write lock at once, so two workers never both read a trial RUNNING and then
    both write it: the second waits, up to a 60 s busy timeout, and reads the first's write).
    SQLite keeps ``FILE-wal`` and ``FILE-shm`` beside the file while workers run (after a kill
    they hold committed trials: the next open folds them back); at the end the file returns to
    SQLite's default journal when no other worker has it open (:func:`_rollback_journal`)."""
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


# -- workers: heartbeats and the takeover of a dead worker's trials --------------------------------
BEAT = "jaco_worker:"  # the study's user attribute per worker: its last heartbeat (time.time(); 0: it stopped)


def _alive_pid(pid: int) -> bool:
    import os

    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # another user's process
        return True
    return True


class _Workers:
    """This worker's heartbeat (a thread writes the study attribute ``jaco_worker:ID`` every
    ``interval`` seconds; 0 when the worker stops) and the takeover of the trials of dead workers:
    a RUNNING trial is a dead worker's when its owner's heartbeat is older than ``grace`` (or 0,
    or the owner was a process of this host that no longer exists). :meth:`claim` fails such a
    trial through one atomic storage transition, so exactly one worker wins it."""

    def __init__(self, study, storage, claim_lock, interval: float, grace: float):
        import os
        import socket
        import threading
        import uuid

        self.study, self.storage, self.claim_lock = study, storage, claim_lock
        self.interval, self.grace = interval, grace
        self.host = socket.gethostname()
        self.id = f"{self.host}:{os.getpid()}:{uuid.uuid4().hex[:8]}"
        self.study_id = storage.get_study_id_from_name(study.study_name)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._beat_loop, name="jaco-heartbeat", daemon=True)

    def start(self) -> None:
        self._beat(time.time())
        self._thread.start()

    def stop(self) -> None:
        """No more heartbeats; a trial this worker leaves RUNNING is free for takeover at once."""
        self._stop.set()
        self._thread.join()
        try:
            self._beat(0.0)
        except Exception:  # noqa: BLE001 - the storage failed (what stopped the search?): its heartbeat ages out
            pass

    def _beat(self, when: float) -> None:
        self.storage.set_study_user_attr(self.study_id, BEAT + self.id, when)

    def _beat_loop(self) -> None:
        while not self._stop.wait(self.interval):
            try:
                self._beat(time.time())
            except Exception:  # noqa: BLE001 - a busy storage misses one beat; the grace period allows it
                pass

    def alive(self, owner: str | None, beats: dict) -> bool:
        """Whether worker ``owner`` (None: a trial of a jaco before workers) may still run its trials."""
        if owner == self.id:
            return True
        beat = beats.get(BEAT + owner) if owner else None
        if not beat:
            return False
        host, pid, _ = owner.rsplit(":", 2)  # type: ignore[union-attr]
        if host == self.host and not _alive_pid(int(pid)):
            return False
        return time.time() - float(beat) < self.grace

    def running(self, trials) -> tuple[list, list]:
        """RUNNING ``trials`` split into (live workers' trials, dead workers' trials); a trial asked
        but never given its parameters (its worker killed in between) is dead once older than the
        grace period."""
        beats = self.storage.get_study_user_attrs(self.study_id)
        live: list = []
        dead: list = []
        for t in trials:
            if "jaco_trial" in t.user_attrs:
                ok = self.alive(t.user_attrs["jaco_trial"].get("owner"), beats)
            else:
                started = t.datetime_start.timestamp() if t.datetime_start else 0.0
                ok = time.time() - started < self.grace
            (live if ok else dead).append(t)
        return live, dead

    def claim(self, frozen) -> bool:
        """Mark a dead worker's RUNNING trial FAIL; True for the one worker whose transition did it."""
        import optuna
        from optuna.trial import TrialState

        tid = self.storage.get_trial_id_from_study_id_trial_number(self.study_id, frozen.number)
        with self.claim_lock():
            try:
                if self.storage.get_trial(tid).state != TrialState.RUNNING:
                    return False
                return bool(self.storage.set_trial_state_values(tid, TrialState.FAIL))
            except (optuna.exceptions.UpdateFinishedTrialError, optuna.exceptions.StorageInternalError):
                return False  # another worker failed it first

    def replace(self, frozen):
        """A new RUNNING trial owned by this worker with ``frozen``'s parameters, attributes and
        intermediate values (``retry_of``: its number)."""
        from datetime import datetime

        from optuna.trial import FrozenTrial, Trial, TrialState

        attrs = dict(frozen.user_attrs)
        attrs["jaco_trial"] = {**attrs["jaco_trial"], "owner": self.id, "retry_of": frozen.number}
        template = FrozenTrial(
            number=-1,
            state=TrialState.RUNNING,
            value=None,
            datetime_start=datetime.now(),
            datetime_complete=None,
            params=frozen.params,
            distributions=frozen.distributions,
            user_attrs=attrs,
            system_attrs=frozen.system_attrs,
            intermediate_values=frozen.intermediate_values,
            trial_id=-1,
        )
        return Trial(self.study, self.storage.create_new_trial(self.study_id, template_trial=template))


@contextmanager
def _no_lock():
    yield


def _claim_lock(store, path):
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
def _quiet():
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


# -- evaluating trials --------------------------------------------------------------------------
class Job(dict):
    """One evaluation: ``trial`` (an Optuna Trial), ``planner``, ``values`` (every parameter),
    ``n_ants``, ``n_iters``; :meth:`Evaluator.__call__` adds ``runs`` and ``objective``."""


def _pow2(n: int) -> int:
    return 1 << max(0, int(n) - 1).bit_length()


class Evaluator:
    """Runs jobs in batches over the study's queries and seeds (see the module)."""

    def __init__(self, space: Space, queries, seeds, *, steplimit, objectives, penalties, batch, budget, devices):
        from jax.sharding import Mesh

        from .sweeps import AXIS, _devices

        self.space, self.queries, self.seeds = space, queries, np.asarray(seeds, np.uint32)
        self.steplimit, self.objectives, self.batch, self.budget = steplimit, objectives, batch, budget  # by planner
        self.paths = "turns" in objectives
        self.mesh = Mesh(np.array(_devices(devices)), (AXIS,))
        self.runners: dict = {}
        cell = np.array([g.cell_size for g, _, _ in queries.queries])
        self.optimal = np.array([float(p.optimal) for p in queries.problems]) * cell
        self.cell = cell
        longest = max(steplimit.values())  # one penalty for every planner: a failure is worse than any success
        worst = math.sqrt(2.0) * longest * cell  # a path of steplimit diagonal steps
        with np.errstate(divide="ignore", invalid="ignore"):
            default = {
                "length": worst,
                "turns": np.full(len(cell), float(longest)),
                "gap": np.where(
                    self.optimal > 0, (worst - self.optimal) / np.where(self.optimal > 0, self.optimal, 1), 0.0
                ),
            }
        self.penalty = {n: (default[n] if v is None else np.full(len(cell), v)) for n, v in penalties.items()}
        self.compiles = 0

    def _runner(self, planner, n_ants, n_iters, n_trials):
        from ..engine.shape import RunShape
        from .sweeps import Runner

        width = min(_pow2(n_trials), _pow2(self.batch)) * len(self.seeds)
        key = (planner, n_ants, n_iters, width)
        if key not in self.runners:

            def compiling():
                self.compiles += 1

            shape = RunShape(n_ants, n_iters, self.steplimit[planner])  # the queries' problems hold their moves
            self.runners[key] = Runner(
                self.space.planners[planner],
                self.queries,
                shape=shape,
                mesh=self.mesh,
                rows=width,
                budget=self.budget,
                on_compile=compiling,
                paths=self.paths,
            )
        return self.runners[key]

    def __call__(self, jobs: list[Job]) -> None:
        groups: dict = {}
        for job in jobs:
            groups.setdefault((job["planner"], job["n_ants"], job["n_iters"]), []).append(job)
        n_s = len(self.seeds)
        for (planner, n_ants, n_iters), group in groups.items():
            runner = self._runner(planner, n_ants, n_iters, len(group))
            names = list(group[0]["values"])
            values = {k: np.repeat([j["values"][k] for j in group], n_s) for k in names}  # trial-major, seeds inner
            outs = runner(values, np.tile(self.seeds, len(group)))
            for i, job in enumerate(group):
                part = [o[:, i * n_s : (i + 1) * n_s] for o in outs]
                job["runs"] = self._runs(part)
                job["objective"] = self.objective(job["runs"], n_ants, n_iters)

    def _runs(self, outs) -> dict:
        """Per-run results, arrays ``(queries, seeds)``."""
        cost, length, best_iter = outs[0], outs[1], outs[2]
        ok = np.isfinite(cost)
        L = np.where(ok, length.astype(np.float64) * self.cell[:, None], np.inf)
        opt = self.optimal[:, None]
        with np.errstate(invalid="ignore", divide="ignore"):
            gap = np.where(ok, np.where(opt > 0, (L - opt) / np.where(opt > 0, opt, 1), 0.0), np.inf)
        runs = {"success": ok, "length": L, "gap": gap, "best_iteration": best_iter.astype(np.int64)}
        if self.paths:
            runs["turns"] = self._turns(outs[4], ok)
        return runs

    def _turns(self, cells, ok) -> np.ndarray:
        from ..engine.result import path_cells
        from ..metrics import turns

        out = np.full(ok.shape, np.inf)
        for q, (g, s, _) in enumerate(self.queries.queries):
            for j in range(ok.shape[1]):
                if ok[q, j]:
                    out[q, j] = turns(path_cells(g, s, cells[q, j]))
        return out

    def objective(self, runs: Any, n_ants: int, n_iters: int) -> list[float]:
        """The trial's objective values, failures counted as their penalty."""
        out = []
        for name in self.objectives:
            if name == "success":
                out.append(float(np.mean(runs["success"])))
            elif name == "budget":
                out.append(float(n_ants * n_iters))
            else:
                v = np.where(runs["success"], runs[name], self.penalty[name][:, None])
                out.append(float(np.mean(v)))
        return out


def trial_info(frozen: Any) -> dict:
    """What jaco stored with a trial: ``planner``, ``params`` (every parameter of the planner),
    ``n_ants``, ``generation`` (and ``bracket``; ``member`` and ``z`` for evosax), ``runs`` (per-run
    results by iterations) and ``n_iters`` (of its last evaluation; None before one)."""
    a = dict(frozen.user_attrs.get("jaco_trial", {}))
    a["runs"] = frozen.user_attrs.get("jaco_runs", {})
    a["n_iters"] = max((int(k) for k in a["runs"]), default=None)
    return a


def _plain_runs(runs: dict) -> dict:
    """Per-run arrays as JSON lists (a failed run's length and gap as None)."""

    def conv(x):
        if isinstance(x, (bool, np.bool_)):
            return bool(x)
        if isinstance(x, (int, np.integer)):
            return int(x)
        x = float(x)
        return x if math.isfinite(x) else None

    return {k: [[conv(x) for x in row] for row in np.asarray(v).tolist()] for k, v in runs.items()}


# -- the search ---------------------------------------------------------------------------------
@accepts_aliases
def search(
    grid: Any,
    start: Any,
    goal: Any,
    space: dict | Space,
    *,
    planner: Any = None,
    trials: int | None = 128,
    timeout: float | None = None,
    batch: int = 32,
    seeds: Any = 4,
    n_ants: int = 50,
    n_iters: int = 100,
    steplimit: int | None = None,
    connectivity: int = 8,
    sampler: Any = "tpe",
    sampler_options: dict | None = None,
    seed: int = 0,
    objective: Any = "gap",
    penalty: Any = None,
    fidelity: Any = None,
    storage: Any = None,
    study_name: str | None = None,
    worker: int = 0,
    heartbeat_interval: float = 30.0,
    grace_period: float | None = None,
    memory_budget: int = 2 << 30,
    devices: Any = None,
    progress: bool | None = None,
) -> "Study":
    """Search ``space`` (planners, parameters, sizes: :mod:`jaco.research.space`) for the best
    configuration on the queries ``start`` → ``goal`` (one pair or lists, as in :func:`jaco.sweep`;
    the objective is over all queries and ``seeds``).

    ``trials`` finished trials in generations of ``batch`` (each one compiled call); ``timeout``:
    a wall-time budget in seconds, counted from this call (a resumed study gets it afresh): no new
    batch starts once it has passed, the running one finishes and is stored, and the first batch
    always runs (with a fidelity schedule the running bracket finishes). With both the search stops
    at whichever comes first (``trials`` counts the study's finished trials, earlier calls
    included); ``trials=None`` runs until the timeout. ``study.stopped`` says why it stopped.
    ``sampler``:
    ``"tpe"``, ``"cmaes"``, ``"random"``, ``"qmc"``, ``"grid"``, ``"gp"``, ``"nsga2"``, an
    ``"evosax:NAME"`` strategy or an Optuna sampler (:mod:`jaco.research.samplers`),
    ``sampler_options`` passed to an evosax strategy; ``seed`` seeds the sampler; ``objective``,
    ``penalty``, ``fidelity``, ``storage`` and ``study_name``: see the module. ``planner``: the
    planner when ``space`` has no ``"variant"`` (default ``"mmas"``). ``worker``: this process's
    index among the workers of the study (its sampler is seeded ``seed + worker``);
    ``heartbeat_interval`` and ``grace_period`` (default three intervals), in seconds: when another
    worker takes over this one's trials (see the module).

    Returns a :class:`Study`: ``best_params`` (ready for ``jaco.solve(grid, start, goal,
    **best_params)``), ``best_value``, ``trials`` (a DataFrame, one row per trial), ``history()``,
    ``runs()``, ``rerun(number)``. Everything is checked before anything compiles; a study that
    resumes must have been made by the same search (space, objective, queries, seeds, sizes,
    sampler, fidelity), else a one-line :class:`SearchError` names what differs.
    """
    from ..engine.checks import check_seed, check_seeds
    from .sweeps import check_budget, prepare_queries

    started = _clock()  # the timeout counts from the call
    require("optuna", "jaco.search")
    space = parse_space(space, planner)
    objectives = _objectives(objective)
    trials = None if trials is None else _positive_int("trials", trials)
    timeout = None if timeout is None else _positive_seconds("timeout", timeout)
    if trials is None and timeout is None:
        raise SearchError("trials=None runs until the timeout: give trials, timeout or both")
    batch = _positive_int("batch", batch)
    seed = check_seed(seed)
    halving = _fidelity(fidelity)
    sampler_name = check_sampler(sampler, space, len(objectives))
    penalties = _penalties(penalty, objectives)
    if sampler_name == "grid":  # every combination once
        from .samplers import grid_of

        if trials is None:
            raise SearchError("sampler 'grid' sizes its grid from trials: give trials (a timeout may stop it sooner)")
        trials = min(trials, math.prod(len(v) for v in grid_of(space, trials).values()))
    if halving is not None:
        if "n_iters" in space.dims or "n_iters" in space.fixed:
            raise SearchError("with a fidelity schedule the iterations are the budget: leave n_iters out of the space")
        if len(objectives) > 1:
            raise SearchError("multi-fidelity ranks trials by one objective: give one objective, or no fidelity")
        if sampler_name.startswith(EVOSAX_PREFIX):
            raise SearchError("evosax strategies need every member of a generation evaluated: no fidelity with evosax")
        halving.rungs(n_iters if isinstance(n_iters, int) else 1)
    sizes = {k: space.fixed.get(k, v) for k, v in (("n_ants", n_ants), ("n_iters", n_iters))}
    largest = {
        k: int(max(space.dims[k].choices) if hasattr(space.dims.get(k), "choices") else space.dims[k].high)
        if k in space.dims
        else sizes[k]
        for k in SIZES
    }
    from ..engine.checks import check_sizes, default_steplimit
    from ..engine.memory import check_run_memory

    queries, _ = prepare_queries(
        grid,
        start,
        goal,
        n_ants=largest["n_ants"],
        n_iters=largest["n_iters"],
        steplimit=steplimit,
        connectivity=connectivity,
    )
    # each planner's own default step limit (backtracking ants get twice the dying ants'), or the one given
    steplimits = {
        name: default_steplimit(queries.grid, v) if steplimit is None else steplimit
        for name, v in space.planners.items()
    }
    check_sizes(largest["n_ants"], largest["n_iters"], max(steplimits.values()))
    check_run_memory(
        queries.grid.n_cells,
        largest["n_ants"],
        largest["n_iters"],
        max(steplimits.values()),
        runs=len(queries.queries),
        what="a search chunk",
    )
    seed_list = check_seeds(seeds)
    budget = check_budget(memory_budget)
    storage_obj, path, storage_text = _storage(storage)
    _check_storage_path(path)
    beats = _heartbeats(worker, heartbeat_interval, grace_period)
    if study_name is not None and (not isinstance(study_name, str) or not study_name.strip()):
        raise SearchError(f"study_name must be a non-empty string, got {study_name!r}")
    if storage is not None:
        from .record_format import recordable_name

        for v in space.planners.values():
            recordable_name(v)  # a stored trial must name a planner the registry finds again
    info = _study_info(
        space,
        objectives,
        penalties,
        queries,
        seed_list,
        sizes,
        steplimits,
        connectivity,
        sampler_name,
        seed,
        halving,
        batch,
    )

    evaluator = Evaluator(
        space,
        queries,
        seed_list,
        steplimit=steplimits,
        objectives=objectives,
        penalties=penalties,
        batch=batch,
        budget=budget,
        devices=devices,
    )
    bar = _progress.Bar(_progress.enabled(progress), f"search {sampler_name}", "trial")
    t0 = time.perf_counter()
    with _quiet(), _opened(storage_obj, path) as store:
        import optuna

        proposer = None
        if sampler_name.startswith(EVOSAX_PREFIX):
            proposer = EvosaxProposer(sampler_name, space, seed=seed, batch=batch, options=sampler_options)
            optuna_s = EvosaxProposer.queue()
        elif isinstance(sampler, str):
            optuna_s = optuna_sampler(sampler_name, space, seed=seed + beats[0], batch=batch, trials=trials or 0)
        else:
            optuna_s = sampler
        try:
            study = optuna.create_study(
                storage=store,
                sampler=optuna_s,
                study_name=study_name or "jaco",
                directions=[OBJECTIVES[n] for n in objectives],
                load_if_exists=True,
            )
        except ValueError as e:  # e.g. an existing study with other directions
            raise SearchError(f"study {study_name or 'jaco'!r} in {storage_text}: {e}") from None
        _attach(study, info, storage_text)
        study.set_user_attr(STOPPED, None)  # until this call ends: a killed call leaves no stale reason
        deadline = None if timeout is None else started + timeout
        workers = _Workers(study, store, _claim_lock(store, path), *beats[1:])
        run = _Run(study, space, evaluator, info, halving, sizes, batch, bar, proposer, workers, deadline)
        bar.start(trials, f"search {sampler_name}")  # type: ignore[arg-type]  # None: no total
        try:
            run.until(trials)
        finally:
            bar.close()
        finished = f"{run._finished()} trials finished"
        study.set_user_attr(
            STOPPED, f"timeout after {timeout:g} s: {finished}" if run.timed_out else f"trials reached: {finished}"
        )
        timings = dict(run.timings, wall_s=time.perf_counter() - t0, compiles=evaluator.compiles)
    if (
        isinstance(storage_obj, str) and storage_obj != "journal"
    ):  # read back through plain connections (SQLite: no WAL)
        with _quiet():
            study = optuna.load_study(study_name=study.study_name, storage=storage_obj)
    return Study(study, timings=timings)


def _heartbeats(worker, interval, grace) -> tuple[int, float, float]:
    """``(worker, heartbeat_interval, grace_period)`` checked; the grace period defaults to three
    heartbeat intervals."""
    if isinstance(worker, bool) or not isinstance(worker, (int, np.integer)) or not 0 <= worker < 2**20:
        raise SearchError(f"worker must be an integer >= 0 (this worker's index), got {worker!r}")
    interval = _positive_seconds("heartbeat_interval", interval)
    grace = 3 * interval if grace is None else _positive_seconds("grace_period", grace)
    if grace <= interval:
        raise SearchError(f"grace_period ({grace:g} s) must be longer than heartbeat_interval ({interval:g} s)")
    return int(worker), interval, grace


def _study_info(
    space, objectives, penalties, queries, seeds, sizes, steplimit, connectivity, sampler, seed, halving, batch
) -> dict:
    """What a study stores about its search: enough to rerun any trial, and to check that a
    resumed study is the same search."""
    from .record_format import map_entry, versions

    maps: list[dict] = []
    where: dict[str, int] = {}
    for g, _, _ in queries.queries:
        entry = map_entry(g)
        if entry["sha256"] not in where:
            where[entry["sha256"]] = len(maps)
            maps.append(entry)
    return {
        "format": FORMAT,
        "format_version": FORMAT_VERSION,
        "space": space.describe(),
        "objectives": list(objectives),
        "penalty": {k: v for k, v in penalties.items()},
        "queries": [
            {
                "map": where[map_entry(g)["sha256"]],
                "start": list(s),
                "goal": list(t),
                "optimal": float(p.optimal) * g.cell_size,
            }
            for (g, s, t), p in zip(queries.queries, queries.problems)
        ],
        "seeds": [int(s) for s in seeds],
        "n_ants": sizes["n_ants"] if "n_ants" not in space.dims else None,
        "n_iters": sizes["n_iters"] if "n_iters" not in space.dims else None,
        "steplimit": {k: int(v) for k, v in steplimit.items()},  # by planner
        "connectivity": int(connectivity),
        "sampler": sampler,
        "sampler_seed": int(seed),
        "fidelity": None if halving is None else halving.describe(),
        "batch": int(batch),
        "maps": maps,
        "versions": versions(),
    }


#: What must be equal for a study to resume (the rest, e.g. versions and batch, may change).
SAME_SEARCH = (
    "space",
    "objectives",
    "penalty",
    "queries",
    "seeds",
    "n_ants",
    "n_iters",
    "steplimit",
    "connectivity",
    "sampler",
    "sampler_seed",
    "fidelity",
)


def _attach(study, info: dict, where: str) -> None:
    """Store ``info`` with a new study, or check that an existing one is the same search."""
    import json

    old = study.user_attrs.get(ATTR)
    if old is None:
        if study.trials:
            raise SearchError(
                f"study {study.study_name!r} in {where} was not made by jaco.search: use another study_name"
            )
        study.set_user_attr(ATTR, json.loads(json.dumps(info)))
        return
    now = json.loads(json.dumps(info))
    differ = [k for k in SAME_SEARCH if old.get(k) != now.get(k)]
    if differ:
        raise SearchError(
            f"study {study.study_name!r} in {where} was made by another search (it differs in: {', '.join(differ)}); "
            "use another study_name to start a new one"
        )


class _Run:
    """One call's progress through a study: finish stale trials, then generations or brackets."""

    def __init__(self, study, space, evaluator, info, halving, sizes, batch, bar, proposer, workers, deadline=None):
        self.study, self.space, self.evaluate, self.info = study, space, evaluator, info
        self.halving, self.sizes, self.batch, self.bar, self.proposer = halving, sizes, batch, bar, proposer
        self.workers, self.deadline, self.ran, self.timed_out = workers, deadline, False, False
        self.timings = {"sampler_s": 0.0, "evaluate_s": 0.0, "storage_s": 0.0, "generations": 0, "retried": 0}
        self.generation = 0

    # trials and their state
    def _trials(self, states=None):
        return self.study.get_trials(deepcopy=False, states=states)

    def _finished(self) -> int:
        from optuna.trial import TrialState

        return len(self._trials((TrialState.COMPLETE, TrialState.PRUNED)))

    def _out_of_time(self) -> bool:
        """The timeout has passed (checked before a new batch; this call's first batch always runs)."""
        self.timed_out = self.ran and self.deadline is not None and _clock() >= self.deadline
        return self.timed_out

    def _progress(self) -> None:
        done = self._finished()
        self.bar.update(min(done, self.bar.total or done))
        try:
            value = self.study.best_value if len(self.study.directions) == 1 else None
        except ValueError:  # no complete trial yet
            value = None
        if value is not None:
            name = self.info["objectives"][0]
            shown = objective_column(name)  # gap_penalised_mean, as the trials table names it
            self.bar.status(
                f"best {shown} {100 * value:.2f}%" if name in ("gap", "success") else f"best {shown} {value:.4g}"
            )

    def _job(self, trial, planner, params: dict, sizes: dict) -> Job:
        """A job: every parameter of the planner (``params`` over its defaults, checked)."""
        from ..engine.checks import resolve_params

        v = self.space.planners[planner]
        params = {k: x for k, x in params.items() if k in v.params}
        values = {k: float(np.asarray(x)) for k, x in resolve_params(v, params, where=f"planner {planner!r}").items()}
        return Job(
            trial=trial,
            planner=planner,
            values=values,
            own={k: values[k] for k in v.params},
            stored={},
            **{k: int(sizes[k]) for k in SIZES},
        )

    def _next_generation(self) -> int:
        """One more than the largest generation stored (workers' generations interleave)."""
        stored = [trial_info(t).get("generation") for t in self._trials()]
        return 1 + max([g for g in stored if g is not None], default=-1)

    def _ask(self, n: int, extra_attrs=None) -> list[Job]:
        t0 = time.perf_counter()
        jobs = []
        for i in range(n):
            trial = self.study.ask()
            try:
                jobs.append(self._described(trial, extra_attrs(i) if extra_attrs else {}))
            except BaseException:  # interrupted before its parameters were stored: never evaluated
                from optuna.trial import TrialState

                self.study.tell(trial, state=TrialState.FAIL)
                raise
        self.timings["sampler_s"] += time.perf_counter() - t0
        return jobs

    def _described(self, trial, extra: dict) -> Job:
        """The job of a trial just asked, its parameters stored with it (``jaco_trial``)."""
        planner, suggested = suggest(trial, self.space)
        job = self._job(trial, planner, {**self.space.fixed, **suggested}, {**self.sizes, **suggested})
        # one attribute, one storage write: what reruns the trial and places it in the search
        trial.set_user_attr(
            "jaco_trial",
            {
                "planner": planner,
                "params": job["own"],
                "n_ants": job["n_ants"],
                "generation": self.generation,
                "owner": self.workers.id,
                **extra,
            },
        )
        return job

    def _retry(self, frozen) -> Job:
        """A dead worker's trial (claimed: now FAIL) evaluated again as a new trial of this worker."""
        a = trial_info(frozen)
        sizes = {"n_ants": a["n_ants"], "n_iters": frozen.params.get("n_iters", self.sizes["n_iters"])}
        job = self._job(self.workers.replace(frozen), a["planner"], a["params"], sizes)
        job["stored"] = dict(a["runs"])
        self.timings["retried"] += 1
        return job

    def _evaluate(self, jobs, n_iters=None) -> None:
        if n_iters is not None:
            for j in jobs:
                j["n_iters"] = int(n_iters)
        t0 = time.perf_counter()
        self.evaluate(jobs)
        self.timings["evaluate_s"] += time.perf_counter() - t0
        self.ran = self.ran or bool(jobs)
        for j in jobs:
            j["stored"][str(j["n_iters"])] = _plain_runs(j["runs"])
            j["trial"].set_user_attr("jaco_runs", j["stored"])  # by iterations: a promoted trial has one per rung

    def _tell(self, jobs, state=None) -> None:
        from optuna.trial import TrialState

        t0 = time.perf_counter()
        for j in jobs:
            if state is TrialState.PRUNED:
                self.study.tell(j["trial"], state=TrialState.PRUNED)
            else:
                self.study.tell(j["trial"], j["objective"])
        self.timings["sampler_s"] += time.perf_counter() - t0

    # the loop
    def until(self, trials: int | None) -> None:
        """Generations (or brackets) until ``trials`` trials of the study are finished, by all its
        workers together; a dead worker's trials are taken over before every batch."""
        self.workers.start()
        try:
            self._takeover()
            self._progress()
            if self.proposer is not None:
                return self._evosax(trials)
            self._loop(trials)
        finally:
            self.workers.stop()

    def _counts(self) -> tuple[int, int]:
        """(finished trials, trials that live workers are evaluating) in the study; a trial still
        being asked (no parameters stored yet) is not counted: see docs/search.md for the bound."""
        from optuna.trial import TrialState

        trials = self._trials((TrialState.COMPLETE, TrialState.PRUNED, TrialState.RUNNING))
        live, _ = self.workers.running([t for t in trials if t.state == TrialState.RUNNING])
        done = sum(t.state != TrialState.RUNNING for t in trials)
        return done, sum("jaco_trial" in t.user_attrs for t in live)

    def _brackets_started(self) -> int:
        """Brackets in the study, all workers' (a bracket is one worker's: its owner and number)."""
        return len({(a.get("owner"), a["bracket"]) for a in map(trial_info, self._trials()) if "bracket" in a})

    def _loop(self, trials: int | None) -> None:
        while True:
            self._takeover()
            done, running = self._counts()
            if (trials is not None and done >= trials) or self._out_of_time():
                return
            n = self.batch if trials is None else min(self.batch, trials - done - running)
            if n <= 0:  # other workers run the last trials: wait, to take them over if they die
                if self.deadline is not None and _clock() >= self.deadline:
                    self.timed_out = True
                    return
                time.sleep(min(1.0, self.workers.interval))
                continue
            self.generation = self._next_generation()
            if self.halving is None:
                jobs = self._ask(n)
                self._evaluate(jobs)
                self._tell(jobs)
            else:
                brackets = self.halving.brackets(self.sizes["n_iters"])
                bracket = self._brackets_started()
                jobs = self._ask(n, lambda i, bracket=bracket: {"bracket": bracket})
                self._bracket(jobs, brackets[bracket % len(brackets)])
            self.timings["generations"] += 1
            self._progress()

    def _takeover(self) -> None:
        """Claim the trials of dead workers (each by exactly one worker: :meth:`_Workers.claim`)
        and evaluate them again as new trials; a trial asked but never given its parameters is
        only failed. An evosax study asks its failed members again when it replays."""
        from optuna.trial import TrialState

        t0 = time.perf_counter()
        _, dead = self.workers.running(self._trials((TrialState.RUNNING,)))
        won = [t for t in dead if self.workers.claim(t) and "jaco_trial" in t.user_attrs]
        self.timings["storage_s"] += time.perf_counter() - t0
        if not won or self.proposer is not None:
            return
        if self.halving is None:
            jobs = [self._retry(t) for t in won]
            self._evaluate(jobs)
            self._tell(jobs)
            return
        brackets = self.halving.brackets(self.sizes["n_iters"])
        by_bracket: dict = {}
        for t in won:
            a = trial_info(t)
            by_bracket.setdefault((a["bracket"], a.get("owner") or ""), []).append(t)
        finished = (TrialState.COMPLETE, TrialState.PRUNED)
        for b, owner in sorted(by_bracket):
            done = [
                t
                for t in self._trials(finished)
                if (trial_info(t).get("bracket"), trial_info(t).get("owner") or "") == (b, owner)
            ]
            jobs = [self._job_of(t) for t in done] + [self._retry(t) for t in by_bracket[b, owner]]
            self._bracket(jobs, brackets[b % len(brackets)], resumed=True)

    def _job_of(self, frozen) -> Job:
        """A finished trial of a resumed bracket (its stored rungs are used, never evaluated again)."""
        from optuna.trial import Trial

        a = trial_info(frozen)
        sizes = {"n_ants": a["n_ants"], "n_iters": frozen.params.get("n_iters", self.sizes["n_iters"])}
        tid = self.workers.storage.get_trial_id_from_study_id_trial_number(self.workers.study_id, frozen.number)
        job = self._job(Trial(self.study, tid), a["planner"], a["params"], sizes)
        job["stored"] = dict(a["runs"])
        return job

    def _bracket(self, jobs, rungs, resumed=False) -> None:
        """Successive halving of ``jobs`` over ``rungs`` (iterations); values already stored for a
        rung (a resumed bracket) are used, not evaluated again."""
        from optuna.trial import TrialState

        sign = 1.0 if self.study.directions[0].name == "MINIMIZE" else -1.0
        alive = list(jobs)
        for k, budget in enumerate(rungs):
            numbers = {j["trial"].number for j in alive}
            stored = {t.number: t for t in self._trials() if t.number in numbers}
            todo = [j for j in alive if budget not in stored[j["trial"].number].intermediate_values]
            self._evaluate(todo, budget)
            for j in todo:
                j["trial"].report(j["objective"][0], budget)
            for j in alive:
                if j not in todo:
                    j["objective"] = [stored[j["trial"].number].intermediate_values[budget]]
            if k == len(rungs) - 1:
                self._tell([j for j in alive if stored[j["trial"].number].state == TrialState.RUNNING])
                return
            ranked = sorted(alive, key=lambda j: (sign * j["objective"][0], j["trial"].number))
            keep = max(1, len(alive) // self.halving.eta)
            dropped = [j for j in ranked[keep:] if stored[j["trial"].number].state == TrialState.RUNNING]
            self._tell(dropped, TrialState.PRUNED)
            alive = ranked[:keep]

    def _evosax(self, trials: int | None) -> None:
        """Generations of an evosax strategy, replaying the finished ones of a resumed study."""
        from optuna.trial import TrialState

        sign = 1.0 if self.study.directions[0].name == "MINIMIZE" else -1.0
        by_gen: dict = {}
        for t in self._trials((TrialState.COMPLETE, TrialState.RUNNING)):
            a = trial_info(t)
            if "member" in a:
                by_gen.setdefault(a["generation"], {})[a["member"]] = t
        generation = 0
        while trials is None or generation * self.batch < trials:
            self.generation = generation
            z = self.proposer.ask(generation)
            members = by_gen.get(generation, {})
            fitness = np.full(len(z), np.nan, np.float32)
            jobs: list = []
            for m, t in sorted(members.items()):
                if not (0 <= m < len(z) and np.array_equal(np.asarray(trial_info(t)["z"], np.float32), z[m])):
                    raise SearchError(
                        f"study {self.study.study_name!r}: generation {generation} does not replay its "
                        "stored proposals (another strategy, batch or seed?)"
                    )
                if t.state == TrialState.COMPLETE:
                    fitness[m] = sign * t.values[0]
                else:  # a dead worker's members were failed (and are asked again): this one runs
                    raise SearchError(
                        f"study {self.study.study_name!r}: generation {generation} is being evaluated by another "
                        "worker; an evosax strategy runs one worker per study"
                    )
            missing = [m for m in range(len(z)) if m not in members]
            if (missing or jobs) and self._out_of_time():  # a stored generation replays at no cost
                break
            proposals = self.proposer.values(z)
            self.study.sampler.pending = [proposals[m] for m in missing]
            new = self._ask(
                len(missing),
                lambda i, missing=missing, z=z: {"member": missing[i], "z": [float(x) for x in z[missing[i]]]},
            )
            jobs += [Job(j, member=m) for j, m in zip(new, missing)]
            self._evaluate(jobs)
            self._tell(jobs)
            for j in jobs:
                fitness[j["member"]] = sign * j["objective"][0]
            self.proposer.tell(generation, z, fitness)
            generation += 1
            self._progress()
            self.timings["generations"] += 1


# -- the result ---------------------------------------------------------------------------------
class Study:
    """A search's trials and what was found; ``study`` is the Optuna study (``optuna.Study``,
    for Optuna's own plots and tools). Made by :func:`jaco.search` or :func:`load_study`."""

    def __init__(self, study, timings: dict | None = None):
        self.study = study
        self.info = study.user_attrs.get(ATTR)
        if self.info is None or self.info.get("format") != FORMAT:
            raise SearchError(f"study {study.study_name!r} was not made by jaco.search")
        self.timings = dict(timings or {})
        #: why the last search call stopped: ``"trials reached: 128 trials finished"`` or ``"timeout after 60 s: 192
        #: trials finished"``; None when it did not end (killed, interrupted or still running).
        self.stopped: str | None = study.user_attrs.get(STOPPED)

    def __repr__(self) -> str:
        return (
            f"Study({self.study.study_name!r}: {len(self.study.trials)} trials, sampler {self.info['sampler']}, "
            f"objectives {', '.join(self.info['objectives'])})"
        )

    @property
    def objectives(self) -> list[str]:
        return list(self.info["objectives"])

    def _params(self, frozen) -> dict:
        """A trial's planner (key ``planner``), its searched values and the fixed values of the
        space that apply (the stored trial keeps the planner under Optuna's parameter ``variant``)."""
        a = trial_info(frozen)
        used = set(a["params"]) | set(SIZES)
        fixed = {k: v for k, v in self.info["space"].items() if isinstance(v, (int, float)) and k in used}
        return BestParams(
            {"planner": a["planner"], **fixed, **{k: v for k, v in frozen.params.items() if k != VARIANT}}
        )

    @property
    def best_trial(self) -> Any:
        """The best finished trial (one objective), an ``optuna.trial.FrozenTrial``."""
        if len(self.objectives) > 1:
            raise SearchError("a study with several objectives has a Pareto front: use best_trials")
        return self.study.best_trial

    @property
    def best_params(self) -> dict:
        """The best trial's planner (key ``planner``), searched and fixed parameters and searched
        sizes: ``jaco.solve(grid, start, goal, **study.best_params)`` runs it (``jaco.solve`` also
        takes the former key, ``variant``, and ``best_params["variant"]`` still reads the planner)."""
        return self._params(self.best_trial)

    @property
    def best_value(self) -> float:
        return float(self.best_trial.value)

    @property
    def best_trials(self) -> pd.DataFrame:
        """The Pareto front (several objectives; one objective: the best trial), as rows of
        :attr:`trials`."""
        numbers = [t.number for t in self.study.best_trials]
        table = self.trials
        return table[table["number"].isin(numbers)].reset_index(drop=True)

    @property
    def trials(self) -> pd.DataFrame:
        """One row per trial: ``number, state, generation, planner``, the searched parameters, the
        objective value(s) (a column per objective, :func:`objective_column`: ``gap_penalised_mean``
        for ``gap``, the mean over runs with the penalty counted for failed runs),
        ``success_rate``, ``gap_median`` and ``length_mean`` over the successful runs only,
        ``n_ants, n_iters`` (of its last evaluation), ``runs``, ``iterations`` (ant-iterations
        spent on it, all rungs), ``start_s`` and ``end_s`` (seconds since the study's first trial
        started)."""
        frozen = self.study.get_trials(deepcopy=False)
        starts = [t.datetime_start for t in frozen if t.datetime_start is not None]
        t0 = min(starts) if starts else None
        rows = []
        for t in frozen:
            a = trial_info(t)
            row = {
                "number": t.number,
                "state": t.state.name,
                "generation": a.get("generation"),
                "planner": a.get("planner"),
            }
            row.update({k: v for k, v in t.params.items() if k != VARIANT})
            values = (
                t.values
                if t.values is not None
                else ([t.intermediate_values[max(t.intermediate_values)]] if t.intermediate_values else [math.nan])
            )
            for name, v in zip(self.objectives, values):
                row[objective_column(name)] = v
            runs = a["runs"]
            last = runs.get(str(a.get("n_iters"))) if runs else None
            if last is not None:
                ok = np.asarray(last["success"], bool)
                gaps = np.asarray([[x if x is not None else np.nan for x in r] for r in last["gap"]], float)
                lengths = np.asarray([[x if x is not None else np.nan for x in r] for r in last["length"]], float)
                row["success_rate"] = float(ok.mean())
                row["gap_median"] = float(np.median(gaps[ok])) if ok.any() else math.nan
                row["length_mean"] = float(np.mean(lengths[ok])) if ok.any() else math.nan
                row["runs"] = int(ok.size)
                row["iterations"] = int(a.get("n_ants", 0)) * ok.size * sum(int(k) for k in runs)
            row["n_ants"], row["n_iters"] = a.get("n_ants"), a.get("n_iters")
            row["start_s"] = (t.datetime_start - t0).total_seconds() if t.datetime_start and t0 else math.nan
            row["end_s"] = (t.datetime_complete - t0).total_seconds() if t.datetime_complete and t0 else math.nan
            rows.append(row)
        return pd.DataFrame(rows)

    def history(self) -> pd.DataFrame:
        """The anytime curve (one objective): finished trials in the order they finished, with the
        ``value``, the ``best`` so far (never worse than before), ``iterations`` spent so far and
        ``end_s``."""
        if len(self.objectives) > 1:
            raise SearchError("history() follows one objective; this study has several")
        table = self.trials
        table = table[table["state"].isin(["COMPLETE", "PRUNED"])].sort_values(["end_s", "number"], kind="stable")
        name = self.objectives[0]
        sign = 1.0 if OBJECTIVES[name] == "minimize" else -1.0
        complete = table["state"].eq("COMPLETE")
        column = objective_column(name)
        best = (sign * table[column].where(complete)).cummin().ffill() * sign  # a pruned trial keeps the best
        out = pd.DataFrame(
            {
                "number": table["number"].to_numpy(),
                "value": table[column].to_numpy(),
                "best": best.to_numpy(),
                "iterations": table["iterations"].cumsum().to_numpy(),
                "end_s": table["end_s"].to_numpy(),
                "state": table["state"].to_numpy(),
            }
        )
        return out.reset_index(drop=True)

    def runs(self, number: int | None = None) -> pd.DataFrame:
        """Every stored run (of one trial, or of all), one row per (trial, iterations, query,
        seed): ``success, length, gap, best_iteration`` (and ``turns``)."""
        rows = []
        for t in self.study.get_trials(deepcopy=False):
            if number is not None and t.number != number:
                continue
            for n_iters, runs in trial_info(t)["runs"].items():
                for q, query in enumerate(self.info["queries"]):
                    for j, s in enumerate(self.info["seeds"]):
                        row = {
                            "number": t.number,
                            "planner": trial_info(t)["planner"],
                            "n_iters": int(n_iters),
                            "query": q,
                            "start": tuple(query["start"]),
                            "goal": tuple(query["goal"]),
                            "seed": s,
                        }
                        for k, v in runs.items():
                            x = v[q][j]
                            row[k] = math.inf if x is None else x
                        rows.append(row)
        return pd.DataFrame(rows)

    def record(self, number: int) -> "TrialRecord":
        """What reruns trial ``number`` (:class:`TrialRecord`)."""
        matches = [t for t in self.study.get_trials(deepcopy=False) if t.number == number]
        if not matches:
            raise SearchError(f"study {self.study.study_name!r} has no trial {number}")
        t = matches[0]
        if not trial_info(t)["runs"]:
            raise SearchError(f"trial {number} of study {self.study.study_name!r} has no stored runs ({t.state.name})")
        return TrialRecord(self.info, t)

    def rerun(self, number: int) -> Any:
        """Rerun trial ``number`` at every budget it was evaluated at and compare each run's
        success, length and best iteration bit for bit (a :class:`jaco.research.records.Rerun`)."""
        return self.record(number).rerun()


class TrialRecord:
    """A stored trial as a record: its planner, parameters, sizes, seeds and queries (maps
    embedded in the study), and its per-run results to compare a rerun with."""

    def __init__(self, info: dict, frozen: Any):
        self.info, self.trial = info, frozen

    def rerun(self) -> Any:
        from .designs import table
        from .record_format import grid_from_entry, version_warnings
        from .records import Rerun
        from .sweeps import sweep

        info, a = self.info, trial_info(self.trial)
        built = [grid_from_entry(e, f"study {self.trial.number}") for e in info["maps"]]
        notes = version_warnings(info.get("versions", {}), 2) + [n for _, ns in built for n in ns]
        grids = [built[q["map"]][0] for q in info["queries"]]
        starts = [tuple(q["start"]) for q in info["queries"]]
        goals = [tuple(q["goal"]) for q in info["queries"]]
        diffs, n_runs = [], 0
        for n_iters, runs in sorted(a["runs"].items(), key=lambda kv: int(kv[0])):
            new = sweep(
                grids,
                starts,
                goals,
                a["planner"],
                table({k: [v] for k, v in a["params"].items()}),
                info["seeds"],
                n_ants=int(a["n_ants"]),
                n_iters=int(n_iters),
                steplimit=info["steplimit"][a["planner"]],
                connectivity=info["connectivity"],
                progress=False,
            )
            n_q, n_s = len(info["queries"]), len(info["seeds"])
            got = {
                "success": new["success"].to_numpy().reshape(n_q, n_s),
                "length": new["length"].to_numpy().reshape(n_q, n_s),
                "best_iteration": new["best_iteration"].to_numpy().reshape(n_q, n_s),
            }
            for k, v in got.items():
                old = np.asarray([[math.inf if x is None else x for x in r] for r in runs[k]], np.float64)
                same = np.array_equal(old, np.asarray(v, np.float64))
                if not same:
                    diffs.append(
                        f"{n_iters} iterations, {k}: {int(np.sum(old != np.asarray(v, np.float64)))} of {old.size} runs differ"
                    )
            n_runs += n_q * n_s
        what = f"trial {self.trial.number}: {n_runs} runs of {a['planner']}"
        return Rerun(not diffs, diffs, notes, None, what)


def load_study(storage: Any, study_name: str | None = None) -> Study:
    """A stored study (no search runs): ``storage`` as in :func:`search`; ``study_name`` may be
    left out when the storage holds one study."""
    optuna = require("optuna", "jaco.load_study")
    storage_obj, path, text = _storage(storage)
    if path is not None and not path.is_file():
        raise SearchError(f"no study storage at {str(path)!r}")
    if storage_obj == "journal":
        storage_obj = _journal(path)
    with _quiet():
        try:
            names = [s.study_name for s in optuna.get_all_study_summaries(storage_obj, include_best_trial=False)]
        except Exception as e:  # noqa: BLE001 - any storage failure is the user's file
            raise SearchError(f"cannot read the studies of {text}: {' '.join(str(e).split())[:200]}") from None
        if study_name is None:
            if len(names) != 1:
                raise SearchError(f"{text} holds {len(names)} studies ({', '.join(names)}): name one with study_name")
            study_name = names[0]
        if study_name not in names:
            raise SearchError(f"{text} has no study {study_name!r}; it has: {', '.join(names) or 'none'}")
        return Study(optuna.load_study(study_name=study_name, storage=storage_obj))
