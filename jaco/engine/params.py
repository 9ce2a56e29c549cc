"""Hyperparameters: each component declares its own (:class:`Param`); a planner's are the union
of its components' (the second of the five concepts).

A :class:`Params` is a pytree of traced floats, one leaf per parameter of the planner, so a search
grid is simply a ``Params`` whose leaves carry a leading axis and ``jax.vmap`` runs the whole grid
in one compiled call. Shapes (ants, iterations, step limit) are never here: they are static
arguments of :func:`jaco.engine.run.make_run`.

Nothing here lists the planners' parameters: the module that holds a component's equations
declares them (:func:`declare`), e.g. :data:`jaco.engine.pheromone.RHO`, so a new component with a
new hyperparameter touches no engine file. :data:`SPECS` is every parameter declared so far (the
name's range and meaning; a name is declared once with one range, and every component that reads
it brings its own default).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any, Iterable, Iterator, Mapping

import jax
import numpy as np

from ..errors import JacoError, ParamError, did_you_mean

INF = math.inf


@dataclass(frozen=True)
class Param:
    """One hyperparameter of a component: its name, default, valid range ``[lo, hi]`` (ends open
    where marked) and what it is, citing the equation it comes from."""

    name: str
    default: float
    lo: float
    hi: float
    doc: str
    lo_open: bool = False
    hi_open: bool = False

    def contains(self, v: np.ndarray) -> np.ndarray:
        above = v > self.lo if self.lo_open else v >= self.lo
        below = v < self.hi if self.hi_open else v <= self.hi
        return above & below

    def describe(self) -> str:
        left = "(" if self.lo_open else "["
        right = ")" if self.hi_open else "]"
        return f"{left}{self.lo:g}, {self.hi:g}{right}"

    def with_default(self, default: float) -> "Param":
        """The same parameter with another component's default."""
        return replace(self, default=float(default))

    def same_range(self, other: "Param") -> bool:
        return (self.lo, self.hi, self.lo_open, self.hi_open) == (other.lo, other.hi, other.lo_open, other.hi_open)


#: Every parameter declared so far, by name (the first declaration's default and meaning).
SPECS: dict[str, Param] = {}
#: Pairs (a, b) that must satisfy a < b wherever a planner has both (τmin < τmax, Q1 < Q2 < Q3,
#: ρ2 < ρ1), declared with the parameters.
ORDERED: list[tuple[str, str]] = []


def declare(*params: Param, order: Iterable[tuple[str, str]] = ()) -> tuple[Param, ...]:
    """Make ``params`` known by name (designs, search spaces and ``jaco.tune`` check names and
    ranges against :data:`SPECS`) and the relations ``order`` (``(a, b)``: a < b); returns the
    parameters. Declaring a name again is harmless with the same range and an error with another."""
    for p in params:
        if not isinstance(p, Param):
            raise JacoError(f"declare takes Param objects, got {type(p).__name__} {p!r}")
        if not (isinstance(p.name, str) and p.name.isidentifier()):
            raise JacoError(f"a parameter's name must be an identifier, got {p.name!r}")
        if not p.lo <= p.hi:  # also NaN ends
            raise JacoError(f"parameter {p.name!r}: its range {p.describe()} is empty")
        if not bool(p.contains(np.asarray(float(p.default)))):
            raise JacoError(f"parameter {p.name!r}: its default {p.default:g} is outside its range {p.describe()}")
        known = SPECS.get(p.name)
        if known is None:
            SPECS[p.name] = p
        elif not known.same_range(p):
            raise JacoError(
                f"parameter {p.name!r} is declared with range {known.describe()} already; "
                f"another component declares {p.describe()}: give it another name"
            )
    for pair in order:
        if tuple(pair) not in ORDERED:
            ORDERED.append((pair[0], pair[1]))
    return params


class Params(Mapping):
    """The values of a planner's parameters, ``params.rho``: a pytree with one leaf per name
    (scalars, or arrays with a leading grid axis under ``vmap``).

    ``Params(**values)`` holds exactly ``values``; a planner's defaults are
    ``planner.default_params()``. Reading a name it does not hold is an :class:`AttributeError`
    that lists the names it has, so a component that reads a parameter its planner did not
    declare fails when the run is traced, not with a silent default."""

    __slots__ = ("_values",)

    def __init__(self, **values: Any) -> None:
        object.__setattr__(self, "_values", dict(values))

    def __getattr__(self, name: str) -> Any:
        values = object.__getattribute__(self, "_values")
        try:
            return values[name]
        except KeyError:
            if name.startswith("__"):
                raise AttributeError(name) from None
            raise AttributeError(
                f"no parameter {name!r} here{did_you_mean(name, values)}; "
                f"these Params hold: {', '.join(sorted(values)) or 'none'}"
            ) from None

    def __setattr__(self, name, value):
        raise AttributeError("Params are immutable: use params.replace(name=value)")

    def __getitem__(self, name: str) -> Any:
        return self._values[name]

    def __iter__(self) -> Iterator[str]:
        return iter(self._values)

    def __len__(self) -> int:
        return len(self._values)

    def __repr__(self) -> str:
        return "Params(" + ", ".join(f"{k}={v!r}" for k, v in self._values.items()) + ")"

    def replace(self, **changes: Any) -> "Params":
        """A copy with ``changes`` (a schedule's α, β or ρ of one iteration; new names are added)."""
        return Params(**{**self._values, **changes})

    def to_dict(self) -> dict:
        """Plain Python floats (or lists, for grid axes)."""
        return {k: _plain(v) for k, v in self._values.items()}


def _flatten(p: Params):
    keys = tuple(sorted(p._values))
    return [(jax.tree_util.GetAttrKey(k), p._values[k]) for k in keys], keys


def _unflatten(keys, leaves) -> Params:
    return Params(**dict(zip(keys, leaves)))


jax.tree_util.register_pytree_with_keys(Params, _flatten, _unflatten)


def _plain(v):
    a = np.asarray(v)
    return a.item() if a.ndim == 0 else a.tolist()


def param_names() -> tuple[str, ...]:
    """Every declared parameter name."""
    return tuple(SPECS)


def unknown_parameter(
    name: str, allowed: Iterable[str], where: str, keywords: Iterable[str] = (), call: str = ""
) -> str:
    """The message for a name that is not a parameter of ``where``: the closest of the parameters
    ``allowed`` and of the call's own ``keywords`` (``n_ant`` -> ``n_ants``), then the valid names."""
    also = f"; the keywords of {call}: {', '.join(keywords)}" if keywords else ""
    return (
        f"unknown parameter {name!r} for {where}{did_you_mean(name, [*allowed, *keywords])}; "
        f"valid: {', '.join(sorted(allowed))}{also}"
    )


def owners(name: str, planners: Iterable[Any]) -> str:
    """Which of ``planners`` (objects with ``name`` and ``params``) have the parameter ``name``, in
    the words of a sweep or a search whose parameter some or all of them lack: ``"parameter 'q0'
    belongs to acs only, not to mmas"``, or ``"parameter 'q0' is not used by planner 'mmas'; it
    uses: alpha, ..."`` when none has it (no "did you mean": the name is right, the planner is not)."""
    planners = list(planners)
    have = [p.name for p in planners if name in p.params]
    lack = [p.name for p in planners if name not in p.params]
    if have:
        return f"parameter {name!r} belongs to {' and '.join(have)} only, not to {', '.join(lack)}"
    used = ", ".join(sorted(set().union(*(p.params for p in planners))))
    if len(lack) == 1:
        return f"parameter {name!r} is not used by planner {lack[0]!r}; it uses: {used}"
    return f"parameter {name!r} is not used by any of the planners {', '.join(lack)}; they use: {used}"


def check_values(values: Mapping, allowed: Iterable[str], where: str) -> dict:
    """Validate user values (names, NaN, ranges of :data:`SPECS`) with numpy; returns float arrays.

    Values may be scalars or 1-D sequences (a sweep axis). Raises :class:`ParamError`.
    """
    allowed = tuple(allowed)
    out = {}
    for name, v in values.items():
        if name not in allowed or name not in SPECS:
            raise ParamError(unknown_parameter(name, allowed, where))
        try:
            if v is None or isinstance(v, (str, bytes)) or np.asarray(v).dtype.kind not in "iuf":
                raise TypeError
            a = np.asarray(v, dtype=np.float64)
        except (TypeError, ValueError):
            raise ParamError(
                f"parameter {name!r} must be a number (float) or a 1-D list of numbers, got {v!r}"
            ) from None
        if a.ndim > 1:
            raise ParamError(f"parameter {name!r} must be a number or a 1-D list, got shape {a.shape}")
        if np.isnan(a).any():
            raise ParamError(f"parameter {name!r} is NaN")
        spec = SPECS[name]
        bad = ~spec.contains(a)
        if bad.any():
            first = a.ravel()[np.argmax(bad.ravel())]
            raise ParamError(f"parameter {name!r} = {first:g} is out of range {spec.describe()} ({spec.doc})")
        out[name] = a
    return out


def ordered_pairs(used: Iterable[str]) -> list[tuple[str, str]]:
    """The relations of :data:`ORDERED` between the parameters ``used`` (a planner's): the pairs
    ``(lo, hi)`` that must keep ``lo < hi``."""
    used = tuple(used)
    return [(lo, hi) for lo, hi in ORDERED if lo in used and hi in used]


def check_order(values: Mapping, used: Iterable[str], *, per_row: bool = False) -> None:
    """Relations between parameters (:data:`ORDERED`) on the merged values of a planner. Values
    may be sweep axes, checked for every combination; with ``per_row`` they are the columns of a
    configuration table, checked row by row, and the first bad row is named."""
    for lo, hi in ordered_pairs(used):
        a, b = np.atleast_1d(values[lo]), np.atleast_1d(values[hi])
        if per_row:
            bad = ~(a < b)
            if bad.any():
                i = int(np.argmax(bad))
                raise ParamError(
                    f"parameters need {lo} < {hi}, got {lo} = {a[i]:g}, {hi} = {b[i]:g} (configuration {i})"
                )
        elif not a.max() < b.min():  # every combination of a sweep must hold
            raise ParamError(f"parameters need {lo} < {hi}, got {lo} = {a.max():g}, {hi} = {b.min():g}")
