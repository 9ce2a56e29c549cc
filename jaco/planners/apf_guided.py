"""APF-ACO: ant colony optimisation guided by an improved artificial potential field (Dong & Zhao
2021), and its baseline PF-ACO (the same with the classic APF; Wang, Yang & Zhang 2018).

Source: Dong Xuanliang, Zhao Guiqing, *Robot navigation path planning based on ant colony algorithm
guided by artificial potential field*, Machinery Design & Manufacture 2021(6):169–173. The APF
table r_jg is :mod:`jaco.potential`'s, the improved APF itself :mod:`jaco.apf`.

Equations: docs/algorithms.md §6; every interpretation and the defaults: docs/planners.md,
"APF-ACO and PF-ACO".
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Callable

import jax
import jax.numpy as jnp
import numpy as np

from ..engine import pheromone as ph
from ..engine.colony import ALPHA, BETA
from ..potential import D0_PARAM, K_REP_PARAM, apf_distance, classic_distance
from .compose import component, compose

if TYPE_CHECKING:
    from ..engine.params import Params
    from ..engine.planner import Planner

__all__ = [
    "apf_eta",
    "apf_init",
    "apf_table",
    "deposit_best_half",
    "apf_factor",
    "APF_ACO",
    "PF_ACO",
    "PAPER_PARAMS",
]


def apf_eta(problem: Any, r: jax.Array, t: Any, n_iters: int) -> jax.Array:
    """Eq. (10): ``η_ij = 1/(d_ij + r_jg) · (Nmax − Nc + 1)/Nmax`` ``(N, 8)``, Nc = t + 1
    (0 where the map forbids the move)."""
    valid = problem.nbr >= 0
    rj = r[jnp.where(valid, problem.nbr, 0)]
    factor = (n_iters - jnp.asarray(t).astype(jnp.float32)) / n_iters
    return jnp.where(valid, factor / jnp.maximum(problem.step + rj, 1e-6), 0.0)


def _heuristic(table):
    def heuristic(problem, params, t, n_iters):
        """Eq. (10) with the table computed on the spot (for tools that want one (N, 8) table;
        the planners' weights read the table computed once per run instead)."""
        return apf_eta(problem, table(problem, params), t, n_iters)

    return heuristic


def apf_table(table: Callable[[Any, Params], jax.Array], slot: str) -> ph.Rule:
    """Keep the APF distance ``r = table(problem, params) (N,)`` in the trail (in the heuristic's
    slot), computed once per run inside the run; the pheromone itself is left to the other pieces."""

    def init(trail, problem, params):
        return ph.with_own(trail, slot, table(problem, params).astype(jnp.float32))

    return ph.Rule(init, ph.keep_update)


def apf_init(table: Callable[[Any, Params], jax.Array], slot: str) -> ph.Rule:
    """τ = τ0 everywhere and ``r = table(problem, params)`` in ``slot`` (once per run, inside the run)."""
    return ph.chain(apf_table(table, slot), ph.init_constant())


def deposit_best_half() -> ph.Rule:
    """Eqs. (11, 12): the best ⌈k/2⌉ of the k successful ants deposit ``s_i·Q/L_i`` on each
    move they took, ``s_i = fit_i / Σ_{depositors} fit``, fit = 1/L (evaporation is a separate
    piece)."""

    def update(trail, walks, problem, params):
        fit = ph.inverse(walks.cost)
        ok = fit > 0
        k = jnp.sum(ok)
        rank = jnp.argsort(jnp.argsort(walks.cost, stable=True), stable=True)  # 0 = best
        dep = ok & (rank < (k + 1) // 2)
        fit = jnp.where(dep, fit, 0.0)
        s = fit / jnp.maximum(jnp.sum(fit), 1e-30)
        return trail._replace(tau=ph.deposit(trail.tau, walks.targets, s * params.q * fit))

    return ph.Rule(ph.keep_init, update)


def apf_factor(slot: str) -> Callable:
    """The factor of rule (6) besides τ^α, in log space: ``β·log η`` ``(N, 8)`` with η of eq. (10)
    from the table the heuristic's init stored in its trail slot (once per run). The engine scales
    each cell's weights to a top of 1, so large β cannot underflow."""

    def factor(planner: Planner, trail: ph.Trail, problem: Any, params: Params, t: Any, n_iters: int) -> jax.Array:
        eta = apf_eta(problem, ph.own(trail, slot), t, n_iters)
        return params.beta * jnp.log(jnp.maximum(eta, _TINY))

    return factor


def _with_table(table: Callable[[Any, Params], jax.Array]) -> Callable[[str], dict]:
    """The heuristic's parts that keep ``table`` in its slot and read it from there."""
    return lambda slot: dict(factor=apf_factor(slot), rule=apf_table(table, slot))


_TINY = float(np.finfo(np.float32).tiny)


def _no_double(chosen) -> str | None:
    if chosen["construct"] == "double":
        return (
            f"construct 'double' walks a second colony from the goal to the start, but the "
            f"'{chosen['heuristic']}' table holds distances to the goal only"
        )
    return None


component(
    "heuristic",
    "apf",
    heuristic=_heuristic(apf_distance),
    state=_with_table(apf_distance),
    params=(BETA.with_default(20.0),),
    why_not=_no_double,
    source="Dong & Zhao 2021 eqs. 4, 5, 10",
)
component(
    "heuristic",
    "pf",
    heuristic=_heuristic(classic_distance),
    state=_with_table(classic_distance),
    params=(BETA.with_default(20.0), K_REP_PARAM, D0_PARAM),
    why_not=_no_double,
    source="classic APF (Khatib)",
)
component(
    "rule",
    "apf",
    rule=ph.chain(ph.init_constant(), ph.evaporate(), deposit_best_half()),
    params=(ALPHA.with_default(2.0), ph.RHO.with_default(0.3), ph.Q.with_default(1.0), ph.TAU0.with_default(1.0)),
    source="Dong & Zhao 2021 eqs. 11, 12",
)

#: The paper prints α = 2, β = 6, ρ = 0.7, Q = 1 (``PAPER_PARAMS``). The defaults move β to 20 and
#: ρ to 0.3: with β = 6 no ant of 50 × 100 ever reached the goal on two dense 30 % maps and the
#: maze of tests/test_quality.py (before the first arrival only β steers), and ρ = 0.7 locks in
#: the first iterations' paths (docs/planners.md, APF-ACO).
PAPER_PARAMS = dict(alpha=2.0, beta=6.0, rho=0.7, q=1.0)
_APF_DEFAULTS = dict(alpha=2.0, beta=20.0, rho=0.3, q=1.0, tau0=1.0)

APF_ACO = compose(heuristic="apf", rule="apf").named(
    "apf-aco",
    source="Dong & Zhao 2021: 3.1, 3.2, eqs. 4, 5, 6, 10, 11, 12",
    doc="Dong & Zhao 2021, Machinery Design & Manufacture 2021(6):169–173, eqs. 4, 5 (improved APF), "
    "6, 10, 11, 12: ACO guided by the improved artificial potential field. η_ij = 1/(d_ij + r_jg)·"
    "(Nmax − Nc + 1)/Nmax with r_jg the length of the improved APF's path from j to the goal "
    "(intermediate points beside the last obstacle the straight line crosses, attraction-only "
    "moves; Euclidean where it loops or is stuck), computed once per run for every cell; roulette "
    "rule; no deposit while walking; after each iteration τ ← (1−ρ)τ and the best half of the "
    "successful ants deposit (fit_i/Σfit)·Q/L_i. Pheromone on moves. Interpretations: jaco.apf "
    "and docs/planners.md (APF-ACO).",
    **_APF_DEFAULTS,
)

PF_ACO = compose(heuristic="pf", rule="apf").named(
    "pf-aco",
    source="Dong & Zhao 2021, baseline of its ref. 10 (Wang, Yang & Zhang 2018)",
    doc="The PF-ACO baseline of Dong & Zhao 2021 (their ref. 10): APF-ACO with r_jg from the classic "
    "artificial potential field, U = ½ρ_g² + ½k_rep(1/d − 1/d0)² within d0 (descent to the lowest "
    "neighbour; Euclidean where it ends in a local minimum). Everything else as apf-aco "
    "(eqs. 6, 10, 11, 12). Interpretations: jaco.apf and docs/planners.md (APF-ACO).",
    **_APF_DEFAULTS,
    k_rep=K_REP_PARAM.default,
    d0=D0_PARAM.default,
)

PLANNERS = (APF_ACO, PF_ACO)
