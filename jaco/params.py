"""Hyperparameters as one frozen dataclass of traced floats (DESIGN.md concept 2).

Every field is a pytree leaf, so a search grid is simply a ``Params`` whose leaves carry a
leading axis, and ``jax.vmap`` runs the whole grid in one compiled call. Shapes (ants,
iterations, step limit) are never here: they are static arguments of :func:`jaco.make_run`.
Each variant uses a subset of the fields (``Variant.params``) and overrides some defaults.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace

import jax
import numpy as np

from .errors import ParamError

INF = math.inf


@jax.tree_util.register_dataclass
@dataclass(frozen=True)
class Params:
    """All hyperparameters of all planners; see :data:`SPECS` for meaning and valid ranges."""

    alpha: float = 1.0
    beta: float = 2.0
    rho: float = 0.1
    q: float = 1.0
    tau0: float = 0.1
    q0: float = 0.9
    xi: float = 0.1
    sigma: float = 5.0
    w: float = 6.0
    p_best: float = 0.05

    def replace(self, **changes) -> "Params":
        return replace(self, **changes)

    def to_dict(self) -> dict:
        return {f.name: _plain(getattr(self, f.name)) for f in fields(self)}


def _plain(v):
    a = np.asarray(v)
    return a.item() if a.ndim == 0 else a.tolist()


@dataclass(frozen=True)
class Spec:
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


SPECS: dict[str, Spec] = {
    "alpha": Spec(0, 20, "pheromone exponent α"),
    "beta": Spec(0, 20, "heuristic exponent β"),
    "rho": Spec(0, 1, "evaporation rate ρ: τ ← (1−ρ)τ + Δτ", lo_open=True),
    "q": Spec(0, INF, "deposit constant Q", lo_open=True, hi_open=True),
    "tau0": Spec(0, INF, "initial pheromone τ0 (ACS: also the local-update target)", lo_open=True, hi_open=True),
    "q0": Spec(0, 1, "exploitation probability q0 of the pseudo-random proportional rule"),
    "xi": Spec(0, 1, "ACS local evaporation ξ: τ ← (1−ξ)τ + ξτ0"),
    "sigma": Spec(0, 1000, "elitist weight σ (number of elite ants) on the best-so-far path"),
    "w": Spec(1, 1000, "rank-based AS: the w−1 best ants deposit, plus the best-so-far with weight w"),
    "p_best": Spec(0, 1, "MMAS: probability of building the best path at convergence (sets τmin)", lo_open=True, hi_open=True),
}


def param_names() -> tuple[str, ...]:
    return tuple(f.name for f in fields(Params))


def check_values(values: dict, allowed: tuple[str, ...], where: str) -> dict:
    """Validate user values (names, NaN, ranges) with numpy; returns float arrays.

    Values may be scalars or 1-D sequences (a sweep axis). Raises :class:`ParamError`.
    """
    out = {}
    for name, v in values.items():
        if name not in allowed:
            raise ParamError(
                f"unknown parameter {name!r} for {where}; valid: {', '.join(sorted(allowed))}"
            )
        try:
            a = np.asarray(v, dtype=np.float64)
        except (TypeError, ValueError):
            raise ParamError(f"parameter {name!r} must be a number, got {v!r}") from None
        if a.ndim > 1:
            raise ParamError(f"parameter {name!r} must be a number or a 1-D list, got shape {a.shape}")
        if np.isnan(a).any():
            raise ParamError(f"parameter {name!r} is NaN")
        spec = SPECS[name]
        bad = ~spec.contains(a)
        if bad.any():
            first = a.ravel()[np.argmax(bad.ravel())]
            raise ParamError(
                f"parameter {name!r} = {first:g} is out of range {spec.describe()} ({spec.doc})"
            )
        out[name] = a
    return out
