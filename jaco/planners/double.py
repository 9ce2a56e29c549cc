"""Double ant colony with complete path crossover: IDACA (thesis chapter 3) and DACA (ref. 58).

Sources: Hua Lu, *Research on path planning based on ant colony algorithm*, MSc thesis, Nanchang
Hangkong University, 2011, chapter 3; its ref. 58, Sun, Lin, Lou et al., *Double ant colony
complete crossover algorithm for global path planning with concave obstacles*, Trans. CSAM, 2008.

:func:`double_colony` is the construct step: two colonies, complete crossover, best population.
Equations: docs/algorithms.md §3; the iteration and every interpretation: docs/planners.md,
"Double colonies: IDACA and DACA".
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING, Any, NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from ..engine import pheromone as ph
from ..engine.colony import ALPHA, Colony, move_weights, step_targets
from ..engine.walk import Tours, walk
from ..moves import MOVES
from .compose import component, compose

if TYPE_CHECKING:
    from ..engine.params import Params
    from ..engine.planner import Planner

SQRT2 = np.float32(np.sqrt(2.0))

#: ``OPPOSITE[k]``: the move that undoes move k (moves are symmetric, corner rule included).
OPPOSITE = np.array([int(np.flatnonzero((MOVES == -m).all(axis=1))[0]) for m in MOVES], dtype=np.int32)

#: Population indices of :attr:`Crossed.population`.
COLONY1, COLONY2, SPLICED = 0, 1, 2


class Splice(NamedTuple):
    """Each colony-1 ant's shortest splice with a colony-2 walk, ``(A,)`` arrays.

    ``partner``: the colony-2 ant; ``s1``: steps taken from colony-1's walk (the meeting cell is
    the cell it entered at step ``s1 − 1``, or the start when 0); ``s2``: steps of the partner's
    walk, run backwards, from the meeting cell to the goal; ``length``: ``d1 + d2`` along the
    two walks (inf where the walks never meet)."""

    partner: jax.Array
    s1: jax.Array
    s2: jax.Array
    length: jax.Array


def _full(cells, first):
    """``(S+1, A)``: the walk's first cell, then the cells it entered (-1 past its end)."""
    head = jnp.broadcast_to(jnp.asarray(first, cells.dtype), (1, cells.shape[1]))
    return jnp.concatenate([head, cells], axis=0)


def distance_along(moves: jax.Array) -> jax.Array:
    """``(S+1, A)`` distance from a walk's first cell to its cell at each position (inf past its
    end), from integer counts of straight and diagonal steps, so the value is exact and the same
    however runs are batched."""
    took = moves >= 0
    zero = jnp.zeros((1, moves.shape[1]), jnp.int32)
    straight = jnp.concatenate([zero, jnp.cumsum((took & (moves < 4)).astype(jnp.int32), axis=0)])
    diagonal = jnp.concatenate([zero, jnp.cumsum((moves >= 4).astype(jnp.int32), axis=0)])
    on = jnp.concatenate([zero == 0, took])
    return jnp.where(on, straight.astype(jnp.float32) + SQRT2 * diagonal.astype(jnp.float32), jnp.inf)


def crossover(
    cells1: jax.Array, moves1: jax.Array, cells2: jax.Array, moves2: jax.Array, start: Any, goal: Any, n_cells: int
) -> Splice:
    """Complete crossover of two colonies' walks (Sun et al. 2008, the thesis's ref. 58;
    docs/algorithms.md §3).

    ``cells1, moves1 (S, A1)``: colony 1's walks from ``start`` (entered cells and move indices,
    -1 past the end), ``cells2, moves2 (S, A2)``: colony 2's walks from ``goal``. For every
    colony-1 ant a, the minimum over colony-2 ants b and common cells x of
    ``d1(a, x) + d2(b, x)`` (distances along the walks). Dead walks take part (any common cell
    joins start and goal). A minimal splice never repeats a cell: a repeated cell y would be a
    common cell with a strictly shorter splice. Ties go to the lowest b, then the earliest x.

    Vectorised without the ``(A1, A2, N)`` pair table: ``min_b,x d1(a,x) + d2(b,x) =
    min_x (d1(a,x) + min_b d2(b,x))``, so scatter-min of colony 2's walks gives, per cell, the
    nearest colony-2 walk ``(N,)``; gathered along colony 1's walks ``(S+1, A1)`` and minimised
    over each walk. O((S+1)·(A1+A2) + N) work per iteration.
    """
    s = cells1.shape[0]
    f1 = _full(cells1, start)
    f2 = _full(cells2, goal)
    d1 = distance_along(moves1)  # (S+1, A1)
    d2 = distance_along(moves2)  # (S+1, A2)
    lanes = jnp.broadcast_to(jnp.arange(cells2.shape[1], dtype=jnp.int32)[None, :], f2.shape)
    where2 = jnp.where(f2 >= 0, f2, n_cells)  # out of range: dropped by the scatters
    # Per cell: the shortest colony-2 distance, the lowest colony-2 ant achieving it, and the
    # position of the cell in that ant's walk (each walk enters a cell at most once).
    d2_near = jnp.full((n_cells,), jnp.inf, jnp.float32).at[where2].min(d2, mode="drop")
    mine = d2 == d2_near[jnp.where(f2 >= 0, f2, 0)]
    near = jnp.full((n_cells,), lanes.shape[1], jnp.int32).at[jnp.where(mine, where2, n_cells)].min(lanes, mode="drop")
    steps = jnp.broadcast_to(jnp.arange(s + 1, dtype=jnp.int32)[:, None], f2.shape)
    chosen = mine & (lanes == near[jnp.where(f2 >= 0, f2, 0)])
    pos = jnp.zeros((n_cells,), jnp.int32).at[jnp.where(chosen, where2, n_cells)].set(steps, mode="drop")
    safe1 = jnp.where(f1 >= 0, f1, 0)
    total = d1 + d2_near[safe1]  # (S+1, A1); inf past colony 1's end and off colony 2's walks
    s1 = jnp.argmin(total, axis=0).astype(jnp.int32)
    length = jnp.min(total, axis=0)
    meet = safe1[s1, jnp.arange(f1.shape[1])]
    partner = near[meet]
    s2 = pos[meet]
    ok = jnp.isfinite(length)
    return Splice(jnp.where(ok, partner, 0), jnp.where(ok, s1, 0), jnp.where(ok, s2, 0), length)


def assemble(
    cells1: jax.Array,
    moves1: jax.Array,
    a: jax.Array,
    s1: jax.Array,
    cells2: jax.Array,
    moves2: jax.Array,
    b: jax.Array,
    s2: jax.Array,
    goal: Any,
) -> tuple[jax.Array, jax.Array]:
    """Paths ``(2S, C)`` made of the first ``s1[c]`` steps of colony-1 walk ``a[c]`` followed by
    the first ``s2[c]`` steps of colony-2 walk ``b[c]`` run backwards (ending on the goal).

    Returns ``(cells, moves)``, -1 padded. ``s2 = 0`` gives colony 1's walks, ``s1 = 0`` with
    ``s2`` = the walk's length gives colony 2's walks reversed; a crossover gives the splices.
    """
    s = cells1.shape[0]
    opposite = jnp.asarray(OPPOSITE)
    k = jnp.arange(2 * s, dtype=jnp.int32)[:, None]
    first = k < s1[None, :]
    j = s2[None, :] - 1 - (k - s1[None, :])  # colony-2 step walked backwards at buffer step k
    second = ~first & (j >= 0)
    i1 = jnp.clip(k, 0, s - 1)
    i2 = jnp.clip(j, 0, s - 1)
    cell2 = jnp.where(j == 0, goal, cells2[jnp.clip(j - 1, 0, s - 1), b[None, :]])  # entered: f2[j]
    move2 = opposite[jnp.clip(moves2[i2, b[None, :]], 0, 7)]
    cells = jnp.where(first, cells1[i1, a[None, :]], jnp.where(second, cell2, -1))
    moves = jnp.where(first, moves1[i1, a[None, :]], jnp.where(second, move2, -1))
    return cells, moves


def _candidates(cells, moves, arrived, n_steps, visited) -> Tours:
    """A :class:`Tours` record of assembled paths (so the planner's cost function applies)."""
    took = moves >= 0
    lengths = jnp.asarray(np.hypot(MOVES[:, 0], MOVES[:, 1]), jnp.float32)
    return Tours(
        cells=cells,
        moves=moves,
        step_len=jnp.where(took, lengths[jnp.where(took, moves, 0)], 0.0),
        arrived=arrived,
        n_steps=n_steps,
        length=jnp.sum(took & (moves < 4), axis=0) + SQRT2 * jnp.sum(moves >= 4, axis=0),
        visited=visited,
    )


def mean_feasible(cost: jax.Array) -> jax.Array:
    """Mean of the finite costs along the last axis; inf when there is none."""
    ok = jnp.isfinite(cost)
    n = jnp.sum(ok, axis=-1)
    total = jnp.sum(jnp.where(ok, cost, 0.0), axis=-1)
    return jnp.where(n > 0, total / jnp.maximum(n, 1), jnp.inf)


def best_population(costs: jax.Array) -> jax.Array:
    """Index of the population ``costs (P, C)`` with the lowest mean feasible cost (Step 4).

    Ties go to the lower index (colony 1, then colony 2, then the splices); when no population
    has a feasible candidate the answer is 0 and nothing deposits."""
    return jnp.argmin(mean_feasible(costs)).astype(jnp.int32)


class Crossed(NamedTuple):
    """Everything one double-colony iteration produced (for inspection and tests)."""

    tours1: Tours
    tours2: Tours
    splice: Splice
    candidates: Tours  # (2S, 3A): colony 1, colony 2 reversed, splices, in this order
    cost: jax.Array  # (3, A)
    population: jax.Array  # the chosen one: COLONY1, COLONY2 or SPLICED
    steps: jax.Array  # (2, S, A): both colonies' edges, for the next iteration's walks (Trail.steps)


def double_walk(
    planner: Planner,
    problem: Any,
    trail: ph.Trail,
    params: Params,
    t: Any,
    n_iters: int,
    key: jax.Array,
    *,
    n_ants: int,
    steplimit: int,
) -> Crossed:
    """Walk both colonies, cross them over and cost the three populations.

    Colony 2 walks the problem with start and goal swapped, so a heuristic must read the goal
    from ``problem.goal`` (as :mod:`jaco.engine.heuristics` does); the precomputed ``goal_dist`` table
    still refers to the original goal and must not be used by a double-colony heuristic."""
    exploit = planner.transition == "pseudo-random"

    def colony(start, goal, k, previous):
        prob = dataclasses.replace(problem, start=start, goal=goal)
        weights = move_weights(planner, trail, prob, params, t, n_iters)
        q0 = params.q0 if exploit else 0.0
        return walk(prob, weights, k, q0, n_ants=n_ants, steplimit=steplimit, exploit=exploit, previous=previous)

    # Both colonies in one vmapped walk (one loop, one compiled body): colony 1 start → goal,
    # colony 2 goal → start, each with its own key and its heuristic toward its own goal, each
    # writing over its own last steps (trail.steps, (2, S, A)).
    ends = jnp.stack([problem.start, problem.goal])
    both = jax.vmap(colony)(ends, ends[::-1], jax.random.split(key), trail.steps)
    tours1, tours2 = (jax.tree.map(lambda v, i=i: v[i], both) for i in range(2))
    n_cells = problem.nbr.shape[0]
    sp = crossover(tours1.cells, tours1.moves, tours2.cells, tours2.moves, problem.start, problem.goal, n_cells)

    ants = jnp.arange(n_ants, dtype=jnp.int32)
    zeros = jnp.zeros_like(ants)
    spliced = jnp.isfinite(sp.length)
    # Dead colony-1 ants keep their partial walk (as in single_colony); reversed dead colony-2
    # walks and failed splices are empty. None of them has a finite cost.
    a = jnp.concatenate([ants, zeros, ants])
    s1 = jnp.concatenate([tours1.n_steps, zeros, sp.s1])
    b = jnp.concatenate([zeros, ants, sp.partner])
    s2 = jnp.concatenate([zeros, jnp.where(tours2.arrived, tours2.n_steps, 0), sp.s2])
    arrived = jnp.concatenate([tours1.arrived, tours2.arrived, spliced])
    cells, moves = assemble(tours1.cells, tours1.moves, a, s1, tours2.cells, tours2.moves, b, s2, problem.goal)
    # n_steps: the real steps both colonies walked (ant i of each colony on candidate i), so the
    # engine's step count measures throughput whatever population wins.
    walked = tours1.n_steps + tours2.n_steps
    cand = _candidates(cells, moves, arrived, jnp.tile(walked, 3), tours1.visited | tours2.visited)
    cost = jnp.where(arrived, planner.cost(cand, problem, params), jnp.inf).reshape(3, n_ants)
    return Crossed(tours1, tours2, sp, cand, cost, best_population(cost), both.edges)


def double_colony(
    planner: Planner,
    problem: Any,
    trail: ph.Trail,
    params: Params,
    t: Any,
    n_iters: int,
    key: jax.Array,
    *,
    n_ants: int,
    steplimit: int,
) -> tuple[ph.Trail, Colony]:
    """Construct step of a double colony with complete crossover (thesis 3.5, Steps 2–4).

    ``n_ants`` ants per colony (2·n_ants walks per iteration). Returns the candidates of the best
    population as a :class:`~jaco.engine.colony.Colony` of ``n_ants`` paths in a ``(2·S, n_ants)``
    buffer; ``n_steps`` counts the steps of both colonies; ``visited`` the cells either entered.
    """
    x = double_walk(planner, problem, trail, params, t, n_iters, key, n_ants=n_ants, steplimit=steplimit)
    c = x.candidates
    pick = lambda v: jax.lax.dynamic_slice_in_dim(v, x.population * n_ants, n_ants, axis=v.ndim - 1)  # noqa: E731
    cells, moves = pick(c.cells), pick(c.moves)
    targets = step_targets(planner.pheromone_on, cells, moves, problem.start, problem.nbr.shape[0])
    cost = x.cost[x.population]
    colony = Colony(cells, targets, pick(c.step_len), cost, pick(c.length), pick(c.n_steps), c.visited)
    return trail._replace(steps=x.steps), colony


# -- pheromone pieces of IDACA --------------------------------------------------------------
def init_max() -> ph.Rule:
    """τ = τmax everywhere, bounds [τmin, τmax] from the parameters (thesis 3.5 Step 1)."""

    def init(trail, problem, params):
        hi = jnp.asarray(params.tau_max, jnp.float32)
        return trail._replace(tau=jnp.full_like(trail.tau, hi), lo=jnp.asarray(params.tau_min, jnp.float32), hi=hi)

    return ph.Rule(init, lambda trail, walks, problem, params: trail)


def rho_ant_cycle(walks: ph.Walks, params: Params) -> jax.Array:
    """ρ·Q/L_k on every step of feasible candidate k: with :func:`jaco.engine.pheromone.evaporate`,
    τ ← (1−ρ)τ + ρ·Σ_k Q/L_k (thesis 3.4.2)."""
    return params.rho * ph.ant_cycle(walks, params)


def idaca_rule() -> ph.Rule:
    """τ0 = τmax; τ ← clip((1−ρ)τ + ρ·Σ_k Q/L_k, τmin, τmax) over the best population's
    feasible candidates k (thesis 3.4.2 and 3.5 Steps 5–6)."""
    return ph.chain(init_max(), ph.evaporate(), ph.deposit_all(rho_ant_cycle), ph.clamp())


def daca_rule() -> ph.Rule:
    """Ant System on cells: τ0 constant; τ ← (1−ρ)τ + Σ_k Q/L_k (thesis eqs. 3-4..3-6)."""
    return ph.chain(ph.init_constant(), ph.evaporate(), ph.deposit_all(ph.ant_cycle))


# -- the components and planners ----------------------------------------------------------------------------
_DOUBLE_NOTE = (
    " Two colonies of n_ants ants each walk start→goal and goal→start (dead at a dead end or the "
    "step limit); complete crossover splices, for every colony-1 walk, the shortest start→x→goal "
    "path through a cell x it shares with some colony-2 walk (dead ants' partial walks included); "
    "the population (colony 1, colony 2 reversed, splices) with the lowest mean feasible length "
    "is the iteration's candidates. Pheromone on cells (node pheromone)."
)

component("construct", "double", construct=double_colony, source="thesis ch. 3: two colonies, crossover")
component(
    "rule",
    "daca",
    rule=daca_rule(),
    pheromone_on="cells",
    params=(ALPHA.with_default(1.0), ph.RHO.with_default(0.6), ph.Q.with_default(10.0), ph.TAU0.with_default(0.1)),
    source="Sun, Lin, Lou et al. 2008 (thesis ref. 58); thesis eqs. 3-4..3-6",
)
component(
    "rule",
    "idaca",
    rule=idaca_rule(),
    pheromone_on="cells",
    params=(
        ALPHA.with_default(1.0),
        ph.RHO.with_default(0.7),
        ph.Q.with_default(20.0),
        ph.TAU_MIN.with_default(0.01),
        ph.TAU_MAX.with_default(20.0),
    ),
    source="Hua Lu 2011 thesis 3.4.2, 3.5",
)

IDACA = compose(construct="double", rule="idaca", schedule="idaca").named(
    "idaca",
    source="Hua Lu 2011, MSc thesis ch. 3 (3.4, 3.5); eqs. 3-7, 3-8, 3-9, 3-10; crossover of ref. 58",
    doc="IDACA (thesis ch. 3; eqs. 3-7..3-10): improved double ant colony. Heuristic η = 1/L_B, L_B the "
    "distance from the candidate to the colony's own goal (eq. 3-7); α, β ramp linearly up to "
    "break_iter then plateau (eqs. 3-8, 3-9); ρ decays as ρ0·a^(−i(i−1)/(2Nc)) down to ρmin "
    "(eq. 3-10); MMAS-style update of 3.4.2: τ initialised to τmax, every feasible candidate of the "
    "best population deposits, τ ← (1−ρ)τ + ρ·Σ Q/L_k, clamped to [τmin, τmax]." + _DOUBLE_NOTE,
    alpha_slope=0.03,
    alpha_end=2.5,
    beta_start=3.0,
    beta_slope=0.015,
    beta_end=2.0,
    break_iter=83.0,
    rho=0.7,
    rho_min=0.3,
    rho_decay=2.0,
    q=20.0,
    tau_min=0.01,
    tau_max=20.0,
)

DACA = compose(construct="double", heuristic="step", rule="daca").named(
    "daca",
    source="Sun, Lin, Lou et al. 2008, Trans. CSAM 39(7) (thesis ref. 58); thesis eqs. 3-3..3-6",
    doc="DACA (ref. 58; thesis eqs. 3-3..3-6): double ant colony with complete crossover, the thesis's "
    "baseline for IDACA. Classic heuristic η = 1/d_ij (eq. 3-3), Ant System update on cells "
    "τ ← (1−ρ)τ + Σ_k Q/L_k over the best population's feasible candidates (eqs. 3-4..3-6), "
    "τ0 constant, no schedules. Ref. 58's own heuristic is not given in the thesis." + _DOUBLE_NOTE,
    alpha=1.0,
    beta=1.0,
    rho=0.6,
    q=10.0,
    tau0=0.1,
)

PLANNERS = (DACA, IDACA)
