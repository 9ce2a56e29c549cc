"""The move model every part of jaco shares: eight moves, their lengths, the neighbour table.

Moves are 8-connected with cost 1 (straight) and √2 (diagonal); a diagonal move needs both
orthogonal cells it passes to be free (no corner cutting, thesis 3.3.1 and MovingAI's rule), so
the ants (:mod:`jaco.engine.problem`) and the exact search (:mod:`jaco.exact`) walk the same
graph. ``connectivity=4`` keeps only the straight moves.
"""

from __future__ import annotations

import numpy as np

from .errors import ProblemError
from .grid import Grid

# The eight moves as (d_row, d_col): the four straight ones first, so 4-connectivity is a prefix.
# The lane walk has this order built in (walk.cc's grid_width, walk_lanes.cc's kAround); with
# another order it would still walk alike, through its slower per-move look-ups.
MOVES = np.array([(-1, 0), (0, 1), (1, 0), (0, -1), (-1, 1), (1, 1), (1, -1), (-1, -1)], dtype=np.int32)
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


def cached_table(grid: Grid, connectivity: int) -> tuple[np.ndarray, np.ndarray]:
    """:func:`neighbour_table` of ``grid``, computed once per grid and connectivity (read-only)."""
    key = f"_nbr{connectivity}"
    if key not in grid.meta:
        nbr, step = neighbour_table(grid.free, connectivity)
        nbr.setflags(write=False)
        step.setflags(write=False)
        grid.meta[key] = (nbr, step)
    return grid.meta[key]
