"""Experimental designs over :class:`~jaco.engine.params.Params` fields: which configurations a sweep runs.

A :class:`Design` is a table of configurations: equal-length float arrays, one per parameter
name, one row per configuration. :func:`jaco.sweep` takes one as ``params`` and runs every row ×
every seed × every query in one compiled call (a plain dict of lists is still a full grid).

>>> import jaco
>>> d = jaco.research.designs.grid(alpha=[0.5, 1.0], beta=[1.0, 2.0, 4.0])
>>> len(d), d.names
(6, ('alpha', 'beta'))
>>> h = jaco.research.designs.latin_hypercube(0, 8, {"alpha": (0.5, 4.0), "rho": (0.01, 0.5)}, log=["rho"])
>>> len(h), bool((h["rho"] >= 0.01).all() and (h["rho"] <= 0.5).all())
(8, True)

Ranges and values are checked against :data:`jaco.engine.params.SPECS` when the design is built, so a
bad range is a :class:`~jaco.errors.ParamError` before anything compiles. Random designs take an
explicit integer ``seed`` (numpy's PCG64 generator): the same seed gives the same design.
"""

from __future__ import annotations

import itertools
import math
from typing import TYPE_CHECKING, Any, Iterable, Mapping

import numpy as np

from .. import planners  # noqa: F401 (its modules declare every component's parameters)
from ..engine.params import SPECS, check_values, param_names
from ..errors import ParamError

if TYPE_CHECKING:
    import pandas as pd


class Design:
    """Configurations as rows: ``values[name]`` is a float64 array of length ``len(design)``.

    Build one with :func:`grid`, :func:`random`, :func:`latin_hypercube`, :func:`table` or
    :func:`product`. A design with no parameter has one row (every parameter at its default).
    """

    __slots__ = ("_values", "_n", "kind")

    def __init__(self, values: Mapping, kind: str = "table", n: int | None = None):
        checked = check_values(dict(values), param_names(), "a design")
        lengths = {k: np.atleast_1d(v).shape[0] for k, v in checked.items()}
        if len(set(lengths.values())) > 1:
            raise ParamError(f"a design needs one value per configuration for every parameter, got lengths {lengths}")
        size = next(iter(lengths.values())) if lengths else (1 if n is None else n)
        if n is not None and lengths and size != n:
            raise ParamError(f"a design of {n} configurations got {size} values")
        if size < 1:
            raise ParamError("a design needs at least one configuration")
        self._values = {k: np.atleast_1d(v).astype(np.float64) for k, v in checked.items()}
        for v in self._values.values():
            v.setflags(write=False)
        self._n = int(size)
        self.kind = kind

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(self._values)

    @property
    def values(self) -> dict[str, np.ndarray]:
        return dict(self._values)

    def __len__(self) -> int:
        return self._n

    def __getitem__(self, name: str) -> np.ndarray:
        return self._values[name]

    def __contains__(self, name) -> bool:
        return name in self._values

    def __eq__(self, other) -> bool:
        return (
            isinstance(other, Design)
            and self.names == other.names
            and len(self) == len(other)
            and all(np.array_equal(self[k], other[k]) for k in self.names)
        )

    __hash__ = None  # type: ignore[assignment]  # unhashable (mutable columns), as object's stub can't say

    def __repr__(self) -> str:
        return f"Design({self.kind}, {len(self)} configurations over {', '.join(self.names) or 'no parameter'})"

    def to_frame(self) -> pd.DataFrame:
        """The design as a pandas DataFrame (one row per configuration, index = ``config``)."""
        import pandas as pd

        frame = pd.DataFrame({k: self._values[k] for k in self.names}, index=pd.RangeIndex(len(self), name="config"))
        return frame


def table(values: Mapping[str, Any] | pd.DataFrame) -> Design:
    """Explicit rows: a dict of equal-length sequences, or a DataFrame with parameter columns."""
    if hasattr(values, "to_dict") and hasattr(values, "columns"):  # a DataFrame
        values = {str(c): np.asarray(values[c]) for c in values.columns}
    return Design(values, kind="table")


def grid(axes: Mapping | None = None, **more: Any) -> Design:
    """Every combination of the axes (name -> list of values), first axis slowest — the same
    order as ``jaco.sweep(..., params={...})`` with a dict."""
    axes = {**(axes or {}), **more}
    checked = check_values(axes, param_names(), "a grid design")
    arrays = {k: np.atleast_1d(v) for k, v in checked.items()}
    for k, v in arrays.items():
        if v.size == 0:
            raise ParamError(f"grid axis {k!r} has no value")
    combos = list(itertools.product(*arrays.values()))
    values = {k: np.array([c[i] for c in combos], np.float64) for i, k in enumerate(arrays)}
    return Design(values, kind="grid", n=len(combos))


def _check_ranges(ranges: Mapping, log) -> tuple[list[str], np.ndarray, np.ndarray, np.ndarray]:
    if not isinstance(ranges, Mapping) or not ranges:
        raise ParamError("ranges must be a non-empty dict: name -> (low, high)")
    log = {log} if isinstance(log, str) else set(log or ())
    unknown = log - set(ranges)
    if unknown:
        raise ParamError(f"log scale asked for {sorted(unknown)}, which have no range")
    names, lo, hi = [], [], []
    for name, r in ranges.items():
        if name not in SPECS:
            raise ParamError(f"unknown parameter {name!r} in ranges; valid: {', '.join(sorted(SPECS))}")
        try:
            a, b = (float(x) for x in r)
        except (TypeError, ValueError):
            raise ParamError(f"range of {name!r} must be a (low, high) pair of numbers, got {r!r}") from None
        if not (math.isfinite(a) and math.isfinite(b)):
            raise ParamError(f"range of {name!r} must be finite, got ({a:g}, {b:g})")
        if not a <= b:
            raise ParamError(f"range of {name!r} needs low <= high, got ({a:g}, {b:g})")
        check_values({name: [a, b]}, tuple(SPECS), "a design range")  # both ends inside SPECS
        if name in log and a <= 0:
            raise ParamError(f"log-scale range of {name!r} needs low > 0, got {a:g}")
        names.append(name)
        lo.append(a)
        hi.append(b)
    is_log = np.array([n in log for n in names])
    return names, np.array(lo), np.array(hi), is_log


def _scale(u: np.ndarray, lo, hi, is_log) -> np.ndarray:
    """Map uniforms u in [0, 1) (n, d) to the ranges, linearly or log-uniformly."""
    to = lambda v: np.where(is_log, np.log(np.where(is_log, v, 1.0)), v)  # noqa: E731 (log only where lo > 0)
    x = to(lo) + u * (to(hi) - to(lo))
    x = np.where(is_log, np.exp(x), x)
    return np.clip(x, lo, hi)  # exp/log rounding must not leave the validated range


def _check_n(n) -> int:
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
        raise ParamError(f"n must be a positive integer, got {n!r}")
    return int(n)


def _rng(seed) -> np.random.Generator:
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ParamError(f"seed must be a non-negative integer, got {seed!r}")
    return np.random.default_rng(int(seed))


def random(seed: int, n: int, ranges: Mapping, *, log: Iterable[str] = ()) -> Design:
    """``n`` configurations drawn independently and uniformly from ``ranges`` (name -> (low,
    high)); names in ``log`` are drawn log-uniformly (uniform in log space, e.g. ρ or Q)."""
    n = _check_n(n)
    names, lo, hi, is_log = _check_ranges(ranges, log)
    u = _rng(seed).random((n, len(names)))
    x = _scale(u, lo, hi, is_log)
    return Design({k: x[:, j] for j, k in enumerate(names)}, kind="random", n=n)


def latin_hypercube(seed: int, n: int, ranges: Mapping, *, log: Iterable[str] = ()) -> Design:
    """A Latin hypercube of ``n`` configurations: every parameter's range (log space for names in
    ``log``) is cut into ``n`` equal strata and every stratum holds exactly one configuration, at a
    uniform position inside it; the strata are paired across parameters by independent random
    permutations (McKay, Beckman & Conover 1979)."""
    n = _check_n(n)
    names, lo, hi, is_log = _check_ranges(ranges, log)
    rng = _rng(seed)
    strata = np.stack([rng.permutation(n) for _ in names], axis=1)
    u = (strata + rng.random((n, len(names)))) / n
    x = _scale(u, lo, hi, is_log)
    return Design({k: x[:, j] for j, k in enumerate(names)}, kind="latin_hypercube", n=n)


def product(*designs: Any) -> Design:
    """Every row of the first design with every row of the next (first slowest), e.g. a Latin
    hypercube over (α, β) crossed with a grid over ρ. The designs must not share a name."""
    parts = [as_design(d) for d in designs]
    seen: set = set()
    for d in parts:
        shared = seen & set(d.names)
        if shared:
            raise ParamError(f"designs in a product must not share parameters, both have {sorted(shared)}")
        seen |= set(d.names)
    index = np.array(list(itertools.product(*(range(len(d)) for d in parts))), np.int64).reshape(-1, len(parts))
    values = {k: d[k][index[:, i]] for i, d in enumerate(parts) for k in d.names}
    return Design(values, kind="product", n=len(index))


def as_design(params: Any) -> Design:
    """What :func:`jaco.sweep` accepts as ``params``: None (defaults only), a dict of axes (a full
    grid, as before), a :class:`Design`, or a DataFrame of rows."""
    if params is None:
        return Design({}, kind="grid")
    if isinstance(params, Design):
        return params
    if hasattr(params, "columns"):
        return table(params)
    if isinstance(params, Mapping):
        return grid(params)
    raise ParamError(
        f"params must be a dict of axes, a jaco.research.designs.Design or a DataFrame, got {type(params).__name__}"
    )
