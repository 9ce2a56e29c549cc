"""The exact optimum: Dijkstra on the same move model as the ants (8-connected, no corner cutting).

Every quality figure in jaco is measured against these lengths. The graph is a scipy sparse
matrix built once per grid from the neighbour table; a single-source Dijkstra over the 512x512
MovingAI map takes a fraction of a second. Moves are symmetric, so a search from the goal gives
the distance *to* the goal from every cell.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import connected_components, dijkstra

from .engine.cache import kept
from .errors import ProblemError
from .grid import Cell, Grid
from .moves import cached_table


def _graph(grid: Grid, connectivity: int) -> csr_matrix:
    key = f"_graph{connectivity}"
    if key not in grid.meta:
        nbr, step = cached_table(grid, connectivity)
        src, k = np.nonzero(nbr >= 0)
        grid.meta[key] = csr_matrix((step[src, k], (src, nbr[src, k])), shape=(grid.n_cells, grid.n_cells))
    return grid.meta[key]


def _check_cell(grid: Grid, cell, what: str) -> int:
    if not isinstance(grid, Grid):
        raise ProblemError(f"expected a jaco.Grid, got {type(grid).__name__}")
    return grid.index(grid.check_cell(cell, what))


#: Distance fields kept per grid and connectivity (the latest goals first): solving one query again
#: (seeds, a search's trials, a notebook's cells) skips its Dijkstra, 9 ms on a 256x256 map.
FIELDS_KEPT = 8


def distance_field(grid: Grid, goal: Cell, *, connectivity: int = 8) -> np.ndarray:
    """Exact distance ``(H, W)`` from every cell to ``goal`` in cell units (inf where unreachable).
    Read-only: the fields of the last :data:`FIELDS_KEPT` goals are cached on the grid."""
    g = _check_cell(grid, goal, "goal")

    def field() -> np.ndarray:
        dist = dijkstra(_graph(grid, connectivity), directed=True, indices=g).reshape(grid.shape)
        dist.setflags(write=False)
        return dist

    return kept(grid.meta.setdefault(f"_fields{connectivity}", {}), g, field, FIELDS_KEPT)


def free_extent(grid: Grid, connectivity: int = 8) -> float:
    """How far apart free cells lie along the free cells: the longest shortest path a double sweep
    of the exact search finds, from a cell of the largest connected region to its farthest cell,
    then from that one to its farthest. A lower bound of the map's geodesic diameter (at least half
    of it, exact on a tree such as a perfect maze); a property of the map, not of any query; 0 with
    fewer than two free cells. Cached on the grid."""
    key = f"_extent{connectivity}"
    if key not in grid.meta:
        graph = _graph(grid, connectivity)
        cells = np.flatnonzero(grid.free.ravel())
        extent = 0.0
        if len(cells) > 1:
            _, labels = connected_components(graph, directed=False)  # each blocked cell is a region of its own
            region = np.bincount(labels[cells]).argmax()
            far = cells[labels[cells] == region][0]
            for _ in range(2):
                d = dijkstra(graph, directed=True, indices=far)
                far = int(np.argmax(np.where(np.isfinite(d), d, -1.0)))
            extent = float(d[far])
        grid.meta[key] = extent
    return grid.meta[key]


def shortest_path(grid: Grid, start: Cell, goal: Cell, *, connectivity: int = 8) -> tuple[float, np.ndarray]:
    """Exact shortest path: ``(length, path)`` with ``path`` a ``(K, 2)`` array of ``(row, col)``.

    ``length`` is in cell units times ``grid.cell_size``. When the goal cannot be reached the
    result is ``(inf, empty (0, 2) array)``.
    """
    s = _check_cell(grid, start, "start")
    g = _check_cell(grid, goal, "goal")
    dist, pred = dijkstra(_graph(grid, connectivity), directed=True, indices=s, return_predecessors=True)
    if not math.isfinite(dist[g]):
        return math.inf, np.empty((0, 2), dtype=np.int64)
    cells = [g]
    while cells[-1] != s:
        cells.append(pred[cells[-1]])
    path = np.array([grid.cell(i) for i in reversed(cells)], dtype=np.int64)
    return float(dist[g]) * grid.cell_size, path


def reachable(grid: Grid, start: Cell, *, connectivity: int = 8) -> np.ndarray:
    """Boolean mask ``(H, W)`` of the cells reachable from ``start`` (moves are symmetric)."""
    s = _check_cell(grid, start, "start")
    _, labels = connected_components(_graph(grid, connectivity), directed=False)
    return (labels == labels[s]).reshape(grid.shape) & grid.free
