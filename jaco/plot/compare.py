"""Figures of a comparison (:func:`jaco.compare`): the critical-difference diagram and the
performance profile."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.ticker import NullLocator

from ..errors import ParamError
from ._common import figure_axes, legend_outside

if TYPE_CHECKING:
    from ..research.compare import Comparison


def _comparison(obj, what):
    from ..research.compare import Comparison

    if not isinstance(obj, Comparison):
        raise ParamError(f"{what} takes the Comparison of jaco.compare(table, ...), got {type(obj).__name__}")
    return obj


def cliques(ranks: np.ndarray, cd: float) -> list[tuple[int, int]]:
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
    fig, ax = figure_axes(ax, figsize=(8.0, 1.6 + 0.3 * k))
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
    for n, (i, j) in enumerate(cliques(ranks, cd)):
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
    fig, ax = figure_axes(ax, figsize=(7.0, 4.5))
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
    legend_outside(ax)
    return fig
