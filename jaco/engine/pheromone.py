"""Pheromone rules as ``(init, update)`` pairs of pure functions, combined by :func:`chain`
(the third of the five concepts, in the manner of optax's gradient transformations).

The pheromone is a flat vector ``tau`` of ``M`` elements: one per cell (``M = N``, the thesis's
"node pheromone") or one per move (``M = 8N``, τ_ij of classic ACO). The engine turns every
ant's steps into element indices (``Walks.targets``), so no piece below needs to know which.
Padding steps point at index ``M`` and are dropped by the scatters.

A piece's ``init(trail, problem, params)`` and ``update(trail, walks, problem, params)`` both
return a new :class:`Trail`; ``chain`` threads the trail through its pieces in order. MMAS, for
example, is ``chain(init_mmas(), evaporate(), deposit_iteration_best(), mmas_bounds(), clamp())``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Callable, Mapping, NamedTuple, Protocol

import jax
import jax.numpy as jnp

from . import native
from .params import INF, Param, declare

if TYPE_CHECKING:
    from .params import Params

RHO, Q, TAU0, XI, SIGMA, W, P_BEST, TAU_MIN, TAU_MAX = declare(
    Param("rho", 0.1, 0, 1, "evaporation rate ρ: τ ← (1−ρ)τ + Δτ (thesis eq. 2-2)", lo_open=True),
    Param("q", 1.0, 0, INF, "deposit constant Q (thesis eqs. 2-4..2-6)", lo_open=True, hi_open=True),
    Param("tau0", 0.1, 0, INF, "initial pheromone τ0 (ACS: also the local-update target)", lo_open=True, hi_open=True),
    Param("xi", 0.1, 0, 1, "ACS local evaporation ξ: τ ← (1−ξ)τ + ξτ0 (thesis eq. 2-16)"),
    Param("sigma", 5.0, 0, 1000, "elitist weight σ (number of elite ants) on the best-so-far path (thesis eq. 2-13)"),
    Param("w", 6.0, 1, 1000, "rank-based AS: the w−1 best ants deposit, plus the best-so-far with weight w"),
    Param(
        "p_best",
        0.05,
        0,
        1,
        "MMAS: probability of building the best path at convergence (sets τmin)",
        lo_open=True,
        hi_open=True,
    ),
    Param("tau_min", 0.01, 0, INF, "lower pheromone bound τmin (fixed bounds)", hi_open=True),
    Param("tau_max", 20.0, 0, INF, "upper pheromone bound τmax (fixed bounds)", lo_open=True, hi_open=True),
    order=[("tau_min", "tau_max")],
)


class Trail(NamedTuple):
    """Pheromone ``tau (M,)``, its current bounds (``lo = 0``, ``hi = inf`` when unbounded) and
    the components' own state by slot (pg-aco's rule: its logits and optimiser state; apf-aco's
    heuristic: a potential-field table). The composition gives each stateful component its slot
    (:func:`jaco.planners.compose.slot`) and refuses two in one, so that components with state
    combine: each reads and writes only its own entry (:func:`own`, :func:`with_own`).

    ``steps``: the step buffers of the construct's last walks (``edges``, 8N where no step, as
    :func:`jaco.engine.walk.walk` takes them back), None before a run's loop sets them: the native
    walk writes over them in place rather than clearing every step slot each iteration."""

    tau: jax.Array
    lo: jax.Array
    hi: jax.Array
    state: Mapping[str, Any] = {}  # never mutated: with_own builds a new dict
    steps: Any = None


def own(trail: Trail, key: str) -> Any:
    """The state kept in the trail's slot ``key``."""
    return trail.state[key]


def with_own(trail: Trail, key: str, value: Any) -> Trail:
    """``trail`` with slot ``key`` set to ``value`` (the other slots kept)."""
    return trail._replace(state={**trail.state, key: value})


class Walks(NamedTuple):
    """What one iteration's colony did, step-major ``(S, A)``, plus the best-so-far path.

    ``targets[t, a]``: pheromone element of ant a's step t (``M`` where it took no step);
    ``step_len``: that step's length (0 where none); ``cost[a]``: the ant's cost (inf if it
    failed); ``best_*``: the best-so-far ant (including this iteration), ``best_cost`` inf
    while no ant has succeeded.
    """

    targets: jax.Array
    step_len: jax.Array
    cost: jax.Array
    best_targets: jax.Array
    best_step_len: jax.Array
    best_cost: jax.Array


class RuleInit(Protocol):
    """``init(trail, problem, params) -> trail``: once per run, inside the run."""

    def __call__(self, trail: Trail, problem: Any, params: Any) -> Trail: ...


class RuleUpdate(Protocol):
    """``update(trail, walks, problem, params) -> trail``: after every iteration's walks."""

    def __call__(self, trail: Trail, walks: Walks, problem: Any, params: Any) -> Trail: ...


class Rule(NamedTuple):
    """A pheromone rule or a piece of one: ``init`` and ``update`` (:class:`RuleInit`,
    :class:`RuleUpdate`); :func:`chain` combines pieces."""

    init: Callable
    update: Callable


def keep_init(trail: Trail, problem: Any, params: Any) -> Trail:
    """The ``init`` of a piece that only updates."""
    return trail


def keep_update(trail: Trail, walks: Walks, problem: Any, params: Any) -> Trail:
    """The ``update`` of a piece that only initialises."""
    return trail


_CHAINS: dict = {}


def chain(*rules: Rule) -> Rule:
    """Apply rules one after the other, at initialisation and at every update. The same pieces
    give the same rule object, so planners built from the same components are equal (and share
    their compiled programs)."""
    hit = _CHAINS.get(rules)
    if hit is not None:
        return hit

    def init(trail, problem, params):
        for r in rules:
            trail = r.init(trail, problem, params)
        return trail

    def update(trail, walks, problem, params):
        for r in rules:
            trail = r.update(trail, walks, problem, params)
        return trail

    return _CHAINS.setdefault(rules, Rule(init, update))


def inverse(cost: jax.Array) -> jax.Array:
    """1/cost for finite positive costs, 0 otherwise (failed ants and empty paths deposit nothing)."""
    ok = jnp.isfinite(cost) & (cost > 0)
    return jnp.where(ok, 1.0 / jnp.where(ok, cost, 1.0), 0.0)


def deposit(tau: jax.Array, targets: jax.Array, amounts: jax.Array | float) -> jax.Array:
    """``tau[targets] += amounts`` in the order of ``targets`` (row-major), targets outside
    ``[0, M)`` dropped (steps not taken); ``amounts`` is a scalar, one value per ant (the last
    axis of ``targets``) or one per target.

    ``targets`` is step-major, ``(S, A)`` or ``(S,)``: each column is one walk whose steps come
    first, then only targets out of range (as every walk records them). On CPU with the native
    walk, a kernel adds in XLA's order (the same bits) but stops at the end of each walk, so
    its cost is the steps taken, not ``S·A``."""
    amounts = jnp.asarray(amounts, jnp.float32)
    if amounts.ndim and amounts.shape != targets.shape:
        if amounts.shape != targets.shape[-1:]:
            raise ValueError(f"amounts {amounts.shape} fit neither targets {targets.shape} nor its last axis")

    def xla(tau, targets, amounts):
        return tau.at[targets.ravel()].add(jnp.broadcast_to(amounts, targets.shape).ravel(), mode="drop")

    return native.dispatch(native.deposit, xla, tau, targets, amounts)


def on_path(tau: jax.Array, targets: jax.Array) -> jax.Array:
    """Mask ``(M,)`` of the elements a path (``targets``, :attr:`Walks.targets`' column) uses."""
    return deposit(jnp.zeros(tau.shape, jnp.float32), targets, 1.0) > 0


def octile(problem: Any) -> jax.Array:
    """Octile distance start→goal: the obstacle-free lower bound of the path length."""
    d = jnp.abs(problem.xy[problem.start] - problem.xy[problem.goal])
    return jnp.max(d) + (jnp.sqrt(2.0) - 1.0) * jnp.min(d)


# -- initialisation ------------------------------------------------------------------------
def init_constant() -> Rule:
    """τ = τ0 everywhere, unbounded."""

    def init(trail, problem, params):
        return trail._replace(tau=jnp.full_like(trail.tau, params.tau0))

    return Rule(init, keep_update)


def init_mmas() -> Rule:
    """τ = τmax = Q/(ρ·L0) with L0 the octile start-goal distance (Stützle & Hoos 2000)."""

    def init(trail, problem, params):
        hi = params.q / (params.rho * jnp.maximum(octile(problem), 1.0))
        return trail._replace(tau=jnp.full_like(trail.tau, hi), lo=hi * 0.0, hi=hi)

    return Rule(init, keep_update)


# -- evaporation and deposits --------------------------------------------------------------
def evaporate() -> Rule:
    """τ ← (1−ρ)τ on every element (thesis eq. 2-2; ρ is the evaporation rate)."""

    def update(trail, walks, problem, params):
        return trail._replace(tau=(1.0 - params.rho) * trail.tau)

    return Rule(keep_init, update)


def deposit_all(amount: Callable) -> Rule:
    """Every successful ant deposits ``amount(walks, params) (S, A)`` on each element it used."""

    def update(trail, walks, problem, params):
        return trail._replace(tau=deposit(trail.tau, walks.targets, amount(walks, params)))

    return Rule(keep_init, update)


def ant_cycle(walks: Walks, params: Params) -> jax.Array:
    """Δτ^k = Q/L_k on every step of ant k (thesis eq. 2-6), one amount per ant."""
    return params.q * inverse(walks.cost)


def ant_density(walks: Walks, params: Params) -> jax.Array:
    """Δτ^k = Q on every step of a successful ant (thesis eq. 2-4), one amount per ant."""
    return jnp.where(jnp.isfinite(walks.cost), params.q, 0.0)


def ant_quantity(walks: Walks, params: Params) -> jax.Array:
    """Δτ^k = Q/d_ij on every step of a successful ant (thesis eqs. 2-5, 4-4)."""
    ok = jnp.isfinite(walks.cost)[None, :] & (walks.step_len > 0)
    return jnp.where(ok, params.q / jnp.where(ok, walks.step_len, 1.0), 0.0)


def deposit_best_so_far(weight: Callable = lambda params: 1.0) -> Rule:
    """The best-so-far ant deposits ``weight(params)·Q/L*`` (elitist AS: weight σ, eq. 2-11..2-13)."""

    def update(trail, walks, problem, params):
        amount = weight(params) * params.q * inverse(walks.best_cost)
        return trail._replace(tau=deposit(trail.tau, walks.best_targets, amount))

    return Rule(keep_init, update)


def deposit_iteration_best() -> Rule:
    """The iteration-best ant deposits Q/L_ib (MMAS, thesis eq. 2-17)."""

    def update(trail, walks, problem, params):
        b = jnp.argmin(walks.cost)
        return trail._replace(tau=deposit(trail.tau, walks.targets[:, b], params.q * inverse(walks.cost[b])))

    return Rule(keep_init, update)


def deposit_ranked() -> Rule:
    """Rank-based AS (Bullnheimer, Hartl & Strauss 1997): the r-th best of the w−1 best ants
    deposits (w−r)·Q/L_r; the best-so-far deposits w·Q/L*. ``w`` is a traced float."""

    def update(trail, walks, problem, params):
        rank = jnp.argsort(jnp.argsort(walks.cost)) + 1  # 1 = best; failed ants sort last
        per_ant = jnp.maximum(params.w - rank, 0.0) * params.q * inverse(walks.cost)
        tau = deposit(trail.tau, walks.targets, per_ant)
        tau = deposit(tau, walks.best_targets, params.w * params.q * inverse(walks.best_cost))
        return trail._replace(tau=tau)

    return Rule(keep_init, update)


# -- ACS -------------------------------------------------------------------------------------
def acs_local() -> Rule:
    """ACS local update τ ← (1−ξ)τ + ξτ0 on every step of every ant (thesis eq. 2-16).

    Ants walk in parallel here, so the updates of one iteration are applied together after the
    walks: an element used k times becomes τ0 + (1−ξ)^k (τ−τ0), exactly what k sequential
    updates give (each is a contraction toward τ0, so their order does not matter). What is
    lost is only that an ant does not see the local updates of ants of its own iteration.
    """

    def update(trail, walks, problem, params):
        k = deposit(jnp.zeros_like(trail.tau), walks.targets, 1.0)
        decay = jnp.exp(k * jnp.log1p(-params.xi))  # (1 − ξ)^k; pow costs 8x as much on CPU
        return trail._replace(tau=params.tau0 + decay * (trail.tau - params.tau0))

    return Rule(keep_init, update)


def acs_global() -> Rule:
    """ACS global update on the global-best path only: τ ← (1−ρ)τ + ρ·Q/L_gb (thesis eq. 2-15)."""

    def update(trail, walks, problem, params):
        on = on_path(trail.tau, walks.best_targets) & jnp.isfinite(walks.best_cost)
        new = (1.0 - params.rho) * trail.tau + params.rho * params.q * inverse(walks.best_cost)
        return trail._replace(tau=jnp.where(on, new, trail.tau))

    return Rule(keep_init, update)


# -- bounds ----------------------------------------------------------------------------------
def mmas_bounds() -> Rule:
    """MMAS bounds from the best-so-far cost (Stützle & Hoos 2000, eqs. 11 and 13):
    τmax = Q/(ρ·L_gb); τmin = τmax·(1 − p^(1/n)) / ((avg − 1)·p^(1/n)), n the number of steps
    of the best path and avg the mean number of choices per decision (half the mean degree)."""

    def update(trail, walks, problem, params):
        found = jnp.isfinite(walks.best_cost)
        hi = jnp.where(found, params.q * inverse(walks.best_cost) / params.rho, trail.hi)
        # n: the best path's pheromone elements in range (one a step), not its step lengths, whose
        # column each iteration would be derived from every step slot of the walk.
        n = jnp.maximum(jnp.sum(walks.best_targets < trail.tau.shape[-1]), 1)
        degree = jnp.sum(problem.nbr >= 0) / jnp.maximum(jnp.sum(jnp.any(problem.nbr >= 0, axis=1)), 1)
        avg = jnp.maximum(degree / 2.0, 1.5)
        root = jnp.power(params.p_best, 1.0 / n)
        lo = jnp.minimum(hi * (1.0 - root) / ((avg - 1.0) * root), hi)
        return trail._replace(lo=jnp.where(found, lo, trail.lo), hi=hi)

    return Rule(keep_init, update)


def clamp() -> Rule:
    """τ ← clip(τ, τmin, τmax)."""

    def update(trail, walks, problem, params):
        return trail._replace(tau=jnp.clip(trail.tau, trail.lo, trail.hi))

    return Rule(keep_init, update)
