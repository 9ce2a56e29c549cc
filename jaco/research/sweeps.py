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
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import jax
import numpy as np
import pandas as pd
from jax.sharding import Mesh, NamedSharding, PartitionSpec

from .. import progress as _progress
from ..engine import native
from ..engine.cache import cached, is_cached
from ..engine.checks import check_relations, check_seeds, check_sizes, default_steplimit, params_from, resolve_params
from ..engine.memory import CONFIG_BYTES, bytes_per_run, check_memory, check_run_memory
from ..engine.params import check_values, owners
from ..engine.planner import Planner
from ..engine.problem import make_problem, stack
from ..engine.run import make_run
from ..engine.shape import RunShape
from ..errors import JacoError, ParamError, accepts_aliases, check_keywords
from ..grid import Grid
from ..metrics import gap
from ..planners.registry import get_planner
from .designs import Design, as_design

AXIS = "config"
RESULT_COLUMNS = ("seed", "success", "length", "cost", "best_iteration", "optimal", "gap", "coverage")


def _queries(grid, start, goal):
    """Normalise (grid | [grids], pair | [pairs], pair | [pairs]) to a list of triples."""

    def is_pair(x):
        try:
            return np.ndim(x) == 1 and len(x) == 2
        except (TypeError, ValueError):  # ragged nesting
            return False

    def as_list(x, what):
        try:
            xs = [] if isinstance(x, (str, bytes)) else list(x)
        except TypeError:
            xs = []
        if not xs:
            raise JacoError(f"{what} must be a (row, col) pair or a non-empty list of pairs, got {x!r}")
        return xs

    grids = [grid] if isinstance(grid, Grid) else list(grid) if isinstance(grid, (list, tuple)) else []
    if not grids or not all(isinstance(g, Grid) for g in grids):
        raise JacoError(
            f"grid must be a jaco.Grid or a non-empty list of Grids of one shape, got {type(grid).__name__}"
        )
    starts = [start] if is_pair(start) else as_list(start, "start")
    goals = [goal] if is_pair(goal) else as_list(goal, "goal")
    n = max(len(grids), len(starts), len(goals))
    for name, xs in (("grids", grids), ("starts", starts), ("goals", goals)):
        if len(xs) not in (1, n):
            raise JacoError(f"{name}: got {len(xs)}, expected 1 or {n} (one per query)")
    pick = lambda xs, i: xs[0] if len(xs) == 1 else xs[i]  # noqa: E731
    return [(pick(grids, i), pick(starts, i), pick(goals, i)) for i in range(n)]


# -- memory ---------------------------------------------------------------------------------
def _footprint(compiled) -> int | None:
    """Per-device bytes of a compiled program: arguments + outputs + XLA temporaries."""
    try:
        m = compiled.memory_analysis()
    except (NotImplementedError, RuntimeError, AttributeError):  # backends without the analysis
        return None
    if m is None:
        return None
    return int(m.argument_size_in_bytes + m.output_size_in_bytes + m.temp_size_in_bytes - m.alias_size_in_bytes)


# -- devices and the compiled chunk program -------------------------------------------------
def _devices(devices) -> list:
    """None: every device (all processes' after ``jax.distributed.initialize``), or the one set
    by ``jax.default_device``; an int n: the first n; or a list of devices."""
    if devices is None:
        chosen = jax.config.jax_default_device  # type: ignore[attr-defined]  # jax's Config makes its flags at runtime
        return [chosen] if isinstance(chosen, jax.Device) else list(jax.devices())
    if isinstance(devices, (int, np.integer)) and not isinstance(devices, bool):
        available = jax.devices()
        if not 1 <= devices <= len(available):
            raise JacoError(f"devices: asked for {devices}, there are {len(available)} ({available[0].platform})")
        return list(available[: int(devices)])
    devs = list(devices)
    if not devs or not all(isinstance(d, jax.Device) for d in devs):
        raise JacoError("devices must be None, a positive int or a non-empty list of jax devices")
    if len({d.id for d in devs}) != len(devs):
        raise JacoError("devices: a device is listed twice")
    return devs


_PER_CONFIG: dict = {}  # (walk, variant, shape, batch shapes) -> measured bytes per configuration and device


def _program(variant: Planner, shape: RunShape, mesh: Mesh, paths: bool = False):
    """The jitted chunk program (cached): ``(seeds, problems, params) -> (cost, length, best
    iteration, covered[, best cells])``, each ``(queries, configurations)``; ``paths`` adds the
    best ant's cells (for path metrics such as turns)."""
    key = ("sweep", variant, *shape.sizes.values(), tuple(d.id for d in mesh.devices.flat), paths)

    def build():
        # reports every iteration: a bar inside the chunk, and an interrupt ends the chunk at once
        run = make_run(variant, **shape.sizes, report="every")
        batched = jax.vmap(jax.vmap(run, in_axes=(0, None, 0)), in_axes=(None, 0, None))

        def chunk(seeds, problems, params):
            out = batched(jax.vmap(jax.random.key)(seeds), problems, params)
            cells = (out.best_cells,) if paths else ()
            return (out.best_cost, out.best_length, out.best_iteration, out.covered) + cells

        # Each device runs its slice on its own (no collective inside), so a device's while-loops
        # stop when its own ants do; check_vma off: the run's loop carries start replicated.
        program = jax.shard_map(
            chunk,
            mesh=mesh,
            in_specs=(PartitionSpec(AXIS), PartitionSpec(), PartitionSpec(AXIS)),
            out_specs=PartitionSpec(None, AXIS),
            check_vma=False,
        )
        return jax.jit(program)

    return key, cached(key, build)


def _shapes(batch) -> tuple:
    return tuple((tuple(x.shape), str(x.dtype)) for x in jax.tree.leaves(batch))


def _executable(
    variant: Planner,
    shape: RunShape,
    mesh: Mesh,
    batch,
    n_params: int,
    chunk: int,
    on_compile=None,
    paths: bool = False,
):
    """The compiled chunk program for ``chunk`` configurations per device (cached), and whether
    it was compiled by this call (``on_compile()`` is called first when it is)."""
    pkey, program = _program(variant, shape, mesh, paths)
    key = (pkey, _shapes(batch), n_params, chunk)
    new = not is_cached(key)

    def build():
        if on_compile is not None:
            on_compile()
        width = chunk * mesh.size
        on_cfg, replicated = NamedSharding(mesh, PartitionSpec(AXIS)), NamedSharding(mesh, PartitionSpec())
        seeds = jax.ShapeDtypeStruct((width,), np.uint32, sharding=on_cfg)
        problems = jax.tree.map(lambda x: jax.ShapeDtypeStruct(x.shape, x.dtype, sharding=replicated), batch)
        params = params_from(variant.default_params().to_dict(), (width,))
        params = jax.tree.map(lambda x: jax.ShapeDtypeStruct(x.shape, np.float32, sharding=on_cfg), params)
        return _progress.run_interruptibly(lambda: program.lower(seeds, problems, params).compile())

    return cached(key, build), new


def _agree(value: int) -> int:
    """Process 0's value on every process (chunk decisions must match everywhere)."""
    if jax.process_count() == 1:
        return int(value)
    from jax.experimental import multihost_utils

    return int(multihost_utils.broadcast_one_to_all(np.int32(value)))


def _fit(budget: int, fixed: int, per: float, rows_per_device: int) -> int:
    """Configurations per device and chunk: as many as fit, then balanced over the chunks."""
    c = int(max(1, min(rows_per_device, (budget - fixed) // max(per, 1.0))))
    n_chunks = math.ceil(rows_per_device / c)
    return math.ceil(rows_per_device / n_chunks)


def _plan(
    variant: Planner,
    shape: RunShape,
    mesh: Mesh,
    batch,
    n_params: int,
    n_rows: int,
    budget: int,
    on_compile=None,
    paths: bool = False,
):
    """Choose the chunk size under the budget from the compiled program's memory analysis: as
    many of ``n_rows`` runs per chunk as fit (``n_rows`` is also the cap: a caller that wants
    smaller chunks passes the chunk it wants).

    Returns ``(executable, configurations per device and chunk, info dict)``."""
    rows_per_device = math.ceil(n_rows / mesh.size)
    fixed = sum(int(np.asarray(x).nbytes) for x in jax.tree.leaves(batch))  # replicated problems
    mkey = (native.active_walk(), variant, *shape.sizes.values(), _shapes(batch), paths)
    path_len = _path_len(variant, shape, batch)
    guess = bytes_per_run(batch.n_cells, shape.n_ants, shape.n_iters, shape.steplimit, path_len) * batch.nbr.shape[0]
    per = _PER_CONFIG.get(mkey, guess)
    chunk = _agree(_fit(budget, fixed, per, rows_per_device))
    compiles, tried = 0, []
    while True:
        exe, new = _executable(variant, shape, mesh, batch, n_params, chunk, on_compile, paths)
        compiles += new
        tried.append(chunk)
        used = _footprint(exe)
        if used is None:
            break
        used = 1024 * _agree(math.ceil(used / 1024))  # KiB: fits an int32 broadcast
        measured = max(1.0, (used - fixed) / chunk)
        _PER_CONFIG[mkey] = measured
        if used <= budget or chunk == 1:
            break
        chunk = _agree(min(chunk - 1, _fit(budget, fixed, 1.05 * measured, rows_per_device)))
    info = dict(
        devices=mesh.size,
        processes=jax.process_count(),
        chunk_per_device=chunk,
        chunk=chunk * mesh.size,
        chunks=math.ceil(rows_per_device / chunk),
        bytes_per_chunk=used,
        bytes_per_config_estimate=guess,
        bytes_per_config_measured=None if used is None else measured,
        memory_budget=budget,
        compiles=compiles,
        chunks_tried=tried,  # configurations per device of each compiled attempt
    )
    return exe, chunk, info


_PATH_LEN: dict = {}


def _path_len(variant: Planner, shape: RunShape, batch) -> int:
    """Length of the construct step's candidate buffer (shape only, traced once per shapes)."""
    key = (variant, *shape.sizes.values(), _shapes(batch))
    if key not in _PATH_LEN:
        run = make_run(variant, **shape.sizes)
        one = jax.tree.map(lambda x: jax.ShapeDtypeStruct(x.shape[1:], x.dtype), batch)
        prm = jax.tree.map(lambda x: jax.ShapeDtypeStruct((), np.float32), variant.default_params())
        out = jax.eval_shape(run, jax.ShapeDtypeStruct((), jax.random.key(0).dtype), one, prm)
        _PATH_LEN[key] = int(out.best_cells.shape[0])
    return _PATH_LEN[key]


def _put(x: np.ndarray, sharding):
    """A (possibly multi-process) global array from the full host array every process holds."""
    x = np.asarray(x)
    return jax.make_array_from_callback(x.shape, sharding, lambda index: x[index])


def _fetch(x) -> np.ndarray:
    if x.is_fully_addressable:
        return np.asarray(x)
    from jax.experimental import multihost_utils

    return np.asarray(multihost_utils.process_allgather(x, tiled=True))


# -- configurations -------------------------------------------------------------------------
def _config_table(variant, params) -> tuple[dict, list[str]]:
    """Per-configuration values (float64, one array per Params field) and the swept names."""
    where = f"planner {variant.name!r}"
    if isinstance(params, dict):
        check_values(params, variant.params, where)  # the variant's own names in the message
        n = math.prod(np.size(v) for v in params.values())
        check_memory(
            n * CONFIG_BYTES,
            f"a grid of {n} configurations",
            "use fewer values per axis, or a random or Latin hypercube design",
        )
    design = as_design(params)
    unknown = [k for k in design.names if k not in variant.params]
    if unknown:
        raise ParamError(f"unknown parameter {unknown[0]!r} for {where}; valid: {', '.join(sorted(variant.params))}")
    base = resolve_params(variant, {}, where=where)
    n = len(design)
    table = {k: np.broadcast_to(design[k] if k in design else base[k], (n,)).astype(np.float64) for k in base}
    check_relations(table, variant.params)  # on every row (τmin < τmax, Q1 < Q2 < Q3, ρ2 < ρ1)
    return table, list(design.names)


class Queries(NamedTuple):
    """The validated queries of a sweep or search: ``(grid, start, goal)`` triples (cells as
    tuples) and their problems (exact optimum included), built once with numpy."""

    queries: list
    problems: list

    @property
    def grid(self) -> Grid:
        return self.queries[0][0]


def prepare_queries(
    grid: Any,
    start: Any,
    goal: Any,
    *,
    n_ants: int,
    n_iters: int,
    steplimit: int | None,
    connectivity: int,
    variant: Any = None,
) -> tuple[Queries, int]:
    """Validate the maps, queries and sizes (before anything compiles) and build the problems;
    returns them and the step limit (when ``steplimit`` is None, the map's default for ``variant``:
    :func:`jaco.engine.checks.default_steplimit`)."""
    queries = _queries(grid, start, goal)
    shapes = {g.shape for g, _, _ in queries}
    if len(shapes) != 1:
        raise JacoError(f"all maps of a sweep must have one shape, got {sorted(shapes)}")
    steplimit = default_steplimit(queries[0][0], variant) if steplimit is None else steplimit
    check_sizes(n_ants, n_iters, steplimit)
    # one configuration of every query must fit: the chunks are cut under memory_budget from there
    check_run_memory(queries[0][0].n_cells, n_ants, n_iters, steplimit, runs=len(queries), what="a sweep chunk")
    problems = [make_problem(g, s, t, connectivity=connectivity) for g, s, t in queries]
    return Queries(
        [(g, tuple(int(x) for x in s), tuple(int(x) for x in t)) for g, s, t in queries], problems
    ), steplimit


def check_budget(memory_budget: Any) -> int:
    if isinstance(memory_budget, bool) or not isinstance(memory_budget, (int, np.integer)) or memory_budget < 1:
        raise JacoError(f"memory_budget must be a positive number of bytes, got {memory_budget!r}")
    return int(memory_budget)


class Runner:
    """One planner's compiled chunk program on fixed queries, sizes and devices: ``runner(values,
    seeds)`` runs one row per (configuration values, seed), in chunks of :attr:`width` rows (the
    last one padded), and returns ``(cost, length, best_iteration, covered[, best_cells])`` as
    numpy arrays ``(queries, rows)``. Every row equals :func:`jaco.solve` with its values and seed,
    whatever the chunk it ran in. Built by :func:`jaco.sweep` and :func:`jaco.search`."""

    def __init__(
        self,
        variant: Planner,
        queries: Queries,
        *,
        shape: RunShape,
        mesh: Mesh,
        rows: int,
        budget: int,
        on_compile=None,
        paths: bool = False,
    ):
        self.variant, self.queries, self.mesh, self.paths, self.shape = variant, queries, mesh, paths, shape
        batch = stack(queries.problems)
        n_params = len(variant.default_params().to_dict())
        self.exe, self.chunk, self.info = _plan(variant, shape, mesh, batch, n_params, rows, budget, on_compile, paths)
        self.width = self.chunk * mesh.size
        self._on_cfg = NamedSharding(mesh, PartitionSpec(AXIS))
        self._batch = jax.tree.map(lambda x: _put(x, NamedSharding(mesh, PartitionSpec())), batch)

    def __call__(self, values: dict, seeds: np.ndarray, on_chunk=None, on_iteration=None) -> tuple:
        """``values``: name -> float array (one per row; every parameter of the planner);
        ``seeds``: uint32 (rows,). ``on_chunk(lo, hi, outputs)`` after each chunk (``outputs`` as
        returned, for rows ``lo:hi``); ``on_iteration(lo, hi, done)`` while a chunk runs (``done``
        of its iterations finished)."""
        n = len(seeds)
        outs = None
        for lo in range(0, n, self.width):
            hi = min(lo + self.width, n)
            idx = np.minimum(np.arange(lo, lo + self.width), n - 1)  # pad the last chunk
            prm = params_from({k: np.asarray(v)[idx] for k, v in values.items()}, (self.width,))
            args = (
                _put(np.asarray(seeds, np.uint32)[idx], self._on_cfg),
                self._batch,
                jax.tree.map(lambda x: _put(x, self._on_cfg), prm),
            )
            update = (lambda done, lo=lo, hi=hi: on_iteration(lo, hi, done)) if on_iteration else (lambda done: None)
            with _progress.reporting(update):
                got = _progress.run_interruptibly(lambda args=args: [_fetch(x) for x in self.exe(*args)])
            got = [x[:, : hi - lo] for x in got]
            if outs is None:
                outs = [np.empty((x.shape[0], n) + x.shape[2:], x.dtype) for x in got]
            for dst, src in zip(outs, got):
                dst[:, lo:hi] = src
            if on_chunk is not None:
                on_chunk(lo, hi, got)
        assert outs is not None, "a sweep has at least one row (check_seeds)"
        return tuple(outs)


class _Setup(NamedTuple):
    variant: object
    queries: list
    problems: list
    values: dict
    config: np.ndarray
    seeds: np.ndarray
    runner: Runner
    info: dict


def _setup(
    grid,
    start,
    goal,
    variant,
    params,
    seeds,
    n_ants,
    n_iters,
    steplimit,
    connectivity,
    memory_budget,
    devices,
    on_compile=None,
    chunk=None,
):
    """Validate everything (before compiling), then plan the chunks and compile the program."""
    variant = get_planner(variant)
    qs, steplimit = prepare_queries(
        grid,
        start,
        goal,
        n_ants=n_ants,
        n_iters=n_iters,
        steplimit=steplimit,
        connectivity=connectivity,
        variant=variant,
    )
    seed_list = check_seeds(seeds)
    budget = check_budget(memory_budget)
    if chunk is not None and (isinstance(chunk, bool) or not isinstance(chunk, (int, np.integer)) or chunk < 1):
        raise JacoError(f"chunk must be a positive number of runs (configurations x seeds), got {chunk!r}")
    values, _ = _config_table(variant, params)
    n_cfg = len(next(iter(values.values())))
    n_rows = n_cfg * len(seed_list) * len(qs.queries)
    check_memory(
        n_rows * 8 * (2 * len(values) + 16),
        f"a table of {n_rows} runs",
        "use fewer configurations, seeds or queries (or several sweeps)",
    )
    mesh = Mesh(np.array(_devices(devices)), (AXIS,))
    config = np.repeat(np.arange(n_cfg), len(seed_list))  # configuration-major, seeds inner
    seed_arr = np.tile(seed_list, n_cfg)
    rows = len(config) if chunk is None else min(len(config), int(chunk))
    shape = RunShape(n_ants, n_iters, steplimit, connectivity)
    runner = Runner(variant, qs, shape=shape, mesh=mesh, rows=rows, budget=budget, on_compile=on_compile)
    info = dict(
        runs=len(config) * len(qs.problems),
        configurations=n_cfg,
        seeds=len(seed_list),
        queries=len(qs.problems),
        steplimit=int(steplimit),
        **runner.info,
    )
    if chunk is not None:  # chunks: over every row, not only the capped first one
        info["chunks"] = math.ceil(len(config) / runner.width)
    return _Setup(variant, qs.queries, qs.problems, values, config, seed_arr, runner, info)


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
    return _setup(
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
    store holds any number of sweeps, each found by a fingerprint of its arguments; a second
    process on the same store gets a one-line error naming the lock.

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
    if isinstance(planner, (list, tuple)) and not isinstance(planner, Planner):  # a Planner is a tuple too
        kwargs = dict(
            n_ants=n_ants,
            n_iters=n_iters,
            steplimit=steplimit,
            connectivity=connectivity,
            memory_budget=memory_budget,
            progress=progress,
            devices=devices,
            store=store,
            chunk=chunk,
        )
        return _over_variants(planner, lambda v: sweep(grid, start, goal, v, params, seeds, **kwargs), params)
    name = get_planner(planner).name
    if store is not None:
        from .store import check_store_path

        store = check_store_path(store)
    bar = _progress.Bar(_progress.enabled(progress) and jax.process_index() == 0, f"sweep {name}", "run")
    try:
        return _sweep(
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
            store,
            chunk,
        )
    finally:
        bar.close()


def _sweep(
    bar,
    grid,
    start,
    goal,
    variant,
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
):
    """The body of :func:`sweep` for one planner, moving ``bar`` (:class:`jaco.progress.Bar`)."""
    if store is not None and chunk is None:
        n_runs = len(as_design(params)) * len(check_seeds(seeds))
        chunk = max(1, math.ceil(n_runs / STORE_CHUNKS))
    st = _setup(
        grid,
        start,
        goal,
        variant,
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
    todo = np.arange(n_rows)
    if store is not None:
        from .store import SweepStore

        with SweepStore(store) as held:  # locked until the sweep ends
            key = held.fingerprint(
                st.variant,
                st.queries,
                st.values,
                st.config,
                st.seeds,
                n_ants=n_ants,
                n_iters=n_iters,
                steplimit=st.runner.shape.steplimit,
                connectivity=connectivity,
            )
            todo = np.flatnonzero(~held.load(key, outs))
            return _run_sweep(bar, st, outs, todo, held, key)
    return _run_sweep(bar, st, outs, todo)


def _run_sweep(bar, st, outs, todo, store=None, key=None) -> pd.DataFrame:
    """Run the rows ``todo`` of a set-up sweep into ``outs`` (appending each chunk to ``store``)."""
    n_q, n_rows = outs[0].shape
    bar.start(n_rows * n_q, f"sweep {st.variant.name}: {n_rows * n_q} runs")
    bar.update((n_rows - len(todo)) * n_q)

    def finished(lo, hi, got):
        rows = todo[lo:hi]
        for dst, src in zip(outs, got):
            dst[:, rows] = src
        if store is not None:
            store.append(key, rows, got)
        bar.update((n_rows - len(todo) + hi) * n_q)

    def running(lo, hi, done):  # runs done inside the chunk, by its finished iterations
        n_iters = st.runner.shape.n_iters
        bar.update((n_rows - len(todo) + lo) * n_q + (hi - lo) * n_q * min(int(done), n_iters) // n_iters)

    if len(todo):
        st.runner(
            {k: v[st.config[todo]] for k, v in st.values.items()},
            st.seeds[todo],
            on_chunk=finished,
            on_iteration=running,
        )
    table = _tidy(st.variant, st.queries, st.problems, st.values, st.config, st.seeds, *outs)
    table.attrs["sweep"] = dict(st.info, resumed_runs=int((n_rows - len(todo)) * n_q)) if store is not None else st.info
    return table


def _over_variants(variants, run, params) -> pd.DataFrame:
    """One sweep per planner (each with its ``planner`` column), stacked; every planner and its
    parameter axes are checked before anything compiles."""
    variants = [get_planner(v) for v in variants]
    if not variants:
        raise JacoError("planner: an empty list of planners")
    names = [v.name for v in variants]
    if len(set(names)) != len(names):
        raise JacoError(f"planner: a planner is listed twice in {names}")
    axes = list(params) if isinstance(params, dict) else as_design(params).names
    for axis in axes:  # one that some planners lack: say which have it (no "did you mean")
        have = [v.name for v in variants if axis in v.params]
        if have and len(have) < len(variants):
            raise ParamError(
                f"{owners(axis, variants)}: a sweep over several planners takes only the parameters every one of "
                f"them has; sweep {' and '.join(have)} on {'its' if len(have) == 1 else 'their'} own, or search "
                "(jaco search, jaco.search), which sets a parameter only for the planners that have it"
            )
    for v in variants:
        _config_table(v, params)
    tables = [run(v) for v in variants]  # each with its first column "planner"
    table = pd.concat(tables, ignore_index=True)
    table.attrs["sweep"] = {v.name: t.attrs["sweep"] for v, t in zip(variants, tables)}
    return table


def _tidy(variant, queries, problems, values, config, seed_arr, cost, length, best_iter, covered) -> pd.DataFrame:
    """The tidy table: one row per query × configuration × seed (query-major)."""
    n_q, n_rows = cost.shape
    cols: dict = {}
    parts = []
    for q, (g, s, t) in enumerate(queries):
        success = np.isfinite(cost[q])
        L = np.where(success, length[q].astype(np.float64) * g.cell_size, math.inf)
        optimal = float(problems[q].optimal) * g.cell_size
        cols = {"planner": [variant.name] * n_rows}  # every table names its planner, one planner too
        if n_q > 1:  # the query as integer columns, so that a CSV round trip keeps them numbers
            cols |= {
                "map": [g.name] * n_rows,
                "start_row": np.full(n_rows, s[0], np.int64),
                "start_col": np.full(n_rows, s[1], np.int64),
                "goal_row": np.full(n_rows, t[0], np.int64),
                "goal_col": np.full(n_rows, t[1], np.int64),
            }
        cols["config"] = config.astype(np.int64)
        cols.update({k: values[k][config] for k in variant.params})
        cols.update(
            seed=seed_arr.astype(np.int64),
            success=success,
            length=L,
            cost=cost[q].astype(np.float64),
            best_iteration=best_iter[q].astype(np.int64),
            optimal=np.full(n_rows, optimal),
            gap=np.where(success, gap(L, optimal), math.inf),
            coverage=covered[q].astype(np.int64) / g.n_free,
        )
        parts.append(pd.DataFrame(cols))
    return parts[0] if n_q == 1 else pd.concat(parts, ignore_index=True)


def summarize(table: pd.DataFrame, by: Any = None) -> pd.DataFrame:
    """Per-configuration summary over seeds, one row per configuration (and query).

    ``by`` defaults to every column that is not a result (the planner, the query columns,
    ``config`` and the parameters). Columns: ``success_rate``; ``length_mean, length_std,
    length_min``, ``length_q1, length_median, length_q3`` (quartiles) and the same for ``gap``
    (``gap_mean, gap_min, gap_q1, gap_median, gap_q3``) over the successful runs, so they are NaN
    for a configuration that failed on every seed (``success_rate`` 0; the std is also NaN with
    fewer than two successes); and ``runs``. A failure is never averaged in as ``inf``: rank
    configurations by ``success_rate`` first, e.g.
    ``summary.sort_values(["success_rate", "gap_median"], ascending=[False, True])``, or compare
    them with :func:`jaco.research.compare.compare`, which counts a failure as worse than any path.
    Gaps are fractions (0.05 is 5 %), as in the table.

    A table of several planners (``jaco.sweep(..., planner=[...])``) has a column for every
    planner's parameters, empty (NaN) on the rows of planners without that parameter. By default
    the summary keeps as columns the parameters every planner of the table has, and folds the
    others into one text column ``params``, each row holding its own planner's values only
    (``"q0=0.8, xi=0.1"``, at float32 precision; empty for a planner without such parameters):
    no column is NaN because of another planner.
    """
    if not isinstance(table, pd.DataFrame):
        raise JacoError(f"summarize takes the DataFrame of jaco.sweep, got {type(table).__name__}")
    if by is None:
        from .tables import fold_params

        table = fold_params(table, RESULT_COLUMNS)
        by = [c for c in table.columns if c not in RESULT_COLUMNS]
    else:
        from .tables import planner_by

        by = planner_by(by, table, "summarize")  # "variant": the planner column's former name
    missing = [c for c in by if c not in table.columns]
    if missing:
        raise JacoError(f"summarize: no column {missing[0]!r} in the table")
    ok = table["success"].astype(bool) & np.isfinite(table["length"])
    finite = table.assign(length=table["length"].where(ok), gap=table["gap"].where(ok))
    # dropna=False: a planner's row may have no value (NaN) for a parameter a given `by` keeps
    quartile = {name: (lambda v, q=q: v.quantile(q)) for name, q in (("q1", 0.25), ("median", 0.5), ("q3", 0.75))}
    stats: dict[str, tuple[str, Any]] = {"success_rate": ("success", "mean")}
    for col in ("length", "gap"):
        stats.update(
            {
                f"{col}_{k}": (col, f)
                for k, f in (
                    ("median", quartile["median"]),
                    ("q1", quartile["q1"]),
                    ("q3", quartile["q3"]),
                    ("mean", "mean"),
                    ("std", "std"),
                    ("min", "min"),
                )
            }
        )
    del stats["gap_std"]
    stats["runs"] = ("seed", "count")
    return finite.groupby(by, sort=False, dropna=False).agg(**stats).reset_index()
