"""Path checks and quality figures, in plain numpy (no jax): what every planner is judged by.

A path is a ``(K, 2)`` integer array-like of ``(row, col)`` cells, row 0 at the top. The move model
is the one of ``docs/algorithms.md`` §1: 8-connected, step cost 1 straight and ``sqrt(2)`` diagonal, and
**no corner cutting** -- a diagonal move ``(r, c) -> (r+dr, c+dc)`` is allowed only when both
``(r+dr, c)`` and ``(r, c+dc)`` are free. ``connectivity=4`` allows straight moves only. Lengths are
in cell units times ``cell_size`` (the thesis uses 10).

Contents:

- single paths: :func:`validate_path`, :func:`path_length`, :func:`turns`, :func:`heading_change`,
  :func:`clearance_stats`, :func:`safety_cost` (S of Miao et al. 2021), :func:`line_of_sight`,
  :func:`shortcut` and :func:`any_angle_length` (``docs/algorithms.md`` §10), :func:`gap`, and
  :func:`path_metrics`, which gathers them all in a dict;
- sets of runs: :func:`performance_indices`, the thesis's E0, Et, Er and E (Hua Lu 2011, 2.3).

The energy cost E of Miao et al. 2021 is :func:`heading_change` (total absolute heading change in
radians).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any, overload

import numpy as np
from numpy.typing import ArrayLike

from .errors import ParamError, ProblemError
from .grid import Cell, Grid

__all__ = [
    "DEFAULT_WEIGHTS",
    "validate_path",
    "path_length",
    "turns",
    "heading_change",
    "clearance_stats",
    "SAFETY_RADIUS",
    "safety_terms",
    "safety_cost",
    "line_of_sight",
    "shortcut",
    "any_angle_length",
    "gap",
    "path_metrics",
    "performance_indices",
]

#: Default weights ``(a, b, c)`` of ``E = a*E0 + b*Et + c*Er``. The thesis does not print its
#: values; quality (best and mean gap) counts twice as much as time, and best and mean equally.
DEFAULT_WEIGHTS = (0.4, 0.2, 0.4)

#: Default radius (cells) of the safety cost S (Miao et al. 2021; ``docs/algorithms.md`` §5), shared
#: by :func:`safety_cost`, :func:`path_metrics` and the in-jit multi-objective cost
#: (``jaco.engine.cost.multi_objective``, ``Params.rs_cost``). The paper's Rs = 0.5 would score every free
#: cell 0 (a free cell is at least 1 cell from an obstacle centre); with 1 a cell orthogonally next
#: to an obstacle (or the map's edge) costs 0.5, a diagonal neighbour 1 − √2/2 ≈ 0.29, others 0.
SAFETY_RADIUS = 1.0

# Headings closer than this (radians) count as "no turn": guards float noise on long
# any-angle segments, far below the smallest real turn on a grid (atan(1/H) for any sane H).
_ANGLE_EPS = 1e-9


# -- helpers -----------------------------------------------------------------------------------
def _as_cells(path) -> np.ndarray:
    """``path`` as a ``(K, 2)`` array (K may be 0); ``None`` is the empty path. No other checks."""
    if path is None:
        return np.zeros((0, 2), dtype=np.int64)
    arr = np.asarray(path)
    if arr.size == 0:
        return np.zeros((0, 2), dtype=np.int64)
    if arr.ndim != 2 or arr.shape[1] != 2:
        raise ProblemError(f"a path must be a (K, 2) array of (row, col) cells, got shape {arr.shape}")
    return arr


def _as_int_cells(path) -> np.ndarray:
    """``path`` as a ``(K, 2)`` int64 array; raises if it holds non-integer values."""
    arr = _as_cells(path)
    if arr.dtype.kind not in "iu":
        if arr.dtype.kind not in "fb" or not np.all(np.isfinite(arr)) or np.any(arr != np.round(arr)):
            raise ProblemError(f"a path must hold integer (row, col) cells, got dtype {arr.dtype}")
    return arr.astype(np.int64)


def _cell(p) -> tuple[int, int]:
    return (int(p[0]), int(p[1]))


def _steps(path) -> np.ndarray:
    """Non-zero step vectors ``(K', 2)`` of a path; repeated cells have no heading and are dropped."""
    arr = np.asarray(_as_cells(path), dtype=float)
    d = np.diff(arr, axis=0)
    return d[np.any(d != 0, axis=1)]


def _turn_angles(path) -> np.ndarray:
    """Absolute heading change in [0, pi] at each interior vertex (between non-zero steps)."""
    d = _steps(path)
    if len(d) < 2:
        return np.zeros(0)
    a, b = d[:-1], d[1:]
    cross = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
    dot = np.sum(a * b, axis=1)
    return np.abs(np.arctan2(cross, dot))


def _clearance_at(grid, cells: np.ndarray) -> np.ndarray:
    """``grid.clearance()`` at the cells; cells off the map count as blocked (clearance 0)."""
    clr = grid.clearance()
    H, W = grid.shape
    r, c = cells[:, 0], cells[:, 1]
    inside = (r >= 0) & (r < H) & (c >= 0) & (c < W)
    out = np.zeros(len(cells), dtype=float)
    out[inside] = clr[r[inside], c[inside]]
    return out


def _check_connectivity(connectivity) -> None:
    if connectivity not in (4, 8):
        raise ParamError(f"connectivity must be 4 or 8, got {connectivity!r}")


# -- validity ----------------------------------------------------------------------------------
def validate_path(
    grid: Grid, path: ArrayLike, start: Cell | None = None, goal: Cell | None = None, connectivity: int = 8
) -> list[str]:
    """The problems of ``path`` on ``grid`` under the move model, as messages; ``[]`` if valid.

    Reports, each message naming the path index (``path[i]``): an empty path, a cell out of
    bounds, a blocked cell, a jump (consecutive cells not neighbours, or the same cell twice in a
    row), a diagonal move with ``connectivity=4``, a corner cut, and -- when ``start`` / ``goal``
    are given -- a wrong first / last cell. A single-cell path equal to both start and goal is
    valid. Revisiting a cell later in the path (a loop) is allowed.
    """
    _check_connectivity(connectivity)
    try:
        cells = _as_int_cells(path)
    except ProblemError as exc:
        return [str(exc)]
    if len(cells) == 0:
        return ["path is empty"]

    H, W = grid.shape
    free = grid.free
    problems: list[str] = []
    inside = (cells[:, 0] >= 0) & (cells[:, 0] < H) & (cells[:, 1] >= 0) & (cells[:, 1] < W)
    for j in np.flatnonzero(~inside):
        problems.append(f"path[{j}] = {_cell(cells[j])} is out of bounds of the {H}x{W} grid")
    for j in np.flatnonzero(inside):
        if not free[cells[j, 0], cells[j, 1]]:
            problems.append(f"path[{j}] = {_cell(cells[j])} is blocked")

    for i in range(len(cells) - 1):
        a, b = _cell(cells[i]), _cell(cells[i + 1])
        dr, dc = b[0] - a[0], b[1] - a[1]
        where = f"path[{i}] -> path[{i + 1}]"
        if dr == 0 and dc == 0:
            problems.append(f"{where}: jump: cell {a} repeated (every step must move)")
        elif max(abs(dr), abs(dc)) > 1:
            problems.append(f"{where}: jump: {a} to {b} are not neighbours")
        elif dr != 0 and dc != 0:
            if connectivity == 4:
                problems.append(f"{where}: diagonal move {a} to {b} is not allowed with connectivity=4")
            elif inside[i] and inside[i + 1]:
                # Both orthogonal cells are in bounds when both ends are.
                blocked = [o for o in ((b[0], a[1]), (a[0], b[1])) if not free[o]]
                if blocked:
                    names = " and ".join(str(o) for o in blocked)
                    problems.append(f"{where}: corner cut: diagonal {a} to {b} passes blocked {names}")

    if start is not None and _cell(cells[0]) != _cell(start):
        problems.append(f"path[0] = {_cell(cells[0])} is not the start {_cell(start)} (wrong first cell)")
    if goal is not None and _cell(cells[-1]) != _cell(goal):
        last = len(cells) - 1
        problems.append(f"path[{last}] = {_cell(cells[-1])} is not the goal {_cell(goal)} (wrong last cell)")
    return problems


# -- shape of a path ---------------------------------------------------------------------------
def path_length(path: ArrayLike, cell_size: float = 1.0) -> float:
    """Sum of the Euclidean step lengths, times ``cell_size``; 0 for fewer than two vertices.

    Works for grid paths and for any-angle vertex lists alike.
    """
    arr = np.asarray(_as_cells(path), dtype=float)
    if len(arr) < 2:
        return 0.0
    return float(np.sum(np.hypot(*np.diff(arr, axis=0).T)) * cell_size)


def turns(path: ArrayLike) -> int:
    """Number of heading changes along the path (repeated cells are ignored, a reversal counts)."""
    return int(np.count_nonzero(_turn_angles(path) > _ANGLE_EPS))


def heading_change(path: ArrayLike) -> float:
    """Total absolute heading change in radians; each turn adds its angle in [0, pi].

    This is the energy cost E of Miao et al. 2021 (``docs/algorithms.md`` §5).
    """
    return float(np.sum(_turn_angles(path)))


# -- obstacle proximity ------------------------------------------------------------------------
def clearance_stats(grid: Grid, path: ArrayLike) -> tuple[float, float]:
    """``(min, mean)`` of ``grid.clearance()`` (cells) over the path cells; ``(nan, nan)`` if empty.

    Cells off the map count as blocked (clearance 0), so an invalid path still gets a number.
    """
    cells = _as_int_cells(path)
    if len(cells) == 0:
        return (math.nan, math.nan)
    d = _clearance_at(grid, cells)
    return (float(d.min()), float(d.mean()))


def safety_terms(d_b: Any, rs: float, xp: Any = np) -> Any:
    """Per-cell safety cost ``max(0, 2*rs - d_b) / (2*rs)`` for clearances ``d_b`` (any shape).

    The one formula of S: :func:`safety_cost` sums it with numpy, the in-jit multi-objective cost
    with ``xp=jax.numpy``.
    """
    return xp.maximum(0.0, 2 * rs - d_b) / (2 * rs)


def safety_cost(grid: Grid, path: ArrayLike, rs: float = SAFETY_RADIUS) -> float:
    """Safety cost S = sum over path cells of ``max(0, 2*rs - d_b) / (2*rs)`` (Miao et al. 2021;
    ``docs/algorithms.md`` §5).

    ``d_b`` is ``grid.clearance()`` at the cell, the centre-to-centre distance in cells to the
    nearest blocked cell (the map's outside counts as blocked), and ``rs`` the safety radius in
    cells. Each cell adds a value in [0, 1]: 1 on an obstacle, 0 at ``2*rs`` or more from one.
    Note that free cells have ``d_b >= 1``, so with Miao et al. 2021's ``rs = 0.5`` a valid path always
    scores 0; the default is therefore :data:`SAFETY_RADIUS` = 1.
    """
    if not (np.isfinite(rs) and rs > 0):
        raise ParamError(f"safety radius rs must be a positive number, got {rs!r}")
    cells = _as_int_cells(path)
    if len(cells) == 0:
        return 0.0
    d = _clearance_at(grid, cells)
    return float(np.sum(safety_terms(d, rs)))


# -- line of sight and any-angle shortcutting ----------------------------------------------------
def _blocked_colsum(free: np.ndarray) -> np.ndarray:
    """``cs[r, c]`` = number of blocked cells in column ``c`` above row ``r``; shape ``(H+1, W)``."""
    return np.vstack([np.zeros((1, free.shape[1]), np.int64), np.cumsum(~free, axis=0, dtype=np.int64)])


def _los(shape, colsum: np.ndarray, a, b) -> bool:
    """Line of sight between cell centres ``a`` and ``b`` (see :func:`line_of_sight`), exact.

    Walk the columns the segment spans; in each, the rows its closed x-range covers form one
    interval, and the segment is clear iff no column's interval holds a blocked cell (one
    subtraction on the column prefix sums). All coordinates are kept as integers over ``2*dx`` so
    touching a grid line or a vertex is decided exactly, never by float rounding.
    """
    H, W = shape
    (r0, c0), (r1, c1) = _cell(a), _cell(b)
    if not (0 <= r0 < H and 0 <= c0 < W and 0 <= r1 < H and 0 <= c1 < W):
        return False
    if c0 > c1:  # walk left to right
        r0, c0, r1, c1 = r1, c1, r0, c0
    dx, dy = c1 - c0, r1 - r0
    if dx == 0:  # vertical: x = c0 + 1/2 never meets a grid line, only column c0 is crossed
        lo, hi = min(r0, r1), max(r0, r1)
        return bool(colsum[hi + 1, c0] - colsum[lo, c0] == 0)
    cols = np.arange(c0, c1 + 1)
    # Twice the x-range of the segment inside each column: [max(2i, 2c0+1), min(2i+2, 2c1+1)].
    x2_lo = np.maximum(2 * cols, 2 * c0 + 1)
    x2_hi = np.minimum(2 * cols + 2, 2 * c1 + 1)
    # y at x is N / (2*dx) with N = (2*r0 + 1)*dx + (2x - 2*c0 - 1)*dy, an integer.
    n_lo = (2 * r0 + 1) * dx + (x2_lo - 2 * c0 - 1) * dy
    n_hi = (2 * r0 + 1) * dx + (x2_hi - 2 * c0 - 1) * dy
    n_min, n_max = np.minimum(n_lo, n_hi), np.maximum(n_lo, n_hi)
    den = 2 * dx
    # Closed squares: row j is touched iff j <= y_max and j + 1 >= y_min.
    row_lo = -((-n_min) // den) - 1  # ceil(y_min) - 1
    row_hi = n_max // den  # floor(y_max)
    row_lo = np.clip(row_lo, 0, H - 1)
    row_hi = np.clip(row_hi, 0, H - 1)
    return bool(np.all(colsum[row_hi + 1, cols] - colsum[row_lo, cols] == 0))


def line_of_sight(grid: Grid, a: Cell, b: Cell) -> bool:
    """Whether the straight segment between the centres of cells ``a`` and ``b`` is clear.

    Rule (a closed supercover): every cell whose *closed* unit square the segment touches must be
    free and in bounds. Where the segment passes exactly through a grid vertex it touches all four
    cells around it, so it needs all four free -- the same rule as no corner cutting. Hence every
    allowed 8-connected step has line of sight, and a diagonal step past a blocked corner does not;
    the rule is symmetric in ``a`` and ``b`` and decided in exact integer arithmetic.
    """
    return _los(grid.shape, _blocked_colsum(grid.free), a, b)


def shortcut(grid: Grid, path: ArrayLike) -> np.ndarray:
    """Greedy line-of-sight shortcutting of a grid path: the any-angle vertex list ``(M, 2)``.

    From the current vertex, jump to the farthest later path vertex in sight (:func:`line_of_sight`)
    and repeat until the last vertex. Consecutive path vertices are always joined, even out of sight
    (an invalid path is shortened where it can be, never broken), so by the triangle inequality the
    result is never longer than the path. Returns the first and last cells and the kept corners.
    """
    cells = _as_int_cells(path)
    if len(cells) <= 2:
        return cells.copy()
    colsum = _blocked_colsum(grid.free)
    keep = [0]
    i, last = 0, len(cells) - 1
    while i < last:
        j = last
        # Farthest first: sight is not monotone along a path, so scanning forward and stopping at
        # the first blocked vertex could miss a farther visible one.
        while j > i + 1 and not _los(grid.shape, colsum, cells[i], cells[j]):
            j -= 1
        keep.append(j)
        i = j
    return cells[keep]


def any_angle_length(grid: Grid, path: ArrayLike, cell_size: float = 1.0) -> float:
    """Length of :func:`shortcut` of the path, times ``cell_size``; never more than ``path_length``."""
    return path_length(shortcut(grid, path), cell_size)


# -- quality against the optimum ---------------------------------------------------------------
@overload
def gap(length: float, optimal: float) -> float: ...
@overload
def gap(length: np.ndarray, optimal: float) -> float | np.ndarray: ...  # a 0-d array: a float


def gap(length: float | np.ndarray, optimal: float) -> float | np.ndarray:
    """Relative gap ``(length - optimal) / optimal``: the one gap of jaco (results, waypoint trips,
    the APF planner, records, sweep tables).

    The convention: inf when ``length`` is inf (a failed run); when ``optimal`` is 0 (start on
    the goal), 0 when ``length`` is 0 too and inf for any positive length. ``length`` may be an
    array (a sweep's column of lengths over one optimum): the gap of each, as float64.
    ``optimal`` must be finite and >= 0, ``length`` >= 0 or inf (a ParamError otherwise).
    """
    optimal = float(optimal)
    if not (math.isfinite(optimal) and optimal >= 0):
        raise ParamError(f"optimal length must be finite and >= 0, got {optimal!r}")
    # a Python number without numpy's calls: a solve's Result asks for one right after its run
    if not isinstance(length, (float, int)) and np.ndim(length):
        lengths = np.asarray(length, np.float64)
        if np.any(np.isnan(lengths) | (lengths < 0)):
            raise ParamError("lengths must be >= 0 (or inf for a failed run)")
        if optimal == 0:
            return np.where(lengths == 0, 0.0, math.inf)
        return np.where(np.isinf(lengths), math.inf, (lengths - optimal) / optimal)
    length = float(length)
    if math.isnan(length) or length < 0:
        raise ParamError(f"length must be >= 0 (or inf for a failed run), got {length!r}")
    if math.isinf(length):
        return math.inf
    if optimal == 0:
        return 0.0 if length == 0 else math.inf
    return (length - optimal) / optimal


def path_metrics(grid: Grid, path: ArrayLike, optimal: float | None = None, rs: float = SAFETY_RADIUS) -> dict:
    """Every single-path figure in one dict.

    Keys: ``length`` and ``any_angle_length`` (times ``grid.cell_size``), ``turns``,
    ``heading_change`` (radians), ``min_clearance`` and ``mean_clearance`` (cells), ``safety``
    (:func:`safety_cost` with ``rs``), ``valid`` (bool) and ``problems`` (list of str, from
    :func:`validate_path` without start/goal), plus ``gap`` only when ``optimal`` (same units as
    ``length``) is given. An empty path (or ``None``) has length 0 and NaN clearances.
    """
    problems = validate_path(grid, path)
    try:
        cells = _as_int_cells(path)
    except ProblemError:
        cells = np.zeros((0, 2), dtype=np.int64)
    length = path_length(cells, grid.cell_size)
    cmin, cmean = clearance_stats(grid, cells)
    out = {
        "length": length,
        "turns": turns(cells),
        "heading_change": heading_change(cells),
        "min_clearance": cmin,
        "mean_clearance": cmean,
        "safety": safety_cost(grid, cells, rs),
        "any_angle_length": any_angle_length(grid, cells, grid.cell_size),
        "valid": not problems,
        "problems": problems,
    }
    if optimal is not None:
        out["gap"] = gap(length if len(cells) else math.inf, optimal)
    return out


# -- indices over a set of runs (thesis 2.3) ---------------------------------------------------
def performance_indices(
    best_lengths: ArrayLike,
    optimal: float,
    iters_to_converge: ArrayLike,
    time_per_iter: ArrayLike,
    max_iters: int,
    weights: Sequence[float] = DEFAULT_WEIGHTS,
) -> dict:
    """The thesis's performance indices over R independent runs (Hua Lu 2011, 2.3;
    ``docs/algorithms.md`` §1).

    - ``E0 = (c_b - c*) / c*``, ``c_b`` the best of the runs' lengths ``best_lengths``;
    - ``Et = I_a * T0 / I_max``, ``I_a`` the mean of ``iters_to_converge``, ``T0`` the mean of
      ``time_per_iter`` (seconds; scalars are accepted for both) and ``I_max = max_iters``;
    - ``Er = (c_a - c*) / c*``, ``c_a`` the mean of the runs' lengths;
    - ``E = a*E0 + b*Et + c*Er`` with ``(a, b, c) = weights``, which must be >= 0 and sum to 1.

    Failed runs (length inf) are left out of ``c_b`` and ``c_a``; if every run failed, E0, Er (and E,
    unless their weights are 0) are inf. NaNs in the iteration counts and times are ignored.
    Besides ``E0, Et, Er, E`` the dict holds ``c_best``, ``c_mean``, ``I_a``, ``T0`` and
    ``success_rate`` (share of runs with a finite length).
    """
    w = np.asarray(weights, dtype=float)
    if w.shape != (3,) or not np.all(np.isfinite(w)) or np.any(w < 0):
        raise ParamError(f"weights must be three numbers >= 0, got {weights!r}")
    if not math.isclose(float(w.sum()), 1.0, rel_tol=0, abs_tol=1e-9):
        raise ParamError(f"weights must sum to 1, got {tuple(w.tolist())} (sum {w.sum():g})")
    optimal = float(optimal)
    if not (np.isfinite(optimal) and optimal > 0):
        raise ParamError(f"optimal length c* must be finite and > 0, got {optimal!r}")
    if not (max_iters > 0):
        raise ParamError(f"max_iters must be > 0, got {max_iters!r}")
    lengths = np.atleast_1d(np.asarray(best_lengths, dtype=float))
    if lengths.size == 0 or np.any(np.isnan(lengths)):
        raise ParamError("best_lengths needs one length (or inf) per run, and no NaN")

    ok = lengths[np.isfinite(lengths)]
    c_best = float(ok.min()) if ok.size else math.inf
    c_mean = float(ok.mean()) if ok.size else math.inf
    e0 = (c_best - optimal) / optimal
    er = (c_mean - optimal) / optimal
    i_a = float(np.nanmean(np.atleast_1d(np.asarray(iters_to_converge, dtype=float))))
    t0 = float(np.nanmean(np.atleast_1d(np.asarray(time_per_iter, dtype=float))))
    et = i_a * t0 / float(max_iters)
    # A zero weight drops its term outright (0 * inf would be NaN).
    e = float(sum(wk * v for wk, v in zip(w, (e0, et, er)) if wk != 0))
    return {
        "E0": e0,
        "Et": et,
        "Er": er,
        "E": e,
        "c_best": c_best,
        "c_mean": c_mean,
        "I_a": i_a,
        "T0": t0,
        "success_rate": float(ok.size / lengths.size),
    }
