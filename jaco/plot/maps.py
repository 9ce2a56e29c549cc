"""Figures on the map: the grid, paths through cell centres, pheromone per cell and its
animation over the iterations."""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
from matplotlib.axes import Axes
from matplotlib.colors import ListedColormap, LogNorm, Normalize
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator

from ..errors import ParamError, ProblemError
from ._common import figure_axes, legend_outside, viridis_with_bad

if TYPE_CHECKING:
    from matplotlib.animation import FuncAnimation
    from numpy.typing import ArrayLike

    from ..grid import Grid

    #: Paths to draw: one ``(K, 2)`` path, a list of paths, or a dict label -> path (None: no path).
    Paths = ArrayLike | Sequence[ArrayLike | None] | Mapping[Any, ArrayLike | None] | None

_MAP_CMAP = ListedColormap(["#2b2b2b", "#f4f4f0"])  # 0 = blocked (dark), 1 = free (light)
_START_STYLE = dict(marker="o", s=90, c="#2ca02c", edgecolors="black", linewidths=0.8, zorder=5)
_GOAL_STYLE = dict(marker="*", s=220, c="#d62728", edgecolors="black", linewidths=0.8, zorder=5)
_GRIDLINES_UP_TO = 60  # draw cell borders only while cells are still big enough to see


def _check_grid(grid):
    from ..grid import Grid

    if not isinstance(grid, Grid):
        raise ProblemError(f"expected a jaco.Grid, got {type(grid).__name__}")
    return grid


def _cell_axes(ax, grid, title) -> None:
    """Cell-coordinate limits (row 0 at the top), equal aspect, optional cell borders and title."""
    H, W = grid.shape
    ax.set_xlim(-0.5, W - 0.5)
    ax.set_ylim(H - 0.5, -0.5)
    ax.set_aspect("equal")
    ax.set_xlabel("col")
    ax.set_ylabel("row")
    ax.xaxis.set_major_locator(MaxNLocator(integer=True))  # ticks on cell centres
    ax.yaxis.set_major_locator(MaxNLocator(integer=True))
    if max(H, W) <= _GRIDLINES_UP_TO:
        ax.set_xticks(np.arange(-0.5, W, 1.0), minor=True)
        ax.set_yticks(np.arange(-0.5, H, 1.0), minor=True)
        ax.grid(which="minor", color="#b0b0b0", linewidth=0.3)
        ax.tick_params(which="minor", length=0)
    if title is not None:
        ax.set_title(title)


def _mark_ends(ax, start, goal) -> None:
    # Scatter, not plot: ax.lines then holds exactly the paths, which tests and users can count.
    if start is not None:
        ax.scatter([start[1]], [start[0]], **_START_STYLE)
    if goal is not None:
        ax.scatter([goal[1]], [goal[0]], **_GOAL_STYLE)


def _as_path(path) -> np.ndarray:
    try:
        arr = np.asarray(path if path is not None else np.zeros((0, 2)), dtype=float)
    except (TypeError, ValueError):
        raise ProblemError(f"a path must be a (K, 2) array of (row, col) cells, got {type(path).__name__}") from None
    if arr.size == 0:
        return np.zeros((0, 2))
    if arr.ndim != 2 or arr.shape[1] != 2:
        raise ProblemError(f"a path must be a (K, 2) array of (row, col) cells, got shape {arr.shape}")
    return arr


def _is_single_path(paths) -> bool:
    if isinstance(paths, np.ndarray):
        return paths.ndim == 2
    try:
        arr = np.asarray(paths, dtype=float)
    except (ValueError, TypeError):  # ragged: a list of paths of different lengths
        return False
    return arr.ndim == 2 and arr.shape[1] == 2


def _normalise_paths(paths, labels) -> tuple[list[np.ndarray], list[str] | None]:
    """``(list of (K,2) arrays, labels or None)`` from a path, a list of paths or a dict."""
    if isinstance(paths, dict):
        if labels is not None:
            raise ParamError("give labels either as the dict's keys or as labels=, not both")
        return [_as_path(p) for p in paths.values()], [str(k) for k in paths]
    if paths is None or _is_single_path(paths):
        paths = [paths]
        if isinstance(labels, str):
            labels = [labels]
    if isinstance(paths, (str, bytes)) or not hasattr(paths, "__iter__"):
        raise ProblemError(
            f"paths: expected a (K, 2) path, a list of paths or a dict of them, got {type(paths).__name__}"
        )
    paths = [_as_path(p) for p in paths]
    if labels is not None:
        labels = [str(lab) for lab in labels]
        if len(labels) != len(paths):
            raise ParamError(f"{len(labels)} labels for {len(paths)} paths")
    return paths, labels


def _draw_path(ax, path, **style):
    """One path as a line through cell centres (x = col, y = row); an empty path draws nothing."""
    (line,) = ax.plot(path[:, 1], path[:, 0], **style)
    return line


# -- maps and paths ----------------------------------------------------------------------------
def plot_map(
    grid: Grid,
    *,
    start: ArrayLike | None = None,
    goal: ArrayLike | None = None,
    ax: Axes | None = None,
    title: str | None = None,
) -> Figure:
    """The occupancy grid: obstacles dark, free cells light, start (green dot) and goal (red star)."""
    _check_grid(grid)
    fig, ax = figure_axes(ax)
    ax.imshow(grid.free.astype(np.uint8), cmap=_MAP_CMAP, vmin=0, vmax=1, origin="upper", interpolation="nearest")
    _cell_axes(ax, grid, title)
    _mark_ends(ax, start, goal)
    return fig


def plot_paths(
    grid: Grid,
    paths: Paths,
    *,
    labels: str | Sequence[str] | None = None,
    start: ArrayLike | None = None,
    goal: ArrayLike | None = None,
    ax: Axes | None = None,
    title: str | None = None,
) -> Figure:
    """The map with one or several paths drawn through cell centres.

    ``paths`` is one ``(K, 2)`` path, a list of paths, or a dict ``label -> path``. With labels
    (``labels=`` or the dict's keys) a legend beside the map names each path; a missing path
    (``None`` or empty, e.g. a failed run) keeps its legend entry, marked "(no path)" unless its
    label says so already. Each path is one ``Line2D`` in ``ax.lines``, in the given order.
    """
    paths, labels = _normalise_paths(paths, labels)
    fig = plot_map(grid, start=start, goal=goal, ax=ax, title=title)
    ax = ax if ax is not None else fig.axes[0]
    colors = [f"C{k % 10}" for k in range(len(paths))]
    for k, path in enumerate(paths):
        label = None if labels is None or len(path) or "no path" in labels[k] else labels[k] + " (no path)"
        label = labels[k] if label is None and labels is not None else label
        # Dots at the vertices only while cells are big enough for them to mean something.
        marker = "." if len(path) <= 80 else None
        _draw_path(
            ax, path, color=colors[k], linewidth=2.0, marker=marker, markersize=5, label=label, zorder=3 + k * 0.01
        )
    if labels is not None:
        legend_outside(ax)
    return fig


# -- pheromone ---------------------------------------------------------------------------------
def _per_cell(grid, tau) -> np.ndarray:
    """Pheromone as ``(H, W)``: from ``(H, W)``, per cell ``(N,)``, or per move ``(N, 8)`` /
    ``(H, W, 8)`` / flat ``(8N,)``.

    Per-move values are summed over the 8 moves out of each cell; non-finite entries (some layouts
    mark impossible moves with inf or NaN) count as 0 in that sum.
    """
    _check_grid(grid)
    H, W = grid.shape
    try:
        t = np.asarray(tau, dtype=float)
    except (TypeError, ValueError):
        raise ProblemError(f"pheromone must be an array of numbers, got {type(tau).__name__}") from None
    if t.shape == (H * W * 8,):  # the engine's flat per-move layout, from·8 + move
        t = t.reshape(H * W, 8)
    if t.shape == (H * W, 8) or t.shape == (H, W, 8):
        t = np.where(np.isfinite(t), t, 0.0).sum(axis=-1)
    if t.shape == (H * W,):
        t = t.reshape(H, W)
    if t.shape != (H, W):
        raise ProblemError(
            f"pheromone of shape {t.shape} does not fit the {H}x{W} grid: expected (H, W), "
            f"({H * W},) per cell or ({H * W}, 8) per move"
        )
    return t


def plot_pheromone(
    grid: Grid,
    tau: ArrayLike,
    *,
    path: ArrayLike | None = None,
    ax: Axes | None = None,
    log: bool = False,
    title: str | None = None,
) -> Figure:
    """Heatmap of the pheromone over the map, obstacles masked (dark), with a colorbar.

    ``tau`` is ``(H, W)``, ``(N,)`` per cell (``N = H*W``, flat index ``row*W + col``) or ``(N, 8)``
    per move (summed over the 8 moves out of each cell). ``log=True`` uses a log colour scale over
    the positive values (zeros are then shown as masked). ``path`` is drawn on top in white.
    The figure's one ``AxesImage`` holds the displayed per-cell values as a masked array.
    """
    per_cell = _per_cell(grid, tau)
    masked = np.ma.masked_where(~grid.free | ~np.isfinite(per_cell), per_cell)
    cmap = viridis_with_bad()
    norm = Normalize()
    if log:
        positive = masked.compressed()
        positive = positive[positive > 0]
        if positive.size:
            masked = np.ma.masked_where(np.ma.getmaskarray(masked) | (per_cell <= 0), per_cell)
            vmin, vmax = float(positive.min()), float(positive.max())
            norm = LogNorm(vmin=vmin, vmax=vmax if vmax > vmin else vmin * 10)
    fig, ax = figure_axes(ax, figsize=(7.0, 6.0))
    im = ax.imshow(masked, cmap=cmap, norm=norm, origin="upper", interpolation="nearest")
    fig.colorbar(im, ax=ax, label="pheromone" + (" (log scale)" if log else ""), shrink=0.85)
    _cell_axes(ax, grid, title)
    if path is not None:
        p = _as_path(path)
        if len(p):
            _draw_path(ax, p, color="white", linewidth=1.8)
            _mark_ends(ax, p[0], p[-1])
    return fig


# -- animation -----------------------------------------------------------------------------------
def animate_pheromone(
    grid: Grid,
    history: Iterable[ArrayLike],
    *,
    path: ArrayLike | None = None,
    every: int = 1,
    interval: int = 150,
    log: bool = True,
    title: str = "pheromone",
) -> FuncAnimation:
    """A :class:`matplotlib.animation.FuncAnimation` of the pheromone over the iterations.

    ``history`` is ``(T, N)`` or ``(T, N*8)`` — ``Result.pheromone`` of
    ``jaco.solve(..., keep_pheromone="history")`` — or a list of per-iteration arrays; every
    ``every``-th frame is drawn. The colour scale is fixed over all frames (log by default:
    pheromone spans orders of magnitude once the colony converges). Save with :func:`save_gif`.
    """
    from matplotlib.animation import FuncAnimation

    frames = [_per_cell(grid, h) for h in list(history)[:: max(1, int(every))]]
    if not frames:
        raise ParamError("animate_pheromone needs at least one pheromone frame")
    stack = np.ma.masked_where(np.broadcast_to(~grid.free, (len(frames),) + grid.shape), np.stack(frames))
    positive = stack.compressed()
    positive = positive[positive > 0]
    if log and positive.size:
        vmin, vmax = float(positive.min()), float(positive.max())
        norm: Normalize = LogNorm(vmin=vmin, vmax=vmax if vmax > vmin else vmin * 10)
    else:
        norm = Normalize(vmin=float(stack.min()), vmax=float(stack.max()))
    fig = Figure(figsize=(6.5, 6.0))
    ax = fig.add_subplot()
    im = ax.imshow(stack[0], cmap=viridis_with_bad(), norm=norm, origin="upper", interpolation="nearest")
    fig.colorbar(im, ax=ax, label="pheromone" + (" (log scale)" if log else ""), shrink=0.85)
    _cell_axes(ax, grid, None)
    if path is not None and len(_as_path(path)):
        p = _as_path(path)
        _draw_path(ax, p, color="white", linewidth=1.5)
        _mark_ends(ax, p[0], p[-1])
    step = max(1, int(every))

    def draw(i):
        im.set_data(stack[i])
        ax.set_title(f"{title}, iteration {i * step + 1}")
        return (im,)

    draw(0)
    return FuncAnimation(fig, draw, frames=len(frames), interval=interval, blit=False)
