"""Seeded map generators: random maps with a guaranteed path, U-traps, the thesis's Wall, Circle,
H and S maps, and look-alikes of the papers' maps.

All are seeded with ``numpy.random.default_rng``, so the same arguments always give the same map;
every map with endpoints is connected start to goal under 8-connected moves without corner
cutting and carries ``meta["start"]`` / ``meta["goal"]``.
"""

from __future__ import annotations

import numbers
from typing import Any

import numpy as np

from ..errors import ProblemError
from ..exact import reachable
from ..grid import Cell, Grid


def _connected(grid: Grid, start, goal) -> bool:
    """Is ``goal`` reachable from ``start`` (8-connected, no corner cutting)?"""
    return bool(reachable(grid, start)[goal[0], goal[1]])


MAX_CELLS = 2**28  # a generated map's limit: its boolean mask and index tables stay a few GiB


def _hw(size_or_hw) -> tuple[int, int]:
    if isinstance(size_or_hw, (tuple, list)):
        if len(size_or_hw) != 2:
            raise ProblemError(f"size must be an int or (height, width), got {size_or_hw!r}")
        h, w = size_or_hw
    else:
        h = w = size_or_hw
    if not all(isinstance(v, (int, np.integer)) and not isinstance(v, bool) and v >= 1 for v in (h, w)):
        raise ProblemError(f"map size must be positive integers, got {size_or_hw!r}")
    if int(h) * int(w) > MAX_CELLS:
        raise ProblemError(f"map size {int(h)}x{int(w)} is more than the {MAX_CELLS} cells a generated map may have")
    return int(h), int(w)


def _cell_arg(cell, h: int, w: int, what: str) -> tuple[int, int]:
    return Grid(np.ones((h, w), bool)).check_cell(cell, what)


def _seed_arg(seed) -> int:
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ProblemError(f"seed must be an integer >= 0, got {type(seed).__name__} {seed!r}")
    return int(seed)


def _check_random_map_options(p: float, method: str, max_tries: int) -> None:
    """:func:`random_map`'s obstacle ratio, method and number of draws."""
    if not (isinstance(p, numbers.Real) and 0.0 <= p < 0.9):
        raise ProblemError(f"obstacle ratio p must be in [0, 0.9), got {p!r}")
    if method not in ("resample", "carve"):
        raise ProblemError(f"method must be 'resample' or 'carve', got {method!r}")
    if int(max_tries) < 1:
        raise ProblemError(f"max_tries must be >= 1, got {max_tries!r}")


def random_map(
    size_or_hw: int | tuple[int, int],
    p: float,
    seed: int,
    start: Cell | None = None,
    goal: Cell | None = None,
    *,
    method: str = "resample",
    max_tries: int = 1000,
) -> Grid:
    """A random map with obstacle ratio ``p`` whose ``start`` and ``goal`` are connected.

    Exactly ``round(p * H * W)`` cells are blocked (never ``start`` or ``goal``), drawn uniformly
    without replacement by ``numpy.random.default_rng(seed)``; the same arguments always give the
    same map.

    How a path is guaranteed (``method``):

    * ``"resample"`` (default): if ``goal`` is not reachable from ``start`` (8-connected moves, no
      corner cutting, :func:`jaco.exact.reachable`), draw a whole new map from the same seeded
      generator; give up with :class:`ProblemError` after ``max_tries`` draws. The map is an
      unconditioned draw given connectivity. Note that without corner cutting connectivity equals
      4-connectivity, whose percolation threshold is about 41 % obstacles: around p = 0.5 on
      30x30 and larger, resampling essentially never succeeds.
    * ``"carve"``: draw once, then clear a uniformly random monotone staircase (4-connected steps,
      each toward the goal) from ``start`` to ``goal``, and block as many other random free cells
      as the carving cleared, so the ratio stays exact (short of it only when the map is too small
      to hold the obstacles beside the corridor). Works for any ``p`` < 0.9, but the map then
      contains one planted corridor.

    Parameters
    ----------
    size_or_hw : int or (int, int)
        Side of a square map, or ``(H, W)``.
    p : float
        Obstacle ratio in [0, 0.9).
    seed : int
        Seed of the generator.
    start, goal : (row, col), optional
        Default to opposite corners ``(0, 0)`` and ``(H - 1, W - 1)``.

    Returns
    -------
    Grid
        Named ``random-{H}x{W}-p{p}-s{seed}``; ``meta`` has ``start``, ``goal``, ``p``, ``seed``,
        ``method`` and ``tries`` (draws used).
    """
    h, w = _hw(size_or_hw)
    _check_random_map_options(p, method, max_tries)
    start = _cell_arg((0, 0) if start is None else start, h, w, "start")
    goal = _cell_arg((h - 1, w - 1) if goal is None else goal, h, w, "goal")
    rng = np.random.default_rng(_seed_arg(seed))
    n = h * w
    protected = {start[0] * w + start[1], goal[0] * w + goal[1]}
    allowed = np.ones(n, dtype=bool)
    allowed[list(protected)] = False
    candidates = np.flatnonzero(allowed)
    k = min(int(round(p * n)), candidates.size)
    name = f"random-{h}x{w}-p{p:g}-s{seed}"
    meta = {"start": start, "goal": goal, "p": float(p), "seed": seed, "method": method}

    tries = 1 if method == "carve" else int(max_tries)
    for attempt in range(1, tries + 1):
        flat = np.ones(n, dtype=bool)
        flat[rng.permutation(candidates)[:k]] = False
        if method == "carve":
            flat = _carve(flat, h, w, start, goal, rng, protected)
        grid = Grid(flat.reshape(h, w), name=name, meta={**meta, "tries": attempt})
        if _connected(grid, start, goal):
            return grid
    if method == "carve":  # pragma: no cover - the staircase always connects
        raise AssertionError("carved map is not connected")
    raise ProblemError(
        f"no {h}x{w} map with obstacle ratio {p} connects {start} to {goal} in {max_tries} draws "
        f"(seed {seed}); lower p, raise max_tries, or use method='carve'"
    )


def _carve(flat, h, w, start, goal, rng, protected) -> np.ndarray:
    """Clear a random monotone staircase start -> goal, then re-block as many cells elsewhere."""
    dr, dc = goal[0] - start[0], goal[1] - start[1]
    steps = np.array([0] * abs(dr) + [1] * abs(dc))
    rng.shuffle(steps)  # a uniformly random monotone lattice path
    r, c = start
    path = [r * w + c]
    for s in steps:
        if s == 0:
            r += int(np.sign(dr))
        else:
            c += int(np.sign(dc))
        path.append(r * w + c)
    cells = np.array(path)
    cleared = int((~flat[cells]).sum())
    flat = flat.copy()
    flat[cells] = True
    if cleared:
        keep_free = np.zeros_like(flat)
        keep_free[cells] = True
        keep_free[list(protected)] = True
        spare = np.flatnonzero(flat & ~keep_free)
        flat[rng.choice(spare, size=min(cleared, spare.size), replace=False)] = False
    return flat


def with_endpoints(free: np.ndarray, name: str, start: Cell, goal: Cell, **meta: Any) -> Grid:
    grid = Grid(free, name=name, meta={"start": tuple(start), "goal": tuple(goal), **meta})
    if not (grid.is_free(start) and grid.is_free(goal) and _connected(grid, start, goal)):
        raise ProblemError(f"map {name!r}: goal {goal} is not reachable from start {start}")
    return grid


def utrap(size: int = 20) -> Grid:
    """A square map with a concave U-shaped trap (the thesis's concave maps: 15x15, 20x20, 30x30).

    The U is a one-cell-thick wall: two horizontal arms and a vertical back wall on the right;
    its opening faces left, away from the goal on the right edge. The start is in the middle of
    the pocket, so a walker that greedily heads for the goal runs into the back wall and must
    first walk out of the opening and around an arm. ``meta["start"]`` = middle of the pocket,
    ``meta["goal"]`` = ``(size // 2, size - 1)``; ``meta["trap"]`` = ``(top, bottom, left, right)``
    rows/columns of the U's walls.
    """
    n = int(size)
    if n < 7:
        raise ProblemError(f"a U trap needs size >= 7, got {size}")
    m = max(2, n // 5)  # free margin around the trap
    top, bottom, left, right = m, n - 1 - m, m, n - 1 - m
    free = np.ones((n, n), dtype=bool)
    free[top, left : right + 1] = False
    free[bottom, left : right + 1] = False
    free[top : bottom + 1, right] = False
    start = (n // 2, (left + right) // 2)
    goal = (n // 2, n - 1)
    return with_endpoints(free, f"utrap-{n}", start, goal, trap=(top, bottom, left, right))


def _corners(n: int):
    return (0, 0), (n - 1, n - 1)


def wall(size: int = 40) -> Grid:
    """Thesis fig. 4-9 "Wall": a 2-thick wall across the middle row band with one gap at 3/4 width.

    Start ``(0, 0)``, goal ``(size-1, size-1)``.
    """
    n = int(size)
    free = np.ones((n, n), dtype=bool)
    free[n // 2 - 1 : n // 2 + 1, :] = False
    g0 = (3 * n) // 4
    free[n // 2 - 1 : n // 2 + 1, g0 : g0 + max(2, n // 10)] = True
    return with_endpoints(free, f"wall-{n}", *_corners(n))


def circle(size: int = 40) -> Grid:
    """Thesis fig. 4-9 "Circle": a disc of radius size/4 in the centre.

    Start ``(0, 0)``, goal ``(size-1, size-1)``.
    """
    n = int(size)
    rr, cc = np.mgrid[0:n, 0:n]
    c = (n - 1) / 2
    free = np.hypot(rr - c, cc - c) > n / 4
    return with_endpoints(free, f"circle-{n}", *_corners(n))


def h_shape(size: int = 40) -> Grid:
    """Thesis fig. 4-9 "H": two 2-wide vertical bars joined by a crossbar in the middle.

    The H's upper pocket opens toward the start ``(0, 0)`` and the crossbar blocks the diagonal to
    the goal ``(size-1, size-1)``, so it also acts as a trap.
    """
    n = int(size)
    free = np.ones((n, n), dtype=bool)
    r0, r1 = n // 5, n - n // 5  # bar rows [r0, r1)
    a, b = n // 4, n - n // 4  # left bar starts at a, right bar ends at b (exclusive)
    free[r0:r1, a : a + 2] = False
    free[r0:r1, b - 2 : b] = False
    free[n // 2 - 1 : n // 2 + 1, a:b] = False
    return with_endpoints(free, f"h-{n}", *_corners(n))


def s_shape(size: int = 40) -> Grid:
    """Thesis fig. 4-9 "S": three 2-thick horizontal bars joined left-top and right-bottom.

    The upper pocket opens right, the lower pocket left. Start ``(0, 0)``, goal opposite.
    """
    n = int(size)
    free = np.ones((n, n), dtype=bool)
    a, b, mid = n // 5, n - n // 5, n // 2
    free[a : a + 2, a:b] = False  # top bar
    free[a : mid + 1, a : a + 2] = False  # upper-left upright
    free[mid - 1 : mid + 1, a:b] = False  # middle bar
    free[mid - 1 : b, b - 2 : b] = False  # lower-right upright
    free[b - 2 : b, a:b] = False  # bottom bar
    return with_endpoints(free, f"s-{n}", *_corners(n))


def _rect_map(h, w, n_rects, sides, seed, start, goal, name) -> Grid:
    """Axis-aligned rectangles of random sides in ``sides`` placed by ``default_rng(seed)``.

    Rectangles keep clear of ``start``/``goal``; a layout that disconnects them is redrawn.
    """
    rng = np.random.default_rng(_seed_arg(seed))
    for _ in range(1000):
        free = np.ones((h, w), dtype=bool)
        placed = 0
        while placed < n_rects:
            rh, rw = (int(v) for v in rng.integers(sides[0], sides[1] + 1, size=2))
            r0, c0 = int(rng.integers(0, h - rh + 1)), int(rng.integers(0, w - rw + 1))
            if any(r0 - 1 <= r <= r0 + rh and c0 - 1 <= c <= c0 + rw for r, c in (start, goal)):
                continue  # keep a free ring around the endpoints
            free[r0 : r0 + rh, c0 : c0 + rw] = False
            placed += 1
        grid = Grid(free, name=name, meta={"start": start, "goal": goal, "seed": seed})
        if _connected(grid, start, goal):
            return grid
    raise ProblemError(f"could not draw a connected {name}")  # pragma: no cover


def simple_20() -> Grid:
    """Look-alike of Dong & Zhao 2021's 20x20 "simple" map: a few scattered rectangles (seed 3020).

    The paper gives start (0, 0) and goal (20, 20) as lattice corners with y up, i.e. the
    bottom-left and top-right cells: start ``(19, 0)``, goal ``(0, 19)`` as (row, col).
    """
    return _rect_map(20, 20, 7, (2, 4), 3020, (19, 0), (0, 19), "simple-20")


def complex_30() -> Grid:
    """Look-alike of Dong & Zhao 2021's 30x30 "complex" map: many rectangles of sides 2..6 (seed 3030).

    The paper's start (0, 30) and goal (30, 0) are lattice corners with y up, i.e. the top-left and
    bottom-right cells: start ``(0, 0)``, goal ``(29, 29)`` as (row, col).
    """
    return _rect_map(30, 30, 18, (2, 6), 3030, (0, 0), (29, 29), "complex-30")
