"""Hyperparameters as one frozen dataclass of traced floats (the second of the five concepts).

Every field is a pytree leaf, so a search grid is simply a ``Params`` whose leaves carry a
leading axis, and ``jax.vmap`` runs the whole grid in one compiled call. Shapes (ants,
iterations, step limit) are never here: they are static arguments of
:func:`jaco.engine.run.make_run`.
Each variant uses a subset of the fields (``Variant.params``) and overrides some defaults.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace

import jax
import numpy as np

from ..errors import ParamError, did_you_mean

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
    # Fixed MMAS-style bounds (IDACA 3.4.2, IACA 4.2.3)
    tau_min: float = 0.01
    tau_max: float = 20.0
    # IDACA schedules (thesis eqs. 3-8, 3-9, 3-10)
    alpha_slope: float = 0.03
    alpha_end: float = 2.5
    beta_start: float = 3.0
    beta_slope: float = 0.015
    beta_end: float = 2.0
    break_iter: float = 83.0
    rho_min: float = 0.3
    rho_decay: float = 2.0
    # IACA (thesis chapter 4)
    k_init: float = 10.0
    rho_local: float = 0.1
    q1: float = 1.0
    q2: float = 5.0
    q3: float = 15.0
    rho1: float = 0.7
    rho2: float = 0.2
    q_step: float = 0.5
    # Chaos ACO (the Xi'an Technological University paper; docs/algorithms.md §7)
    gamma: float = 4.0
    chaos_iters: float = 10.0
    chaos_mu: float = 4.0
    # IAACO (Miao et al. 2021; docs/algorithms.md §5) and the multi-objective cost
    sigma1: float = 0.1
    sigma2: float = 0.9
    lam: float = 1.0
    mu_min: float = 0.1
    rs: float = 0.5
    delta0: float = 0.15
    k_rho: float = 0.3
    k_len: float = 0.7
    k_safe: float = 0.1
    k_energy: float = 0.2
    rs_cost: float = 1.0
    # Policy-gradient ACO (pg-aco, Meuleau & Dorigo 2002; docs/algorithms.md §8; jaco.planners.pg)
    penalty: float = 0.3
    # PF-ACO baseline of APF-ACO (Dong & Zhao 2021; docs/algorithms.md §6; jaco.planners.apf_guided): classic APF repulsion
    k_rep: float = 100.0
    d0: float = 3.0

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
    "tau_min": Spec(0, INF, "lower pheromone bound τmin (fixed bounds)", hi_open=True),
    "tau_max": Spec(0, INF, "upper pheromone bound τmax (fixed bounds)", lo_open=True, hi_open=True),
    "alpha_slope": Spec(0, 10, "IDACA eq. 3-8: α(i) = alpha_slope·i up to break_iter"),
    "alpha_end": Spec(0, 20, "IDACA eq. 3-8: α after break_iter"),
    "beta_start": Spec(0, 20, "IDACA eq. 3-9: β(0)"),
    "beta_slope": Spec(0, 10, "IDACA eq. 3-9: β(i) = beta_start − beta_slope·i up to break_iter"),
    "beta_end": Spec(0, 20, "IDACA eq. 3-9: β after break_iter"),
    "break_iter": Spec(0, 1e6, "IDACA eqs. 3-8, 3-9: iteration where α and β switch to their plateaus"),
    "rho_min": Spec(0, 1, "IDACA eq. 3-10: floor of the decaying evaporation rate", lo_open=True),
    "rho_decay": Spec(1, 1000, "IDACA eq. 3-10: ρ(t+1) = ρ(t)·a^(−t/Nc), a = rho_decay > 1"),
    "k_init": Spec(0, INF, "IACA 4.2.3: initial pheromone K·η_goal(j)", lo_open=True, hi_open=True),
    "rho_local": Spec(0, 1, "IACA eqs. 4-2..4-4: local update τ ← (1−ρ)τ + Q/d_ij while walking"),
    "q1": Spec(0, INF, "IACA eq. 4-6: threshold Q1", hi_open=True),
    "q2": Spec(0, INF, "IACA eq. 4-6: threshold Q2 (> Q1)", hi_open=True),
    "q3": Spec(0, INF, "IACA eq. 4-6: threshold Q3 (> Q2)", hi_open=True),
    "rho1": Spec(0, 1, "IACA eq. 4-6: factor for Q1 < P ≤ Q2 (ρ1 > ρ2)", lo_open=True),
    "rho2": Spec(0, 1, "IACA eq. 4-6: factor for Q2 < P ≤ Q3", lo_open=True),
    "q_step": Spec(0, INF, "IACA eq. 4-6: increment q for P ≤ Q1, decrement for P > Q3", hi_open=True),
    # Chaos ACO (the Xi'an Technological University paper; docs/algorithms.md §7)
    "gamma": Spec(0, 20, "chaos ACO eq. 11: exponent γ of the selection function (P_free·P_θ)^γ"),
    "chaos_iters": Spec(0, 1000, "chaos ACO eq. 14: Logistic iterations i_c (rounded to an integer)"),
    "chaos_mu": Spec(0, 4, "chaos ACO: Logistic control parameter μ (4 = fully chaotic; ≤ 4 keeps h in [0, 1])"),
    # IAACO (Miao et al. 2021; docs/algorithms.md §5) and the multi-objective cost
    "sigma1": Spec(0, INF, "IAACO eq. 1: weight σ1 of the step length d_ij in η", hi_open=True),
    "sigma2": Spec(0, INF, "IAACO eq. 1: weight σ2 of the goal distance d_jG in η", hi_open=True),
    "lam": Spec(0, 20, "IAACO eq. 3: exponent λ of the angle guidance μ"),
    "mu_min": Spec(0, 1, "IAACO eq. 4: floor of the angle guidance μ (keeps every move possible)", lo_open=True),
    "rs": Spec(0, INF, "IAACO eq. 5: safety radius Rs (cells) of the obstacle exclusion ξ", lo_open=True, hi_open=True),
    "delta0": Spec(0, 1, "IAACO eq. 7: q0 = δ0·exp(−½(Nc/Nmax)²); the paper uses δ0 ∈ [0.1, 0.5]"),
    "k_rho": Spec(0, 1, "IAACO eq. 10: adaptive evaporation ρ = k·L_SG/J_best, k < 1", lo_open=True, hi_open=True),
    "k_len": Spec(0, INF, "multi-objective cost J = kL·L + kS·S + kE·E: weight kL of the length", lo_open=True, hi_open=True),
    "k_safe": Spec(0, INF, "multi-objective cost: weight kS of the safety cost S", hi_open=True),
    "k_energy": Spec(0, INF, "multi-objective cost: weight kE of the heading change E (radians)", hi_open=True),
    "rs_cost": Spec(0, INF, "multi-objective cost: radius (cells) of S = Σ max(0, 2r − d_b)/(2r)", lo_open=True, hi_open=True),
    # Policy-gradient ACO (pg-aco, Meuleau & Dorigo 2002; docs/algorithms.md §8; jaco.planners.pg)
    "penalty": Spec(0, INF, "pg-aco: a failed ant costs (1 + penalty)·L̄, L̄ the mean cost of the iteration's successful ants", hi_open=True),
    # PF-ACO baseline of APF-ACO (Dong & Zhao 2021; docs/algorithms.md §6; jaco.planners.apf_guided)
    "k_rep": Spec(0, INF, "pf-aco: repulsion gain k_rep of the classic APF, U_rep = ½k_rep(1/d − 1/d0)² (attraction ½ρ²)", hi_open=True),
    "d0": Spec(0, INF, "pf-aco: range d0 (cells) of the classic APF's repulsion", lo_open=True, hi_open=True),
}

# Pairs (a, b) that must satisfy a < b (or a > b) when both are used: checked like ranges.
ORDERED = (("tau_min", "tau_max"), ("q1", "q2"), ("q2", "q3"), ("rho2", "rho1"))


def param_names() -> tuple[str, ...]:
    return tuple(f.name for f in fields(Params))


def unknown_parameter(name, allowed, where: str, keywords=(), call: str = "") -> str:
    """The message for a name that is not a parameter of ``where``: the closest of the parameters
    ``allowed`` and of the call's own ``keywords`` (``n_ant`` -> ``n_ants``), then the valid names."""
    also = f"; the keywords of {call}: {', '.join(keywords)}" if keywords else ""
    return (f"unknown parameter {name!r} for {where}{did_you_mean(name, [*allowed, *keywords])}; "
            f"valid: {', '.join(sorted(allowed))}{also}")


def check_values(values: dict, allowed: tuple[str, ...], where: str) -> dict:
    """Validate user values (names, NaN, ranges) with numpy; returns float arrays.

    Values may be scalars or 1-D sequences (a sweep axis). Raises :class:`ParamError`.
    """
    out = {}
    for name, v in values.items():
        if name not in allowed:
            raise ParamError(unknown_parameter(name, allowed, where))
        try:
            if v is None or isinstance(v, (str, bytes)) or np.asarray(v).dtype.kind not in "iuf":
                raise TypeError
            a = np.asarray(v, dtype=np.float64)
        except (TypeError, ValueError):
            raise ParamError(f"parameter {name!r} must be a number (float) or a 1-D list of numbers, got {v!r}") from None
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


def check_order(values: dict, used: tuple[str, ...]) -> None:
    """Relations between parameters (τmin < τmax, Q1 < Q2 < Q3, ρ2 < ρ1) on the
    merged values of a variant; values may be sweep axes (checked for every combination)."""
    for lo, hi in ORDERED:
        if lo in used and hi in used:
            a, b = np.atleast_1d(values[lo]), np.atleast_1d(values[hi])
            if not a.max() < b.min():  # every combination of a sweep must hold
                raise ParamError(f"parameters need {lo} < {hi}, got {lo} = {a.max():g}, {hi} = {b.min():g}")
