"""The classic family: Ant System (ant-cycle, ant-density, ant-quantity), elitist and rank-based
Ant System, Ant Colony System and MAX-MIN Ant System (thesis chapter 2).

Every one is the engine's single colony of dying ants (:func:`jaco.engine.colony.single_colony`)
with its own pheromone rule, a chain of the pieces of :mod:`jaco.engine.pheromone`; ACS also
takes the pseudo-random proportional rule.

Each rule is a component (:func:`jaco.planners.compose.component`) and each planner a composition
of it with the engine's dying ants and η = 1/(distance to the goal):
``compose(rule="as", heuristic="step")`` is textbook AS with η = 1/d_ij.
"""

from __future__ import annotations

from ..engine import pheromone as ph
from ..engine.colony import ALPHA
from .compose import component, compose

_A1 = ALPHA.with_default(1.0)
_AS = (_A1, ph.RHO.with_default(0.3), ph.Q.with_default(1.0), ph.TAU0.with_default(0.1))
_AS_SMALL_Q = (_A1, ph.RHO.with_default(0.3), ph.Q.with_default(0.01), ph.TAU0.with_default(0.1))
_SOURCE = "Dorigo, Maniezzo & Colorni 1996"

component(
    "rule",
    "as",
    rule=ph.chain(ph.init_constant(), ph.evaporate(), ph.deposit_all(ph.ant_cycle)),
    params=_AS,
    source=_SOURCE + "; thesis eqs. 2-2, 2-3, 2-6",
)
component(
    "rule",
    "as-density",
    rule=ph.chain(ph.init_constant(), ph.evaporate(), ph.deposit_all(ph.ant_density)),
    params=_AS_SMALL_Q,
    source=_SOURCE + "; thesis eq. 2-4",
)
component(
    "rule",
    "as-quantity",
    rule=ph.chain(ph.init_constant(), ph.evaporate(), ph.deposit_all(ph.ant_quantity)),
    params=_AS_SMALL_Q,
    source=_SOURCE + "; thesis eqs. 2-5, 4-4",
)
component(
    "rule",
    "eas",
    rule=ph.chain(
        ph.init_constant(), ph.evaporate(), ph.deposit_all(ph.ant_cycle), ph.deposit_best_so_far(lambda p: p.sigma)
    ),
    params=_AS + (ph.SIGMA.with_default(5.0),),
    source="Dorigo 1992; thesis eqs. 2-11..2-13",
)
component(
    "rule",
    "ras",
    rule=ph.chain(ph.init_constant(), ph.evaporate(), ph.deposit_ranked()),
    params=_AS + (ph.W.with_default(6.0),),
    source="Bullnheimer, Hartl & Strauss 1997",
)
component(
    "rule",
    "acs",
    rule=ph.chain(ph.init_constant(), ph.acs_local(), ph.acs_global()),
    default_transition="q0",
    params=(_A1, ph.RHO.with_default(0.3), ph.Q.with_default(1.0), ph.TAU0.with_default(0.01), ph.XI.with_default(0.1)),
    source="Dorigo & Gambardella 1997; thesis eqs. 2-15, 2-16",
)
component(
    "rule",
    "mmas",
    rule=ph.chain(ph.init_mmas(), ph.evaporate(), ph.deposit_iteration_best(), ph.mmas_bounds(), ph.clamp()),
    params=(ALPHA.with_default(2.0), ph.RHO.with_default(0.05), ph.Q.with_default(1.0), ph.P_BEST.with_default(0.05)),
    source="Stützle & Hoos 2000; thesis eq. 2-17",
)

_CLASSIC_NOTE = (
    " Heuristic: η = 1/(distance of the candidate to the goal) (thesis eq. 3-7), because the "
    "textbook η = 1/d_ij is 1 or 1/√2 on a grid and gives no guidance; compose(rule=..., "
    'heuristic="step") gives the textbook form. Pheromone on moves (τ_ij).'
)

AS = compose(rule="as").named(
    "as",
    source="Dorigo, Maniezzo & Colorni 1996; thesis eqs. 2-1, 2-2, 2-3, 2-6",
    doc="Ant System, ant-cycle: τ ← (1−ρ)τ + Σ_k Q/L_k on ant k's path." + _CLASSIC_NOTE,
    alpha=1.0,
    beta=4.0,
    rho=0.3,
    q=1.0,
    tau0=0.1,
)

AS_DENSITY = compose(rule="as-density").named(
    "as-density",
    source="Dorigo, Maniezzo & Colorni 1996; thesis eq. 2-4",
    doc="Ant System, ant-density: every successful ant deposits Q on each element it used." + _CLASSIC_NOTE,
    alpha=1.0,
    beta=4.0,
    rho=0.3,
    q=0.01,
    tau0=0.1,
)

AS_QUANTITY = compose(rule="as-quantity").named(
    "as-quantity",
    source="Dorigo, Maniezzo & Colorni 1996; thesis eqs. 2-5, 4-4",
    doc="Ant System, ant-quantity: every successful ant deposits Q/d_ij on each step i→j." + _CLASSIC_NOTE,
    alpha=1.0,
    beta=4.0,
    rho=0.3,
    q=0.01,
    tau0=0.1,
)

EAS = compose(rule="eas").named(
    "eas",
    source="Dorigo 1992; thesis eqs. 2-11, 2-12, 2-13",
    doc="Elitist Ant System: ant-cycle AS plus σ·Q/L* on the best-so-far path." + _CLASSIC_NOTE,
    alpha=1.0,
    beta=4.0,
    rho=0.3,
    q=1.0,
    tau0=0.1,
    sigma=5.0,
)

RAS = compose(rule="ras").named(
    "ras",
    source="Bullnheimer, Hartl & Strauss 1997 (thesis ref. 1)",
    doc="Rank-based Ant System: the w−1 best ants of the iteration deposit (w−r)·Q/L_r, the "
    "best-so-far deposits w·Q/L*." + _CLASSIC_NOTE,
    alpha=1.0,
    beta=4.0,
    rho=0.3,
    q=1.0,
    tau0=0.1,
    w=6.0,
)

ACS = compose(rule="acs").named(
    "acs",
    source="Dorigo & Gambardella 1997; thesis eqs. 2-14, 2-15, 2-16",
    doc="Ant Colony System: pseudo-random proportional rule (argmax of τ^α η^β with probability "
    "q0, else roulette), local update τ ← (1−ξ)τ + ξτ0 on every step (applied after the "
    "iteration's walks, see jaco.engine.pheromone.acs_local), global update on the global-best path "
    "only, τ ← (1−ρ)τ + ρQ/L_gb." + _CLASSIC_NOTE,
    alpha=1.0,
    beta=4.0,
    rho=0.3,
    q=1.0,
    tau0=0.01,
    q0=0.8,
    xi=0.1,
)

MMAS = compose(rule="mmas").named(
    "mmas",
    source="Stützle & Hoos 2000; thesis eq. 2-17",
    doc="MAX-MIN Ant System: τ initialised to τmax, only the iteration-best ant deposits "
    "Q/L_ib, τ clamped to [τmin, τmax] with τmax = Q/(ρ·L_gb) and τmin from p_best "
    "(see jaco.engine.pheromone.mmas_bounds)." + _CLASSIC_NOTE,
    alpha=2.0,
    beta=8.0,
    rho=0.05,
    q=1.0,
    p_best=0.05,
)

PLANNERS = (AS, AS_DENSITY, AS_QUANTITY, EAS, RAS, ACS, MMAS)
