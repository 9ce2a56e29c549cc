"""jaco: ant colony optimisation path planners on occupancy grids, batched and jitted with JAX.

>>> import jaco
>>> grid = jaco.maps.named("demo")
>>> result = jaco.solve(grid, grid.meta["start"], grid.meta["goal"], "mmas", seed=0, n_iters=20)
>>> result.success and result.length >= result.optimal - 1e-4
True

Submodules and the heavy parts (jax, pandas, matplotlib) load on first use, so that
``import jaco`` and ``jaco --help`` stay fast.
"""

from importlib import import_module

from .errors import JacoError, MapFormatError, ParamError, ProblemError
from .grid import Grid

__version__ = "0.1.0"

_LAZY = {
    "Params": "params",
    "Problem": "problem",
    "make_problem": "problem",
    "Result": "run",
    "make_run": "run",
    "solve": "run",
    "sweep": "sweeps",
    "summarize": "sweeps",
    # sweeps at scale (issue 6)
    "plan_sweep": "sweeps",
    "VARIANTS": "variants",
    "Variant": "variants",
    # records (run records, issue 6)
    "load_run": "records",
    # tuning with optax (the module is jaco.tuning: jaco.tune is the function)
    "tune": "tuning",
    "TuneResult": "tuning",
}
_SUBMODULES = {"apf", "chaos", "construct", "designs", "exact", "heuristics", "iaaco", "maps", "metrics", "params", "pheromone", "plot", "problem", "records", "run", "sweeps", "variants", "waypoints", "cli", "pg", "tuning"}

__all__ = ["Grid", "JacoError", "MapFormatError", "ParamError", "ProblemError", *_LAZY, *sorted(_SUBMODULES)]


def __getattr__(name):
    if name in _LAZY:
        value = getattr(import_module(f".{_LAZY[name]}", __name__), name)
    elif name in _SUBMODULES:
        value = import_module(f".{name}", __name__)
    else:
        raise AttributeError(f"module 'jaco' has no attribute {name!r}")
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(__all__))
