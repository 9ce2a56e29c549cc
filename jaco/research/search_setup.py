"""A call of :func:`jaco.search` checked before anything compiles (:func:`prepare_search`: the
options by :mod:`.search_checks`, the queries' problems and step limits, the storage and the
worker), and what a study stores about its search (:func:`study_info`, checked again when a study
resumes: :func:`attach_info`). The search itself is :mod:`jaco.research.search`."""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from functools import cached_property
from typing import Any

import numpy as np

from .samplers import EVOSAX_PREFIX, check_sampler
from .search_checks import (
    Halving,
    SearchError,
    check_fidelity,
    check_objectives,
    check_penalties,
    positive_int,
    positive_seconds,
)
from .search_storage import StorageTarget, check_storage_path, storage_target
from .search_workers import Heartbeats, check_heartbeats
from .space import SIZES, Space, parse_space

FORMAT = "jaco-search"
FORMAT_VERSION = 1
ATTR = "jaco"  # the study's user attribute with everything jaco needs to rerun and resume it
STOPPED = "jaco_stopped"  # the study's user attribute: why the last search call stopped (None: it did not end)


# -- the whole call, checked ----------------------------------------------------------------------
@dataclass
class SearchSetup:
    """A call of :func:`jaco.search`, checked (:func:`prepare_search`): the arguments as the search
    uses them (``sampler``: the one given, a name or an Optuna sampler; ``sampler_name``: its
    checked name), the queries' problems and each planner's step limit."""

    space: Space
    objectives: tuple[str, ...]
    trials: int | None
    timeout: float | None
    batch: int
    seed: int
    halving: Halving | None
    sampler: Any
    sampler_name: str
    sampler_options: dict | None
    penalties: dict
    sizes: dict  # n_ants and n_iters, fixed in the space or given
    queries: Any  # jaco.research.queries.Queries
    steplimits: dict  # by planner
    seeds: np.ndarray
    connectivity: int
    budget: int
    storage: StorageTarget
    heartbeats: Heartbeats
    study_name: str
    devices: Any
    progress: bool | None

    @cached_property
    def optima(self) -> np.ndarray:
        """Each query's exact optimum in length units (cells × ``cell_size``)."""
        return np.array(
            [float(p.optimal) * g.cell_size for (g, _, _), p in zip(self.queries.queries, self.queries.problems)]
        )

    @cached_property
    def info(self) -> dict:
        """What the study stores about this search (:func:`study_info`)."""
        return study_info(self)


def prepare_search(
    grid,
    start,
    goal,
    space,
    *,
    planner,
    trials,
    timeout,
    batch,
    seeds,
    n_ants,
    n_iters,
    steplimit,
    connectivity,
    sampler,
    sampler_options,
    seed,
    objective,
    penalty,
    fidelity,
    storage,
    study_name,
    worker,
    heartbeat_interval,
    grace_period,
    memory_budget,
    devices,
    progress,
) -> SearchSetup:
    """The arguments of :func:`jaco.search` (the same names) checked, each mistake one line, in
    this order; the queries' problems built. Nothing compiles."""
    from ..engine.checks import check_seed, check_seeds
    from .sweep_setup import check_budget

    space = parse_space(space, planner)
    objectives = check_objectives(objective)
    trials, timeout = _trials_and_timeout(trials, timeout)
    batch, seed, halving = positive_int("batch", batch), check_seed(seed), check_fidelity(fidelity)
    sampler_name = check_sampler(sampler, space, len(objectives))
    penalties = check_penalties(penalty, objectives)
    if sampler_name == "grid":
        trials = _grid_trials(space, trials)
    if halving is not None:
        _check_halving(halving, space, objectives, sampler_name, n_iters)
    sizes = {k: space.fixed.get(k, v) for k, v in (("n_ants", n_ants), ("n_iters", n_iters))}
    queries, steplimits = _queries(grid, start, goal, space, sizes, steplimit, connectivity)
    seed_list, budget, target = check_seeds(seeds), check_budget(memory_budget), storage_target(storage)
    check_storage_path(target.path)
    beats = check_heartbeats(worker, heartbeat_interval, grace_period)
    return SearchSetup(
        space, objectives, trials, timeout, batch, seed, halving, sampler, sampler_name, sampler_options, penalties,
        sizes, queries, steplimits, seed_list, connectivity, budget, target, beats,
        _study_name(study_name, storage, space), devices, progress,
    )  # fmt: skip


def _trials_and_timeout(trials, timeout) -> tuple[int | None, float | None]:
    trials = None if trials is None else positive_int("trials", trials)
    timeout = None if timeout is None else positive_seconds("timeout", timeout)
    if trials is None and timeout is None:
        raise SearchError("trials=None runs until the timeout: give trials, timeout or both")
    return trials, timeout


def _grid_trials(space: Space, trials: int | None) -> int:
    """Sampler ``"grid"`` runs every combination once: at most the grid's size."""
    from .samplers import grid_of

    if trials is None:
        raise SearchError("sampler 'grid' sizes its grid from trials: give trials (a timeout may stop it sooner)")
    return min(trials, math.prod(len(v) for v in grid_of(space, trials).values()))


def _check_halving(halving: Halving, space: Space, objectives, sampler_name: str, n_iters) -> None:
    if "n_iters" in space.dims or "n_iters" in space.fixed:
        raise SearchError("with a fidelity schedule the iterations are the budget: leave n_iters out of the space")
    if len(objectives) > 1:
        raise SearchError("multi-fidelity ranks trials by one objective: give one objective, or no fidelity")
    if sampler_name.startswith(EVOSAX_PREFIX):
        raise SearchError("evosax strategies need every member of a generation evaluated: no fidelity with evosax")
    halving.rungs(n_iters if isinstance(n_iters, int) else 1)


def _queries(grid, start, goal, space: Space, sizes: dict, steplimit, connectivity) -> tuple[Any, dict]:
    """The queries' problems and each planner's step limit (its own default, backtracking ants
    getting twice the dying ants', or the one given), checked at the largest sizes searched."""
    from ..engine.checks import resolve_steplimit
    from ..engine.memory import check_run_memory
    from .queries import prepare_queries

    largest = {
        k: int(max(space.dims[k].choices) if hasattr(space.dims.get(k), "choices") else space.dims[k].high)
        if k in space.dims
        else sizes[k]
        for k in SIZES
    }
    queries, _ = prepare_queries(
        grid,
        start,
        goal,
        n_ants=largest["n_ants"],
        n_iters=largest["n_iters"],
        steplimit=steplimit,
        connectivity=connectivity,
    )
    steplimits = {
        name: resolve_steplimit(queries.grid, v, steplimit, n_ants=largest["n_ants"], n_iters=largest["n_iters"])
        for name, v in space.planners.items()
    }
    longest = max(steplimits.values())
    check_run_memory(
        queries.grid.n_cells,
        largest["n_ants"],
        largest["n_iters"],
        longest,
        runs=len(queries.queries),
        what="a search chunk",
    )
    return queries, steplimits


def _study_name(study_name, storage, space: Space) -> str:
    """The study's name (default ``"jaco"``); a stored study must name planners the registry finds again."""
    if study_name is not None and (not isinstance(study_name, str) or not study_name.strip()):
        raise SearchError(f"study_name must be a non-empty string, got {study_name!r}")
    if storage is not None:
        from .record_format import recordable_name

        for v in space.planners.values():
            recordable_name(v)  # a stored trial must name a planner the registry finds again
    return study_name or "jaco"


# -- what a study stores about its search ----------------------------------------------------------
def study_info(setup: SearchSetup) -> dict:
    """What a study stores about its search: enough to rerun any trial, and to check that a
    resumed study is the same search."""
    from .record_map import map_entry
    from .record_versions import versions

    space, queries, sizes = setup.space, setup.queries, setup.sizes
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
        "objectives": list(setup.objectives),
        "penalty": dict(setup.penalties),
        "queries": [
            {
                "map": where[map_entry(g)["sha256"]],
                "start": list(s),
                "goal": list(t),
                "optimal": float(optimal),
            }
            for (g, s, t), optimal in zip(queries.queries, setup.optima)
        ],
        "seeds": [int(s) for s in setup.seeds],
        "n_ants": sizes["n_ants"] if "n_ants" not in space.dims else None,
        "n_iters": sizes["n_iters"] if "n_iters" not in space.dims else None,
        "steplimit": {k: int(v) for k, v in setup.steplimits.items()},  # by planner
        "connectivity": int(setup.connectivity),
        "sampler": setup.sampler_name,
        "sampler_seed": int(setup.seed),
        "fidelity": None if setup.halving is None else setup.halving.describe(),
        "batch": int(setup.batch),
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


def attach_info(study, info: dict, where: str) -> None:
    """Store ``info`` with a new study, or check that an existing one is the same search."""
    old = study.user_attrs.get(ATTR)
    if old is None:
        if not study.trials:
            study.set_user_attr(ATTR, json.loads(json.dumps(info)))
            return
        # Read again: another worker that opened the study at the same time may have attached its
        # info (jaco does so before it asks for a trial) between the first read and the trials'.
        old = study.user_attrs.get(ATTR)
        if old is None:
            raise SearchError(
                f"study {study.study_name!r} in {where} was not made by jaco.search: use another study_name"
            )
    now = json.loads(json.dumps(info))
    differ = [k for k in SAME_SEARCH if old.get(k) != now.get(k)]
    if differ:
        raise SearchError(
            f"study {study.study_name!r} in {where} was made by another search (it differs in: {', '.join(differ)}); "
            "use another study_name to start a new one"
        )
