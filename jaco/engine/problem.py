"""A planning problem: the grid as a fixed-degree graph, as arrays (the first of the five concepts).

Built and validated with numpy outside any jit, so that a user mistake is a clear
:class:`~jaco.errors.ProblemError` and never a traceback from XLA. The result is a pytree whose
leaves are arrays; start and goal are leaves too, so one compiled run serves many start/goal
pairs and many maps of one shape (stack problems with :func:`stack`).
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from ..errors import ProblemError
from ..grid import Grid
from ..moves import MOVES, cached_table
from .cache import kept

#: A Problem's array leaf: numpy when built by :func:`make_problem`, a jax array inside jit or on device.
ArrayLike = jax.Array | np.ndarray
#: A Problem's scalar leaves, numpy scalars when built and 0-d (or batched) arrays once stacked or
#: traced: a cell index (start, goal) and a length (optimal).
IndexLike = jax.Array | np.ndarray | np.integer
LengthLike = jax.Array | np.ndarray | np.floating


@jax.tree_util.register_dataclass
@dataclass(frozen=True)
class Problem:
    """One start/goal query on one map, as arrays (all lengths in cell units).

    ``nbr[i, k]`` is the cell reached from cell ``i`` by move ``k`` (``MOVES[k]``) or -1;
    ``step[i, k]`` its length (1 or sqrt 2, 0 where not allowed); ``offsets[k]`` the flat-index
    change of move k (``row·W + col`` arithmetic, so walks need no neighbour gather); ``xy[i]`` the cell's
    ``(row, col)``; ``clearance[i]`` its distance to the nearest obstacle; ``goal_dist[i]`` the
    exact shortest-path distance from cell ``i`` to the goal (inf where unreachable);
    ``optimal`` the exact optimum from start to goal.
    """

    nbr: ArrayLike
    step: ArrayLike
    offsets: ArrayLike
    xy: ArrayLike
    clearance: ArrayLike
    goal_dist: ArrayLike
    start: IndexLike
    goal: IndexLike
    optimal: LengthLike

    @property
    def n_cells(self) -> int:
        return self.nbr.shape[-2]


#: Queries whose :class:`Problem` (and its copy on the device) each grid keeps, the latest used.
QUERIES_KEPT = 8


def make_problem(grid: Grid, start: Any, goal: Any, *, connectivity: int = 8) -> Problem:
    """Validate a query and build its :class:`Problem` (numpy arrays, ready for jit).

    Raises :class:`ProblemError` for an empty map, a start or goal outside the map or on an
    obstacle, and a goal that cannot be reached from the start (found by the exact search).
    The arrays are read-only: a grid cannot change, so the problems of its last
    :data:`QUERIES_KEPT` queries are kept on it and a repeated query returns the same arrays.
    """
    return _query(grid, start, goal, connectivity)[0]


def device_problem(grid: Grid, start: Any, goal: Any, *, connectivity: int = 8) -> tuple[Problem, Problem]:
    """:func:`make_problem`'s problem, and the same with its arrays on the default device, kept on
    the grid with the query's numpy arrays: a repeated solve hands the compiled run device arrays,
    not numpy arrays that every call would copy (about 35 µs an array on the CPU, 0.3 ms of a
    solve)."""
    entry = _query(grid, start, goal, connectivity)
    if entry[1] is None:
        tables = grid.meta.setdefault(f"_device_tables{connectivity}", {})
        if not tables:  # the arrays every query of this grid shares, copied once
            tables.update({k: jnp.asarray(getattr(entry[0], k)) for k in ("nbr", "step", "offsets", "xy", "clearance")})
        entry[1] = Problem(
            **tables, **{k: jnp.asarray(getattr(entry[0], k)) for k in ("goal_dist", "start", "goal", "optimal")}
        )
    return entry[0], entry[1]


def _query(grid: Grid, start: Any, goal: Any, connectivity: int) -> list:
    """``[Problem, its device copy or None]`` of a query, validated, from the grid's cache."""
    if not isinstance(grid, Grid):
        raise ProblemError(f"expected a jaco.Grid, got {type(grid).__name__}")
    if isinstance(connectivity, bool) or connectivity not in (4, 8):
        raise ProblemError(f"connectivity must be 4 or 8 (int), got {connectivity!r}")
    if grid.n_free == 0:
        raise ProblemError(f"map {grid.name!r} has no free cell")
    s = grid.check_cell(start, "start")
    g = grid.check_cell(goal, "goal")
    queries = grid.meta.setdefault("_queries", {})
    return kept(queries, (s, g, connectivity), lambda: [_build(grid, s, g, connectivity), None], QUERIES_KEPT)


def _build(grid: Grid, s: tuple[int, int], g: tuple[int, int], connectivity: int) -> Problem:
    from ..exact import distance_field  # scipy loads on the first problem, not on import

    dist = distance_field(grid, g, connectivity=connectivity)
    if not math.isfinite(dist[s]):
        raise ProblemError(
            f"goal {g} cannot be reached from start {s} on map {grid.name!r} "
            f"({connectivity}-connected, no corner cutting)"
        )
    tables = grid.meta.get(f"_problem_tables{connectivity}")
    if tables is None:  # what every query of the grid shares
        nbr, step = cached_table(grid, connectivity)
        h, w = grid.shape
        rows, cols = np.divmod(np.arange(h * w), w)
        tables = dict(
            nbr=nbr,
            step=step.astype(np.float32),
            offsets=(MOVES[:, 0] * w + MOVES[:, 1]).astype(np.int32),
            xy=np.stack([rows, cols], axis=1).astype(np.float32),
            clearance=grid.clearance().ravel().astype(np.float32),
        )
        for a in tables.values():
            a.setflags(write=False)
        grid.meta[f"_problem_tables{connectivity}"] = tables
    goal_dist = dist.ravel().astype(np.float32)
    goal_dist.setflags(write=False)
    return Problem(
        **tables,
        goal_dist=goal_dist,
        start=np.int32(grid.index(s)),
        goal=np.int32(grid.index(g)),
        optimal=np.float32(dist[s]),
    )


def stack(problems: Iterable[Any]) -> Problem:
    """Stack problems of one map shape along a new leading axis (a batch of queries or maps)."""
    problems = list(problems)
    shapes = {p.nbr.shape for p in problems}
    if len(shapes) != 1:
        raise ProblemError(f"only problems of one map shape can be batched, got {sorted(shapes)}")
    return jax.tree.map(lambda *xs: np.stack([np.asarray(x) for x in xs]), *problems)


def to_device(problem: Problem) -> Problem:
    return jax.tree.map(jnp.asarray, problem)
