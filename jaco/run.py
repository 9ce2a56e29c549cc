"""The colony loop (DESIGN.md concept 5): ``make_run(variant, ...) -> run(key, problem, params)``.

Iterations are a ``lax.scan``; the ants of an iteration walk together (vectorised over the ant
axis, see :mod:`jaco.construct`); a sweep is ``jit(vmap(run))``. The key is always the first
argument and is never stored in state, so the same key gives the same result bit for bit.
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass, field
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from .errors import JacoError
from .grid import Grid
from .params import Params, check_order, check_values
from .pheromone import Trail, Walks
from .problem import Problem, make_problem
from .variants import Variant, get_variant


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


def make_run(variant, *, n_ants: int, n_iters: int, steplimit: int, keep_pheromone: bool | str = False):
    """Build ``run(key, problem, params) -> RunOutput`` for fixed shapes (not jitted here).

    ``keep_pheromone``: False (none), True (the final pheromone ``(M,)``) or ``"history"`` (the
    pheromone after every iteration, ``(n_iters, M)``, e.g. for :func:`jaco.plot.animate_pheromone`).
    """
    variant = get_variant(variant)
    if keep_pheromone not in (False, True, "history"):
        raise JacoError(f"keep_pheromone must be False, True or 'history', got {keep_pheromone!r}")

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
    hit = _COMPILED.get(key)
    if hit is None:
        hit = _COMPILED[key] = (keep, build())
    return hit[1]


def clear_compiled() -> None:
    """Forget every cached program (e.g. to bound memory in a long session)."""
    _COMPILED.clear()


def compiled_run(variant: Variant, n_ants: int, n_iters: int, steplimit: int, keep_pheromone: bool, batched: bool):
    """The jitted run for these static choices (cached by variant identity and shapes).

    ``batched``: ``run(keys (B,), problems (P, ...), params (B,))`` vmapped over configurations
    × seeds (inner) and problems (outer) -> outputs ``(P, B, ...)``.
    """

    def build():
        run = make_run(variant, n_ants=n_ants, n_iters=n_iters, steplimit=steplimit, keep_pheromone=keep_pheromone)
        if batched:
            run = jax.vmap(jax.vmap(run, in_axes=(0, None, 0)), in_axes=(None, 0, None))
        return jax.jit(run)

    return cached(("run", id(variant), n_ants, n_iters, steplimit, keep_pheromone, batched), build, variant)


def default_steplimit(grid: Grid) -> int:
    """Step limit when none is given: 4·(H + W), at most the number of free cells (a walk
    with a tabu list can never be longer)."""
    return int(max(1, min(4 * (grid.height + grid.width), grid.n_free)))


def check_sizes(n_ants, n_iters, steplimit):
    for name, v in (("n_ants", n_ants), ("n_iters", n_iters), ("steplimit", steplimit)):
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 1:
            raise JacoError(f"{name} must be a positive integer, got {v!r}")


def resolve_params(variant: Variant, values: dict, *, where: str) -> dict:
    """Validated parameter values (numpy float arrays) over the variant's defaults."""
    merged = {k: np.asarray(v, np.float64) for k, v in variant.default_params().to_dict().items()}
    merged.update(check_values(values, variant.params, where))
    check_order(merged, variant.params)
    return merged


def params_from(values: dict, shape=()) -> Params:
    return Params(**{k: np.broadcast_to(np.float32(v), shape) for k, v in values.items()})


# -- results ------------------------------------------------------------------------------
@dataclass
class Result:
    """The outcome of one run: the best path and how the colony got there.

    ``path`` is a ``(K, 2)`` array of ``(row, col)`` (empty when no ant reached the goal);
    ``length`` and ``optimal`` are in cell units times the grid's ``cell_size``; ``cost`` is the
    variant's objective (the length in cell units unless the variant says otherwise).
    """

    variant: str
    path: np.ndarray
    length: float
    success: bool
    cost: float
    optimal: float
    gap: float
    best_iteration: int
    history: dict
    coverage: float
    seed: int
    params: dict
    n_ants: int
    n_iters: int
    steplimit: int
    start: tuple
    goal: tuple
    grid: Grid | None = field(default=None, repr=False)
    pheromone: np.ndarray | None = field(default=None, repr=False)
    connectivity: int = 8  # records: a rerun needs the move set (jaco.records)
    waypoints: tuple = ()  # the targets visited between start and goal (jaco.waypoints)

    def metrics(self) -> dict:
        """:func:`jaco.metrics.path_metrics` of the best path (length, turns, heading change E,
        clearance, safety cost S, any-angle length, valid, gap) plus the run's ``cost``,
        ``coverage`` and ``best_iteration``. S uses the run's ``rs_cost`` when the variant has one
        (the multi-objective cost), else :data:`jaco.metrics.SAFETY_RADIUS`, so S and E are those
        of the cost. A failed run has length inf and no path figures."""
        from .metrics import SAFETY_RADIUS, path_metrics

        run = {"cost": self.cost, "coverage": self.coverage, "best_iteration": self.best_iteration}
        if not self.success:
            return {"length": math.inf, "valid": False, **run}
        rs = self.params.get("rs_cost", SAFETY_RADIUS)
        return {**path_metrics(self.grid, self.path, optimal=self.optimal, rs=rs), **run}

    def to_dict(self) -> dict:
        """JSON-ready dict (no numpy types; inf written as None where JSON has no inf)."""

        def num(x):
            x = float(x)
            return x if math.isfinite(x) else None

        return {
            "variant": self.variant,
            "path": self.path.tolist(),
            "length": num(self.length),
            "success": bool(self.success),
            "cost": num(self.cost),
            "optimal": num(self.optimal),
            "gap": num(self.gap),
            "best_iteration": int(self.best_iteration),
            "coverage": float(self.coverage),
            "seed": int(self.seed),
            "params": {k: float(v) for k, v in self.params.items()},
            "n_ants": self.n_ants,
            "n_iters": self.n_iters,
            "steplimit": self.steplimit,
            "start": list(self.start),
            "goal": list(self.goal),
            "map": None if self.grid is None else self.grid.name,
            "history": {k: [num(x) for x in v] for k, v in self.history.items()},
        }

    # -- records and world coordinates (jaco.records, docs/records.md) ------------------------
    def save(self, path):
        """Write this run as a JSON record (parameters, seed, variant, the map embedded with its
        sha256, sizes, connectivity, result and history, jaco/jax versions); returns the path.
        ``jaco.load_run(path).rerun()`` or ``jaco rerun PATH`` reruns it and checks it bit for bit."""
        from .records import save_run

        return save_run(self, path)

    def to_world(self) -> np.ndarray:
        """The path as ``(K, 2)`` world ``(x, y)`` in metres (cell centres), from the map's ROS
        ``resolution`` and ``origin``; a ProblemError when the map has none."""
        if self.grid is None:
            raise JacoError("this Result has no grid: world coordinates need the map")
        return self.grid.cell_to_world(np.asarray(self.path, np.int64).reshape(-1, 2))

    def save_path(self, path, frame: str | None = None):
        """Write the path as ``.csv`` (columns ``row,col`` and, in the world frame, ``x,y``
        in metres) or ``.json``; ``frame`` is ``"world"`` or ``"cells"`` (default: world when the
        map has a resolution). Returns the path written."""
        from .records import save_path

        return save_path(self, path, frame)


def path_cells(grid: Grid, start, best_cells) -> np.ndarray:
    """``(K, 2)`` path from the start cell and the best ant's entered cells."""
    cells = np.asarray(best_cells)
    flat = np.concatenate([[grid.index(start)], cells[cells >= 0]])
    return np.stack(np.divmod(flat, grid.width), axis=1).astype(np.int64)


def gap(length, optimal) -> float:
    if not math.isfinite(length):
        return math.inf
    return 0.0 if optimal == 0 else (length - optimal) / optimal


def to_result(
    out, *, grid, variant, start, goal, optimal, seed, params, n_ants, n_iters, steplimit, connectivity=8
) -> Result:
    """Convert one (unbatched) :class:`RunOutput` to a :class:`Result`."""
    success = bool(np.isfinite(out.best_cost))
    length = float(out.best_length) * grid.cell_size if success else math.inf
    opt = float(optimal) * grid.cell_size
    return Result(
        variant=variant.name,
        path=path_cells(grid, start, out.best_cells) if success else np.empty((0, 2), np.int64),
        length=length,
        success=success,
        cost=float(out.best_cost),
        optimal=opt,
        gap=gap(length, opt),
        best_iteration=int(out.best_iteration),
        history={k: np.asarray(v) for k, v in out.history._asdict().items()},
        coverage=int(out.covered) / grid.n_free,
        seed=int(seed),
        params={k: float(params[k]) for k in variant.params},
        n_ants=n_ants,
        n_iters=n_iters,
        steplimit=steplimit,
        start=tuple(int(v) for v in start),
        goal=tuple(int(v) for v in goal),
        grid=grid,
        pheromone=None if out.tau is None else np.asarray(out.tau),
        connectivity=int(connectivity),
    )


def solve(
    grid: Grid,
    start,
    goal,
    variant="mmas",
    *,
    seed: int = 0,
    n_ants: int = 50,
    n_iters: int = 100,
    steplimit: int | None = None,
    connectivity: int = 8,
    keep_pheromone: bool = False,
    waypoints=None,
    **params,
) -> Result:
    """Plan a path from ``start`` to ``goal`` (``(row, col)`` cells) with one ACO variant.

    Everything is validated before anything compiles: the map, start and goal (and that the goal
    is reachable), the sizes, and every parameter (unknown names list the valid ones).
    ``waypoints=[(r, c), ...]``: visit them in order, then the goal; one leg per target, all legs
    in one batched call, one combined Result (:mod:`jaco.waypoints`).

    >>> import jaco
    >>> grid = jaco.Grid.from_rows(["....", ".##.", "...."])
    >>> r = jaco.solve(grid, (0, 0), (2, 3), "mmas", seed=1, n_ants=8, n_iters=5)
    >>> r.success, round(r.length, 3), round(r.optimal, 3)
    (True, 5.0, 5.0)
    """
    variant = get_variant(variant)
    steplimit = default_steplimit(grid) if steplimit is None else steplimit
    check_sizes(n_ants, n_iters, steplimit)
    if not isinstance(seed, (int, np.integer)) or isinstance(seed, bool):
        raise JacoError(f"seed must be an integer, got {seed!r}")
    values = resolve_params(variant, params, where=f"variant {variant.name!r}")
    for k, v in values.items():
        if v.ndim:
            raise JacoError(f"solve takes one value per parameter; {k!r} has {v.size} (use jaco.sweep)")
    if waypoints is not None:  # several targets (ALGORITHMS.md §8.5)
        from .waypoints import solve_waypoints

        return solve_waypoints(
            grid, start, goal, variant, waypoints, seed=seed, n_ants=n_ants, n_iters=n_iters,
            steplimit=steplimit, connectivity=connectivity, keep_pheromone=keep_pheromone, values=values,
        )
    problem = make_problem(grid, start, goal, connectivity=connectivity)
    run = compiled_run(variant, n_ants, n_iters, steplimit, keep_pheromone, batched=False)
    out = run(jax.random.key(seed), problem, params_from(values))
    return to_result(
        jax.device_get(out),
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
