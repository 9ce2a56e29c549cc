"""The front door: :func:`solve` and :func:`make_run` as ``jaco.solve`` / ``jaco.make_run``.

They take a planner by name or as a :class:`~jaco.engine.planner.Planner`, resolve the name
through the registry (:mod:`jaco.planners.registry`) and hand the planner to the engine:
:func:`jaco.engine.run.solve` for one run, :func:`jaco.waypoints.solve_waypoints` when there are
waypoints. This is the one place where the engine, the registry and the waypoints meet, so the
engine never imports the planners and the waypoints sit above the single run.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

from .engine import run as _run
from .engine.params import unknown_parameter
from .engine.planner import Planner
from .engine.result import Result
from .errors import ParamError, accepts_aliases
from .grid import Cell, Grid
from .planners.registry import get_planner
from .waypoints import solve_waypoints

__all__ = ["solve", "make_run"]

#: The keywords of :func:`solve` besides the planner's parameters.
SOLVE_KEYWORDS = ("seed", "n_ants", "n_iters", "steplimit", "connectivity", "keep_pheromone", "waypoints", "progress")


@accepts_aliases
def solve(
    grid: Grid,
    start: Cell,
    goal: Cell,
    planner: str | Planner = "mmas",
    *,
    seed: int = 0,
    n_ants: int = 50,
    n_iters: int = 100,
    steplimit: int | None = None,
    connectivity: int = 8,
    keep_pheromone: bool = False,
    waypoints: Sequence[Cell] | None = None,
    progress: bool | None = None,
    **params: float,
) -> Result:
    """Plan a path from ``start`` to ``goal`` (``(row, col)`` cells) with one ACO planner.

    Everything is validated before anything compiles: the map, start and goal (and that the goal
    is reachable), the sizes, and every parameter (an unknown name is answered with the closest
    parameters and keywords, ``n_ant`` -> ``n_ants``, and the valid ones).
    ``waypoints=[(r, c), ...]``: visit them in order, then the goal; one leg per target, all legs
    in one batched call, one combined Result (:mod:`jaco.waypoints`).
    ``progress``: a bar of iterations on stderr when the call takes more than two seconds; None
    (default) shows it on a terminal or in a notebook, True always, False never
    (:mod:`jaco.progress`; the results are the same either way; the legs of ``waypoints`` run as
    one batch, without a bar).

    >>> import jaco
    >>> grid = jaco.Grid.from_rows(["....", ".##.", "...."])
    >>> r = jaco.solve(grid, (0, 0), (2, 3), "mmas", seed=1, n_ants=8, n_iters=5)
    >>> r.success, round(r.length, 3), round(r.optimal, 3)
    (True, 5.0, 5.0)
    """
    planner = get_planner(planner)
    for name in params:  # a misspelt keyword of solve lands among the parameters: suggest both
        if name not in planner.params:
            raise ParamError(
                unknown_parameter(name, planner.params, f"planner {planner.name!r}", SOLVE_KEYWORDS, "jaco.solve")
            )
    kw: dict[str, Any] = dict(
        seed=seed,
        n_ants=n_ants,
        n_iters=n_iters,
        steplimit=steplimit,
        connectivity=connectivity,
        keep_pheromone=keep_pheromone,
        **params,
    )
    if waypoints is not None:
        return solve_waypoints(grid, start, goal, planner, waypoints, **kw)
    return _run.solve(grid, start, goal, planner, progress=progress, **kw)


@accepts_aliases
def make_run(
    planner: str | Planner, *, n_ants: int, n_iters: int, steplimit: int, keep_pheromone: bool | str = False
) -> Callable:
    """:func:`jaco.engine.run.make_run` for a planner given by name or as a :class:`Planner`:
    ``run(key, problem, params) -> RunOutput`` for fixed shapes (not jitted here)."""
    return _run.make_run(
        get_planner(planner), n_ants=n_ants, n_iters=n_iters, steplimit=steplimit, keep_pheromone=keep_pheromone
    )
