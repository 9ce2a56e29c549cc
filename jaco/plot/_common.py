"""What every family of figures shares: a figure's axes, a legend beside them, the colormap
with obstacles dark, the planner column's names."""

from __future__ import annotations

from matplotlib.figure import Figure

OBSTACLE_COLOR = "#2b2b2b"
#: A table's planner column: ``planner``, or ``variant`` in tables written before it was renamed.
PLANNER_COLUMNS = ("planner", "variant")


def figure_axes(ax, figsize=(6.0, 6.0)):
    """``(fig, ax)``: the given axes and its figure, or a new standalone figure with one axes."""
    if ax is not None:
        return ax.figure, ax
    fig = Figure(figsize=figsize)
    return fig, fig.add_subplot()


def legend_outside(ax, handles=None, labels=None, *, beside=(), **kw):
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


def viridis_with_bad():
    """viridis with masked cells (obstacles, values a figure leaves out) in the obstacles' colour."""
    from matplotlib import colormaps

    return colormaps["viridis"].with_extremes(bad=OBSTACLE_COLOR)
