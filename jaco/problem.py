"""A planning problem: the grid as a fixed-degree graph, as arrays (DESIGN.md concept 1).

Built and validated with numpy outside any jit, so that a user mistake is a clear
:class:`~jaco.errors.ProblemError` and never a traceback from XLA. The result is a pytree whose
leaves are arrays; start and goal are leaves too, so one compiled run serves many start/goal
pairs and many maps of one shape (stack problems with :func:`stack`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import jax
import jax.numpy as jnp
import numpy as np

from .errors import ProblemError
from .grid import Grid

# The eight moves as (d_row, d_col): the four straight ones first, so 4-connectivity is a prefix.
MOVES = np.array(
    [(-1, 0), (0, 1), (1, 0), (0, -1), (-1, 1), (1, 1), (1, -1), (-1, -1)], dtype=np.int32
)
MOVE_LENGTHS = np.hypot(MOVES[:, 0], MOVES[:, 1]).astype(np.float64)


def neighbour_table(free: np.ndarray, connectivity: int = 8) -> tuple[np.ndarray, np.ndarray]:
    """Neighbour table ``(N, 8)`` (flat index, -1 where the move is not allowed) and step lengths.

    A move is allowed when both cells are free and in bounds; a diagonal move also needs both
    orthogonal cells it passes to be free (no corner cutting, thesis 3.3.1 and MovingAI's rule).
    """
    if connectivity not in (4, 8):
        raise ProblemError(f"connectivity must be 4 or 8, got {connectivity!r}")
    free = np.asarray(free, dtype=bool)
    h, w = free.shape
    padded = np.pad(free, 1, constant_values=False)
    rows, cols = np.meshgrid(np.arange(h), np.arange(w), indexing="ij")
    nbr = np.full((h * w, 8), -1, dtype=np.int32)
    n_moves = 4 if connectivity == 4 else 8
    for k in range(n_moves):
        dr, dc = MOVES[k]
        ok = free & padded[1 + dr : 1 + dr + h, 1 + dc : 1 + dc + w]
        if dr and dc:  # diagonal: both orthogonal cells must be free
            ok &= padded[1 + dr : 1 + dr + h, 1 : 1 + w] & padded[1 : 1 + h, 1 + dc : 1 + dc + w]
        target = (rows + dr) * w + (cols + dc)
        nbr[:, k] = np.where(ok, target, -1).ravel()
    step = np.where(nbr >= 0, MOVE_LENGTHS[None, :], 0.0)
    return nbr, step


def _as_cell(grid: Grid, cell, what: str) -> tuple[int, int]:
    try:
        r, c = (int(v) for v in cell)
        if (r, c) != tuple(float(v) for v in cell):
            raise ValueError
    except (TypeError, ValueError):
        raise ProblemError(f"{what} must be a (row, col) pair of integers, got {cell!r}") from None
    if not grid.in_bounds((r, c)):
        raise ProblemError(
            f"{what} {(r, c)} is outside the {grid.height}x{grid.width} map "
            f"(rows 0..{grid.height - 1}, cols 0..{grid.width - 1})"
        )
    if not grid.free[r, c]:
        raise ProblemError(f"{what} {(r, c)} is on an obstacle")
    return r, c


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

    nbr: jax.Array
    step: jax.Array
    offsets: jax.Array
    xy: jax.Array
    clearance: jax.Array
    goal_dist: jax.Array
    start: jax.Array
    goal: jax.Array
    optimal: jax.Array

    @property
    def n_cells(self) -> int:
        return self.nbr.shape[-2]


def make_problem(grid: Grid, start, goal, *, connectivity: int = 8) -> Problem:
    """Validate a query and build its :class:`Problem` (numpy arrays, ready for jit).

    Raises :class:`ProblemError` for an empty map, a start or goal outside the map or on an
    obstacle, and a goal that cannot be reached from the start (found by the exact search).
    """
    from .exact import distance_field

    if not isinstance(grid, Grid):
        raise ProblemError(f"expected a jaco.Grid, got {type(grid).__name__}")
    if grid.n_free == 0:
        raise ProblemError(f"map {grid.name!r} has no free cell")
    s = _as_cell(grid, start, "start")
    g = _as_cell(grid, goal, "goal")
    dist = distance_field(grid, g, connectivity=connectivity)
    if not math.isfinite(dist[s]):
        raise ProblemError(
            f"goal {g} cannot be reached from start {s} on map {grid.name!r} "
            f"({connectivity}-connected, no corner cutting)"
        )
    nbr, step = _cached_table(grid, connectivity)
    h, w = grid.shape
    rows, cols = np.divmod(np.arange(h * w), w)
    return Problem(
        nbr=nbr,
        step=step.astype(np.float32),
        offsets=(MOVES[:, 0] * w + MOVES[:, 1]).astype(np.int32),
        xy=np.stack([rows, cols], axis=1).astype(np.float32),
        clearance=grid.clearance().ravel().astype(np.float32),
        goal_dist=dist.ravel().astype(np.float32),
        start=np.int32(grid.index(s)),
        goal=np.int32(grid.index(g)),
        optimal=np.float32(dist[s]),
    )


def _cached_table(grid: Grid, connectivity: int):
    key = f"_nbr{connectivity}"
    if key not in grid.meta:
        nbr, step = neighbour_table(grid.free, connectivity)
        nbr.setflags(write=False)
        step.setflags(write=False)
        grid.meta[key] = (nbr, step)
    return grid.meta[key]


def stack(problems) -> Problem:
    """Stack problems of one map shape along a new leading axis (a batch of queries or maps)."""
    problems = list(problems)
    shapes = {p.nbr.shape for p in problems}
    if len(shapes) != 1:
        raise ProblemError(f"only problems of one map shape can be batched, got {sorted(shapes)}")
    return jax.tree.map(lambda *xs: np.stack([np.asarray(x) for x in xs]), *problems)


def to_device(problem: Problem) -> Problem:
    return jax.tree.map(jnp.asarray, problem)
