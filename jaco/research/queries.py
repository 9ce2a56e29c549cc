"""The queries of a sweep or search: maps, start/goal pairs and run sizes, validated before anything
compiles, and their problems (exact optimum included), built once with numpy."""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np

from ..engine.checks import resolve_steplimit
from ..engine.memory import check_run_memory
from ..engine.problem import make_problem
from ..errors import JacoError
from ..grid import Grid


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
    planner: Any = None,
) -> tuple[Queries, int]:
    """Validate the maps, queries and sizes (before anything compiles) and build the problems;
    returns them and the step limit (when ``steplimit`` is None, the map's default for ``planner``:
    :func:`jaco.engine.checks.resolve_steplimit`)."""
    queries = _queries(grid, start, goal)
    shapes = {g.shape for g, _, _ in queries}
    if len(shapes) != 1:
        raise JacoError(f"all maps of a sweep must have one shape, got {sorted(shapes)}")
    steplimit = resolve_steplimit(queries[0][0], planner, steplimit, n_ants=n_ants, n_iters=n_iters)
    # one configuration of every query must fit: the chunks are cut under memory_budget from there
    check_run_memory(queries[0][0].n_cells, n_ants, n_iters, steplimit, runs=len(queries), what="a sweep chunk")
    problems = [make_problem(g, s, t, connectivity=connectivity) for g, s, t in queries]
    return Queries(
        [(g, tuple(int(x) for x in s), tuple(int(x) for x in t)) for g, s, t in queries], problems
    ), steplimit
