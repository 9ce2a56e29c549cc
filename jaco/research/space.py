"""Search spaces for :func:`jaco.search`: which planners, parameters and sizes a search may choose.

A space is a dict, name -> dimension::

    {"variant": ["iaca", "acs"],        # the planner: a categorical of names or compositions
     "beta": (1.0, 20.0, "log"),        # a float, log-uniform
     "rho": (0.01, 0.5),                # a float, uniform
     "q0": [0.5, 0.8, 0.95],            # a categorical of numbers
     "n_ants": [20, 50],                # a size: every distinct value is its own compiled program
     "w": (2, 12, "int"),               # an integer ("int", "log" may be combined)
     "alpha": 1.0}                      # a fixed value (not searched)

or the same dimensions as :class:`Float`, :class:`Int` and :class:`Categorical` objects. A
parameter that only some of the planners use is *conditional*: it is sampled only for those
planners (Optuna's define-by-run space, TPE with ``group=True``). Everything is checked here,
with numpy, before anything compiles: names, ranges (inside the parameter's valid range, a log
range above 0, low < high), the planners, a parameter that no chosen planner uses, and order
relations (τmin < τmax, Q1 < Q2 < Q3, ρ2 < ρ1) that a sample could break.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from .. import planners as _planners  # noqa: F401 (its modules declare every component's parameters)
from ..engine.params import SPECS, check_values, ordered_pairs, owners
from ..engine.planner import Planner
from ..errors import ParamError

#: Sizes a search may choose (static shapes: each distinct value compiles its own program, so a
#: categorical of a few values is the usual choice).
SIZES = ("n_ants", "n_iters")
VARIANT = "variant"


class SpaceError(ParamError):
    """A search space that cannot be searched (one line, before anything compiles)."""


@dataclass(frozen=True)
class Float:
    """A real parameter in ``[low, high]``, uniform or (``log``) log-uniform."""

    low: float
    high: float
    log: bool = False

    def describe(self) -> str:
        return f"{self.low:g}:{self.high:g}" + (":log" if self.log else "")


@dataclass(frozen=True)
class Int:
    """An integer in ``[low, high]`` (both included), uniform or (``log``) log-uniform."""

    low: int
    high: int
    log: bool = False

    def describe(self) -> str:
        return f"{self.low}:{self.high}:int" + (":log" if self.log else "")


@dataclass(frozen=True)
class Categorical:
    """One of ``choices`` (numbers, or planner names for ``planner``)."""

    choices: tuple

    def describe(self) -> str:
        return ",".join(str(c) for c in self.choices)


Dim = Float | Int | Categorical


def _dim(name: str, spec) -> Dim | float:
    """One entry of a space dict as a dimension, or a plain number (a fixed value)."""
    if isinstance(spec, (Float, Int, Categorical)):
        return spec
    if isinstance(spec, (bool, np.bool_)):
        raise SpaceError(f"space[{name!r}]: expected a range, a list of values or a number, got {spec!r}")
    if isinstance(spec, (int, float, np.integer, np.floating)):
        return float(spec)
    if isinstance(spec, tuple):
        tags = [x for x in spec[2:] if isinstance(x, str)]
        ends = spec[:2]
        if len(spec) < 2 or len(tags) != len(spec) - 2 or set(tags) - {"log", "int", "linear"}:
            raise SpaceError(f"space[{name!r}]: a range is (low, high) with optional 'log' and/or 'int', got {spec!r}")
        try:
            lo, hi = (float(x) for x in ends)
        except (TypeError, ValueError):
            raise SpaceError(f"space[{name!r}]: the ends of a range must be numbers, got {spec!r}") from None
        if "int" in tags:
            if not (float(lo).is_integer() and float(hi).is_integer()):
                raise SpaceError(f"space[{name!r}]: an 'int' range needs integer ends, got {spec!r}")
            return Int(int(lo), int(hi), "log" in tags)
        return Float(lo, hi, "log" in tags)
    if isinstance(spec, (list, np.ndarray)) or (isinstance(spec, Sequence) and not isinstance(spec, (str, bytes))):
        return Categorical(tuple(spec))
    raise SpaceError(
        f"space[{name!r}]: expected (low, high[, 'log'][, 'int']), a list of values or a number, got {spec!r}"
    )


def _check_range(name: str, dim: Float | Int) -> None:
    lo, hi = float(dim.low), float(dim.high)
    if not (math.isfinite(lo) and math.isfinite(hi)):
        raise SpaceError(f"space[{name!r}]: the range must be finite, got ({lo:g}, {hi:g})")
    if not lo < hi:
        raise SpaceError(
            f"space[{name!r}]: empty range ({lo:g}, {hi:g}); it needs low < high (a fixed value is a number)"
        )
    if dim.log and lo <= 0:
        raise SpaceError(f"space[{name!r}]: a log range needs low > 0, got ({lo:g}, {hi:g})")
    if name in SPECS:
        check_values({name: [lo, hi]}, (name,), "a search space")


def _check_size(name: str, dim) -> Dim | int:
    if isinstance(dim, float):
        if not dim.is_integer() or dim < 1:
            raise SpaceError(f"space[{name!r}]: a size must be a positive integer, got {dim:g}")
        return int(dim)
    if isinstance(dim, Float):
        raise SpaceError(f"space[{name!r}]: a size is an integer: use (low, high, 'int') or a list of values")
    if isinstance(dim, Int):
        _check_range(name, dim)
        if dim.low < 1:
            raise SpaceError(f"space[{name!r}]: sizes start at 1, got ({dim.low}, {dim.high})")
        return dim
    values = dim.choices
    if not values or not all(isinstance(v, (int, np.integer)) and not isinstance(v, bool) and v >= 1 for v in values):
        raise SpaceError(f"space[{name!r}]: a size takes positive integers, got {list(values)}")
    if len(set(values)) != len(values):
        raise SpaceError(f"space[{name!r}]: a value is listed twice in {list(values)}")
    return Categorical(tuple(int(v) for v in values))


@dataclass(frozen=True)
class Space:
    """A checked search space: ``planners`` (name -> :class:`Planner`, in the given order),
    ``dims`` (name -> dimension: the planner's, the sizes', the parameters'), ``fixed`` (name ->
    value, parameters and sizes that are not searched)."""

    planners: dict
    dims: dict
    fixed: dict

    @property
    def searches_planner(self) -> bool:
        return VARIANT in self.dims

    def uses(self, planner: str, name: str) -> bool:
        """Whether dimension ``name`` applies to ``planner``."""
        return name == VARIANT or name in SIZES or name in self.planners[planner].params

    def conditional(self) -> bool:
        """Whether some dimension applies to some planners only."""
        return any(not all(self.uses(p, n) for p in self.planners) for n in self.dims)

    def describe(self) -> dict:
        """The space as plain JSON (stored with a study, compared when it resumes)."""
        out = {
            n: d.describe() if not isinstance(d, Categorical) or n != VARIANT else list(d.choices)
            for n, d in self.dims.items()
        }
        out.update({n: v for n, v in self.fixed.items()})
        if VARIANT not in self.dims:
            out[VARIANT] = next(iter(self.planners))
        return out


def parse_space(space: Any, planner: Any = None) -> Space:
    """Check ``space`` (see the module) and resolve its planners; ``planner`` is the planner when
    the space names none (default ``"mmas"``)."""
    from ..planners.registry import get_planner

    if not isinstance(space, Mapping):
        raise SpaceError(f"space must be a dict of name -> range, values or number, got {type(space).__name__}")
    entries = dict(space)
    for name in entries:
        if not isinstance(name, str):
            raise SpaceError(f"space: names must be strings, got {name!r}")
    if "planner" in entries:  # the planner's name; "variant" is the key tables and stored studies use
        if VARIANT in entries:
            raise SpaceError("space['planner'] and space['variant'] are the same entry: give one")
        entries[VARIANT] = entries.pop("planner")
    if VARIANT in entries and planner is not None:
        raise SpaceError("the planner is given twice: as planner= and as space['planner']; keep one")
    chosen = entries.pop(VARIANT, "mmas" if planner is None else planner)
    several = isinstance(chosen, (list, tuple, Categorical)) and not isinstance(chosen, Planner)
    names = list(chosen.choices if isinstance(chosen, Categorical) else chosen) if several else [chosen]
    if not names:
        raise SpaceError("space['planner']: an empty list of planners")
    planners = {}
    for v in names:
        resolved = get_planner(v)  # an unknown planner: one JacoError line listing the registered ones
        planners[resolved.name] = resolved
    if len(planners) != len(names):
        raise SpaceError(f"space['planner']: a planner is listed twice in {names}")
    dims: dict = {VARIANT: Categorical(tuple(planners))} if len(planners) > 1 else {}
    fixed: dict = {}
    used = set().union(*(v.params for v in planners.values()))
    for name, spec in entries.items():
        if name not in SPECS and name not in SIZES:
            raise SpaceError(
                f"unknown parameter {name!r} in the search space; valid: {', '.join(sorted(used | set(SIZES)))}"
            )
        dim = _dim(name, spec)
        if name in SIZES:
            dim = _check_size(name, dim)
        elif name not in used:
            raise SpaceError(owners(name, planners.values()))
        elif isinstance(dim, float):
            check_values({name: dim}, (name,), "a search space")
        elif isinstance(dim, Categorical):
            if not dim.choices:
                raise SpaceError(f"space[{name!r}]: an empty list of values")
            if not all(
                isinstance(c, (int, float, np.integer, np.floating)) and not isinstance(c, bool) for c in dim.choices
            ):
                raise SpaceError(f"space[{name!r}]: the values must be numbers, got {list(dim.choices)}")
            if len(set(dim.choices)) != len(dim.choices):
                raise SpaceError(f"space[{name!r}]: a value is listed twice in {list(dim.choices)}")
            check_values({name: np.asarray(dim.choices, np.float64)}, (name,), "a search space")
            dim = Categorical(tuple(float(c) for c in dim.choices))
        else:
            _check_range(name, dim)
        if isinstance(dim, (int, float)):
            fixed[name] = dim
        else:
            dims[name] = dim
    searched = [n for n in dims if n != VARIANT]
    if not searched and len(planners) == 1:
        raise SpaceError("the search space has nothing to search: give a range or a list of values")
    _check_order(planners, dims, fixed)
    return Space(planners, dims, fixed)


def bounds(dim: Any, value: Any = None) -> tuple[float, float]:
    """The smallest and largest value a dimension (or a fixed value) can take."""
    if isinstance(dim, (Float, Int)):
        return float(dim.low), float(dim.high)
    if isinstance(dim, Categorical):
        return float(min(dim.choices)), float(max(dim.choices))
    return float(value), float(value)


def _check_order(planners, dims, fixed) -> None:
    """Every sample must keep τmin < τmax, Q1 < Q2 < Q3, ρ2 < ρ1 for every planner (the
    partner's value is its range, its fixed value or the planner's default)."""
    for name, v in planners.items():
        defaults = v.default_params().to_dict()
        for lo, hi in ordered_pairs(v.params):
            if not (lo in dims or hi in dims):  # only where a range is searched
                continue
            _, lo_max = bounds(dims.get(lo), fixed.get(lo, defaults[lo]))
            hi_min, _ = bounds(dims.get(hi), fixed.get(hi, defaults[hi]))
            if not lo_max < hi_min:
                raise SpaceError(
                    f"planner {name!r} needs {lo} < {hi}, but the space allows {lo} = {lo_max:g} with {hi} = {hi_min:g}: "
                    f"make the ranges of {lo} and {hi} disjoint"
                )
