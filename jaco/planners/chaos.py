"""Chaos ACO with a probability-selection function (docs/algorithms.md §7).

Source: a Xi'an Technological University paper (School of Electronic Information Engineering; the
copy we worked from names neither title nor authors and has lost its formulas): a selection
function P_free·P_θ (free-cell share, angle to the goal) in the transition rule (11) and a
Logistic-chaos perturbation of the pheromone (14) before the global update (15).

The interpretation built here: docs/algorithms.md §7 and docs/planners.md, "Chaos ACO".
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import jax
import jax.numpy as jnp

from ..engine import heuristics
from ..engine import pheromone as ph
from ..engine.colony import ALPHA, BETA, eta_factor
from ..engine.params import Param, declare
from ..moves import MOVES
from .compose import component, compose

if TYPE_CHECKING:
    from ..engine.params import Params
    from ..engine.planner import Planner

GAMMA, CHAOS_ITERS, CHAOS_MU = declare(
    Param("gamma", 4.0, 0, 20, "chaos ACO eq. 11: exponent γ of the selection function (P_free·P_θ)^γ"),
    Param("chaos_iters", 10.0, 0, 1000, "chaos ACO eq. 14: Logistic iterations i_c (rounded to an integer)"),
    Param("chaos_mu", 4.0, 0, 4, "chaos ACO: Logistic control parameter μ (4 = fully chaotic; ≤ 4 keeps h in [0, 1])"),
)

# A successful path is "above the mean" only when longer by more than this relative margin, so
# that equal lengths never count as above through the round-off of the float32 mean.
_MEAN_RTOL = 1e-6


# -- probability-selection function (docs/algorithms.md §7) -----------------------------------
def _free_neighbours(problem) -> jax.Array:
    """``(N,)`` number of free in-bounds cells among each cell's 8 neighbours (the outside of
    the map counts as blocked, as in :meth:`jaco.Grid.clearance`)."""
    n = problem.nbr.shape[0]
    width = -problem.offsets[0]  # move 0 is (-1, 0): its flat offset is -W
    height = n // width
    free = problem.clearance > 0  # clearance is 0 exactly on blocked cells
    rc = problem.xy.astype(jnp.int32)
    r = rc[:, 0:1] + jnp.asarray(MOVES[:, 0])[None, :]
    c = rc[:, 1:2] + jnp.asarray(MOVES[:, 1])[None, :]
    inside = (r >= 0) & (r < height) & (c >= 0) & (c < width)
    idx = jnp.where(inside, r * width + c, 0)
    return jnp.sum(inside & free[idx], axis=1)


def free_share(problem: Any) -> jax.Array:
    """P_free ``(N, 8)`` of every move i→j: (free neighbours of j other than i) / 7.

    Every free neighbour of j counts, whether or not the move to it would cut a corner (the paper
    counts the free cells around j); 0 where the map forbids the move."""
    valid = problem.nbr >= 0
    count = _free_neighbours(problem)[jnp.where(valid, problem.nbr, 0)]
    return jnp.where(valid, (count - 1).astype(jnp.float32) / 7.0, 0.0)


def move_angles(problem: Any) -> jax.Array:
    """θ ``(N, 8)`` in [0, π]: the angle between move k from cell i and the direction i→goal
    (0 at the goal itself, where that direction is undefined)."""
    to_goal = problem.xy[problem.goal][None, :] - problem.xy  # (N, 2)
    moves = jnp.asarray(MOVES, jnp.float32)  # (8, 2)
    dot = to_goal @ moves.T
    cross = to_goal[:, 0:1] * moves[None, :, 1] - to_goal[:, 1:2] * moves[None, :, 0]
    return jnp.arctan2(jnp.abs(cross), dot)  # atan2(0, 0) = 0 at the goal


def angle_share(problem: Any) -> jax.Array:
    """P_θ ``(N, 8)``: 1 − θ_j / Σ_s θ_s over the moves s the map allows from i;
    1 where Σθ = 0 (guard), 0 where the move is forbidden.

    The sum runs over the map's allowed moves, not over the ant's non-tabu ones, so the share is
    a per-move constant of the problem (computed once per iteration, not per ant step)."""
    valid = problem.nbr >= 0
    theta = jnp.where(valid, move_angles(problem), 0.0)
    total = jnp.sum(theta, axis=1, keepdims=True)
    share = jnp.where(total > 0, 1.0 - theta / jnp.where(total > 0, total, 1.0), 1.0)
    return jnp.where(valid, share, 0.0)


def selection(problem: Any) -> jax.Array:
    """The probability-selection function P_free·P_θ ``(N, 8)`` (the product is
    our interpretation: the paper's text omits the formula)."""
    return free_share(problem) * angle_share(problem)


def selection_factor(
    planner: Planner, trail: ph.Trail, problem: Any, params: Params, t: Any, n_iters: int
) -> jax.Array:
    """The factor of transition rule (11) besides τ^α, in log space: ``β·log η + γ·log(P_free·P_θ)``
    ``(N, 8)``.

    The selection shares go into the weights here, not into ``heuristic`` (η' = η·sel^(γ/β)), so
    that γ still acts at β = 0. A zero share (P_θ = 0 for the widest-angle move of a cell with few
    moves) gives −inf, i.e. the engine's floor of 1e-30 (relative to the cell's best move): an ant
    whose only non-tabu move it is still takes it instead of dying."""
    sel = selection(problem)
    shares = jnp.where(  # γ·log sel, with 0^γ = 0 for γ > 0 and 1 for γ = 0
        sel > 0, params.gamma * jnp.log(jnp.where(sel > 0, sel, 1.0)), jnp.where(params.gamma > 0, -jnp.inf, 0.0)
    )
    return eta_factor(planner, trail, problem, params, t, n_iters) + shares


# -- Logistic-chaos pheromone update (eqs. 14, 15) ------------------------------------------
def logistic(h0: jax.Array | float, mu: jax.Array | float, n: jax.Array | int) -> jax.Array:
    """``n`` steps of the Logistic map h ← μh(1−h) from ``h0`` (the paper's chaos iteration; fully
    chaotic at μ = 4 with h0 ∈ [0, 1]). ``n`` may be traced: the loop is a ``while_loop`` with a
    traced trip count, so i_c can be swept like any parameter."""
    n = jnp.asarray(n, jnp.int32)
    return jax.lax.fori_loop(0, n, lambda _, h: mu * h * (1.0 - h), jnp.asarray(h0, jnp.float32))


def ordered_sum(x: jax.Array) -> jax.Array:
    """Sum over the leading axis, added strictly in order. A plain ``jnp.sum`` may reduce in
    another order inside a vmapped sweep than in a single run; the Logistic map amplifies that
    last-bit difference (×4 per step), and sweep rows must equal solves bit for bit."""
    return jax.lax.scan(lambda acc, row: (acc + row, None), jnp.zeros_like(x[0]), x)[0]


def above_mean(cost: jax.Array) -> tuple[jax.Array, jax.Array]:
    """Masks ``(A,)`` of the successful paths above the iteration's mean length (the N_L paths)
    and of those at or below it; failed ants (cost inf) are in neither."""
    ok = jnp.isfinite(cost)
    count = jnp.sum(ok)
    mean = ordered_sum(jnp.where(ok, cost, 0.0)) / jnp.maximum(count, 1)
    above = ok & (cost > mean * (1.0 + _MEAN_RTOL))
    return above, ok & ~above


def chaos_perturb() -> ph.Rule:
    """Logistic-chaos perturbation of the paths above the mean length (eq. 14).

    For each of the N_L successful paths l longer than the mean: τ_l = mean pheromone over the
    elements (moves or cells) it used; h0 = (τ_l − τmin)/(τmax − τmin) with τmin, τmax the
    smallest and largest pheromone on the elements of the N_L paths (the paper: "the maximum and
    minimum of the pheromone distributed on the N_L paths"); h = i_c Logistic steps (μ =
    ``chaos_mu``, i_c = ``round(chaos_iters)``); every element of path l is set to
    τmin + h·(τmax − τmin). An element on several such paths gets the mean of their values;
    an element that a path at or below the mean also used is left as it is (that path updates
    it normally). The new values lie in [τmin, τmax], so the pheromone stays finite and never
    exceeds its previous maximum.
    """

    def update(trail, walks, problem, params):
        tau = trail.tau
        m = tau.shape[0]
        above, below = above_mean(walks.cost)
        used = walks.targets < m  # (S, A): steps actually taken
        on_long = used & above[None, :]
        tau_steps = tau[jnp.where(used, walks.targets, 0)]
        n_el = jnp.sum(used, axis=0)
        tau_l = ordered_sum(jnp.where(used, tau_steps, 0.0)) / jnp.maximum(n_el, 1)
        lo = jnp.min(jnp.where(on_long, tau_steps, jnp.inf))
        hi = jnp.max(jnp.where(on_long, tau_steps, -jnp.inf))
        span = jnp.where(jnp.isfinite(hi - lo), hi - lo, 0.0)
        base = jnp.where(jnp.isfinite(lo), lo, 0.0)
        h0 = jnp.clip(jnp.where(span > 0, (tau_l - base) / jnp.where(span > 0, span, 1.0), 0.0), 0.0, 1.0)
        h = logistic(h0, params.chaos_mu, jnp.round(params.chaos_iters))
        new = base + h * span  # (A,)
        targets = jnp.where(on_long, walks.targets, m)  # only the N_L paths write
        total = ph.deposit(jnp.zeros_like(tau), targets, new)
        count = ph.deposit(jnp.zeros_like(tau), targets, 1.0)
        protected = ph.on_path(tau, jnp.where(used & below[None, :], walks.targets, m))
        hit = (count > 0) & ~protected
        return trail._replace(tau=jnp.where(hit, total / jnp.maximum(count, 1.0), tau))

    return ph.Rule(ph.keep_init, update)


def at_or_below_mean_cycle(walks: ph.Walks, params: Params) -> jax.Array:
    """Δτ^k = Q/L_k on every step of a successful ant whose length is at or below the mean
    (eq. 15: these "update directly"; the longer ones were perturbed instead)."""
    _, below = above_mean(walks.cost)
    return jnp.where(below, params.q * ph.inverse(walks.cost), 0.0)  # one amount per ant


def deposit_at_or_below_mean() -> ph.Rule:
    """Global update (15) after the perturbation: τ ← (1−ρ)τ + Σ_k Q/L_k over the paths at or
    below the mean (``chain(evaporate(), deposit_at_or_below_mean())``)."""
    return ph.deposit_all(at_or_below_mean_cycle)


component(
    "heuristic",
    "chaos",
    heuristic=heuristics.inverse_goal_distance,
    factor=selection_factor,
    params=(BETA.with_default(8.0), GAMMA),
    source="Xi'an Technological University, rule (11)",
)
component(
    "rule",
    "chaos",
    rule=ph.chain(ph.init_constant(), chaos_perturb(), ph.evaporate(), deposit_at_or_below_mean()),
    params=(
        ALPHA.with_default(1.0),
        ph.RHO.with_default(0.3),
        ph.Q.with_default(1.0),
        ph.TAU0.with_default(0.1),
        CHAOS_ITERS,
        CHAOS_MU,
    ),
    source="Xi'an Technological University, updates (14), (15)",
)

CHAOS_ACO = compose(heuristic="chaos", rule="chaos").named(
    "chaos-aco",
    source="Xi'an Technological University paper: transition (11), chaos update (14), global update (15)",
    doc="Chaos ACO: transition p ∝ τ^α η^β (P_free·P_θ)^γ with the free-cell share P_free and the angle "
    "share P_θ of each move (a per-move constant folded into the weight table once per iteration); "
    "after each iteration the paths above the mean length get their pheromone re-drawn by i_c steps "
    "of the Logistic map (μ = 4) between the smallest and largest pheromone on those paths, then "
    "τ ← (1−ρ)τ + Σ Q/L_k over the paths at or below the mean. η = 1/(distance to the goal) "
    "(thesis eq. 3-7) as for the classic planners; pheromone on moves (τ_ij). See docs/planners.md.",
    alpha=1.0,
    beta=8.0,
    rho=0.3,
    q=1.0,
    tau0=0.1,
    gamma=4.0,
    chaos_iters=10.0,
    chaos_mu=4.0,
)

PLANNERS = (CHAOS_ACO,)

__all__ = [
    "CHAOS_ACO",
    "above_mean",
    "angle_share",
    "at_or_below_mean_cycle",
    "chaos_perturb",
    "deposit_at_or_below_mean",
    "free_share",
    "logistic",
    "ordered_sum",
    "move_angles",
    "selection",
    "selection_factor",
]
