"""IAACO: the improved adaptive ant colony algorithm (Miao et al. 2021).

Source: Miao, Chen, Yan et al., *Path planning optimization of indoor mobile robot based on
adaptive ant colony algorithm*, Computers & Industrial Engineering 156 (2021) 107230. The
multi-objective cost (:func:`jaco.engine.cost.multi_objective`) is open to every planner through
``jaco.planners.registry.with_cost``.

Equations: docs/algorithms.md §5; every interpretation and the defaults: docs/planners.md, "IAACO".
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Callable

import jax
import jax.numpy as jnp

from ..engine import pheromone as ph
from ..engine.colony import ALPHA, BETA
from ..engine.heuristics import goal_distance
from ..engine.params import INF, Param, declare
from .compose import component, compose

if TYPE_CHECKING:
    from ..engine.params import Params
    from ..engine.planner import Factor

__all__ = [
    "adaptive_eps",
    "iaaco_heuristic",
    "target_cells",
    "mu_printed",
    "mu_robust",
    "obstacle_exclusion",
    "guided_factor",
    "q0_schedule",
    "adaptive_rho",
    "init_floor",
    "best_worst",
    "IAACO",
    "IAACO_PRINTED",
]

SIGMA1, SIGMA2, LAM, MU_MIN, RS, DELTA0, K_RHO = declare(
    Param("sigma1", 0.1, 0, INF, "IAACO eq. 1: weight σ1 of the step length d_ij in η", hi_open=True),
    Param("sigma2", 0.9, 0, INF, "IAACO eq. 1: weight σ2 of the goal distance d_jG in η", hi_open=True),
    Param("lam", 1.0, 0, 20, "IAACO eq. 3: exponent λ of the angle guidance μ"),
    Param("mu_min", 0.1, 0, 1, "IAACO eq. 4: floor of the angle guidance μ (keeps every move possible)", lo_open=True),
    Param(
        "rs",
        0.5,
        0,
        INF,
        "IAACO eq. 5: safety radius Rs (cells) of the obstacle exclusion ξ",
        lo_open=True,
        hi_open=True,
    ),
    Param("delta0", 0.15, 0, 1, "IAACO eq. 7: q0 = δ0·exp(−½(Nc/Nmax)²); the paper uses δ0 ∈ [0.1, 0.5]"),
    Param(
        "k_rho", 0.3, 0, 1, "IAACO eq. 10: adaptive evaporation ρ = k·L_SG/J_best, k < 1", lo_open=True, hi_open=True
    ),
)


def _ratio(t, n_iters):
    """Nc/Nmax with the sources' 1-based iteration count Nc = t + 1."""
    return (jnp.asarray(t).astype(jnp.float32) + 1.0) / n_iters


# -- heuristic (1, 2) ------------------------------------------------------------------------
def adaptive_eps(t: Any, n_iters: int) -> jax.Array:
    """ε = exp(−2 (Nc/Nmax)²) (eq. 2)."""
    return jnp.exp(-2.0 * _ratio(t, n_iters) ** 2)


def iaaco_heuristic(problem: Any, params: Params, t: Any, n_iters: int) -> jax.Array:
    """η_ij = ε / (σ1·d_ij + σ2·d_jG) (eq. 1), d_jG Euclidean; the denominator is floored at 1e-6
    (it is σ1·d_ij at the goal, 0 only when σ1 = 0)."""
    den = params.sigma1 * problem.step + params.sigma2 * goal_distance(problem)
    return adaptive_eps(t, n_iters) / jnp.maximum(den, 1e-6)


# -- angle guidance (4) and obstacle exclusion (5) -------------------------------------------
def target_cells(problem: Any) -> jax.Array:
    """Flat index ``(N, 8)`` of the cell each move leads to (the own cell where not allowed)."""
    return jnp.where(problem.nbr >= 0, problem.nbr, jnp.arange(problem.nbr.shape[0])[:, None])


def _to_goal(problem):
    """Vector j→G ``(N, 8, 2)`` and its length ``(N, 8)`` for every move's target j."""
    v = problem.xy[problem.goal][None, None, :] - problem.xy[target_cells(problem)]
    return v, jnp.sqrt(jnp.sum(v * v, axis=-1))


def mu_printed(problem: Any, params: Params) -> jax.Array:
    """μ = |y_j − y_G| / d_jG as printed (eq. 4), y the row; 1 at the goal; floored at μ_min."""
    v, d = _to_goal(problem)
    mu = jnp.where(d > 0, jnp.abs(v[..., 0]) / jnp.where(d > 0, d, 1.0), 1.0)
    return jnp.maximum(mu, params.mu_min)


def mu_robust(problem: Any, params: Params) -> jax.Array:
    """μ = max(μ_min, cos∠(j→G, S→G)) (the robust form of eq. 4); 1 at the goal and when S = G."""
    v, d = _to_goal(problem)
    sg = problem.xy[problem.goal] - problem.xy[problem.start]
    l_sg = jnp.sqrt(jnp.sum(sg * sg))
    dot = jnp.sum(v * sg[None, None, :], axis=-1)
    ok = (d > 0) & (l_sg > 0)
    cos = jnp.where(ok, dot / jnp.where(ok, d * l_sg, 1.0), 1.0)
    return jnp.maximum(cos, params.mu_min)


def obstacle_exclusion(problem: Any, params: Params) -> jax.Array:
    """ξ (eq. 5) of every move's target j from its obstacle distance d_b: 0 below Rs, Rs/d_b on
    [Rs, 2Rs], 1 above; 1 at the goal (the target is entered whatever its clearance)."""
    j = target_cells(problem)
    d = problem.clearance[j]
    rs = params.rs
    xi = jnp.where(d < rs, 0.0, jnp.where(d <= 2 * rs, rs / jnp.maximum(d, 1e-12), 1.0))
    return jnp.where(j == problem.goal, 1.0, xi)


def guided_factor(mu: Callable[[Any, Params], jax.Array]) -> Factor:
    """The factor of eq. (3) besides τ^α, in log space: ``β·log η + λ·log μ + log ξ`` ``(N, 8)``
    (−inf where ξ = 0), with ``mu`` one of :func:`mu_robust`, :func:`mu_printed` (a static
    choice). The engine's :func:`jaco.engine.colony.move_weights` adds α·log τ and scales each
    cell's weights so that the largest is 1: large β, ε^β (down to e^(−2β)) and far-from-goal
    η^β stay away from float32's limits, and a move with ξ = 0 weighs 1e-30 (taken only when
    nothing else is allowed)."""

    def factor(planner, trail, problem, params, t, n_iters):
        eta = planner.heuristic(problem, params, t, n_iters)
        xi = obstacle_exclusion(problem, params)
        return (
            params.beta * jnp.log(eta)
            + params.lam * jnp.log(mu(problem, params))
            + jnp.where(xi > 0, jnp.log(jnp.where(xi > 0, xi, 1.0)), -jnp.inf)
        )  # Eq. (3) without τ^α

    return factor


# -- adaptive pseudo-random rule (6, 7) ------------------------------------------------------
def q0_schedule(params: Params, t: Any, n_iters: int) -> Params:
    """q0 = δ0·exp(−½ (Nc/Nmax)²) (eq. 7), read by the engine's pseudo-random rule (eq. 6)."""
    return params.replace(q0=params.delta0 * jnp.exp(-0.5 * _ratio(t, n_iters) ** 2))


# -- pheromone (8, 9, 10) --------------------------------------------------------------------
def adaptive_rho(problem: Any, j_best: jax.Array, params: Params) -> jax.Array:
    """ρ = k·L_SG/J_best (eq. 10), clipped to [0, ``params.rho``]; 0 when J_best is not a
    positive finite number."""
    sg = problem.xy[problem.goal] - problem.xy[problem.start]
    l_sg = jnp.sqrt(jnp.sum(sg * sg))
    return jnp.clip(params.k_rho * l_sg * ph.inverse(j_best), 0.0, params.rho)


def init_floor() -> ph.Rule:
    """τ = max(τ0, τmin) everywhere, lower bound τmin (> 0, so a penalised move stays possible)."""

    def init(trail, problem, params):
        lo = jnp.float32(params.tau_min)
        tau = jnp.full_like(trail.tau, jnp.maximum(params.tau0, params.tau_min))
        return trail._replace(tau=tau, lo=lo, hi=jnp.float32(jnp.inf))

    return ph.Rule(init, ph.keep_update)


def best_worst() -> ph.Rule:
    """Eqs. (8, 9) with ρ of eq. (10), over the iteration's successful ants:
    τ ← (1−ρ)τ + ρ·(Q/J_best)·(J_best + J_worst)/2 on the best path, then
    τ ← (1−ρ)τ − ρ·Q/J_worst on the worst path; then τ ≥ τmin. No successful ant: unchanged."""

    def update(trail, walks, problem, params):
        ok = jnp.isfinite(walks.cost)
        b = jnp.argmin(walks.cost)
        w = jnp.argmax(jnp.where(ok, walks.cost, -jnp.inf))
        j_b, j_w = walks.cost[b], walks.cost[w]
        rho = adaptive_rho(problem, j_b, params)  # Eq. (10)
        reward = params.q * ph.inverse(j_b) * (j_b + j_w) / 2.0
        tau = trail.tau
        tau = jnp.where(ph.on_path(tau, walks.targets[:, b]), (1.0 - rho) * tau + rho * reward, tau)  # Eq. (8)
        penalty = params.q * ph.inverse(j_w)
        tau = jnp.where(ph.on_path(tau, walks.targets[:, w]), (1.0 - rho) * tau - rho * penalty, tau)  # Eq. (9)
        tau = jnp.maximum(tau, trail.lo)
        return trail._replace(tau=jnp.where(jnp.any(ok), tau, trail.tau))

    return ph.Rule(ph.keep_init, update)


# -- the components and planners -------------------------------------------------------------
_HEURISTIC = (BETA.with_default(20.0), LAM.with_default(3.0), SIGMA1, SIGMA2, MU_MIN.with_default(0.3), RS)
component(
    "heuristic",
    "iaaco",
    heuristic=iaaco_heuristic,
    factor=guided_factor(mu_robust),
    params=_HEURISTIC,
    source="Miao et al. 2021 eqs. 1-5",
)
component(
    "heuristic",
    "iaaco-printed",
    heuristic=iaaco_heuristic,
    factor=guided_factor(mu_printed),
    params=_HEURISTIC,
    source="Miao et al. 2021 eqs. 1-5 as printed",
)
component(
    "rule",
    "iaaco",
    rule=ph.chain(init_floor(), best_worst()),
    default_transition="adaptive-q0",
    params=(
        ALPHA.with_default(1.0),
        ph.Q.with_default(2.5),
        ph.TAU0.with_default(0.01),
        ph.TAU_MIN.with_default(0.01),
        ph.RHO.with_default(0.9),
        K_RHO.with_default(0.6),
    ),
    source="Miao et al. 2021 eqs. 8-10",
)
component(
    "transition",
    "adaptive-q0",
    transition="pseudo-random",
    schedule=q0_schedule,
    params=(DELTA0,),
    source="Miao et al. 2021 eqs. 6-7",
)

#: IAACO's defaults, in the order its tables show them.
IAACO_DEFAULTS = dict(
    alpha=1.0,
    beta=20.0,
    lam=3.0,
    q=2.5,
    tau0=0.01,
    tau_min=0.01,
    rho=0.9,
    k_rho=0.6,
    delta0=0.15,
    sigma1=0.1,
    sigma2=0.9,
    mu_min=0.3,
    rs=0.5,
    k_len=0.7,
    k_safe=0.1,
    k_energy=0.2,
    rs_cost=1.0,
)

_DOC = (
    "Improved adaptive ACO: η = ε/(σ1·d_ij + σ2·d_jG) with ε = exp(−2(Nc/Nmax)²) (1, 2); "
    "p ∝ τ^α η^β μ^λ ξ with angle guidance μ and obstacle exclusion ξ (3–5), folded into the move "
    "weights once per iteration; pseudo-random rule with q0 = δ0·exp(−½(Nc/Nmax)²) (6, 7); the "
    "iteration's best path is reinforced and its worst penalised (8, 9) with ρ = k·L_SG/J_best "
    "clipped to [0, rho] (10); τ ≥ τmin; cost J = kL·L + kS·S + kE·E. Pheromone on moves."
)

IAACO = compose(heuristic="iaaco", rule="iaaco", cost="multi").named(
    "iaaco",
    source="Miao et al. 2021, eqs. 1–10",
    doc=_DOC + " Angle guidance μ = max(μ_min, cos∠(j→G, S→G)) (robust form of eq. 4).",
    **IAACO_DEFAULTS,
)

IAACO_PRINTED = compose(heuristic="iaaco-printed", rule="iaaco", cost="multi").named(
    "iaaco-printed",
    source="Miao et al. 2021, eqs. 1–10",
    doc=_DOC + " Angle guidance as printed in eq. 4: μ = max(μ_min, |y_j − y_G|/d_jG), y the row.",
    **IAACO_DEFAULTS,
)

PLANNERS = (IAACO, IAACO_PRINTED)
