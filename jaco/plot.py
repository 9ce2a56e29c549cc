"""Figures of maps, paths, pheromone and convergence, safe to use headless.

Every function returns a :class:`matplotlib.figure.Figure` and never calls ``plt.show``: figures are
built as plain ``Figure`` objects (no pyplot state, no GUI backend needed), or drawn into an existing
``Axes`` passed as ``ax=`` (then its figure is returned). Write them with :func:`save`; in a notebook
a returned ``Figure`` displays itself.

Axes are in cell coordinates: column on x, row on y with row 0 at the top (``imshow`` with
``origin="upper"``), and the centre of cell ``(row, col)`` at ``(x, y) = (col, row)``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.colors import ListedColormap, LogNorm, Normalize
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator

from .errors import ParamError, ProblemError

__all__ = ["plot_map", "plot_paths", "plot_pheromone", "plot_convergence", "save"]

_MAP_CMAP = ListedColormap(["#2b2b2b", "#f4f4f0"])  # 0 = blocked (dark), 1 = free (light)
_OBSTACLE_COLOR = "#2b2b2b"
_START_STYLE = dict(marker="o", s=90, c="#2ca02c", edgecolors="black", linewidths=0.8, zorder=5)
_GOAL_STYLE = dict(marker="*", s=220, c="#d62728", edgecolors="black", linewidths=0.8, zorder=5)
_GRIDLINES_UP_TO = 60  # draw cell borders only while cells are still big enough to see


# -- helpers -----------------------------------------------------------------------------------
def _figure_axes(ax, figsize=(6.0, 6.0)):
    """``(fig, ax)``: the given axes and its figure, or a new standalone figure with one axes."""
    if ax is not None:
        return ax.figure, ax
    fig = Figure(figsize=figsize)
    return fig, fig.add_subplot()


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
    arr = np.asarray(path if path is not None else np.zeros((0, 2)), dtype=float)
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


def _normalise_paths(paths, labels):
    """``(list of (K,2) arrays, labels or None)`` from a path, a list of paths or a dict."""
    if isinstance(paths, dict):
        if labels is not None:
            raise ParamError("give labels either as the dict's keys or as labels=, not both")
        return [_as_path(p) for p in paths.values()], [str(k) for k in paths]
    if paths is None or _is_single_path(paths):
        paths = [paths]
        if isinstance(labels, str):
            labels = [labels]
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
def plot_map(grid, *, start=None, goal=None, ax=None, title=None) -> Figure:
    """The occupancy grid: obstacles dark, free cells light, start (green dot) and goal (red star)."""
    fig, ax = _figure_axes(ax)
    ax.imshow(grid.free.astype(np.uint8), cmap=_MAP_CMAP, vmin=0, vmax=1, origin="upper",
              interpolation="nearest")
    _cell_axes(ax, grid, title)
    _mark_ends(ax, start, goal)
    return fig


def plot_paths(grid, paths, *, labels=None, start=None, goal=None, ax=None, title=None) -> Figure:
    """The map with one or several paths drawn through cell centres.

    ``paths`` is one ``(K, 2)`` path, a list of paths, or a dict ``label -> path``. With labels
    (``labels=`` or the dict's keys) a legend names each path; a missing path (``None`` or empty,
    e.g. a failed run) keeps its legend entry, marked "(no path)". Each path is one ``Line2D`` in
    ``ax.lines``, in the given order.
    """
    paths, labels = _normalise_paths(paths, labels)
    fig = plot_map(grid, start=start, goal=goal, ax=ax, title=title)
    ax = ax if ax is not None else fig.axes[0]
    colors = [f"C{k % 10}" for k in range(len(paths))]
    for k, path in enumerate(paths):
        label = None if labels is None else labels[k] + ("" if len(path) else " (no path)")
        # Dots at the vertices only while cells are big enough for them to mean something.
        marker = "." if len(path) <= 80 else None
        _draw_path(ax, path, color=colors[k], linewidth=2.0, marker=marker, markersize=5,
                   label=label, zorder=3 + k * 0.01)
    if labels is not None:
        ax.legend(loc="best", fontsize="small", framealpha=0.85)
    return fig


# -- pheromone ---------------------------------------------------------------------------------
def _per_cell(grid, tau) -> np.ndarray:
    """Pheromone as ``(H, W)``: from ``(H, W)``, per cell ``(N,)``, or per move ``(N, 8)`` / ``(H, W, 8)``.

    Per-move values are summed over the 8 moves out of each cell; non-finite entries (some layouts
    mark impossible moves with inf or NaN) count as 0 in that sum.
    """
    H, W = grid.shape
    t = np.asarray(tau, dtype=float)
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


def plot_pheromone(grid, tau, *, path=None, ax=None, log=False, title=None) -> Figure:
    """Heatmap of the pheromone over the map, obstacles masked (dark), with a colorbar.

    ``tau`` is ``(H, W)``, ``(N,)`` per cell (``N = H*W``, flat index ``row*W + col``) or ``(N, 8)``
    per move (summed over the 8 moves out of each cell). ``log=True`` uses a log colour scale over
    the positive values (zeros are then shown as masked). ``path`` is drawn on top in white.
    The figure's one ``AxesImage`` holds the displayed per-cell values as a masked array.
    """
    per_cell = _per_cell(grid, tau)
    masked = np.ma.masked_where(~grid.free | ~np.isfinite(per_cell), per_cell)
    cmap = _viridis_with_bad()
    norm = Normalize()
    if log:
        positive = masked.compressed()
        positive = positive[positive > 0]
        if positive.size:
            masked = np.ma.masked_where(np.ma.getmaskarray(masked) | (per_cell <= 0), per_cell)
            vmin, vmax = float(positive.min()), float(positive.max())
            norm = LogNorm(vmin=vmin, vmax=vmax if vmax > vmin else vmin * 10)
    fig, ax = _figure_axes(ax, figsize=(7.0, 6.0))
    im = ax.imshow(masked, cmap=cmap, norm=norm, origin="upper", interpolation="nearest")
    fig.colorbar(im, ax=ax, label="pheromone" + (" (log scale)" if log else ""), shrink=0.85)
    _cell_axes(ax, grid, title)
    if path is not None:
        p = _as_path(path)
        if len(p):
            _draw_path(ax, p, color="white", linewidth=1.8)
            _mark_ends(ax, p[0], p[-1])
    return fig


def _viridis_with_bad():
    from matplotlib import colormaps

    return colormaps["viridis"].with_extremes(bad=_OBSTACLE_COLOR)


# -- convergence -------------------------------------------------------------------------------
def _masked(values) -> np.ma.MaskedArray:
    # Iterations with no successful ant carry inf (or NaN): mask them so lines just break there.
    return np.ma.masked_invalid(np.asarray(values, dtype=float).ravel())


def plot_convergence(history, *, ax=None, optimal=None, label=None, title=None) -> Figure:
    """Best-so-far (solid) and iteration mean (dashed) cost per iteration, for one run or several.

    ``history`` is a dict with arrays under ``"best"`` (iteration best or best-so-far: the running
    minimum is drawn) and ``"mean"`` (optional), and optionally ``"success_rate"`` (drawn dotted on a
    twin axis, 0..1) and ``"label"``; or a list of such dicts. ``label`` is a string for one run or a
    list of strings, one per run (default: the dict's ``"label"``, else ``run i``). Inf or NaN values
    (iterations where no ant arrived) are masked. ``optimal`` adds a dashed horizontal line.
    """
    runs = [history] if isinstance(history, dict) else list(history)
    if not runs:
        raise ParamError("plot_convergence needs at least one history")
    if label is None:
        labels = [None] * len(runs)  # resolved per run below
    elif isinstance(label, str):
        labels = [label] if len(runs) == 1 else [f"{label} {k}" for k in range(len(runs))]
    else:
        labels = [str(lab) for lab in label]
        if len(labels) != len(runs):
            raise ParamError(f"{len(labels)} labels for {len(runs)} histories")
    fig, ax = _figure_axes(ax, figsize=(7.0, 4.5))
    twin = None
    for k, (run, lab) in enumerate(zip(runs, labels)):
        if "best" not in run:
            raise ParamError(f"history {k} has no 'best' array (keys: {sorted(run)})")
        if lab is None:
            lab = str(run.get("label", f"run {k}" if len(runs) > 1 else "run"))
        color = f"C{k % 10}"
        best = np.asarray(run["best"], dtype=float).ravel()
        # Running minimum; inf stays inf until the first success and is then masked.
        best_so_far = _masked(np.minimum.accumulate(np.where(np.isnan(best), np.inf, best)))
        iters = np.arange(len(best))
        ax.plot(iters, best_so_far, color=color, linewidth=2.0, label=f"{lab} best so far")
        if run.get("mean") is not None:
            mean = _masked(run["mean"])
            ax.plot(np.arange(len(mean)), mean, color=color, linewidth=1.2, linestyle="--",
                    alpha=0.8, label=f"{lab} iteration mean")
        if run.get("success_rate") is not None:
            if twin is None:
                twin = ax.twinx()
                twin.set_ylim(0.0, 1.05)
                twin.set_ylabel("success rate")
            rate = _masked(run["success_rate"])
            twin.plot(np.arange(len(rate)), rate, color=color, linewidth=1.0, linestyle=":",
                      alpha=0.9, label=f"{lab} success rate")
    if optimal is not None:
        ax.axhline(float(optimal), color="black", linestyle="--", linewidth=1.0,
                   label=f"optimum {float(optimal):.4g}")
    ax.set_xlabel("iteration")
    ax.set_ylabel("path cost")
    if title is not None:
        ax.set_title(title)
    handles, names = ax.get_legend_handles_labels()
    if twin is not None:
        h2, n2 = twin.get_legend_handles_labels()
        handles, names = handles + h2, names + n2
    # The twin axes is drawn over ax: its legend must live there to stay on top of its lines.
    (twin if twin is not None else ax).legend(handles, names, loc="best", fontsize="small",
                                              framealpha=0.85)
    return fig


# -- output ------------------------------------------------------------------------------------
def save(fig, path) -> Path:
    """Write ``fig`` as PNG (dpi 120, tight bounding box), creating parent folders; returns the path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120, bbox_inches="tight", format="png")
    return path
