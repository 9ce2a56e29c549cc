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
(:mod:`jaco.research.search_workers`). ``worker`` (an index per process) offsets the sampler's seed
(docs/search.md).

**Modules.** This one holds :func:`search`, the ask / evaluate / tell loop; the call is checked by
:mod:`~jaco.research.search_setup` (the options by :mod:`~jaco.research.search_checks`), the study
lives in :mod:`~jaco.research.search_storage`, workers share it through
:mod:`~jaco.research.search_workers`, a batch is evaluated by :mod:`~jaco.research.search_evaluation`
and the result is read back by :mod:`~jaco.research.search_results`. Every name they define for
users is importable from here.
"""

from __future__ import annotations

import time
from dataclasses import replace
from typing import Any

import numpy as np

from .. import progress as _progress
from ..errors import accepts_aliases
from .record_json import plain_json
from .samplers import EVOSAX_PREFIX, EvosaxProposer, optuna_sampler, require, suggest
from .search_checks import (  # noqa: F401  (importable from here)
    OBJECTIVES,
    PENALIZED,
    Halving,
    SearchError,
)
from .search_evaluation import Evaluator, Job  # noqa: F401  (importable from here)
from .search_results import (  # noqa: F401  (importable from here)
    BestParams,
    Study,
    TrialRecord,
    load_study,
    objective_column,
    trial_info,
)
from .search_setup import (  # noqa: F401  (importable from here)
    ATTR,
    FORMAT,
    FORMAT_VERSION,
    SAME_SEARCH,
    STOPPED,
    SearchSetup,
    attach_info,
    prepare_search,
)
from .search_storage import claim_lock, end_session, opened, quiet
from .search_workers import BEAT, Workers  # noqa: F401  (importable from here)
from .space import Space

_clock = time.monotonic  # the timeout's clock (a module name, so tests can replace it)


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
) -> Study:
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
    call = dict(locals())  # the arguments, as given: prepare_search checks them all (and names them the same)
    started = _clock()  # the timeout counts from the call
    require("optuna", "jaco.search")
    setup = prepare_search(**call)
    evaluator = Evaluator(setup)
    bar = _progress.Bar(_progress.enabled(progress), f"search {setup.sampler_name}", "trial")
    t0 = time.perf_counter()
    with quiet(), opened(setup.storage.storage, setup.storage.path) as store:
        study, proposer = _open_study(store, setup)
        deadline = None if setup.timeout is None else started + setup.timeout
        beats = setup.heartbeats
        workers = Workers(study, store, claim_lock(store, setup.storage.path), beats.interval, beats.grace)
        run = _Run(study, setup, evaluator, bar, proposer, workers, deadline)
        run.until(setup.trials)
        timings = dict(run.timings, wall_s=time.perf_counter() - t0, compiles=evaluator.compiles)
    return Study(_read_back(study, setup), timings=timings)


def _open_study(store, setup: SearchSetup) -> tuple[Any, EvosaxProposer | None]:
    """The study (created, or loaded and checked to be the same search) with its sampler, and the
    evosax proposer that feeds that sampler (None for any other sampler)."""
    import optuna

    proposer = None
    if setup.sampler_name.startswith(EVOSAX_PREFIX):
        proposer = EvosaxProposer(
            setup.sampler_name, setup.space, seed=setup.seed, batch=setup.batch, options=setup.sampler_options
        )
        sampler = EvosaxProposer.queue()
    elif isinstance(setup.sampler, str):
        seed = setup.seed + setup.heartbeats.worker
        sampler = optuna_sampler(
            setup.sampler_name, setup.space, seed=seed, batch=setup.batch, trials=setup.trials or 0
        )
    else:
        sampler = setup.sampler
    try:
        study = optuna.create_study(
            storage=store,
            sampler=sampler,
            study_name=setup.study_name,
            directions=[OBJECTIVES[n] for n in setup.objectives],
            load_if_exists=True,
        )
    except ValueError as e:  # e.g. an existing study with other directions
        raise SearchError(f"study {setup.study_name!r} in {setup.storage.text}: {e}") from None
    attach_info(study, setup.info, setup.storage.text)
    study.set_user_attr(STOPPED, None)  # until this call ends: a killed call leaves no stale reason
    return study, proposer


def _read_back(study, setup: SearchSetup):
    """The study read back through plain connections (SQLite: no write-ahead log) where it is stored
    at a URL; else as it is."""
    import optuna

    storage = setup.storage.storage
    if not isinstance(storage, str) or storage == "journal":
        return study
    with quiet():
        return optuna.load_study(study_name=study.study_name, storage=storage)


class _Run:
    """One call's progress through a study: finish stale trials, then generations or brackets."""

    def __init__(self, study, setup: SearchSetup, evaluator, bar, proposer, workers, deadline=None):
        self.study, self.evaluate, self.bar, self.proposer, self.workers = study, evaluator, bar, proposer, workers
        self.space, self.info, self.halving, self.sizes = setup.space, setup.info, setup.halving, setup.sizes
        self.batch, self.timeout, self.deadline = setup.batch, setup.timeout, deadline
        self.ran, self.timed_out, self.generation = False, False, 0
        times = {"sampler_s": 0.0, "evaluate_s": 0.0, "storage_s": 0.0}
        self.timings = {**times, "generations": 0, "retried": 0, "lost": 0}  # lost: claimed by other workers

    def until(self, trials: int | None) -> None:
        """:meth:`_generations` until ``trials`` trials are finished (or the timeout passes), with the
        progress bar shown; then why it stopped, stored with the study."""
        self.bar.start(trials)  # type: ignore[arg-type]  # None: no total
        try:
            self._generations(trials)
        finally:
            self.bar.close()
        finished = f"{self._finished()} trials finished"
        stopped = f"timeout after {self.timeout:g} s: {finished}" if self.timed_out else f"trials reached: {finished}"
        self.study.set_user_attr(STOPPED, stopped)

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
            n_ants=int(sizes["n_ants"]),
            n_iters=int(sizes["n_iters"]),
        )

    def _next_generation(self) -> int:
        """One more than the largest generation stored (workers' generations interleave)."""
        stored = [trial_info(t).get("generation") for t in self._trials()]
        return 1 + max([g for g in stored if g is not None], default=-1)

    def _ask(self, n: int, extra_attrs=None) -> list[Job]:
        from optuna.exceptions import UpdateFinishedTrialError
        from optuna.trial import TrialState

        t0 = time.perf_counter()
        jobs: list[Job] = []
        lost = 0
        while len(jobs) < n:
            trial = self.study.ask()
            try:
                jobs.append(self._described(trial, extra_attrs(len(jobs)) if extra_attrs else {}))
            except UpdateFinishedTrialError:  # asked for longer than the grace period: claimed as a dead worker's
                self.timings["lost"] += 1
                lost += 1
                if lost == 3:
                    raise SearchError(
                        f"asking a trial took longer than grace_period ({self.workers.grace:g} s) three times, and "
                        "other workers failed the trials as abandoned: give a longer grace_period"
                    ) from None
            except BaseException:  # interrupted before its parameters were stored: never evaluated
                self.study.tell(trial, state=TrialState.FAIL, skip_if_finished=True)
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
                "params": job.own,
                "n_ants": job.n_ants,
                "generation": self.generation,
                "owner": self.workers.id,
                **extra,
            },
        )
        return job

    def _retry(self, frozen, trial) -> Job:
        """The job of a dead worker's trial (``frozen``, claimed: now FAIL) evaluated again as
        ``trial``, a new trial of this worker (:meth:`Workers.take_over`)."""
        a = trial_info(frozen)
        sizes = {"n_ants": a["n_ants"], "n_iters": frozen.params.get("n_iters", self.sizes["n_iters"])}
        job = self._job(trial, a["planner"], a["params"], sizes)
        job.stored = dict(a["runs"])
        self.timings["retried"] += 1
        return job

    def _evaluate(self, jobs, n_iters=None) -> list[Job]:
        """``jobs`` evaluated and their runs stored; returned: those still this worker's (:meth:`_kept`)."""
        if n_iters is not None:
            for j in jobs:
                j.n_iters = int(n_iters)
        t0 = time.perf_counter()
        self.evaluate(jobs)
        self.timings["evaluate_s"] += time.perf_counter() - t0
        self.ran = self.ran or bool(jobs)
        for j in jobs:
            j.stored[str(j.n_iters)] = plain_json(j.runs)  # a failed run's inf length and gap: None
        # by iterations: a promoted trial has one per rung
        return self._kept(jobs, lambda j: j.trial.set_user_attr("jaco_runs", j.stored))

    def _kept(self, jobs, write) -> list[Job]:
        """The ``jobs`` whose trial took ``write(job)``. A trial that another worker claimed while
        this one evaluated it (this worker looked dead: its heartbeats were late past the grace
        period) is dropped with its result; the claimer evaluates it again."""
        from optuna.exceptions import UpdateFinishedTrialError

        kept = []
        for j in jobs:
            try:
                write(j)
            except UpdateFinishedTrialError:
                self.timings["lost"] += 1
                continue
            kept.append(j)
        return kept

    def _tell(self, jobs, state=None) -> None:
        from optuna.trial import TrialState

        t0 = time.perf_counter()
        for j in jobs:
            # skip_if_finished: claimed by another worker since its runs were stored (a dropped result)
            if state is TrialState.PRUNED:
                self.study.tell(j.trial, state=TrialState.PRUNED, skip_if_finished=True)
            else:
                self.study.tell(j.trial, j.objective, skip_if_finished=True)
        self.timings["sampler_s"] += time.perf_counter() - t0

    # the loop
    def _generations(self, trials: int | None) -> None:
        """Generations (or brackets) until ``trials`` trials of the study are finished, by all its
        workers together; a dead worker's trials are taken over before every batch."""
        stopped_by = None
        try:
            self.workers.start()  # (inside: an interrupt after its first heartbeat still says it stopped)
            self._takeover()
            self._progress()
            if self.proposer is not None:
                return self._evosax(trials)
            self._loop(trials)
        except BaseException as e:
            stopped_by = e
            raise
        finally:
            end_session(self.workers.storage, stopped_by)  # an interrupt may have left a transaction open
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
                jobs = self._evaluate(self._ask(n))
                self._tell(jobs)
            else:
                brackets = self.halving.brackets(self.sizes["n_iters"])
                bracket = self._brackets_started()
                jobs = self._ask(n, lambda i, bracket=bracket: {"bracket": bracket})
                self._bracket(jobs, brackets[bracket % len(brackets)])
            self.timings["generations"] += 1
            self._progress()

    def _takeover(self) -> None:
        """Claim the trials of dead workers (each by exactly one worker: :meth:`Workers.claim`)
        and evaluate them again as new trials; a trial asked but never given its parameters is
        only failed. An evosax study asks its failed members again when it replays."""
        from optuna.trial import TrialState

        t0 = time.perf_counter()
        _, dead = self.workers.running(self._trials((TrialState.RUNNING,)))
        won = []  # (a dead worker's trial, claimed: now FAIL; the new trial that evaluates it again)
        for t in dead:
            trial = self.workers.take_over(t, retry="jaco_trial" in t.user_attrs and self.proposer is None)
            if trial is not None:
                won.append((t, trial))
        self.timings["storage_s"] += time.perf_counter() - t0
        if not won:
            return
        if self.halving is None:
            jobs = self._evaluate([self._retry(*w) for w in won])
            self._tell(jobs)
            return
        brackets = self.halving.brackets(self.sizes["n_iters"])
        by_bracket: dict = {}
        for w in won:
            a = trial_info(w[0])
            by_bracket.setdefault((a["bracket"], a.get("owner") or ""), []).append(w)
        finished = (TrialState.COMPLETE, TrialState.PRUNED)
        for b, owner in sorted(by_bracket):
            done = [
                t
                for t in self._trials(finished)
                if (trial_info(t).get("bracket"), trial_info(t).get("owner") or "") == (b, owner)
            ]
            jobs = [self._job_of(t) for t in done] + [self._retry(*w) for w in by_bracket[b, owner]]
            self._bracket(jobs, brackets[b % len(brackets)], resumed=True)

    def _job_of(self, frozen) -> Job:
        """A finished trial of a resumed bracket (its stored rungs are used, never evaluated again)."""
        from optuna.trial import Trial

        a = trial_info(frozen)
        sizes = {"n_ants": a["n_ants"], "n_iters": frozen.params.get("n_iters", self.sizes["n_iters"])}
        job = self._job(Trial(self.study, self.workers.trial_id(frozen.number)), a["planner"], a["params"], sizes)
        job.stored = dict(a["runs"])
        return job

    def _bracket(self, jobs, rungs, resumed=False) -> None:
        """Successive halving of ``jobs`` over ``rungs`` (iterations); values already stored for a
        rung (a resumed bracket) are used, not evaluated again."""
        from optuna.trial import TrialState

        assert self.halving is not None  # brackets run only with a fidelity schedule
        sign = 1.0 if self.study.directions[0].name == "MINIMIZE" else -1.0
        alive = list(jobs)
        for k, budget in enumerate(rungs):
            numbers = {j.trial.number for j in alive}
            stored = {t.number: t for t in self._trials() if t.number in numbers}
            todo = [j for j in alive if budget not in stored[j.trial.number].intermediate_values]
            kept = self._kept(self._evaluate(todo, budget), lambda j, b=budget: j.trial.report(j.objective[0], b))
            lost = {id(j) for j in todo} - {id(j) for j in kept}
            alive = [j for j in alive if id(j) not in lost]
            for j in alive:
                if j not in todo:
                    j.objective = [stored[j.trial.number].intermediate_values[budget]]
            if k == len(rungs) - 1:
                self._tell([j for j in alive if stored[j.trial.number].state == TrialState.RUNNING])
                return
            ranked = sorted(alive, key=lambda j: (sign * j.objective[0], j.trial.number))
            keep = max(1, len(alive) // self.halving.eta)
            dropped = [j for j in ranked[keep:] if stored[j.trial.number].state == TrialState.RUNNING]
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
            jobs += [replace(j, member=m) for j, m in zip(new, missing)]
            self._evaluate(jobs)  # one worker per evosax study: no other claims its trials
            self._tell(jobs)
            for j in jobs:
                fitness[j.member] = sign * j.objective[0]
            self.proposer.tell(generation, z, fitness)
            generation += 1
            self._progress()
            self.timings["generations"] += 1
