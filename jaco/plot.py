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
#: A table's planner column: ``planner``, or ``variant`` in tables written before it was renamed.
_PLANNER_COLUMNS = ("planner", "variant")


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

    if name in _PLANNER_COLUMNS:
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
    (sorted) or of text, e.g. the ``planner`` of a sweep over planners (in order of appearance);
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

    ``x`` and ``y`` may be parameters or text columns such as the planner (``"planner"``, or
    ``"variant"`` in older tables, shown by its short name); ``value`` must be a column of numbers. Cells where at least one run failed
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
    parts = [
        (_tick(n, k) if n in _PLANNER_COLUMNS or isinstance(k, str) else f"{n}={_tick(n, k)}") for n, k in zip(by, key)
    ]
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
    column(s) ``by``: parameters, or text such as the planner, ``"planner"`` (``"variant"`` in
    older tables), shown by its short name). Failed runs (inf) are left out of the boxes and counted in the labels. Numbers are
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


def _log_axis(ax, values) -> None:
    """A log y axis for ``values`` (objective values as drawn): log where all are > 0; symlog,
    linear below the smallest positive value's power of ten, where some are 0 (a gap of 0, the
    optimum: a log axis would drop it); linear where none is > 0. The axis label says which."""
    v = np.asarray(values, float)
    v = v[np.isfinite(v)]
    positive = v[v > 0]
    if not positive.size:
        note = " (no value > 0: linear scale)"
    elif (v <= 0).any():
        linthresh = 10.0 ** np.floor(np.log10(positive.min()))
        ax.set_yscale("symlog", linthresh=linthresh, linscale=0.5)
        note = f" (log scale, linear below {linthresh:g})"
    else:
        ax.set_yscale("log")
        note = " (log scale)"
    ax.set_ylabel(ax.get_ylabel() + note)


def plot_search_history(
    studies: Studies, *, x: str = "trials", ax: Axes | None = None, title: str | None = None, log: bool = False
) -> Figure:
    """The anytime curve of one or several searches: the best objective so far (a step line) against
    finished ``trials``, ant-``iterations`` spent (fair across multi-fidelity searches) or wall
    ``time`` (seconds since the first trial started); one line per study (e.g. per sampler), with a
    single study's trial values as points behind it. ``studies``: a Study, a list, or a dict label ->
    Study. The y axis of a gap or success rate is in %. ``log``: a log y axis (symlog, linear near
    0, when a value is 0, e.g. a gap that reached the optimum; the axis label says which)."""
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
    shown = []  # every value drawn (for a log axis)
    for label, study in studies.items():
        h = study.history()
        xs = np.arange(1, len(h) + 1) if columns[x] is None else h[columns[x]].to_numpy(float)
        shown.append(scale * h["best"].to_numpy(float))
        (line,) = ax.step(xs, shown[-1], where="post", label=label, linewidth=1.8)
        if len(studies) == 1:
            done = h["state"].eq("COMPLETE").to_numpy()
            shown.append(scale * h["value"].to_numpy(float)[done])
            ax.scatter(xs[done], shown[-1], s=10, alpha=0.35, color=line.get_color(), label="trials")
    if log:
        _log_axis(ax, np.concatenate(shown))
    ax.set_xlabel({"trials": "finished trials", "iterations": "ant-iterations spent", "time": "wall time (s)"}[x])
    ax.set_title(title if title is not None else f"best {name} so far")
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize="small", borderaxespad=0.0)
    fig.tight_layout()
    return fig


def _planner_column(table: pd.DataFrame) -> str | None:
    """The table's planner column: ``planner``, else ``variant`` (older tables), else None."""
    return next((c for c in _PLANNER_COLUMNS if c in table.columns), None)


def _planner_groups(study: Study, table: pd.DataFrame, planner: Any, what: str) -> list[tuple[Any, pd.DataFrame]]:
    """``[(planner, its rows)]`` of a table of finished trials: one entry per planner the trials
    span (in the order of the study's space, then of appearance), or only ``planner`` (its name or
    short name) when given; ``[(None, table)]`` for a table without a planner column."""
    from .research.tables import short_name

    column = _planner_column(table)
    if column is None:
        if planner is not None:
            raise ParamError(f"{what}: planner={planner!r}, but the study's trials name no planner")
        return [(None, table)]
    present = list(table[column].dropna().drop_duplicates())
    space = next((study.info["space"].get(c) for c in _PLANNER_COLUMNS if c in study.info["space"]), None)
    order = [p for p in (space if isinstance(space, list) else [space]) if p in present]
    names = order + [p for p in present if p not in order]
    if planner is not None:
        chosen = [p for p in names if p == planner or short_name(str(p)) == planner]
        if not chosen:
            raise ParamError(
                f"{what}: no finished trial of planner {planner!r} (its trials' planners: "
                f"{', '.join(map(str, names)) or 'none'})"
            )
        names = chosen[:1]
    return [(p, table[table[column] == p]) for p in names] or [(None, table)]


def _finished(study: Study, what: str) -> tuple[str, pd.DataFrame]:
    """The study's one objective and its finished trials (:attr:`Study.trials` rows, the objective's
    column under the objective's name)."""
    if len(study.objectives) > 1:
        raise ParamError(f"{what}: one objective only")
    table = _by_objective(study, study.trials)
    return study.objectives[0], table[table["state"] == "COMPLETE"]


def _by_objective(study: Study, table: pd.DataFrame) -> pd.DataFrame:
    """Trials with each objective's column (``gap_penalised_mean``, ...:
    :func:`jaco.research.search.objective_column`) named by its objective (``gap``)."""
    from .research.search import objective_column

    return table.rename(columns={objective_column(n): n for n in study.objectives})


def _planner_effect(values: ArrayLike, planners: ArrayLike) -> float:
    """The share of the variance of ``values`` explained by the planner, η² (eta squared): the
    between-planner sum of squares over the total, ``Σ_p n_p (mean_p − mean)² / Σ_i (v_i − mean)²``
    over the finite values, 0 (the planners' means are equal) to 1 (every planner's values are all
    equal: the planner decides everything); NaN when the values do not vary."""
    v = np.asarray(values, float)
    groups = np.asarray(planners, dtype=object)
    if v.shape != groups.shape:
        raise ParamError(f"planner effect: {v.size} values for {groups.size} planners")
    keep = np.isfinite(v)
    v, groups = v[keep], groups[keep]
    total = float(((v - v.mean()) ** 2).sum()) if v.size else 0.0
    if total <= 0.0:
        return float("nan")
    between = sum(
        float((groups == g).sum()) * (float(v[groups == g].mean()) - float(v.mean())) ** 2 for g in set(groups)
    )
    return between / total


def _importance_within(study: Study, numbers: Iterable[int]) -> dict[str, float] | None:
    """PED-ANOVA importance of the parameters of the trials ``numbers`` (one planner's finished
    trials), on those trials alone, as shares that sum to 1; all 0 when no parameter's
    distribution among the best trials differs from all (e.g. equal values); None with fewer than
    two trials."""
    import warnings

    import optuna

    from .research.search import _quiet

    numbers = set(numbers)
    trials = [t for t in study.study.get_trials(deepcopy=False) if t.number in numbers and t.value is not None]
    if len(trials) < 2:
        return None
    if not {k for t in trials for k in t.params if k not in _PLANNER_COLUMNS}:
        return {}
    with _quiet(), warnings.catch_warnings():
        warnings.simplefilter("ignore")  # "too few trials", "target and region select the same trials": handled here
        alone = optuna.create_study(direction=study.study.direction)  # the planner's trials alone
        for t in trials:
            params = {k: v for k, v in t.params.items() if k not in _PLANNER_COLUMNS}
            alone.add_trial(
                optuna.trial.create_trial(
                    params=params, distributions={k: t.distributions[k] for k in params}, value=t.value
                )
            )
        raw = optuna.importance.get_param_importances(
            alone, evaluator=optuna.importance.PedAnovaImportanceEvaluator(), normalize=False
        )
    total = sum(raw.values())
    return {k: (v / total if total > 0 else 0.0) for k, v in raw.items()}


def plot_param_importance(
    study: Studies, *, planner: Any = None, ax: Axes | None = None, title: str | None = None
) -> Figure:
    """How much the planner and each searched parameter matter to the objective, over the
    finished trials (their objective values: failed runs counted with the study's penalty).

    * **The planner's effect** (when the trials span several planners): η², the share of the
      variance of the objective values between planners (between-planner sum of squares / total,
      ``Σ_p n_p (mean_p − mean)² / Σ_i (v_i − mean)²``); 0: the planners' means are equal, 1: all
      of a planner's trials have the same value (the planner decides everything).
      Drawn in a panel of its own, on its own scale.
    * **Parameter importance within each planner**: Optuna's PED-ANOVA (Watanabe et al. 2023) over
      that planner's own finished trials only: how differently a parameter is distributed among the
      planner's best 10% of trials than among all its trials (a Pearson divergence of Parzen
      estimates), as shares that sum to 1 per planner; one bar per planner and parameter (a
      parameter the planner does not use has none: "not used"). All 0 ("nothing separates its best
      trials") when no parameter's distribution differs, e.g. when every trial of the planner has
      the same value (Optuna's normalisation would show equal shares). The legend gives each
      planner's trials: PED-ANOVA wants at least 5 in the best 10%, about 50 per planner. The
      shares rank parameters within a planner; they are not comparable to η².

    ``planner``: draw one planner's importances only (its name or short name), in one axes (or in
    ``ax``); a study over several planners otherwise needs a figure of its own (``ax`` refused).
    """
    from .research.tables import short_name

    study = next(iter(_studies(study).values()))
    name, table = _finished(study, "plot_param_importance")
    if len(table) < 2:
        raise ParamError("plot_param_importance needs at least two finished trials")
    groups = _planner_groups(study, table, planner, "plot_param_importance")
    several = len(groups) > 1
    if several and ax is not None:
        raise ParamError(
            f"plot_param_importance: the trials span {len(groups)} planners "
            f"({', '.join(short_name(p) for p, _ in groups)}), drawn in two panels of a figure of their own; "
            "leave ax out, or pass planner= to draw one planner's importances into ax"
        )
    shares = {p: _importance_within(study, part["number"]) for p, part in groups}
    params = sorted(
        {k for s in shares.values() if s for k in s}, key=lambda k: max((s or {}).get(k, 0.0) for s in shares.values())
    )
    if not params:
        raise ParamError("plot_param_importance: no searched parameter with at least two finished trials")
    rows = len(params) * (len(groups) if several else 1)
    if several:
        fig = Figure(figsize=(7.5, 0.32 * rows + 3.2), layout="constrained")
        effect_ax, ax = fig.subplots(2, 1, height_ratios=[1.0, max(2.0, 0.32 * rows)])
        column = _planner_column(table)
        eta = _planner_effect(table[name], table[column])
        effect_ax.barh(
            ["planner"], [0.0 if np.isnan(eta) else eta], color="#c44e52", height=0.5, label="planner effect"
        )
        inside = not np.isnan(eta) and eta > 0.75  # the value's text inside the bar's end
        effect_ax.text(
            0.0 if np.isnan(eta) else eta,
            0,
            " η² = n/a (the values do not vary)"
            if np.isnan(eta)
            else f" η² = {eta:.2f} "
            if inside
            else f" η² = {eta:.2f}",
            va="center",
            ha="right" if inside else "left",
            color="white" if inside else "black",
            fontsize="small",
        )
        effect_ax.set_xlim(0.0, 1.0)
        effect_ax.set_xlabel(
            f"share of the variance of {name} between planners (η², over {len(table)} finished trials)"
        )
        effect_ax.set_title(f"the planner's effect ({len(groups)} planners)")
    else:
        fig, ax = _figure_axes(ax, figsize=(6.0, 0.5 * rows + 1.5))
    height = 0.8 / len(groups)
    notes = []
    for g, (p, part) in enumerate(groups):
        s = shares[p]
        note = f"{len(part)} trials"
        if s is None:
            note += ": too few"
        elif s and not any(s.values()):
            note += ": nothing separates its best trials"
        notes.append(note)
        label = f"{'all trials' if p is None else short_name(p)} ({note})"
        ys = np.arange(len(params)) + (0.4 - height * (g + 0.5) if several else 0.0)
        widths = [(s or {}).get(k, np.nan) for k in params]
        ax.barh(ys, np.nan_to_num(widths), height=height if several else 0.8, color=f"C{g % 10}", label=label)
        for y, w in zip(ys, widths):
            ax.text(
                0.0 if np.isnan(w) else w,
                y,
                " not used" if np.isnan(w) else f" {w:.2f}",
                va="center",
                fontsize="x-small" if several else "small",
                color="#7f7f7f" if np.isnan(w) else "black",
            )
    ax.set_yticks(range(len(params)), params)
    ax.set_xlim(0, 1.15)
    first = groups[0][0]
    within = " within each planner" if several else "" if first is None else f" within {short_name(first)}"
    ax.set_xlabel(f"importance{within} for {name} (PED-ANOVA shares, sum 1 per planner)")
    if title is not None:
        (fig.suptitle if several else ax.set_title)(title)
    else:
        ax.set_title("parameter importance" + within + ("" if several else f" ({notes[0]})"))
    if several:
        _legend_outside(ax, title="planner")
    else:
        fig.tight_layout()
    return fig


def _contour_panel(ax, part, x, y, name, logs, norm, scale, best_label):
    """One contour panel: the trials of ``part`` as points over a contour between them, the best
    starred (none when all are equal); returns the points' collection."""
    import matplotlib.tri as mtri

    px, py = (np.log10(part[c].to_numpy(float)) if lg else part[c].to_numpy(float) for c, lg in zip((x, y), logs))
    v = scale * part[name].to_numpy(float)
    try:
        tri = mtri.Triangulation(10**px if logs[0] else px, 10**py if logs[1] else py)
        ax.tricontourf(tri, v, levels=12, cmap="viridis_r", norm=norm, alpha=0.55)
    except (ValueError, RuntimeError):  # fewer than three distinct points: the points alone
        pass
    sc = ax.scatter(
        part[x], part[y], c=v, cmap="viridis_r", norm=norm, s=22, edgecolors="black", linewidths=0.4, label="trials"
    )
    if part[name].nunique() > 1 or len(part) == 1:  # all trials equal: none is the best
        best = part.loc[part[name].idxmin() if OBJECTIVE_MAX.get(name) is None else part[name].idxmax()]
        ax.scatter([best[x]], [best[y]], marker="*", s=220, c="#d62728", edgecolors="black", zorder=5, label=best_label)
    return sc


def plot_search_contour(
    study: Studies, x: str, y: str, *, planner: Any = None, ax: Axes | None = None, title: str | None = None
) -> Figure:
    """The objective over two searched parameters: every finished trial as a point coloured by
    its value, over a contour interpolated between them (log axes for log ranges); the best trial
    is starred (none when all have the same value).

    A contour is interpolated between the trials of one planner only: when the trials span several
    planners, one panel per planner holds that planner's own trials (its best starred), on shared
    axes and one colour scale; a planner whose trials lack ``x`` or ``y`` has an empty panel that
    says so. ``planner`` (a name or short name) draws that planner's trials alone, in one axes (or
    in ``ax``, which a study over several planners needs ``planner`` for)."""
    from matplotlib.ticker import NullFormatter, ScalarFormatter

    from .research.tables import short_name

    study = next(iter(_studies(study).values()))
    name, table = _finished(study, "plot_search_contour")
    for c in (x, y):
        if c not in table.columns or c in _PLANNER_COLUMNS:
            raise ParamError(
                f"{c!r} is not a searched number of this study (columns: {', '.join(map(str, table.columns))})"
            )
    groups = [
        (p, part.dropna(subset=[x, y, name]))
        for p, part in _planner_groups(study, table, planner, "plot_search_contour")
    ]
    if sum(len(part) for _, part in groups) < 2:
        raise ParamError("plot_search_contour needs at least two finished trials with both parameters")
    several = len(groups) > 1
    if several and ax is not None:
        raise ParamError(
            f"plot_search_contour: the trials span {len(groups)} planners "
            f"({', '.join(short_name(p) for p, _ in groups)}), one panel each; leave ax out, or pass planner= "
            "to draw one planner's trials into ax"
        )
    scale = 100.0 if name in ("gap", "success") else 1.0
    logs = [str(study.info["space"].get(c, "")).endswith(":log") for c in (x, y)]
    values = scale * np.concatenate([part[name].to_numpy(float) for _, part in groups])
    low, high = np.nanmin(values), np.nanmax(values)
    norm = Normalize(low, high if high > low else low + 1)
    if several:
        cols = min(len(groups), 3)
        rows = -(-len(groups) // cols)
        fig = Figure(figsize=(4.6 * cols + 1.2, 4.0 * rows + 0.6), layout="constrained")
        grid = fig.subplots(rows, cols, sharex=True, sharey=True, squeeze=False).ravel()
        for extra in grid[len(groups) :]:
            fig.delaxes(extra)
        axes = list(grid[: len(groups)])
    else:
        fig, ax = _figure_axes(ax, figsize=(6.2, 4.8))
        axes = [ax]
    for a, (p, part) in zip(axes, groups):
        sc = _contour_panel(a, part, x, y, name, logs, norm, scale, "best" if p is None else f"best of {short_name(p)}")
        if several:
            equal = ", all equal" if len(part) > 1 and part[name].nunique() == 1 else ""
            a.set_title(f"{short_name(p)} ({len(part)} trials{equal})", fontsize="medium")
            if not len(part):
                a.text(
                    0.5, 0.5, f"no finished trial\nwith {x} and {y}", transform=a.transAxes, ha="center", va="center"
                )
        for lg, axis, setter in zip(logs, (a.xaxis, a.yaxis), (a.set_xscale, a.set_yscale)):
            if lg:
                setter("log")
                axis.set_major_formatter(ScalarFormatter())
                axis.set_minor_formatter(NullFormatter())
        a.set_xlabel(x)
        a.set_ylabel(y)
    fig.colorbar(sc, ax=axes if several else axes[0], label=name + (" (%)" if scale == 100.0 else ""))
    if several:
        fig.suptitle(
            title if title is not None else f"{name} over {x} and {y}, one panel per planner (★ its best trial)"
        )
    else:
        p = groups[0][0]
        of = "" if p is None or planner is None else f" of {short_name(p)}"
        axes[0].set_title(title if title is not None else f"{name} over {x} and {y}{of} (★ best trial)")
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
    table = _by_objective(study, study.trials)
    table = table[table["state"] == "COMPLETE"]
    front = _by_objective(study, study.best_trials).sort_values(a)
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


#: Line styles, markers and widths of the performance profile's curves: their periods (4, 7, 3) are
#: coprime, so the (colour, line style, marker, width) of any two of the first 84 curves differ in
#: more than colour.
_PROFILE_STYLES = ("-", "--", ":", "-.")
_PROFILE_MARKERS = ("o", "s", "^", "D", "v", "P", "X")
_PROFILE_WIDTHS = (3.4, 2.2, 1.3)


def _qualitative_colors(n: int) -> list:
    """``n`` colours of qualitative colormaps, all distinct up to 60: tab10 (up to 10), tab20 (up
    to 20), else tab20, tab20b and tab20c (then they repeat)."""
    from matplotlib import colormaps

    names = ["tab10"] if n <= 10 else ["tab20"] if n <= 20 else ["tab20", "tab20b", "tab20c"]
    colors = [colormaps[name](i) for name in names for i in range(colormaps[name].N)]
    return [colors[i % len(colors)] for i in range(n)]


def plot_performance_profile(
    comparison: Comparison, *, ax: Axes | None = None, title: str | None = None, log2: bool = True
) -> Figure:
    """Performance profile (Dolan & Moré 2002) of a :func:`jaco.compare` result: for each
    configuration the share ρ(τ) of pairs on which its path length is within a factor τ of the
    best length any configuration reached there (a step function; τ on a log₂ axis by default).
    The value at τ = 1 is the share of pairs it won (ties included); where a line levels off below
    1 are the pairs it failed. The legend sits beside the axes.

    Every curve is told apart by its colour (a qualitative colormap: tab10, tab20 or more, one
    colour per configuration) and by a line style, a hollow marker and a line width that cycle
    independently (periods 4, 7 and 3). Markers sit where the curve steps up (τ, ρ(τ)), the values
    drawn exactly (nothing is offset); wider lines are drawn below narrower ones, with some
    transparency, so curves that coincide stay visible, and the legend names a curve equal to an
    earlier one ("same curve as A")."""
    c = _comparison(comparison, "plot_performance_profile")
    profile = c.profile()
    taus = profile.index.to_numpy(float)
    top = taus.max() if taus.size else 1.0
    right = top * 1.1 if top > 1 else 1.1
    fig, ax = _figure_axes(ax, figsize=(7.0, 4.5))
    colors = _qualitative_colors(len(profile.columns))
    drawn: list[tuple[str, np.ndarray]] = []
    for n, name in enumerate(profile.columns):
        rho = profile[name].to_numpy(float)
        never = not np.isfinite(c.ratios[name].to_numpy(float)).any()
        same = next((other for other, r in drawn if np.array_equal(r, rho)), None)
        drawn.append((name, rho))
        steps = np.flatnonzero(np.diff(np.concatenate([[0.0], rho])) != 0)  # where ρ steps up
        width = _PROFILE_WIDTHS[n % len(_PROFILE_WIDTHS)]
        ax.step(
            np.append(taus, right),
            np.append(rho, rho[-1]),
            where="post",
            linewidth=width,
            color=colors[n],
            linestyle=_PROFILE_STYLES[n % len(_PROFILE_STYLES)],
            marker=_PROFILE_MARKERS[n % len(_PROFILE_MARKERS)],
            markevery=list(steps),
            markersize=3.0 + 1.6 * width,
            markerfacecolor="none",
            markeredgewidth=1.3,
            alpha=0.85,
            zorder=2.0 + 0.1 * (n % len(_PROFILE_WIDTHS)),  # the widths decrease: wider below
            label=name
            + (" (no path: on the τ axis)" if never else "")
            + (f" (same curve as {same})" if same is not None else ""),
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
