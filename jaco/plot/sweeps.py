"""Figures of a sweep table (:func:`jaco.sweep`): heatmaps of the mean over seeds, box plots
across seeds; parameters and text columns such as the planner as axes."""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from ..errors import ParamError
from ._common import PLANNER_COLUMNS, figure_axes, legend_outside, viridis_with_bad

if TYPE_CHECKING:
    import pandas as pd


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
    from ..research.tables import number, short_name

    if name in PLANNER_COLUMNS:
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
    fig, ax = figure_axes(ax, figsize=(max(1.2, 0.09 * longest) * len(xs) + 2.5, 0.9 * len(ys) + 1.8))
    masked = np.ma.masked_invalid(shown)
    im = ax.imshow(masked, cmap=viridis_with_bad().with_extremes(bad="#bdbdbd"), origin="lower", aspect="auto")
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
        (_tick(n, k) if n in PLANNER_COLUMNS or isinstance(k, str) else f"{n}={_tick(n, k)}") for n, k in zip(by, key)
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
    fig, ax = figure_axes(ax, figsize=(max(5.0, 0.8 * len(groups) + 2.0), 4.5))
    ax.boxplot([g if len(g) else [np.nan] for g in groups])
    ax.set_xticks(range(1, len(groups) + 1), labels)  # (boxplot's own label keyword was renamed in 3.9)
    if optimal is None and value != "gap" and "optimal" in table.columns and table["optimal"].nunique() == 1:
        optimal = float(table["optimal"].iloc[0])
    if optimal is not None:
        ax.axhline(float(optimal), color="black", linestyle="--", linewidth=1.0, label=f"optimum {float(optimal):.4g}")
        legend_outside(ax)
    ax.set_ylabel(value + (" (%)" if value == "gap" else ""))
    long = max(len(label.split("\n")[0]) for label in labels)
    ax.tick_params(axis="x", labelrotation=45 if len(groups) > 6 or long > 12 else 0, labelsize="small")
    if len(groups) > 6 or long > 12:
        for label in ax.get_xticklabels():
            label.set_horizontalalignment("right")
    ax.set_title(title if title is not None else f"{value} across seeds")
    return fig
