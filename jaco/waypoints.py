"""Several targets (the chaos-ACO paper; docs/algorithms.md §7): visit waypoints in order, then
the goal.

``jaco.solve(grid, start, goal, planner, waypoints=[(r, c), ...])`` works with every planner.
The trip start → w₀ → w₁ → … → goal is cut into legs; each leg is an ordinary run of the
planner from one target to the next (its ants start with a fresh tabu list, and the leg has its
own pheromone, started afresh). All legs are problems of one map shape, so they are stacked
(:func:`jaco.engine.problem.stack`) and run as ONE jitted call, vmapped over (key, problem) pairs:
repeated calls with the same number of legs, sizes and map shape reuse the compiled function.

Seeds: leg 0 uses ``jax.random.key(seed)`` (so it is exactly ``jaco.solve(grid, start, w₀,
seed=seed)``), leg i ≥ 1 uses ``jax.random.fold_in(jax.random.key(seed), i)``. The same seed
therefore gives the same trip bit for bit.

The combined :class:`~jaco.engine.result.Result`: ``path`` is the concatenation of the legs' best paths
(each junction cell once); ``length``, ``cost`` and ``optimal`` are the sums over the legs (the
optimum of a trip through fixed waypoints in a fixed order is the sum of the exact leg optima);
``success`` only when every leg succeeded; ``best_iteration`` is the last leg's best iteration
(the max; −1 when a leg failed). ``history`` combines the legs iteration by iteration: ``best``,
``iteration_best`` and ``mean`` are sums over the legs (the best-so-far trip, the trip of each
leg's iteration-best ant, the expected length of a trip made of random successful ants; inf while
some leg has none), ``success_rate`` is the product (the chance that ants drawn one per leg all
arrive). ``coverage`` is the largest leg coverage (a lower bound of the union, which the run does
not record). With ``keep_pheromone`` the pheromone has a leading leg axis.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any, cast

import jax
import jax.numpy as jnp
import numpy as np

from .engine.cache import cached
from .engine.checks import params_from, prepare
from .engine.planner import Planner
from .engine.problem import make_problem, stack
from .engine.result import Result, to_result
from .engine.run import fetched, make_run, paired_runs, seed_key
from .engine.shape import RunShape
from .errors import ProblemError
from .exact import distance_field, shortest_path
from .grid import Grid
from .metrics import gap
from .progress import run_interruptibly


def check_waypoints(
    grid: Grid, start: Any, goal: Any, waypoints: Any, *, connectivity: int = 8
) -> list[tuple[int, int]]:
    """The trip's targets ``[start, w₀, …, goal]`` as ``(row, col)`` tuples, validated with numpy.

    Raises :class:`~jaco.errors.ProblemError` naming the offending point (``waypoints[i]``) when
    it is not a pair of integers, lies outside the map, on an obstacle, or cannot be reached from
    the previous target (exact search, same move model)."""
    if not isinstance(grid, Grid):
        raise ProblemError(f"expected a jaco.Grid, got {type(grid).__name__}")
    bad = f"waypoints must be a list of (row, col) pairs (one waypoint: [(r, c)]), got {waypoints!r}"
    if isinstance(waypoints, (str, bytes)):
        raise ProblemError(bad)
    try:
        items = list(waypoints)
    except TypeError:
        raise ProblemError(bad) from None
    if len(items) == 2 and all(np.isscalar(v) for v in items):  # a lone (r, c), not a list of them
        raise ProblemError(bad)
    waypoints = items
    labels = ["start"] + [f"waypoints[{i}]" for i in range(len(waypoints))] + ["goal"]
    points = [grid.check_cell(p, label) for p, label in zip([start, *waypoints, goal], labels)]
    for i in range(1, len(points)):
        dist = distance_field(grid, points[i], connectivity=connectivity)
        if not math.isfinite(dist[points[i - 1]]):
            raise ProblemError(
                f"{labels[i]} {points[i]} cannot be reached from {labels[i - 1]} {points[i - 1]} "
                f"on map {grid.name!r} ({connectivity}-connected, no corner cutting)"
            )
    return points


def leg_keys(seed: int, n_legs: int) -> jax.Array:
    """Keys ``(n_legs,)``: ``key(seed)`` for leg 0, ``fold_in(key(seed), i)`` for leg i ≥ 1."""
    base = seed_key(seed)  # a solve's key: leg 0 is that solve
    return jnp.stack([base] + [jax.random.fold_in(base, i) for i in range(1, n_legs)])


def compiled_legs(planner: Planner, shape: RunShape) -> Any:
    """The jitted run over (key, problem) pairs with shared params
    (:func:`jaco.engine.run.paired_runs`), cached like :func:`jaco.engine.run.compiled_run` (by
    the planner and :attr:`RunShape.program`)."""

    def build():
        run = make_run(planner, **shape.sizes, keep_pheromone=shape.keep_pheromone)
        return jax.jit(paired_runs(run))

    return cached(("legs", planner, *shape.program), build)


def run_legs(grid: Grid, points: list, planner: Planner, *, seed: int, shape: RunShape, values: dict) -> list[Result]:
    """One :class:`Result` per leg ``points[i] → points[i+1]``, all legs in one batched call.
    ``points`` come from :func:`check_waypoints`; ``values`` are validated parameter values."""
    legs = list(zip(points[:-1], points[1:]))
    problems = [make_problem(grid, a, b, connectivity=shape.connectivity) for a, b in legs]
    run = compiled_legs(planner, shape)
    out = run_interruptibly(lambda: fetched(run(leg_keys(seed, len(legs)), stack(problems), params_from(values))))
    return [
        to_result(
            jax.tree.map(lambda x, i=i: x[i], out),
            grid=grid,
            planner=planner,
            start=a,
            goal=b,
            optimal=problems[i].optimal,
            seed=seed,
            params=values,
            shape=shape,
        )
        for i, (a, b) in enumerate(legs)
    ]


def combine(legs: list[Result]) -> Result:
    """One :class:`Result` for the whole trip (see the module docstring for each field)."""
    success = all(r.success for r in legs)
    path = np.concatenate([legs[0].path] + [r.path[1:] for r in legs[1:]]) if success else np.empty((0, 2), np.int64)
    length = float(sum(r.length for r in legs)) if success else math.inf
    optimal = float(sum(r.optimal for r in legs))
    hist = {k: np.stack([r.history[k] for r in legs]) for k in legs[0].history}
    history = {k: np.prod(v, axis=0) if k == "success_rate" else np.sum(v, axis=0) for k, v in hist.items()}
    # every leg ran with the same keep_pheromone: all kept a pheromone, or none did
    pheromone = None if legs[0].pheromone is None else np.stack(cast("list[np.ndarray]", [r.pheromone for r in legs]))
    return dataclasses.replace(
        legs[0],
        path=path,
        length=length,
        success=success,
        cost=float(sum(r.cost for r in legs)),
        optimal=optimal,
        gap=gap(length, optimal),
        best_iteration=max(r.best_iteration for r in legs) if success else -1,
        history=history,
        coverage=max(r.coverage for r in legs),
        goal=legs[-1].goal,
        pheromone=pheromone,
    )


def solve_waypoints(
    grid: Grid,
    start: Any,
    goal: Any,
    planner: Planner,
    waypoints: Any,
    *,
    seed: int,
    n_ants: int,
    n_iters: int,
    steplimit: int | None,
    connectivity: int,
    keep_pheromone: bool | str,
    **params: Any,
) -> Result:
    """The body of ``jaco.solve(..., waypoints=...)`` (whose signature has the defaults): validate
    the call as a single run is validated, and every target; run the legs in one batched call;
    combine them."""
    points = check_waypoints(grid, start, goal, waypoints, connectivity=connectivity)
    steplimit, values = prepare(
        grid,
        planner,
        seed=seed,
        n_ants=n_ants,
        n_iters=n_iters,
        steplimit=steplimit,
        params=params,
        runs=len(points) - 1,
        keep_pheromone=keep_pheromone,
    )
    shape = RunShape(n_ants, n_iters, steplimit, connectivity, keep_pheromone)
    legs = run_legs(grid, points, planner, seed=seed, shape=shape, values=values)
    return dataclasses.replace(combine(legs), waypoints=tuple(tuple(p) for p in points[1:-1]))


def exact_trip(grid: Grid, points: Any, *, connectivity: int = 8) -> tuple[float, np.ndarray]:
    """Exact optimum of the trip through ``points`` in order: ``(length, path)``, the sum and the
    concatenation of the legs' shortest paths (``(inf, empty)`` when a leg is unreachable)."""
    legs = [shortest_path(grid, a, b, connectivity=connectivity) for a, b in zip(points[:-1], points[1:])]
    if not all(math.isfinite(length) for length, _ in legs):
        return math.inf, np.empty((0, 2), np.int64)
    path = np.concatenate([legs[0][1]] + [p[1:] for _, p in legs[1:]])
    return float(sum(length for length, _ in legs)), path
