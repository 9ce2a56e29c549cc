"""jaco: ant colony optimisation path planners on occupancy grids, batched and jitted with JAX.

>>> import jaco
>>> grid = jaco.maps.named("demo")
>>> result = jaco.solve(grid, grid.meta["start"], grid.meta["goal"], "mmas", seed=0, n_iters=20)
>>> result.success and result.length >= result.optimal - 1e-4
True

Submodules and the heavy parts (jax, pandas, matplotlib) load on first use, so that
``import jaco`` and ``jaco --help`` stay fast. The layout (docs/architecture.md, "Layout"): :mod:`jaco.engine`
(problem, params, pheromone rules, variants, walk, colony, run, result), :mod:`jaco.planners`
(one module per source, and the registry), :mod:`jaco.maps`, :mod:`jaco.research` (sweeps,
designs, tuning, records, result tables and their statistics), and :mod:`jaco.api` (``solve``), :mod:`jaco.waypoints`,
:mod:`jaco.exact`, :mod:`jaco.metrics`, :mod:`jaco.plot`, :mod:`jaco.apf`, :mod:`jaco.cli`.
"""

import warnings
from importlib import import_module
from importlib.util import find_spec

from .errors import JacoError, MapFormatError, OutputError, ParamError, ProblemError, ResourceError
from .grid import Grid

__version__ = "0.1.0"

#: Public names and the module each comes from.
_LAZY = {
    "Params": "engine.params",
    "Problem": "engine.problem",
    "make_problem": "engine.problem",
    "Result": "engine.result",
    "make_run": "api",
    "solve": "api",
    "sweep": "research.sweeps",
    "summarize": "research.sweeps",
    "plan_sweep": "research.sweeps",
    "PLANNERS": "planners.registry",
    "compose": "planners.compose",
    "Planner": "engine.planner",
    # the names before planners had one name, kept because users type them: the same objects
    "VARIANTS": "planners.registry",
    "Variant": "engine.planner",
    "load_run": "research.records",
    # statistics on a results table (the module is jaco.research.compare: jaco.compare is the function)
    "compare": "research.compare",
    # which ant walk compiled programs use: the native kernel or the JAX walk
    "set_walk": "engine.native",
    # tuning with optax (the module is jaco.research.tuning: jaco.tune is the function)
    "tune": "research.tuning",
    "TuneResult": "research.tuning",
    # adaptive batched search with Optuna / evosax samplers (pip install 'jaco[search]')
    "search": "research.search",
    "load_study": "research.search",
}
_SUBMODULES = {
    "api",
    "apf",
    "cli",
    "engine",
    "exact",
    "maps",
    "metrics",
    "moves",
    "outputs",
    "planners",
    "plot",
    "potential",
    "research",
    "testing",
    "waypoints",
}
#: Modules that moved into the engine, planners and research packages, by the name they had
#: before (the ``pheromone`` attribute is :mod:`jaco.engine.pheromone`, ``variants`` the registry):
#: deprecated, so an access warns (DeprecationWarning) with the new path, and they are not in
#: ``__all__`` or ``dir(jaco)``.
_MOVED = {
    "colony": "engine.colony",
    "construct": "engine.walk",
    "heuristics": "engine.heuristics",
    "params": "engine.params",
    "pheromone": "engine.pheromone",
    "problem": "engine.problem",
    "run": "engine.run",
    "schedules": "engine.schedules",
    "variant": "engine.planner",
    "variants": "planners.registry",
    "chaos": "planners.chaos",
    "double": "planners.double",
    "iaaco": "planners.iaaco",
    "iaca": "planners.iaca",
    "pg": "planners.pg",
    "designs": "research.designs",
    "records": "research.records",
    "sweeps": "research.sweeps",
    "tuning": "research.tuning",
}

__all__ = [
    "Grid",
    "JacoError",
    "MapFormatError",
    "OutputError",
    "ParamError",
    "ProblemError",
    "ResourceError",
    *_LAZY,
    *sorted(_SUBMODULES),
]


def __getattr__(name):
    if name in _LAZY:
        value = getattr(import_module(f".{_LAZY[name]}", __name__), name)
    elif name in _SUBMODULES:
        value = import_module(f".{name}", __name__)
    elif name in _MOVED:  # not cached, so that every access warns
        warnings.warn(f"jaco.{name} is deprecated; use jaco.{_MOVED[name]}", DeprecationWarning, stacklevel=2)
        return import_module(f".{_MOVED[name]}", __name__)
    else:
        raise AttributeError(f"module 'jaco' has no attribute {name!r}")
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(__all__))


def _submodules_on_access(package: str):
    """A module ``__getattr__`` for ``package`` (PEP 562) that imports a submodule when it is first
    used as an attribute, so ``jaco.engine.run.TRACES`` works without importing every submodule
    when the package loads."""

    def getattr_(name):
        if not name.startswith("_") and find_spec(f"{package}.{name}") is not None:
            return import_module(f"{package}.{name}")
        raise AttributeError(f"module {package!r} has no attribute {name!r}")

    return getattr_
