"""The classic family: Ant System (ant-cycle, ant-density, ant-quantity), elitist and rank-based
Ant System, Ant Colony System and MAX-MIN Ant System (thesis chapter 2).

Every one is the engine's single colony of dying ants (:func:`jaco.engine.colony.single_colony`)
with its own pheromone rule, a chain of the pieces of :mod:`jaco.engine.pheromone`; ACS also
takes the pseudo-random proportional rule.

To change a piece of a planner, replace it: ``AS._replace(heuristic=inverse_step)`` is textbook
AS with η = 1/d_ij (:func:`jaco.engine.heuristics.inverse_step`).
"""

from __future__ import annotations

from ..engine import pheromone as ph
from ..engine.variant import make_variant

BASE = ("alpha", "beta", "rho", "q", "tau0")

_CLASSIC_NOTE = (
    " Heuristic: η = 1/(distance of the candidate to the goal) (thesis eq. 3-7), because the "
    "textbook η = 1/d_ij is 1 or 1/√2 on a grid and gives no guidance; replace `heuristic` with "
    "`jaco.heuristics.inverse_step` for the textbook form. Pheromone on moves (τ_ij)."
)

AS = make_variant(
    "as",
    "Dorigo, Maniezzo & Colorni 1996; thesis eqs. 2-1, 2-2, 2-3, 2-6",
    "Ant System, ant-cycle: τ ← (1−ρ)τ + Σ_k Q/L_k on ant k's path." + _CLASSIC_NOTE,
    BASE,
    dict(alpha=1.0, beta=4.0, rho=0.3, q=1.0, tau0=0.1),
    ph.chain(ph.init_constant(), ph.evaporate(), ph.deposit_all(ph.ant_cycle)),
)

AS_DENSITY = make_variant(
    "as-density",
    "Dorigo, Maniezzo & Colorni 1996; thesis eq. 2-4",
    "Ant System, ant-density: every successful ant deposits Q on each element it used." + _CLASSIC_NOTE,
    BASE,
    dict(alpha=1.0, beta=4.0, rho=0.3, q=0.01, tau0=0.1),
    ph.chain(ph.init_constant(), ph.evaporate(), ph.deposit_all(ph.ant_density)),
)

AS_QUANTITY = make_variant(
    "as-quantity",
    "Dorigo, Maniezzo & Colorni 1996; thesis eqs. 2-5, 4-4",
    "Ant System, ant-quantity: every successful ant deposits Q/d_ij on each step i→j." + _CLASSIC_NOTE,
    BASE,
    dict(alpha=1.0, beta=4.0, rho=0.3, q=0.01, tau0=0.1),
    ph.chain(ph.init_constant(), ph.evaporate(), ph.deposit_all(ph.ant_quantity)),
)

EAS = make_variant(
    "eas",
    "Dorigo 1992; thesis eqs. 2-11, 2-12, 2-13",
    "Elitist Ant System: ant-cycle AS plus σ·Q/L* on the best-so-far path." + _CLASSIC_NOTE,
    BASE + ("sigma",),
    dict(alpha=1.0, beta=4.0, rho=0.3, q=1.0, tau0=0.1, sigma=5.0),
    ph.chain(
        ph.init_constant(),
        ph.evaporate(),
        ph.deposit_all(ph.ant_cycle),
        ph.deposit_best_so_far(lambda p: p.sigma),
    ),
)

RAS = make_variant(
    "ras",
    "Bullnheimer, Hartl & Strauss 1997 (thesis ref. 1)",
    "Rank-based Ant System: the w−1 best ants of the iteration deposit (w−r)·Q/L_r, the "
    "best-so-far deposits w·Q/L*." + _CLASSIC_NOTE,
    BASE + ("w",),
    dict(alpha=1.0, beta=4.0, rho=0.3, q=1.0, tau0=0.1, w=6.0),
    ph.chain(ph.init_constant(), ph.evaporate(), ph.deposit_ranked()),
)

ACS = make_variant(
    "acs",
    "Dorigo & Gambardella 1997; thesis eqs. 2-14, 2-15, 2-16",
    "Ant Colony System: pseudo-random proportional rule (argmax of τ^α η^β with probability "
    "q0, else roulette), local update τ ← (1−ξ)τ + ξτ0 on every step (applied after the "
    "iteration's walks, see jaco.pheromone.acs_local), global update on the global-best path "
    "only, τ ← (1−ρ)τ + ρQ/L_gb." + _CLASSIC_NOTE,
    BASE + ("q0", "xi"),
    dict(alpha=1.0, beta=4.0, rho=0.3, q=1.0, tau0=0.01, q0=0.8, xi=0.1),
    ph.chain(ph.init_constant(), ph.acs_local(), ph.acs_global()),
    transition="pseudo-random",
)

MMAS = make_variant(
    "mmas",
    "Stützle & Hoos 2000; thesis eq. 2-17",
    "MAX-MIN Ant System: τ initialised to τmax, only the iteration-best ant deposits "
    "Q/L_ib, τ clamped to [τmin, τmax] with τmax = Q/(ρ·L_gb) and τmin from p_best "
    "(see jaco.pheromone.mmas_bounds)." + _CLASSIC_NOTE,
    BASE[:4] + ("p_best",),
    dict(alpha=2.0, beta=8.0, rho=0.05, q=1.0, p_best=0.05),
    ph.chain(ph.init_mmas(), ph.evaporate(), ph.deposit_iteration_best(), ph.mmas_bounds(), ph.clamp()),
)
