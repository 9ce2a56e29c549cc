"""jaco: ant colony optimisation path planners on occupancy grids, batched and jitted with JAX.

>>> import jaco
>>> grid = jaco.maps.named("demo")
>>> result = jaco.solve(grid, grid.meta["start"], grid.meta["goal"], "acs", seed=0)
"""

from . import exact, heuristics, maps, metrics, pheromone, plot
from .errors import JacoError, MapFormatError, ParamError, ProblemError
from .grid import Grid
from .params import Params
from .problem import Problem, make_problem
from .run import Result, make_run, solve
from .sweep import summarize, sweep
from .variants import VARIANTS, Variant

__version__ = "0.1.0"
__all__ = [
    "Grid", "Params", "Problem", "Result", "Variant", "VARIANTS",
    "JacoError", "MapFormatError", "ParamError", "ProblemError",
    "make_problem", "make_run", "solve", "sweep", "summarize",
    "exact", "heuristics", "maps", "metrics", "pheromone", "plot",
]
