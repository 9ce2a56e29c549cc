"""Figures of maps, paths, pheromone and convergence, safe to use headless.

Every function returns a :class:`matplotlib.figure.Figure` and never calls ``plt.show``: figures are
built as plain ``Figure`` objects (no pyplot state, no GUI backend needed), or drawn into an existing
``Axes`` passed as ``ax=`` (then its figure is returned). Write them with :func:`save`; in a notebook
a returned ``Figure`` displays itself.

Legends sit outside the axes, to the right (of a twin axis too), so they never cover data; the
saved and displayed figures grow to hold them (``bbox_inches="tight"``). Gaps are fractions in the
data and shown in % on axes, labels and annotations.

Axes are in cell coordinates: column on x, row on y with row 0 at the top (``imshow`` with
``origin="upper"``), and the centre of cell ``(row, col)`` at ``(x, y) = (col, row)``.
"""

from __future__ import annotations

import io
import tempfile
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from matplotlib.axes import Axes
from matplotlib.colors import ListedColormap, LogNorm, Normalize
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator, NullLocator

from .errors import ParamError, ProblemError
from .outputs import PathArg, check_output, write_bytes

if TYPE_CHECKING:
    import pandas as pd
    from matplotlib.animation import Animation, FuncAnimation
    from numpy.typing import ArrayLike

    from .grid import Grid
    from .research.compare import Comparison
    from .research.search import Study

    #: Paths to draw: one ``(K, 2)`` path, a list of paths, or a dict label -> path (None: no path).
    Paths = ArrayLike | Sequence[ArrayLike | None] | Mapping[Any, ArrayLike | None] | None
    #: One search study, a list of them, or a dict label -> study.
    Studies = Study | Sequence[Study] | Mapping[str, Study]

__all__ = [
    "plot_map",
    "plot_paths",
    "plot_pheromone",
    "plot_convergence",
    "plot_sweep_heatmap",
    "plot_sweep_box",
    "animate_pheromone",
    "save_gif",
    "save",
    "plot_search_history",
    "plot_param_importance",
    "plot_search_contour",
    "plot_pareto",
    "plot_critical_difference",
    "plot_performance_profile",
]

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


def _legend_outside(ax, handles=None, labels=None, *, beside=(), **kw):
    """A legend to the right of ``ax``, outside its data area and beyond the axes in ``beside``
    (a twin axis with its ticks and label on the right); None when there is nothing to show."""
    if handles is None:
        handles, labels = ax.get_legend_handles_labels()
    if not handles:
        return None
    x = 1.02
    for other in beside:
        box = other.get_tightbbox()
        if box is not None:
            x = max(x, ax.transAxes.inverted().transform((box.x1, 0.0))[0] + 0.02)
    kw = {"fontsize": "small", "framealpha": 0.85, **kw}
    return ax.legend(handles, labels, loc="upper left", bbox_to_anchor=(x, 1.0), borderaxespad=0.0, **kw)


def _check_grid(grid):
    from .grid import Grid

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
    fig, ax = _figure_axes(ax)
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
        _legend_outside(ax)
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


def plot_convergence(
    history: dict[str, Any] | Sequence[dict[str, Any]],
    *,
    ax: Axes | None = None,
    optimal: float | None = None,
    label: str | Sequence[str] | None = None,
    title: str | None = None,
    ylabel: str = "path cost",
) -> Figure:
    """Best-so-far (solid) and iteration mean (dashed) cost per iteration, for one run or several.

    ``history`` is a dict with arrays under ``"best"`` (iteration best or best-so-far: the running
    minimum is drawn) and ``"mean"`` (optional), and optionally ``"success_rate"`` (drawn dotted on a
    twin axis, 0..1: the share of the iteration's ants that reached the goal) and ``"label"``; or a
    list of such dicts. ``label`` is a string for one run or a
    list of strings, one per run (default: the dict's ``"label"``, else ``run i``). Inf or NaN values
    (iterations where no ant arrived) are masked. ``optimal`` adds a dashed horizontal line.
    ``ylabel``: the y axis's label (the cost a planner minimises; for most planners it is the path
    length, so ``ylabel="path length"`` says so). The legend sits beside the axes (and beside the
    success rate's axis).
    """
    runs = [history] if isinstance(history, dict) else list(history)
    if not runs:
        raise ParamError("plot_convergence needs at least one history")
    if label is None:
        labels: list[str | None] = [None] * len(runs)  # resolved per run below
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
            ax.plot(
                np.arange(len(mean)),
                mean,
                color=color,
                linewidth=1.2,
                linestyle="--",
                alpha=0.8,
                label=f"{lab} iteration mean",
            )
        if run.get("success_rate") is not None:
            if twin is None:
                twin = ax.twinx()
                twin.set_ylim(0.0, 1.05)
                twin.set_ylabel("success rate")
            rate = _masked(run["success_rate"])
            twin.plot(
                np.arange(len(rate)),
                rate,
                color=color,
                linewidth=1.0,
                linestyle=":",
                alpha=0.9,
                label=f"{lab} success rate",
            )
    if optimal is not None:
        ax.axhline(float(optimal), color="black", linestyle="--", linewidth=1.0, label=f"optimum {float(optimal):.4g}")
    ax.set_xlabel("iteration")
    ax.set_ylabel(ylabel)
    if title is not None:
        ax.set_title(title)
    handles, names = ax.get_legend_handles_labels()
    if twin is not None:
        h2, n2 = twin.get_legend_handles_labels()
        handles, names = handles + h2, names + n2
    _legend_outside(ax, handles, names, beside=[twin] if twin is not None else [])
    return fig


# -- sweeps ------------------------------------------------------------------------------------
def _sweep_column(table, name, what):
    if name not in table.columns:
        raise ParamError(
            f"{what} {name!r} is not a column of the sweep table (columns: {', '.join(map(str, table.columns))})"
        )
    return name


def _is_numbers(column) -> bool:
    import pandas as pd

    return pd.api.types.is_numeric_dtype(column.dtype)


def _numbers_column(table, name, what):
    """``name`` checked to be a column of numbers (a string column is one ParamError line)."""
    _sweep_column(table, name, what)
    if not _is_numbers(table[name]):
        shown = ", ".join(repr(str(v)) for v in table[name].drop_duplicates().head(3))
        raise ParamError(
            f"{what} {name!r} is a column of text ({shown} ...): it needs numbers, e.g. gap, length, cost or success"
        )
    return name


def _tick(name, v) -> str:
    """A tick label: a planner's short name, a text value as it is, a number without float noise."""
    from .research.tables import number, short_name

    if name == "variant":
        return short_name(v)
    return v if isinstance(v, str) else number(v)


def _axis_values(table, name):
    """The values of an axis: sorted numbers, or text (a planner's name, ...) in order of first
    appearance; empty (NaN) entries, e.g. a parameter a planner lacks, are left out."""
    col = table[name]
    if _is_numbers(col):
        v = np.asarray(col, float)
        return np.unique(v[~np.isnan(v)])
    return np.array(list(col.dropna().drop_duplicates()), dtype=object)


def _finite_mean(values) -> float:
    """Mean over runs; inf (a failed run has gap/length inf) if any run failed, NaN never."""
    v = np.asarray(values, dtype=float)
    return float(v.mean()) if v.size and np.isfinite(v).all() else float("inf")


def sweep_grid(table: pd.DataFrame, x: str, y: str, value: str = "gap") -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(xs, ys, Z)``: the mean of ``value`` over every other column (seeds, other parameters)
    for each pair of ``x`` and ``y`` values, ``Z[i, j]`` at ``ys[i], xs[j]``; inf where a run
    failed, NaN where the sweep has no such pair. ``x`` and ``y`` may be columns of numbers
    (sorted) or of text, e.g. the ``variant`` of a sweep over planners (in order of appearance);
    ``value`` must hold numbers."""
    _sweep_column(table, x, "x")
    _sweep_column(table, y, "y")
    _numbers_column(table, value, "value")
    xs, ys = _axis_values(table, x), _axis_values(table, y)
    where_x = {(float(v) if _is_numbers(table[x]) else v): j for j, v in enumerate(xs)}
    where_y = {(float(v) if _is_numbers(table[y]) else v): i for i, v in enumerate(ys)}
    Z = np.full((len(ys), len(xs)), np.nan)
    for (xv, yv), part in table.groupby([x, y])[value]:
        xv, yv = (float(xv) if _is_numbers(table[x]) else xv), (float(yv) if _is_numbers(table[y]) else yv)
        Z[where_y[yv], where_x[xv]] = _finite_mean(part)
    return xs, ys, Z


def plot_sweep_heatmap(
    table: pd.DataFrame,
    x: str,
    y: str,
    value: str = "gap",
    *,
    ax: Axes | None = None,
    title: str | None = None,
    percent: bool | None = None,
) -> Figure:
    """Heatmap of a sweep table (:func:`jaco.sweep`): the mean ``value`` over seeds (and over any
    other swept parameter) for every ``(x, y)`` pair, each cell annotated with its number.

    ``x`` and ``y`` may be parameters or text columns such as the planner (``"variant"``, shown by
    its short name); ``value`` must be a column of numbers. Cells where at least one run failed
    (inf) are hatched grey and marked "fail"; ``percent`` (default: True for ``gap``, a fraction in
    the table) shows the value ×100 with a % sign; a value of integers reads as integers.
    """
    xs, ys, Z = sweep_grid(table, x, y, value)
    percent = (value == "gap") if percent is None else percent
    shown = Z * 100 if percent else Z
    integers = not percent and np.all(np.isnan(shown) | np.isinf(shown) | (shown == np.round(shown)))
    longest = max([len(_tick(x, v)) for v in xs] + [1])
    fig, ax = _figure_axes(ax, figsize=(max(1.2, 0.09 * longest) * len(xs) + 2.5, 0.9 * len(ys) + 1.8))
    masked = np.ma.masked_invalid(shown)
    im = ax.imshow(masked, cmap=_viridis_with_bad().with_extremes(bad="#bdbdbd"), origin="lower", aspect="auto")
    fig.colorbar(im, ax=ax, label=f"mean {value}" + (" (%)" if percent else ""), shrink=0.85)
    finite = shown[np.isfinite(shown)]
    middle = np.mean(finite) if finite.size else 0.0
    for i in range(len(ys)):
        for j in range(len(xs)):
            v = shown[i, j]
            if np.isinf(v):
                text = "fail"
            elif np.isnan(v):
                text = ""
            else:
                text = f"{v:.1f}%" if percent else (f"{v:.0f}" if integers else f"{v:.3g}")
            ax.text(
                j,
                i,
                text,
                ha="center",
                va="center",
                fontsize="small",
                color="black" if not np.isfinite(v) or v > middle else "white",
            )
    ax.set_xticks(range(len(xs)), [_tick(x, v) for v in xs])
    ax.set_yticks(range(len(ys)), [_tick(y, v) for v in ys])
    if longest > 8:
        ax.tick_params(axis="x", labelrotation=30)
        for label in ax.get_xticklabels():
            label.set_horizontalalignment("right")
    ax.set_xlabel(x)
    ax.set_ylabel(y)
    ax.set_title(title if title is not None else f"mean {value} over seeds")
    return fig


def _box_label(by, key, fails) -> str:
    parts = [(_tick(n, k) if n == "variant" or isinstance(k, str) else f"{n}={_tick(n, k)}") for n, k in zip(by, key)]
    return ", ".join(parts) + (f"\n({fails} failed)" if fails else "")


def plot_sweep_box(
    table: pd.DataFrame,
    by: str | Sequence[str],
    value: str = "length",
    *,
    ax: Axes | None = None,
    title: str | None = None,
    optimal: float | None = None,
) -> Figure:
    """Box plots of ``value`` across seeds, one box per configuration (the distinct values of the
    column(s) ``by``: parameters, or text such as the planner, ``"variant"``, shown by its short
    name). Failed runs (inf) are left out of the boxes and counted in the labels. Numbers are
    sorted, text keeps its order of appearance. ``optimal`` (default: the table's ``optimal``
    column when it holds one value) is a dashed line named in a legend beside the axes. A gap (a
    fraction in the table) is drawn in %."""
    by = [by] if isinstance(by, str) else list(by)
    for name in by:
        _sweep_column(table, name, "by")
    _numbers_column(table, value, "value")
    order = {n: {v: i for i, v in enumerate(_axis_values(table, n))} for n in by}
    scale = 100.0 if value == "gap" else 1.0
    groups, labels, keys = [], [], []
    for key, part in table.groupby(by, sort=False)[value]:
        key = key if isinstance(key, tuple) else (key,)
        v = np.asarray(part, float) * scale
        ok = v[np.isfinite(v)]
        keys.append(tuple(order[n].get(float(k) if _is_numbers(table[n]) else k, -1) for n, k in zip(by, key)))
        groups.append(ok)
        labels.append(_box_label(by, key, len(v) - len(ok)))
    if not groups:
        raise ParamError("plot_sweep_box: the table is empty")
    ranked = sorted(range(len(groups)), key=lambda i: keys[i])
    groups, labels = [groups[i] for i in ranked], [labels[i] for i in ranked]
    fig, ax = _figure_axes(ax, figsize=(max(5.0, 0.8 * len(groups) + 2.0), 4.5))
    ax.boxplot([g if len(g) else [np.nan] for g in groups])
    ax.set_xticks(range(1, len(groups) + 1), labels)  # (boxplot's own label keyword was renamed in 3.9)
    if optimal is None and value != "gap" and "optimal" in table.columns and table["optimal"].nunique() == 1:
        optimal = float(table["optimal"].iloc[0])
    if optimal is not None:
        ax.axhline(float(optimal), color="black", linestyle="--", linewidth=1.0, label=f"optimum {float(optimal):.4g}")
        _legend_outside(ax)
    ax.set_ylabel(value + (" (%)" if value == "gap" else ""))
    long = max(len(label.split("\n")[0]) for label in labels)
    ax.tick_params(axis="x", labelrotation=45 if len(groups) > 6 or long > 12 else 0, labelsize="small")
    if len(groups) > 6 or long > 12:
        for label in ax.get_xticklabels():
            label.set_horizontalalignment("right")
    ax.set_title(title if title is not None else f"{value} across seeds")
    return fig


# -- searches (jaco.search) ---------------------------------------------------------------------
def _studies(studies: Studies) -> dict[str, Study]:
    """A :class:`jaco.research.search.Study`, a list of them or a dict label -> study."""
    from .research.search import Study

    if isinstance(studies, Study):
        studies = {studies.info["sampler"]: studies}
    elif isinstance(studies, (list, tuple)):
        studies = {
            f"{s.info['sampler']} ({s.study.study_name})"
            if sum(t.info["sampler"] == s.info["sampler"] for t in studies) > 1
            else s.info["sampler"]: s
            for s in studies
        }
    if not isinstance(studies, dict) or not studies or not all(isinstance(s, Study) for s in studies.values()):
        raise ParamError("expected a jaco search Study, a list of Studies or a dict label -> Study")
    return studies


def _objective_axis(ax, name: str, axis: str = "y") -> bool:
    """Label an objective's axis; gaps and success rates are fractions shown as %."""
    percent = name in ("gap", "success")
    label = {
        "gap": "gap to the optimum (%)",
        "success": "success rate (%)",
        "length": "path length",
        "turns": "turns",
        "budget": "ants × iterations",
    }.get(name, name)
    (ax.set_ylabel if axis == "y" else ax.set_xlabel)(label)
    return percent


def plot_search_history(
    studies: Studies, *, x: str = "trials", ax: Axes | None = None, title: str | None = None, log: bool = False
) -> Figure:
    """The anytime curve of one or several searches: the best objective so far (a step line) against
    finished ``trials``, ant-``iterations`` spent (fair across multi-fidelity searches) or wall
    ``time`` (seconds since the first trial started); one line per study (e.g. per sampler), with a
    single study's trial values as points behind it. ``studies``: a Study, a list, or a dict label ->
    Study. The y axis of a gap or success rate is in %."""
    studies = _studies(studies)
    columns = {"trials": None, "iterations": "iterations", "time": "end_s"}
    if x not in columns:
        raise ParamError(f"x must be one of {', '.join(columns)}, got {x!r}")
    fig, ax = _figure_axes(ax, figsize=(7.0, 4.2))
    names = {tuple(s.objectives) for s in studies.values()}
    if len(names) != 1 or len(next(iter(names))) != 1:
        raise ParamError("plot_search_history: the studies must share one objective (several: plot_pareto)")
    name = next(iter(names))[0]
    scale = 100.0 if _objective_axis(ax, name) else 1.0
    for label, study in studies.items():
        h = study.history()
        xs = np.arange(1, len(h) + 1) if columns[x] is None else h[columns[x]].to_numpy(float)
        (line,) = ax.step(xs, scale * h["best"].to_numpy(float), where="post", label=label, linewidth=1.8)
        if len(studies) == 1:
            done = h["state"].eq("COMPLETE").to_numpy()
            ax.scatter(
                xs[done],
                scale * h["value"].to_numpy(float)[done],
                s=10,
                alpha=0.35,
                color=line.get_color(),
                label="trials",
            )
    if log:
        ax.set_yscale("log")
    ax.set_xlabel({"trials": "finished trials", "iterations": "ant-iterations spent", "time": "wall time (s)"}[x])
    ax.set_title(title if title is not None else f"best {name} so far")
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize="small", borderaxespad=0.0)
    fig.tight_layout()
    return fig


def plot_param_importance(study: Studies, *, ax: Axes | None = None, title: str | None = None) -> Figure:
    """How much each searched parameter matters to the objective (Optuna's PED-ANOVA, Watanabe et al.
    2023: how differently a parameter is distributed in the best trials than in all, over the finished
    trials; parameters that only some planners use are left
    out when the planner is searched)."""
    import optuna

    study = next(iter(_studies(study).values()))
    if len(study.objectives) > 1:
        raise ParamError("plot_param_importance: one objective only")
    from .research.search import _quiet

    finished = [t for t in study.study.trials if t.state.name == "COMPLETE"]
    if len(finished) < 2:
        raise ParamError("plot_param_importance needs at least two finished trials")
    with _quiet():
        imp = optuna.importance.get_param_importances(
            study.study, evaluator=optuna.importance.PedAnovaImportanceEvaluator()
        )
    fig, ax = _figure_axes(ax, figsize=(6.0, 0.5 * len(imp) + 1.5))
    names = list(imp)[::-1]
    ax.barh(names, [imp[n] for n in names], color="#4c72b0")
    for i, n in enumerate(names):
        ax.text(imp[n], i, f" {imp[n]:.2f}", va="center", fontsize="small")
    ax.set_xlim(0, 1.1 * max(imp.values()) if imp else 1)
    ax.set_xlabel(f"importance for {study.objectives[0]} (PED-ANOVA)")
    ax.set_title(title if title is not None else "parameter importance")
    fig.tight_layout()
    return fig


def plot_search_contour(study: Studies, x: str, y: str, *, ax: Axes | None = None, title: str | None = None) -> Figure:
    """The objective over two searched parameters: every finished trial as a point coloured by
    its value, over a contour interpolated between them (log axes for log ranges); the best trial
    is starred."""
    import matplotlib.tri as mtri

    study = next(iter(_studies(study).values()))
    if len(study.objectives) > 1:
        raise ParamError("plot_search_contour: one objective only")
    name = study.objectives[0]
    table = study.trials
    table = table[table["state"] == "COMPLETE"]
    for c in (x, y):
        if c not in table.columns or c == "variant":
            raise ParamError(
                f"{c!r} is not a searched number of this study (columns: {', '.join(map(str, table.columns))})"
            )
    table = table.dropna(subset=[x, y, name])
    if len(table) < 2:
        raise ParamError("plot_search_contour needs at least two finished trials with both parameters")
    fig, ax = _figure_axes(ax, figsize=(6.2, 4.8))
    scale = 100.0 if name in ("gap", "success") else 1.0
    logs = [str(study.info["space"].get(c, "")).endswith(":log") for c in (x, y)]
    px, py = (np.log10(table[c].to_numpy(float)) if lg else table[c].to_numpy(float) for c, lg in zip((x, y), logs))
    v = scale * table[name].to_numpy(float)
    norm = Normalize(np.nanmin(v), np.nanmax(v) if np.nanmax(v) > np.nanmin(v) else np.nanmin(v) + 1)
    try:
        tri = mtri.Triangulation(10**px if logs[0] else px, 10**py if logs[1] else py)
        ax.tricontourf(tri, v, levels=12, cmap="viridis_r", norm=norm, alpha=0.55)
    except (ValueError, RuntimeError):  # fewer than three distinct points: the points alone
        pass
    sc = ax.scatter(table[x], table[y], c=v, cmap="viridis_r", norm=norm, s=22, edgecolors="black", linewidths=0.4)
    best = table.loc[table[name].idxmin() if OBJECTIVE_MAX.get(name) is None else table[name].idxmax()]
    ax.scatter([best[x]], [best[y]], marker="*", s=220, c="#d62728", edgecolors="black", zorder=5, label="best")
    from matplotlib.ticker import NullFormatter, ScalarFormatter

    for lg, axis, setter in zip(logs, (ax.xaxis, ax.yaxis), (ax.set_xscale, ax.set_yscale)):
        if lg:
            setter("log")
            axis.set_major_formatter(ScalarFormatter())
            axis.set_minor_formatter(NullFormatter())
    fig.colorbar(sc, ax=ax, label=name + (" (%)" if scale == 100.0 else ""))
    ax.set_xlabel(x)
    ax.set_ylabel(y)
    ax.set_title(title if title is not None else f"{name} over {x} and {y} (★ best trial)")
    fig.tight_layout()
    return fig


OBJECTIVE_MAX = {"success": True}  # objectives a search maximises (the rest are minimised)


def plot_pareto(study: Studies, a: str, b: str, *, ax: Axes | None = None, title: str | None = None) -> Figure:
    """Two objectives of a search: every finished trial, with the Pareto front (the trials no
    other trial beats on both) joined by a line."""
    study = next(iter(_studies(study).values()))
    for n in (a, b):
        if n not in study.objectives:
            raise ParamError(f"{n!r} is not an objective of this study ({', '.join(study.objectives)})")
    table = study.trials
    table = table[table["state"] == "COMPLETE"]
    front = study.best_trials.sort_values(a)
    fig, ax = _figure_axes(ax, figsize=(6.0, 4.5))
    sa, sb = (100.0 if n in ("gap", "success") else 1.0 for n in (a, b))
    ax.scatter(sa * table[a], sb * table[b], s=16, alpha=0.45, color="#7f7f7f", label="trials")
    ax.plot(sa * front[a], sb * front[b], "o-", color="#d62728", markersize=5, label="Pareto front")
    _objective_axis(ax, a, "x")
    _objective_axis(ax, b, "y")
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize="small", borderaxespad=0.0)
    ax.set_title(title if title is not None else f"{a} against {b}")
    fig.tight_layout()
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
    im = ax.imshow(stack[0], cmap=_viridis_with_bad(), norm=norm, origin="upper", interpolation="nearest")
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


def save_gif(animation: Animation, path: PathArg, fps: int = 8) -> Path:
    """Write an animation as an animated GIF with matplotlib's Pillow writer; returns the path."""
    from matplotlib.animation import PillowWriter

    path = check_output(path, "animation", suffixes=(".gif",))
    with tempfile.TemporaryDirectory(prefix="jaco-") as folder:  # Pillow's writer takes a file name only
        drawn = Path(folder) / "animation.gif"
        animation.save(drawn, writer=PillowWriter(fps=fps))
        return write_bytes(path, drawn.read_bytes(), "animation")


# -- comparisons (jaco.research.compare) -------------------------------------------------------
def _comparison(obj, what):
    from .research.compare import Comparison

    if not isinstance(obj, Comparison):
        raise ParamError(f"{what} takes the Comparison of jaco.compare(table, ...), got {type(obj).__name__}")
    return obj


def _cliques(ranks: np.ndarray, cd: float) -> list[tuple[int, int]]:
    """Maximal runs ``(i, j)`` of configurations (sorted by mean rank) whose mean ranks lie within
    ``cd`` of each other: the groups a critical-difference diagram joins with a bar."""
    out: list[tuple[int, int]] = []
    for i in range(len(ranks)):
        j = i
        while j + 1 < len(ranks) and ranks[j + 1] - ranks[i] < cd:
            j += 1
        if j > i and not any(a <= i and j <= b for a, b in out):
            out.append((i, j))
    return out


def plot_critical_difference(comparison: Comparison, *, ax: Axes | None = None, title: str | None = None) -> Figure:
    """Critical-difference diagram (Demšar 2006) of a :func:`jaco.compare` result: the mean rank
    of each configuration over the blocks on an axis (rank 1, the best, on the left), the Nemenyi
    critical difference CD as a bar above it, and thick bars joining configurations whose mean
    ranks differ by less than CD (they cannot be told apart at the comparison's ``alpha``)."""
    c = _comparison(comparison, "plot_critical_difference")
    names, ranks = list(c.ranks.index), c.ranks.to_numpy(float)
    k, cd = len(names), float(c.friedman["cd"])
    fig, ax = _figure_axes(ax, figsize=(8.0, 1.6 + 0.3 * k))
    left = (k + 1) // 2
    step = 0.45
    ax.plot([1, k], [0, 0], color="black", linewidth=1.2)
    for r in range(1, k + 1):
        ax.plot([r, r], [0, 0.12], color="black", linewidth=1.0)
        ax.text(r, 0.2, str(r), ha="center", va="bottom", fontsize="small")
    for i, (name, r) in enumerate(zip(names, ranks)):
        side = i < left
        y = -(1 + (i if side else k - 1 - i)) * step - 0.2
        end = 1 - 0.15 if side else k + 0.15
        ax.plot([r, r, end], [0, y, y], color="black", linewidth=0.9)
        ax.text(
            end + (-0.05 if side else 0.05),
            y,
            f"{name} ({r:.2f})",
            ha="right" if side else "left",
            va="center",
            fontsize="small",
        )
    ax.plot([1, 1 + cd], [0.75, 0.75], color="black", linewidth=1.5)
    for x in (1, 1 + cd):
        ax.plot([x, x], [0.68, 0.82], color="black", linewidth=1.0)
    ax.text(1 + cd / 2, 0.86, f"CD = {cd:.2f}", ha="center", va="bottom", fontsize="small")
    for n, (i, j) in enumerate(_cliques(ranks, cd)):
        y = -0.1 - 0.09 * n
        ax.plot([ranks[i] - 0.03, ranks[j] + 0.03], [y, y], color="black", linewidth=3.5, solid_capstyle="butt")
    lowest = -(1 + max(left, k - left)) * step - 0.45
    ax.set_xlim(0.5, k + 0.5)
    ax.set_ylim(lowest, 1.15)
    ax.axis("off")
    f = c.friedman
    if title is None:
        p = f"Friedman p = {f['pvalue']:.2g}, " if f["pvalue"] is not None else ""
        title = f"mean rank of {c.value} over {f['n']} blocks ({p}Nemenyi CD at alpha {c.alpha:g})"
    ax.set_title(title, fontsize="medium")
    return fig


def plot_performance_profile(
    comparison: Comparison, *, ax: Axes | None = None, title: str | None = None, log2: bool = True
) -> Figure:
    """Performance profile (Dolan & Moré 2002) of a :func:`jaco.compare` result: for each
    configuration the share ρ(τ) of pairs on which its path length is within a factor τ of the
    best length any configuration reached there (a step function; τ on a log₂ axis by default).
    The value at τ = 1 is the share of pairs it won (ties included); where a line levels off below
    1 are the pairs it failed. The legend sits beside the axes."""
    c = _comparison(comparison, "plot_performance_profile")
    profile = c.profile()
    taus = profile.index.to_numpy(float)
    top = taus.max() if taus.size else 1.0
    right = top * 1.1 if top > 1 else 1.1
    fig, ax = _figure_axes(ax, figsize=(7.0, 4.5))
    styles = ["-", "--", "-.", ":"]
    for n, name in enumerate(profile.columns):
        rho = profile[name].to_numpy(float)
        never = not np.isfinite(c.ratios[name].to_numpy(float)).any()
        ax.step(
            np.append(taus, right),
            np.append(rho, rho[-1]),
            where="post",
            linewidth=1.8,
            color=f"C{n % 10}",
            linestyle=styles[(n // 10) % len(styles)],
            label=name + (" (no path: on the τ axis)" if never else ""),
            clip_on=False,
        )
    if log2:
        ax.set_xscale("log", base=2)
    ticks = [t for t in (1, 1.05, 1.1, 1.2, 1.5, 2, 3, 4, 8, 16, 32, 64, 128) if t <= right]
    ax.set_xticks(ticks, [f"{t:g}" for t in ticks])
    ax.xaxis.set_minor_locator(NullLocator())
    ax.set_xlim(1.0, right)
    ax.set_ylim(0.0, 1.02)
    ax.set_xlabel(f"τ: {c.ratio_of} / best {c.ratio_of} on the pair" + (" (log scale)" if log2 else ""))
    ax.set_ylabel("share of pairs with ratio ≤ τ")
    ax.grid(True, linewidth=0.3)
    ax.set_title(title if title is not None else f"performance profile over {len(c.ratios)} pairs")
    _legend_outside(ax)
    return fig


# -- output ------------------------------------------------------------------------------------
def figure_suffixes() -> tuple[str, ...]:
    """The file suffixes matplotlib writes figures in (``.png``, ``.svg``, ``.pdf``, ...)."""
    from matplotlib.backend_bases import FigureCanvasBase

    return tuple(sorted("." + s for s in FigureCanvasBase.get_supported_filetypes()))


def check_figure_path(
    path: PathArg, what: str = "figure", inputs: Iterable[Any] = (), format: str | None = None, how: str = "format="
) -> Path:
    """:func:`jaco.outputs.check_output` for a figure: a suffix matplotlib can write, or ``format``
    (``"png"``, ``"svg"`` ...) naming one."""
    return check_output(path, what, suffixes=figure_suffixes(), inputs=inputs, format=format, how=how)


def save(fig: Figure, path: PathArg, format: str | None = None) -> Path:
    """Write ``fig`` in the format its suffix names (``.png`` at dpi 120, ``.svg``, ``.pdf``, ...;
    tight bounding box), or in ``format`` when given (needed for ``-``, a device or a FIFO, whose
    names have no suffix); atomically to a file, creating parent folders (see
    :mod:`jaco.outputs`); returns the path."""
    path = check_figure_path(path, format=format)
    data = io.BytesIO()  # drawn in memory first: a drawing error never touches the output
    fig.savefig(data, dpi=120, bbox_inches="tight", format=(format or path.suffix[1:]).lower())
    return write_bytes(path, data.getvalue(), "figure")
