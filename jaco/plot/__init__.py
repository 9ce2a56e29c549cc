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

One module per family of figures: :mod:`.maps` (the map, paths, pheromone and its animation),
:mod:`.convergence`, :mod:`.sweeps`, :mod:`.search`, :mod:`.compare`; :mod:`.files` writes them.
"""

# Reached as jaco.plot.<name> but not in __all__: check_figure_path and figure_suffixes by the
# command line, sweep_grid and OBJECTIVE_MAX by users.
from .compare import plot_critical_difference, plot_performance_profile
from .convergence import plot_convergence
from .files import check_figure_path as check_figure_path
from .files import figure_suffixes as figure_suffixes
from .files import save, save_gif
from .maps import animate_pheromone, plot_map, plot_paths, plot_pheromone
from .search import OBJECTIVE_MAX as OBJECTIVE_MAX
from .search import plot_param_importance, plot_pareto, plot_search_contour, plot_search_history
from .sweeps import plot_sweep_box, plot_sweep_heatmap
from .sweeps import sweep_grid as sweep_grid

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
