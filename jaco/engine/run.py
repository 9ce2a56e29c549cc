"""The colony loop (the fifth of the five concepts): ``make_run(variant, ...) -> run(key, problem,
params)``.

Iterations are a ``lax.scan``; the ants of an iteration walk together (vectorised over the ant
axis, see :mod:`jaco.engine.walk`); a sweep is ``jit(vmap(run))``. The key is always the first
argument and is never stored in state, so the same key gives the same result bit for bit.

Everything here takes a :class:`~jaco.engine.variant.Variant` itself: names are resolved one layer
up, by :func:`jaco.solve` (:mod:`jaco.api`) through the registry, so the engine never imports the
planners. :func:`solve` is the plain single run; several targets (:mod:`jaco.waypoints`) are
built on top of it.
"""

from __future__ import annotations

import math
import os
from collections import Counter
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from .. import progress as _progress
from ..errors import JacoError, ProblemError, ResourceError
from . import native
from ..grid import Grid
from .params import Params, check_order, check_values
from .pheromone import Trail, Walks
from .problem import Problem, make_problem
from .result import Result, to_result
from .variant import Variant


class History(NamedTuple):
    """Per iteration: best-so-far cost, the iteration's best and mean cost over successful ants
    (inf when none succeeded) and its success rate."""

    best: jax.Array
    iteration_best: jax.Array
    mean: jax.Array
    success_rate: jax.Array


class RunOutput(NamedTuple):
    """Raw arrays of one run (or, under vmap, of a batch of runs)."""

    best_cells: jax.Array  # (S,) cells entered by the best ant, -1 padded
    best_cost: jax.Array
    best_length: jax.Array
    best_iteration: jax.Array  # -1 while no ant succeeded
    history: History
    covered: jax.Array  # number of free cells visited by any ant (coverage = covered / free)
    steps: jax.Array  # real ant-steps taken in the whole run (for throughput figures)
    tau: jax.Array | None


class _Best(NamedTuple):
    cells: jax.Array
    targets: jax.Array
    step_len: jax.Array
    cost: jax.Array
    length: jax.Array
    iteration: jax.Array


def make_run(variant, *, n_ants: int, n_iters: int, steplimit: int, keep_pheromone: bool | str = False,
             report: bool = False):
    """Build ``run(key, problem, params) -> RunOutput`` for fixed shapes (not jitted here).

    ``keep_pheromone``: False (none), True (the final pheromone ``(M,)``) or ``"history"`` (the
    pheromone after every iteration, ``(n_iters, M)``, e.g. for :func:`jaco.plot.animate_pheromone`).
    ``report``: hand the number of finished iterations to :func:`jaco.progress.report` every
    :func:`jaco.progress.every` iterations, or with ``"every"`` after each iteration (a host
    callback that reads nothing back; under vmap the iteration is the same for every run of the
    batch, so the batch reports once). A report is also where an interrupted call ends
    (:func:`jaco.progress.run_interruptibly`).
    """
    if not isinstance(variant, Variant):
        raise JacoError(f"make_run takes a Variant, got {variant!r} (by name: jaco.make_run or jaco.VARIANTS[name])")
    if keep_pheromone not in (False, True, "history"):
        raise JacoError(f"keep_pheromone must be False, True or 'history', got {keep_pheromone!r}")
    check_sizes(n_ants, n_iters, steplimit)

    def run(key, problem: Problem, params: Params) -> RunOutput:
        TRACES[variant.name] += 1  # Python side effect: runs once per trace, never when cached
        n = problem.nbr.shape[0]
        size = n if variant.pheromone_on == "cells" else 8 * n
        trail = variant.rule.init(
            Trail(jnp.zeros(size, jnp.float32), jnp.float32(0.0), jnp.float32(jnp.inf)), problem, params
        )

        def construct(trail, t, key):
            p = variant.schedule(params, t, n_iters)
            trail, colony = variant.construct(
                variant, problem, trail, p, t, n_iters, key, n_ants=n_ants, steplimit=steplimit
            )
            return p, trail, colony

        # The candidates' path buffer length is the construct step's own (two colonies: longer).
        path_len = jax.eval_shape(construct, trail, jnp.int32(0), key)[2].cells.shape[0]
        trivial = problem.start == problem.goal  # an ant on the goal has arrived, path empty
        best = _Best(
            cells=jnp.full((path_len,), -1, jnp.int32),
            targets=jnp.full((path_len,), size, jnp.int32),
            step_len=jnp.zeros((path_len,), jnp.float32),
            cost=jnp.where(trivial, 0.0, jnp.inf).astype(jnp.float32),
            length=jnp.where(trivial, 0.0, jnp.inf).astype(jnp.float32),
            iteration=jnp.where(trivial, 0, -1).astype(jnp.int32),
        )

        def iteration(carry, xs):
            trail, best, seen, steps = carry
            key_t, t = xs
            p, trail, col = construct(trail, t, key_t)
            if variant.local_search is not None:  # the improved paths are deposited and become the best
                col = variant.local_search(variant, problem, col, p)
            b = jnp.argmin(col.cost)
            better = col.cost[b] < best.cost
            candidate = _Best(col.cells[:, b], col.targets[:, b], col.step_len[:, b], col.cost[b], col.length[b], t)
            best = jax.tree.map(lambda new, old: jnp.where(better, new, old), candidate, best)
            walks = Walks(col.targets, col.step_len, col.cost, best.targets, best.step_len, best.cost)
            trail = variant.rule.update(trail, walks, problem, p)
            ok = jnp.isfinite(col.cost)
            count = jnp.sum(ok)
            mean = jnp.where(count > 0, jnp.sum(jnp.where(ok, col.cost, 0.0)) / jnp.maximum(count, 1), jnp.inf)
            hist = History(best.cost, col.cost[b], mean, count / col.cost.shape[0])
            snapshot = trail.tau if keep_pheromone == "history" else None
            if report == "every":  # each iteration: a sweep chunk's bar and its interrupts
                jax.debug.callback(_progress.report, t + 1)
            elif report:
                k = _progress.every(n_iters)
                jax.lax.cond((t + 1) % k == 0, lambda: jax.debug.callback(_progress.report, t + 1), lambda: None)
            return (trail, best, seen | col.visited, steps + jnp.sum(col.n_steps)), (hist, snapshot)

        seen = jnp.zeros((n,), bool)
        xs = (jax.random.split(key, n_iters), jnp.arange(n_iters, dtype=jnp.int32))
        carry = (trail, best, seen, jnp.int32(0))
        (trail, best, seen, steps), (history, snapshots) = jax.lax.scan(iteration, carry, xs)
        return RunOutput(
            best_cells=best.cells,
            best_cost=best.cost,
            best_length=best.length,
            best_iteration=best.iteration,
            history=history,
            covered=jnp.sum(seen & (problem.clearance > 0)),
            steps=steps,
            tau=snapshots if keep_pheromone == "history" else trail.tau if keep_pheromone else None,
        )

    return run


# -- compiled programs, cached so repeated calls of one shape never recompile ---------------
_COMPILED: dict = {}
TRACES: Counter = Counter()  # how often each variant's run was traced (tests check "once")


def cached(key: tuple, build, *keep):
    """The one cache of every compiled program (runs, sweep chunks, waypoint legs, tuning loops):
    ``build()`` once per ``key``. Keys hold ``id()``s of variants and optimisers (they are not
    hashable by value); ``keep`` holds those objects alive so that an id is never reused."""
    hit = _COMPILED.get(_walk_key(key))
    if hit is None:
        hit = _COMPILED[_walk_key(key)] = (keep, build())
    return hit[1]


def is_cached(key: tuple) -> bool:
    """Whether :func:`cached` holds a program for ``key``."""
    return _walk_key(key) in _COMPILED


def _walk_key(key: tuple) -> tuple:
    return (native.active_walk(),) + key  # a program traced for one walk never serves the other


def clear_compiled() -> None:
    """Forget every cached program (e.g. to bound memory in a long session)."""
    _COMPILED.clear()


def compiled_run(variant: Variant, n_ants: int, n_iters: int, steplimit: int, keep_pheromone: bool, batched: bool,
                 report: bool = False):
    """The jitted run for these static choices (cached by variant identity and shapes).

    ``report``: the unbatched run that reports its iterations to a progress bar (a program of its
    own, compiled once, so that a run without a bar pays nothing for the callbacks; the two give
    the same results bit for bit).

    ``batched``: ``run(keys (B,), problems (P, ...), params (B,))`` vmapped over configurations
    × seeds (inner) and problems (outer) -> outputs ``(P, B, ...)``.
    """

    def build():
        run = make_run(variant, n_ants=n_ants, n_iters=n_iters, steplimit=steplimit, keep_pheromone=keep_pheromone,
                       report=report and not batched)
        if batched:
            run = jax.vmap(jax.vmap(run, in_axes=(0, None, 0)), in_axes=(None, 0, None))
        return jax.jit(run)

    key = ("run", id(variant), n_ants, n_iters, steplimit, keep_pheromone, batched)
    return cached(key + (("report",) if report and not batched else ()), build, variant)


def default_steplimit(grid: Grid, variant: Variant | None = None) -> int:
    """Step limit when none is given: 4·(H + W), at most the number of free cells (a walk with a
    tabu list can never be longer). Ants that step back at dead ends (a construct marked
    ``back_steps``, IACA's) count their back-steps against the limit and explore dead branches,
    whose length grows with how far apart the free cells lie: they get 8·E, at most twice the free
    cells, with E = max(H + W, the free cells' extent :func:`jaco.exact.free_extent`, the longest
    shortest path between two free cells). Twice 4·(H + W) gives them the forward reach of the
    ants that die (a back-step undoes a forward step); the extent stretches it on mazes, where
    paths are much longer than the map is wide; 2·(free cells) is the depth-first search's bound
    (every cell entered once and left once), so where it is the limit every backtracking ant
    reaches a reachable goal (docs/compose.md, "The step limit")."""
    if variant is not None and getattr(variant.construct, "back_steps", False):
        from ..exact import free_extent

        extent = max(grid.height + grid.width, math.ceil(free_extent(grid)))
        return int(max(1, min(8 * extent, 2 * grid.n_free)))
    return int(max(1, min(4 * (grid.height + grid.width), grid.n_free)))


def legacy_steplimit(grid: Grid, variant: Variant | None = None, format_version: int = 2) -> int:
    """The default step limit of the jaco that wrote a record of ``format_version`` (a sweep record
    stores ``steplimit: null`` when none was given): before format 3, 4·(H + W) at most the free
    cells for every planner; in format 3, twice that (at most twice the free cells) for
    backtracking ants; since format 4, :func:`default_steplimit`."""
    if format_version >= 4:
        return default_steplimit(grid, variant)
    free, extent = grid.n_free, 4 * (grid.height + grid.width)
    if format_version == 3 and variant is not None and getattr(variant.construct, "back_steps", False):
        free, extent = 2 * free, 2 * extent
    return int(max(1, min(extent, free)))


INT32_MAX = 2**31 - 1
#: Seeds are 32-bit: ``jax.random.key(seed)`` keeps only the low 32 bits, so 2**32 would silently
#: give the run of seed 0. A larger seed is an error, never wrapped.
SEED_LIMIT = 2**32


def check_sizes(n_ants, n_iters, steplimit):
    """Positive integers whose products still fit the compiled program's 32-bit indices."""
    for name, v in (("n_ants", n_ants), ("n_iters", n_iters), ("steplimit", steplimit)):
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 1:
            raise JacoError(f"{name} must be a positive integer (int), got {type(v).__name__} {v!r}")
        if v > INT32_MAX:
            raise ResourceError(f"{name} = {v} is more than the compiled program's 32-bit indices hold ({INT32_MAX})")
    if int(n_ants) * int(steplimit) > INT32_MAX:
        raise ResourceError(
            f"n_ants x steplimit = {int(n_ants) * int(steplimit)} ant-steps per iteration is more than the "
            f"compiled program's 32-bit indices hold ({INT32_MAX})"
        )


def check_seed(seed, what: str = "seed") -> int:
    """An integer seed in [0, 2**32) (:data:`SEED_LIMIT`), as a Python int."""
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)):
        raise JacoError(f"{what} must be an integer in [0, 2**32), got {type(seed).__name__} {seed!r}")
    if not 0 <= seed < SEED_LIMIT:
        raise JacoError(
            f"{what} must be in [0, 2**32) (jax keys take 32 bits; a larger one would alias a smaller seed), got {seed}"
        )
    return int(seed)


def bytes_per_run(n_cells: int, n_ants: int, n_iters: int, steplimit: int, path_len: int | None = None) -> int:
    """First guess of the peak bytes one run (one configuration, one query) adds to a batch.

    Fitted to XLA's memory analysis of compiled sweeps (one and two colonies, both walks): about
    8 bytes per ant and step slot with the native walk (moves, cells, targets, step lengths), 14
    with the JAX walk, which also keeps every ant's tabu bitmap (``A·N`` bytes) in XLA's memory;
    the pheromone, weights and heuristic tables ``(N, 8)``, about 100 bytes per cell; the
    history. ``path_len`` is the length of the construct step's candidate buffer: when it is
    longer than one walk (two colonies spliced by crossover), the crossover tables cost about 52
    bytes per ant and candidate slot. A 10 % margin on top. :func:`jaco.sweep` only starts from
    this guess: the compiled program's own memory analysis decides.
    """
    s = steplimit
    path_len = s if path_len is None else path_len
    jax_walk = native.active_walk() == "jax"
    per_slot = 52 if path_len > s else (14 if jax_walk else 8)
    per = (n_ants * n_cells if jax_walk else 0) + per_slot * path_len * n_ants + 100 * n_cells + 32 * n_iters
    return int(1.1 * per)


#: Host bytes one configuration of a sweep costs before it runs: every parameter as float64 in the
#: configuration table, its copies while the design is built, and its row of the result table
#: (a bound: 45 parameters, every parameter of jaco's components together).
CONFIG_BYTES = 16 * (45 + 8)


def _parse_bytes(text: str) -> int:
    units = {"": 1, "K": 1 << 10, "M": 1 << 20, "G": 1 << 30, "T": 1 << 40}
    t = text.strip().upper().removesuffix("IB").removesuffix("B")
    unit = t[-1:] if t[-1:] in units else ""
    try:
        value = float(t[: len(t) - len(unit)]) * units[unit]
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value >= 1):
        raise JacoError(f"JACO_MEMORY_BUDGET must be a number of bytes (e.g. 8G, 512M, 1000000), got {text!r}")
    return int(value)


def memory_budget() -> int:
    """Bytes one call may plan to use: ``JACO_MEMORY_BUDGET`` (bytes, or with a K, M, G or T
    suffix) when set, else half of the physical memory (8 GiB where that cannot be read)."""
    text = os.environ.get("JACO_MEMORY_BUDGET")
    if text:
        return _parse_bytes(text)
    try:
        return int(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")) // 2
    except (AttributeError, ValueError, OSError):  # pragma: no cover - not a POSIX system
        return 8 << 30


def _size(n: float) -> str:
    for unit in ("B", "KiB", "MiB", "GiB", "TiB"):
        if n < 1024 or unit == "TiB":
            return f"{n:.3g} {unit}" if unit != "B" else f"{int(n)} B"
        n /= 1024
    return f"{n:.3g} PiB"  # pragma: no cover


def check_memory(need: int, what: str, hint: str) -> None:
    """A :class:`ResourceError` naming the estimate and the budget when ``need`` bytes exceed
    :func:`memory_budget`."""
    budget = memory_budget()
    if need > budget:
        raise ResourceError(
            f"{what} needs about {_size(need)} of memory, more than the budget of {_size(budget)} "
            f"(half the physical memory, or JACO_MEMORY_BUDGET): {hint}"
        )


def check_run_memory(n_cells, n_ants, n_iters, steplimit, *, runs: int = 1, keep_pheromone=False, what="this call"):
    """The memory estimate of ``runs`` runs held at once (:func:`bytes_per_run`, plus the
    pheromone of every iteration with ``keep_pheromone="history"``) against the budget."""
    need = runs * bytes_per_run(n_cells, n_ants, n_iters, steplimit)
    if keep_pheromone == "history":
        need += runs * n_iters * 8 * n_cells * 4
    check_memory(
        need, f"{what} ({runs} run(s) of {n_ants} ants x {n_iters} iterations, step limit {steplimit}, {n_cells} cells)",
        "use fewer ants, iterations or runs, or a smaller step limit",
    )


def resolve_params(variant: Variant, values: dict, *, where: str) -> dict:
    """Validated parameter values (numpy float arrays) over the variant's defaults."""
    merged = {k: np.asarray(v, np.float64) for k, v in variant.default_params().to_dict().items()}
    merged.update(check_values(values, variant.params, where))
    check_order(merged, variant.params)
    return merged


def params_from(values: dict, shape=()) -> Params:
    return Params(**{k: np.broadcast_to(np.float32(v), shape) for k, v in values.items()})


def check_grid(grid) -> Grid:
    if not isinstance(grid, Grid):
        hint = " (a map name: load it with jaco.maps.named or jaco.maps.load first)" if isinstance(grid, str) else ""
        raise ProblemError(f"expected a jaco.Grid, got {type(grid).__name__}{hint}")
    return grid


def prepare(grid: Grid, variant: Variant, *, seed, n_ants, n_iters, steplimit, params: dict, runs: int = 1,
            keep_pheromone=False) -> tuple[int, dict]:
    """Validate one call with numpy before anything compiles: the map's type, the sizes and their
    memory estimate (``runs`` runs at once), the seed and every parameter (unknown names list the
    valid ones). Returns the step limit (the default when ``steplimit`` is None) and the parameter
    values over the variant's defaults."""
    check_grid(grid)
    if keep_pheromone not in (False, True, "history"):
        raise JacoError(f"keep_pheromone must be False, True or 'history', got {keep_pheromone!r}")
    steplimit = default_steplimit(grid, variant) if steplimit is None else steplimit
    check_sizes(n_ants, n_iters, steplimit)
    check_seed(seed)
    check_run_memory(grid.n_cells, n_ants, n_iters, steplimit, runs=runs, keep_pheromone=keep_pheromone)
    values = resolve_params(variant, params, where=f"variant {variant.name!r}")
    for k, v in values.items():
        if v.ndim:
            raise JacoError(f"solve takes one value per parameter; {k!r} has {v.size} (use jaco.sweep)")
    return steplimit, values


def solve(grid: Grid, start, goal, variant: Variant, *, seed, n_ants, n_iters, steplimit, connectivity, keep_pheromone,
          progress=None, **params) -> Result:
    """One run of ``variant`` from ``start`` to ``goal``: the body of :func:`jaco.solve` without
    waypoints (whose signature has the defaults). The call is validated by :func:`prepare` and
    :func:`~jaco.engine.problem.make_problem` (map, start, goal, reachability) before anything
    compiles. ``progress`` (:mod:`jaco.progress`): a bar of iterations once the call has taken
    :data:`jaco.progress.SOLVE_DELAY` seconds."""
    steplimit, values = prepare(grid, variant, seed=seed, n_ants=n_ants, n_iters=n_iters, steplimit=steplimit,
                                params=params, keep_pheromone=keep_pheromone)
    problem = make_problem(grid, start, goal, connectivity=connectivity)
    show = _progress.enabled(progress)
    bar = _progress.Bar(show, f"solve {variant.name}", "it", delay=_progress.SOLVE_DELAY)
    bar.start(n_iters)
    with _progress.listening(bar):
        run = compiled_run(variant, n_ants, n_iters, steplimit, keep_pheromone, batched=False, report=show)
        out = _progress.run_interruptibly(lambda: jax.device_get(run(jax.random.key(seed), problem, params_from(values))))
    return to_result(
        out,
        grid=grid,
        variant=variant,
        start=start,
        goal=goal,
        optimal=problem.optimal,
        seed=seed,
        params=values,
        n_ants=n_ants,
        n_iters=n_iters,
        steplimit=steplimit,
        connectivity=connectivity,
    )
