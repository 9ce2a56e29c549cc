"""Hyperparameter sweeps (``jaco.sweep``): configurations × seeds × queries as one compiled program.

The program is ``vmap(vmap(run))``: the inner vmap goes over configurations × seeds (one flat
axis, the *configuration axis*), the outer over queries (start/goal pairs, or maps of one shape).
Every row of the table equals :func:`jaco.solve` with the same parameters and seed.

Scale (docs/cluster.md):

* **Designs** — ``params`` is a dict of axes (a full grid) or a :class:`jaco.research.designs.Design`
  (grid, random, Latin hypercube, explicit rows), validated against :data:`jaco.engine.params.SPECS`
  before anything compiles.
* **Chunking** — the configuration axis is cut into equal chunks so that one chunk fits in
  ``memory_budget`` bytes per device. The chunk size starts from :func:`bytes_per_run` (or from an
  earlier measurement of the same shapes), the chunk program is compiled ahead of time and its own
  XLA memory analysis (arguments + outputs + temporaries) is checked against the budget; if it does
  not fit, a smaller chunk is compiled. The last chunk is padded, so one executable serves all.
* **Sharding** — the configuration axis of a chunk is split over a 1-D :class:`jax.sharding.Mesh`
  of devices (``jax.shard_map``, inputs placed with ``NamedSharding``); each device runs its own
  slice with no communication, so results do not depend on the number of devices, bit for bit.
* **Processes and hosts** — after ``jax.distributed.initialize`` the mesh spans every process's
  devices; every process calls ``sweep`` with the same arguments, runs its slice, and gets the
  whole table (gathered with ``multihost_utils.process_allgather``; on CPU through XLA's gloo
  collectives, the default ``jax_cpu_collectives_implementation`` of the jax tested here, 0.10).
* **A shared store** — without ``jax.distributed``, independent processes calling the same sweep
  with one ``store`` claim its chunks (fixed units of ``chunk`` rows), beat while they run them,
  take over the chunks of a worker that stopped beating, and each return the whole table
  (:mod:`jaco.research.store`).

This module holds :func:`sweep` and :func:`plan_sweep`; the parts live beside it and every public
name they had here is still importable from here: the queries (:mod:`.queries`), the chunk program and
its ``Runner`` (:mod:`.chunks`), the set-up (:mod:`.sweep_setup`), the shared store's worker loop
(:mod:`.shared_sweep`) and the table (:mod:`.sweep_table`).
"""

from __future__ import annotations

import math
from typing import Any

import jax
import numpy as np
import pandas as pd

from .. import progress as _progress
from ..engine.checks import check_seeds
from ..engine.params import owners
from ..engine.planner import Planner
from ..errors import JacoError, ParamError, accepts_aliases, check_keywords
from ..planners.registry import get_planner
from .chunks import AXIS, Runner, bytes_per_run  # noqa: F401  (importable from here, as jaco.search and docs name them)
from .designs import Design, as_design
from .queries import Queries, prepare_queries  # noqa: F401
from .shared_sweep import GRACE_PERIOD, check_sharing, stored_sweep
from .sweep_setup import check_budget, config_table, set_up_sweep  # noqa: F401
from .sweep_table import RESULT_COLUMNS, summarize, tidy_table  # noqa: F401


@accepts_aliases
def plan_sweep(
    grid: Any,
    start: Any,
    goal: Any,
    planner: Any = "mmas",
    params: dict | Design | None = None,
    seeds: Any = 4,
    *,
    n_ants: int = 50,
    n_iters: int = 100,
    steplimit: int | None = None,
    connectivity: int = 8,
    memory_budget: int = 2 << 30,
    devices: Any = None,
    chunk: int | None = None,
) -> dict:
    """What :func:`sweep` with the same arguments would do, without running it: compiles the chunk
    program and returns its plan (``steplimit``, the one given or the planner's default;
    ``chunk``, ``chunks``, ``chunk_per_device``, ``devices``,
    ``bytes_per_chunk`` from XLA's memory analysis, ``bytes_per_config_estimate`` and
    ``_measured``, ``compiles``...). The compiled program is cached, so the sweep reuses it."""
    return set_up_sweep(
        grid,
        start,
        goal,
        planner,
        params,
        seeds,
        n_ants,
        n_iters,
        steplimit,
        connectivity,
        memory_budget,
        devices,
        chunk=chunk,
    ).info


#: With a store and no ``chunk``, a sweep runs in about this many chunks, so that a kill loses at
#: most about a tenth of the work.
STORE_CHUNKS = 10


@check_keywords
def sweep(
    grid: Any,
    start: Any,
    goal: Any,
    planner: Any = "mmas",
    params: dict | Design | None = None,
    seeds: Any = 4,
    *,
    n_ants: int = 50,
    n_iters: int = 100,
    steplimit: int | None = None,
    connectivity: int = 8,
    memory_budget: int = 2 << 30,
    progress: bool | None = None,
    devices: Any = None,
    store: Any = None,
    chunk: int | None = None,
    grace_period: float | None = None,
    heartbeat_interval: float | None = None,
) -> pd.DataFrame:
    """Run every configuration of ``params`` × ``seeds`` × queries; one row per run.

    ``params``: a dict ``name -> list of values`` (every combination, first name slowest), a
    :class:`jaco.research.designs.Design` (its rows as given: ``jaco.research.designs.random``, ``latin_hypercube``,
    ``grid``, ``table``, ``product``) or a DataFrame of rows. ``seeds`` is a count
    (``range(seeds)``) or a list of integer seeds. ``grid`` may be a list of grids of one shape and
    ``start``/``goal`` lists of pairs (one per query, or one for all).

    ``memory_budget``: bytes one chunk may take on each device (arguments, outputs and XLA's
    temporaries, from the compiled program's memory analysis); the configurations run in as few
    equal chunks as fit. ``chunk``: at most this many runs (configurations × seeds, each over
    every query) per chunk. ``devices``: None (all devices, all processes' after
    ``jax.distributed.initialize``; or the one chosen by ``jax.default_device``), an int (the
    first n) or a list; the configuration axis is sharded over them. ``progress``: a bar on stderr
    (process 0) that says "compiling…" while the chunk program compiles, then counts the chunks
    and ends with the elapsed time; None (default) shows it on a terminal or in a notebook, True
    always, False never (:mod:`jaco.progress`).

    ``store``: a file (SQLite, :mod:`jaco.research.store`) where every chunk is appended as soon
    as it finishes. The same call again with the same store skips the finished runs, so a sweep
    that was killed resumes where it stopped, and the final table equals an uninterrupted sweep
    bit for bit (every run depends only on its configuration, seed and query, never on its
    chunk). Without ``chunk``, a stored sweep runs in about :data:`STORE_CHUNKS` chunks. One
    store holds any number of sweeps, each found by a fingerprint of its arguments.

    Several processes (on one machine, or on hosts sharing the store's filesystem) calling the same
    sweep with the same store fill it together: each claims chunks that nobody has stored and no
    live worker holds, refreshes its claims every ``heartbeat_interval`` seconds (default a sixth
    of the grace period) from a background thread, and takes over the claims of a worker that
    stopped beating for ``grace_period`` seconds (default :data:`GRACE_PERIOD`; at once for a dead
    process of the same host). Every process returns the whole table, equal to a one-process sweep
    bit for bit; one that has nothing left to claim waits for the others' chunks.

    Returns a tidy DataFrame: ``planner`` (its name: every table names its planner, one planner
    too), ``map, start_row, start_col, goal_row, goal_col`` (when there are several queries),
    ``config`` (the configuration's row in the design), the planner's parameters, ``seed`` and the results
    ``success, length, cost, best_iteration, optimal, gap, coverage``. ``table.attrs["sweep"]``
    holds the plan (:func:`plan_sweep`).

    ``planner`` may also be a list of planners (names, compositions of :func:`jaco.compose`,
    ``Planner`` objects): a categorical axis. Each planner runs the same
    configurations × seeds × queries as its own compiled batch (a planner's structure is part of
    the program), every ``params`` axis must be a parameter of every planner, and the tables are
    stacked with a first column ``planner``; ``attrs["sweep"]`` maps each planner to its plan.
    """
    sizes: dict[str, Any] = dict(n_ants=n_ants, n_iters=n_iters, steplimit=steplimit, connectivity=connectivity)
    running: dict[str, Any] = dict(memory_budget=memory_budget, progress=progress, devices=devices, chunk=chunk)
    sharing: dict[str, Any] = dict(store=store, grace_period=grace_period, heartbeat_interval=heartbeat_interval)
    if isinstance(planner, (list, tuple)) and not isinstance(planner, Planner):  # a Planner is a tuple too
        return sweep_each_planner(
            planner, lambda v: sweep(grid, start, goal, v, params, seeds, **sizes, **running, **sharing), params
        )
    return _sweep_planner(grid, start, goal, planner, params, seeds, **sizes, **running, **sharing)


def _sweep_planner(
    grid, start, goal, planner, params, seeds, *, store, grace_period, heartbeat_interval, progress, **options
):
    """:func:`sweep` of one planner: the store's arguments checked, then :func:`_sweep` moving a
    progress bar (``options``: the rest of :func:`_sweep`'s arguments)."""
    name = get_planner(planner).name
    sharing = check_sharing(store, grace_period, heartbeat_interval)
    if store is not None:
        from .store import check_store_path

        store = check_store_path(store)
    bar = _progress.Bar(_progress.enabled(progress) and jax.process_index() == 0, f"sweep {name}", "run")
    try:
        return _sweep(bar, grid, start, goal, planner, params, seeds, store=store, sharing=sharing, **options)
    finally:
        bar.close()


def _sweep(
    bar,
    grid,
    start,
    goal,
    planner,
    params,
    seeds,
    n_ants,
    n_iters,
    steplimit,
    connectivity,
    memory_budget,
    devices,
    store=None,
    chunk=None,
    sharing=(GRACE_PERIOD, GRACE_PERIOD / 6),
):
    """The body of :func:`sweep` for one planner, moving ``bar`` (:class:`jaco.progress.Bar`)."""
    if store is not None and chunk is None:
        n_runs = len(as_design(params)) * len(check_seeds(seeds))
        chunk = max(1, math.ceil(n_runs / STORE_CHUNKS))
    st = set_up_sweep(
        grid,
        start,
        goal,
        planner,
        params,
        seeds,
        n_ants,
        n_iters,
        steplimit,
        connectivity,
        memory_budget,
        devices,
        on_compile=lambda: bar.status("compiling…"),
        chunk=chunk,
    )
    n_rows, n_q = len(st.config), len(st.problems)
    outs = [np.empty((n_q, n_rows), dt) for dt in (np.float32, np.float32, np.int32, np.int32)]
    if store is not None:
        return stored_sweep(bar, st, outs, store, chunk, *sharing)
    return _run_sweep(bar, st, outs, np.arange(n_rows))


def _run_sweep(bar, st, outs, todo) -> pd.DataFrame:
    """Run the rows ``todo`` of a set-up sweep into ``outs``."""
    n_q, n_rows = outs[0].shape
    bar.start(n_rows * n_q, f"sweep {st.planner.name}: {n_rows * n_q} runs")

    def finished(lo, hi, got):
        rows = todo[lo:hi]
        for dst, src in zip(outs, got):
            dst[:, rows] = src
        bar.update(hi * n_q)

    def running(lo, hi, done):  # runs done inside the chunk, by its finished iterations
        n_iters = st.runner.shape.n_iters
        bar.update(lo * n_q + (hi - lo) * n_q * min(int(done), n_iters) // n_iters)

    st.runner(
        {k: v[st.config[todo]] for k, v in st.values.items()}, st.seeds[todo], on_chunk=finished, on_iteration=running
    )
    table = tidy_table(st.planner, st.queries, st.problems, st.values, st.config, st.seeds, *outs)
    table.attrs["sweep"] = st.info
    return table


def sweep_each_planner(planners, run, params) -> pd.DataFrame:
    """One sweep per planner (each with its ``planner`` column), stacked; every planner and its
    parameter axes are checked before anything compiles."""
    planners = [get_planner(v) for v in planners]
    if not planners:
        raise JacoError("planner: an empty list of planners")
    names = [v.name for v in planners]
    if len(set(names)) != len(names):
        raise JacoError(f"planner: a planner is listed twice in {names}")
    axes = list(params) if isinstance(params, dict) else as_design(params).names
    for axis in axes:  # one that some planners lack: say which have it (no "did you mean")
        have = [v.name for v in planners if axis in v.params]
        if have and len(have) < len(planners):
            raise ParamError(
                f"{owners(axis, planners)}: a sweep over several planners takes only the parameters every one of "
                f"them has; sweep {' and '.join(have)} on {'its' if len(have) == 1 else 'their'} own, or search "
                "(jaco search, jaco.search), which sets a parameter only for the planners that have it"
            )
    for v in planners:
        config_table(v, params)
    tables = [run(v) for v in planners]  # each with its first column "planner"
    table = pd.concat(tables, ignore_index=True)
    table.attrs["sweep"] = {v.name: t.attrs["sweep"] for v, t in zip(planners, tables)}
    return table
