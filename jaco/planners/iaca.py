"""IACA: the improved ant colony algorithm with backtracking ants (Hua Lu 2011, thesis chapter 4).

Source: Hua Lu, *Research on path planning based on ant colony algorithm*, MSc thesis, Nanchang
Hangkong University, 2011, chapter 4 (eqs. 4-1..4-6, sections 4.2.2-4.4). Pheromone on cells;
the construct :func:`backtrack_colony` replaces the engine's single colony, because the local
update changes τ while the ants walk and the heuristic (4-5) depends on each ant's tabu list.

Equations: docs/algorithms.md §4; every interpretation and the defaults: docs/planners.md, "IACA".
"""

from __future__ import annotations

import functools
from typing import TYPE_CHECKING, Any, NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from ..engine import native
from ..engine import pheromone as ph
from ..engine.bitexact import power, rounded
from ..engine.colony import ALPHA, BETA, Colony, eta_factor, step_targets
from ..engine.heuristics import goal_distance
from ..engine.params import INF, Param, declare
from ..engine.walk import CHUNK, Tours, choose, key_words, step_uniforms
from ..engine.weights import scaled
from ..moves import MOVE_LENGTHS
from .compose import component, compose

if TYPE_CHECKING:
    from ..engine.params import Params
    from ..engine.planner import Planner

K_INIT, RHO_LOCAL, Q1, Q2, Q3, RHO1, RHO2, Q_STEP = declare(
    Param("k_init", 10.0, 0, INF, "IACA 4.2.3: initial pheromone K·η_goal(j)", lo_open=True, hi_open=True),
    Param("rho_local", 0.1, 0, 1, "IACA eqs. 4-2..4-4: local update τ ← (1−ρ)τ + Q/d_ij while walking"),
    Param("q1", 1.0, 0, INF, "IACA eq. 4-6: threshold Q1", hi_open=True),
    Param("q2", 5.0, 0, INF, "IACA eq. 4-6: threshold Q2 (> Q1)", hi_open=True),
    Param("q3", 15.0, 0, INF, "IACA eq. 4-6: threshold Q3 (> Q2)", hi_open=True),
    Param("rho1", 0.7, 0, 1, "IACA eq. 4-6: factor for Q1 < P ≤ Q2 (ρ1 > ρ2)", lo_open=True),
    Param("rho2", 0.2, 0, 1, "IACA eq. 4-6: factor for Q2 < P ≤ Q3", lo_open=True),
    Param("q_step", 0.5, 0, INF, "IACA eq. 4-6: increment q for P ≤ Q1, decrement for P > Q3", hi_open=True),
    order=[("q1", "q2"), ("q2", "q3"), ("rho2", "rho1")],
)

ETA_FLOOR = 1e-6


# -- heuristic (4-5) -------------------------------------------------------------------------
def detour(problem: Any) -> jax.Array:
    """``d_AB + d_BE`` for every move A→B ``(N, 8)`` (Euclidean; 0 where the map forbids it)."""
    return jnp.where(problem.nbr >= 0, problem.step + goal_distance(problem), 0.0)


def eta_45(r: jax.Array, allowed: jax.Array) -> jax.Array:
    """Eq. (4-5) on rows ``r (..., 8)`` of :func:`detour` over the ``allowed`` moves:
    ``η_B = 1 − r_B / Σ_{C allowed} r_C``; 1 when B is the only allowed move; floored at
    :data:`ETA_FLOOR`; 0 where not allowed."""
    r = jnp.where(allowed, r, 0.0)
    total = r[..., 0]
    for i in range(1, 8):  # left to right, as the native kernel adds
        total = total + r[..., i]
    single = jnp.sum(allowed, axis=-1, keepdims=True) == 1
    eta = jnp.where(single, 1.0, 1.0 - r / jnp.maximum(total, 1e-12)[..., None])
    return jnp.where(allowed, jnp.maximum(eta, ETA_FLOOR), 0.0)


def iaca_heuristic(problem: Any, params: Params, t: Any, n_iters: int) -> jax.Array:
    """Eq. (4-5) with ``M_A`` = every move the map allows (no tabu list): the static form, for
    tools that want one ``(N, 8)`` table. The IACA walk recomputes it per step with the tabu."""
    return eta_45(detour(problem), problem.nbr >= 0)


# -- pheromone pieces ------------------------------------------------------------------------
def goal_closeness(problem: Any) -> jax.Array:
    """``η_goal(j) = 1 − d_jE / max_j d_jE`` over free cells (Euclidean; 4.2.3), 0 on obstacles."""
    d = jnp.sqrt(jnp.sum((problem.xy - problem.xy[problem.goal][None, :]) ** 2, axis=-1))
    free = problem.clearance > 0
    dmax = jnp.max(jnp.where(free, d, 0.0))
    return jnp.where(free, 1.0 - d / jnp.maximum(dmax, 1e-12), 0.0)


def iaca_init() -> ph.Rule:
    """τ0_j = K·η_goal(j) clamped to [τmin, τmax]; fixed bounds ``Trail(lo=τmin, hi=τmax)`` (4.2.3)."""

    def init(trail, problem, params):
        lo, hi = jnp.float32(params.tau_min), jnp.float32(params.tau_max)
        tau = jnp.clip(params.k_init * goal_closeness(problem), lo, hi).astype(trail.tau.dtype)
        return trail._replace(tau=tau, lo=lo, hi=hi)

    return ph.Rule(init, ph.keep_update)


def infeasible_update(tau: jax.Array, params: Params) -> jax.Array:
    """Eq. (4-6) on pheromone values ``P``: ``P + q`` (P ≤ Q1), ``ρ1·P`` (Q1 < P ≤ Q2),
    ``ρ2·P`` (Q2 < P ≤ Q3), ``P − q`` (P > Q3); no clamp here."""
    return jnp.where(
        tau <= params.q1,
        tau + params.q_step,
        jnp.where(
            tau <= params.q2, params.rho1 * tau, jnp.where(tau <= params.q3, params.rho2 * tau, tau - params.q_step)
        ),
    )


def int_power(x: jax.Array | float, k: jax.Array | int) -> jax.Array:
    """``x^k`` for integer ``k`` in [0, 2^16) by binary exponentiation: multiplications in a fixed
    order, so the kernel gets the same bits (``x^1`` is ``x`` exactly)."""
    k = jnp.asarray(k, jnp.int32)
    out = jnp.ones(jnp.broadcast_shapes(jnp.shape(x), k.shape), jnp.float32)
    base = jnp.asarray(x, jnp.float32)
    for bit in range(16):
        out = jnp.where((k >> bit) & 1 == 1, out * base, out)
        base = base * base
    return out


def local_update(
    tau: jax.Array, lo: jax.Array, hi: jax.Array, n_straight: jax.Array, n_diagonal: jax.Array, params: Any
) -> jax.Array:
    """Eqs. (4-2..4-4) for the forward steps of one walk step, all ants together.

    ``n_straight``, ``n_diagonal`` ``(N,)``: how many ants entered each cell by a straight or a
    diagonal move. A cell entered by k ants gets the k sequential updates averaged over their
    orders: ``(1−ρ)^k τ + (Σ Q/d)(1 − (1−ρ)^k)/(kρ)``; then it is clamped to [lo, hi]. Written
    so that the native kernel rounds every operation identically (:mod:`jaco.engine.bitexact`).
    """
    k = n_straight + n_diagonal
    a1, a2 = params.q / jnp.float32(MOVE_LENGTHS[0]), params.q / jnp.float32(MOVE_LENGTHS[4])
    s = rounded(n_straight.astype(jnp.float32) * a1) + rounded(n_diagonal.astype(jnp.float32) * a2)
    keep = 1.0 - params.rho_local
    decay = int_power(keep, k)
    rho = params.rho_local
    # (1 − keep^k)/(kρ) → 1 as ρ → 0; k ≥ 1 wherever it is used.
    mean_decay = jnp.where(rho > 1e-6, (1.0 - decay) / jnp.maximum(k.astype(jnp.float32) * rho, 1e-12), 1.0)
    new = jnp.clip(rounded(decay * tau) + rounded(s * mean_decay), lo, hi)
    return jnp.where(k > 0, new, tau)


def step_weights(tau_nb: jax.Array, r: jax.Array, allowed: jax.Array, params: Any) -> jax.Array:
    """Eq. (4-1) for one step of every ant: ``τ_B^α η_B^β`` ``(A, 8)`` over the ``allowed`` moves
    with η of eq. (4-5) from the detour rows ``r``, floored at 1e-30 (0 where not allowed). The
    powers are :func:`jaco.engine.bitexact.power`, so the kernel computes the same weights."""
    w = power(tau_nb, params.alpha) * power(eta_45(r, allowed), params.beta)
    w = jnp.clip(jnp.where(jnp.isnan(w), 1e-30, w), 1e-30, 1e30)
    return jnp.where(allowed, w, 0.0)


# -- the backtracking walk --------------------------------------------------------------------
def native_backtrack_walk(
    tau: jax.Array,
    rows: jax.Array,
    factors: jax.Array,
    words: jax.Array,
    start: Any,
    goal: Any,
    scalars: jax.Array,
    offsets: Any,
    *,
    n_ants: int,
    steplimit: int,
    exploit: bool,
    table: bool,
) -> tuple:
    """The C++ kernel's backtracking walk (``jaco_backtrack`` of ``jaco/planners/iaca.cc``, called
    through :func:`jaco.engine.native.ffi_call`); same arguments and results as
    :func:`jax_backtrack_walk`."""
    from ..engine.bitexact import TABLES

    n, depth = tau.shape[-1], steplimit + 1
    out = (
        jax.ShapeDtypeStruct((n,), jnp.float32),
        jax.ShapeDtypeStruct((n_ants, depth), jnp.int32),
        jax.ShapeDtypeStruct((n_ants,), jnp.int32),
        jax.ShapeDtypeStruct((n_ants,), jnp.bool_),
        jax.ShapeDtypeStruct((n_ants,), jnp.int32),
        jax.ShapeDtypeStruct((n,), jnp.bool_),
        jax.ShapeDtypeStruct((n,), jnp.bool_),
        jax.ShapeDtypeStruct((n_ants, depth), jnp.int32),
    )
    call = native.ffi_call("jaco_backtrack", out)
    return call(
        tau,
        rows,
        factors,
        words,
        start,
        goal,
        scalars,
        offsets,
        jnp.asarray(TABLES),
        steplimit=np.int64(steplimit),
        exploit=bool(exploit),
        table=bool(table),
    )


class Backtracked(NamedTuple):
    """What one iteration's backtracking walks leave: ``tau (N,)`` after the local updates;
    ``stack (A, steplimit + 1)``: each ant's path from the start with the dead branches removed
    (-1 beyond ``sp``); ``sp (A,)``; ``arrived (A,)``; ``actions (A,)``: forward and back steps;
    ``visited (N,)``: cells any ant entered; ``infeasible (N,)``: the cells of eq. (4-6), entered
    by an ant that failed or popped by backtracking and on no arrived ant's final path; ``moves
    (A, steplimit + 1)``: the move (index into :data:`jaco.moves.MOVES`) that entered each cell of
    ``stack``, -1 for the start and beyond ``sp`` (the walk knows them, so no pass over the stacks
    recovers them from the cells)."""

    tau: jax.Array
    stack: jax.Array
    sp: jax.Array
    arrived: jax.Array
    actions: jax.Array
    visited: jax.Array
    infeasible: jax.Array
    moves: jax.Array


def backtrack_walk(
    problem: Any,
    trail: ph.Trail,
    params: Params,
    key: jax.Array,
    *,
    n_ants: int,
    steplimit: int,
    exploit: bool = True,
    factors: jax.Array | None = None,
) -> Backtracked:
    """Walk ``n_ants`` backtracking ants (thesis 4.3) with the local update (4-2..4-4), in JAX or,
    on CPU when it is active, in the native kernel (:mod:`jaco.engine.native`): the same results
    bit for bit. A move weighs τ_j^α times η_B^β of eq. (4-5), recomputed at every step over the
    ant's allowed moves; or, with ``factors (N, 8)``, times that fixed factor (another planner's
    heuristic, once per iteration)."""
    words = key_words(key)
    rows = detour(problem)
    table = factors is not None
    # Without a table the walks read no factors: an empty array, not N × 8 zeros made every iteration.
    factors = jnp.zeros((0, 8), jnp.float32) if factors is None else jnp.asarray(factors, jnp.float32)
    scalars = jnp.stack(
        [
            jnp.asarray(v, jnp.float32)
            for v in (
                params.q0 if exploit else 0.0,
                params.alpha,
                params.beta,
                trail.lo,
                trail.hi,
                params.rho_local,
                params.q,
            )
        ]
    )
    args = (trail.tau, rows, factors, words, problem.start, problem.goal, scalars, problem.offsets)
    exploit = bool(exploit)
    return Backtracked(
        *native.dispatch(
            functools.partial(native_backtrack_walk, n_ants=n_ants, steplimit=steplimit, exploit=exploit, table=table),
            functools.partial(jax_backtrack_walk, n_ants=n_ants, steplimit=steplimit, exploit=exploit, table=table),
            *args,
        )
    )


def jax_backtrack_walk(
    tau: jax.Array,
    rows: jax.Array,
    factors: jax.Array,
    words: jax.Array,
    start: Any,
    goal: Any,
    scalars: jax.Array,
    offsets: Any,
    *,
    n_ants: int,
    steplimit: int,
    exploit: bool,
    table: bool,
) -> tuple[jax.Array, ...]:
    """The backtracking walk in JAX, all ants in lock-step (the definition; :class:`Backtracked`).
    ``rows``: the detour table of eq. (4-5) (> 0 exactly on the moves the map allows); with
    ``table``, the weights use ``factors (N, 8)`` instead of η^β of eq. (4-5) (without, ``factors``
    is not read: any shape)."""
    q0, alpha, beta, lo, hi, rho_local, q = (scalars[i] for i in range(7))
    params = _Scalars(alpha, beta, rho_local, q)
    n_cells = tau.shape[0]
    depth = steplimit + 1
    lanes = jnp.arange(n_ants)
    valid_rows = rows > 0

    def step(carry, t):
        tau, cur, sp, stack, moves, tabu, running, actions = carry
        nb = jnp.clip(cur[:, None] + offsets[None, :], 0, n_cells - 1)
        allowed = valid_rows[cur] & ~tabu[lanes[:, None], nb]
        live = running & (t < steplimit)
        has = jnp.any(allowed, axis=-1)
        if table:
            w = power(tau[nb], params.alpha) * factors[cur]
            w = jnp.where(allowed, jnp.clip(jnp.where(jnp.isnan(w), 1e-30, w), 1e-30, 1e30), 0.0)
        else:
            w = step_weights(tau[nb], rows[cur], allowed, params)
        k = choose(w, step_uniforms(words, lanes, t), q0, exploit)
        fwd = live & has
        back = live & ~has & (sp > 0)  # 4.3: the dead-end cell stays tabu; return one cell
        nxt = cur + offsets[k]
        prev = stack[lanes, jnp.maximum(sp - 1, 0)]
        cur = jnp.where(fwd, nxt, jnp.where(back, prev, cur))
        sp = sp + fwd.astype(jnp.int32) - back.astype(jnp.int32)
        stack = stack.at[lanes, sp].set(cur, indices_are_sorted=True, unique_indices=True)
        moves = moves.at[lanes, jnp.where(fwd, sp, depth)].set(k, mode="drop", unique_indices=True)
        tabu = tabu.at[lanes, cur].set(True, indices_are_sorted=True, unique_indices=True)
        entered = jnp.where(fwd, cur, n_cells)
        n1 = jnp.zeros((n_cells,), jnp.int32).at[entered].add((k < 4).astype(jnp.int32), mode="drop")
        n2 = jnp.zeros((n_cells,), jnp.int32).at[entered].add((k >= 4).astype(jnp.int32), mode="drop")
        tau = local_update(tau, lo, hi, n1, n2, params)
        actions = actions + (fwd | back).astype(jnp.int32)
        # Back at the start with nothing left (~has, sp == 0): dead; at the goal: arrived.
        running = (fwd & (cur != goal)) | back
        return (tau, cur, sp, stack, moves, tabu, running, actions), None

    def chunk(state):
        t0, carry = state
        carry, _ = jax.lax.scan(step, carry, t0 + jnp.arange(CHUNK))  # not unrolled: compiles 2x faster, runs no slower
        return t0 + CHUNK, carry

    def more(state):
        t0, carry = state
        return (t0 < steplimit) & jnp.any(carry[6])

    stack = jnp.full((n_ants, depth), -1, jnp.int32).at[:, 0].set(start)
    tabu = jnp.zeros((n_ants, n_cells), bool).at[:, start].set(True)
    carry = (
        tau,
        jnp.full((n_ants,), start, jnp.int32),
        jnp.zeros((n_ants,), jnp.int32),
        stack,
        jnp.full((n_ants, depth), -1, jnp.int32),
        tabu,
        jnp.full((n_ants,), start != goal),
        jnp.zeros((n_ants,), jnp.int32),
    )
    _, (tau, cur, sp, stack, moves, tabu, _, actions) = jax.lax.while_loop(more, chunk, (jnp.int32(0), carry))
    arrived = cur == goal
    kept = jnp.arange(depth)[None, :] <= sp[:, None]
    stack = jnp.where(kept, stack, -1)
    moves = jnp.where(kept, moves, -1)
    return tau, stack, sp, arrived, actions, jnp.any(tabu, axis=0), infeasible_cells(stack, arrived, tabu), moves


class _Scalars(NamedTuple):
    alpha: jax.Array
    beta: jax.Array
    rho_local: jax.Array
    q: jax.Array


def stack_tours(walks: Backtracked) -> Tours:
    """Step-major :class:`~jaco.engine.walk.Tours` ``(steplimit, A)`` of the final stacks. Computed
    ant by ant, as the stacks are laid out, and transposed at the end: XLA:CPU sums the steps of a
    path 2x faster along a row than down a column (about 0.6 against 1.3 ms an iteration for 50
    ants on a 256x256 map)."""
    cells, moves = walks.stack[:, 1:], walks.moves[:, 1:]
    took = cells >= 0
    diag = took & (moves >= 4)
    straight = took & (moves >= 0) & (moves < 4)
    return Tours(
        cells=cells.T,
        moves=moves.T,
        step_len=jnp.where(diag, jnp.sqrt(jnp.float32(2)), jnp.where(straight, 1.0, 0.0)).astype(jnp.float32).T,
        arrived=walks.arrived,
        n_steps=walks.actions,
        # Integer counts, so a length is bit-identical however the runs are batched.
        length=jnp.sum(straight, axis=1) + jnp.sqrt(jnp.float32(2)) * jnp.sum(diag, axis=1),
        visited=walks.visited,
    )


def infeasible_cells(stack: jax.Array, arrived: jax.Array, tabu: jax.Array) -> jax.Array:
    """Cells ``(N,)`` for eq. (4-6): visited by a failed ant or popped by backtracking, and on no
    arrived ant's final path (``stack (A, D)``: the final paths, -1 padded; ``tabu (A, N)``: the
    cells each ant entered)."""
    n_ants, n_cells = tabu.shape
    kept = jnp.where(stack >= 0, stack, n_cells)
    on_path = jnp.zeros((n_ants, n_cells), bool).at[jnp.arange(n_ants)[:, None], kept].set(True, mode="drop")
    bad = jnp.any(tabu & (~on_path | ~arrived[:, None]), axis=0)
    good = jnp.any(on_path & arrived[:, None], axis=0)
    return bad & ~good


def backtrack_colony(
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
    """One iteration of IACA's backtracking ants (thesis 4.4, Steps 2–5): walks with the local
    update (4-2..4-4), then the infeasible-path update (4-6); returns the updated trail and the
    final stacks as a :class:`~jaco.engine.colony.Colony` (the rule's update follows). With IACA's
    heuristic (``per_step_heuristic``) a move weighs τ_j^α·η^β of eq. (4-5) over the ant's allowed moves;
    with another one, τ_j^α times the planner's ``factor`` (once per iteration, each cell's factors
    scaled to a top of 1). Pheromone on cells."""
    if planner.per_step_heuristic:
        factors = None
    else:
        factors = scaled(planner.factor(planner, trail, problem, params, t, n_iters), problem.nbr >= 0)
    return _backtrack(planner, problem, trail, params, key, factors, n_ants=n_ants, steplimit=steplimit)


def _backtrack(planner, problem, trail, params, key, factors, *, n_ants: int, steplimit: int):
    exploit = planner.transition == "pseudo-random"
    walks = backtrack_walk(
        problem, trail, params, key, n_ants=n_ants, steplimit=steplimit, exploit=exploit, factors=factors
    )
    tau = jnp.where(
        walks.infeasible, jnp.clip(infeasible_update(walks.tau, params), trail.lo, trail.hi), walks.tau
    )  # Eq. (4-6)
    tours = stack_tours(walks)
    cost = jnp.where(walks.arrived, planner.cost(tours, problem, params), jnp.inf)
    targets = step_targets("cells", tours.cells, tours.moves, problem.start, problem.nbr.shape[0])
    colony = Colony(tours.cells, targets, tours.step_len, cost, tours.length, tours.n_steps, tours.visited)
    return trail._replace(tau=tau), colony


component(
    "construct",
    "backtrack",
    construct=backtrack_colony,
    back_steps=True,  # back-steps count against the step limit: twice the default (jaco.engine.checks.default_steplimit)
    pheromone_on="cells",
    params=(RHO_LOCAL, Q1, Q2, Q3, RHO1, RHO2, Q_STEP),
    source="Hua Lu 2011 thesis 4.3, eqs. 4-2..4-4, 4-6",
)
component(
    "heuristic",
    "iaca",
    heuristic=iaca_heuristic,
    # backtracking ants see their tabu list: they recompute eq. (4-5) at every step over the
    # allowed moves (backtrack_colony), instead of weighing a fixed table
    per_step_heuristic=True,
    factor=eta_factor,
    params=(BETA.with_default(8.0),),
    source="thesis eq. 4-5",
)
component(
    "rule",
    "iaca",
    rule=ph.chain(iaca_init(), ph.evaporate(), ph.deposit_best_so_far(lambda p: p.sigma), ph.clamp()),
    pheromone_on="cells",
    default_transition="q0",
    params=(
        ALPHA.with_default(1.0),
        ph.RHO.with_default(0.05),
        ph.Q.with_default(0.1),
        ph.SIGMA.with_default(1000.0),
        ph.TAU_MIN.with_default(0.01),
        ph.TAU_MAX.with_default(20.0),
        K_INIT,
    ),
    source="Hua Lu 2011 thesis 4.2.3, 4.4",
)

IACA = compose(construct="backtrack", heuristic="iaca", rule="iaca").named(
    "iaca",
    source="Hua Lu 2011 thesis, chapter 4: eqs. 4-1..4-6, 4.2.2, 4.2.3, 4.3",
    doc="Hua Lu 2011, MSc thesis, chapter 4 (eqs. 4-1..4-6, sections 4.2.2, 4.2.3, 4.3, 4.4): improved "
    "ACO with backtracking ants. Pheromone on cells, initialised to K·(1 − d_jE/max d) (4.2.3) "
    "within [τmin, τmax]; heuristic (4-5) η_B = 1 − (d_AB + d_BE)/Σ_{C∈M_A}(d_AC + d_CE) over the "
    "allowed, non-tabu neighbours (η = 1 for a single one); ranked selection = argmax with "
    "probability q0, else roulette (4.2.2); local update τ_j ← (1−ρ_local)τ_j + Q/d_ij on every "
    "step of all ants (4-2..4-4), applied after each parallel step; ants at a dead end step back "
    "along their path (4.3), back-steps count toward the step limit and the path is the stack "
    "without dead branches; after the walks, the piecewise rule (4-6) on the cells of failed "
    "ants and of popped dead branches; then, MMAS-style, evaporation (1−ρ), a deposit σ·Q/L* on "
    "the best-so-far path and the clamp to [τmin, τmax]. Every interpretation: docs/planners.md (IACA).",
    alpha=1.0,
    beta=8.0,
    rho=0.05,
    q=0.1,
    sigma=1000.0,
    q0=0.9,
    tau_min=0.01,
    tau_max=20.0,
    k_init=10.0,
    rho_local=0.1,
    q1=1.0,
    q2=5.0,
    q3=15.0,
    rho1=0.7,
    rho2=0.2,
    q_step=0.5,
)

PLANNERS = (IACA,)
