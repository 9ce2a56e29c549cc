"""Policy-gradient ACO (``pg-aco``): log-pheromone as the logits of the ants' policy, stepped by an
optax optimiser from a REINFORCE estimate of the expected path cost.

Source: Meuleau & Dorigo, *Ant colony optimization and stochastic gradient descent*, Artificial
Life 8(2), 2002 (Ant System's update as stochastic gradient descent), taken literally, with
Williams's REINFORCE (1992) as the estimator. The rule's state in the trail (its slot, given by
the composition) carries the logits and the optimiser's state through the engine's loop; :func:`make_pg_aco` picks the optimiser.

Equations (1)-(4): docs/algorithms.md §8; choices, defaults: docs/planners.md, "Policy-gradient ACO".
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import jax
import jax.numpy as jnp
import optax

from ..engine import pheromone as ph
from ..engine.colony import move_weights, single_colony
from ..engine.params import INF, Param, declare
from ..engine.planner import Planner
from ..errors import JacoError
from .compose import component, compose, slot

if TYPE_CHECKING:
    from ..engine.planner import Construct

(PENALTY,) = declare(
    Param(
        "penalty",
        0.3,
        0,
        INF,
        "pg-aco: a failed ant costs (1 + penalty)·L̄, L̄ the mean cost of the iteration's successful ants",
        hi_open=True,
    ),
)

#: Bound on the logits |θ| (τ ∈ [e^−20, e^20]): a policy can still be all but deterministic.
LOGIT_MAX = 20.0


def first_visit(problem: Any, cells: jax.Array) -> jax.Array:
    """``(A, N)`` position at which each ant first stood on each cell: 0 for the start, ``t + 1``
    for the cell entered at step t, a large number for cells never visited. Tabu lists make
    every visit a first visit, so the scatter indices are unique."""
    s, a = cells.shape
    n = problem.nbr.shape[0]
    big = jnp.int32(2**30)
    time = jnp.full((a, n), big, jnp.int32).at[:, problem.start].set(0)
    lanes = jnp.broadcast_to(jnp.arange(a)[None, :], (s, a))
    when = jnp.broadcast_to(jnp.arange(1, s + 1, dtype=jnp.int32)[:, None], (s, a))
    return time.at[lanes.ravel(), jnp.where(cells >= 0, cells, n).ravel()].set(when.ravel(), mode="drop")


def step_probabilities(
    problem: Any, weights: jax.Array, cells: jax.Array, moves: jax.Array
) -> tuple[jax.Array, jax.Array]:
    """The policy (1) at every recorded step: ``(cur (S, A), p (S, A, 8))``.

    ``cur[t, a]`` is the cell ant a stood on at step t; ``p[t, a, j]`` the probability it gave move
    j there: the weights ``W[cur]`` over the moves the map allows whose target the ant had not yet
    visited, normalised (0 where no move was taken).
    """
    n = problem.nbr.shape[0]
    cur = jnp.concatenate([jnp.broadcast_to(problem.start, cells[:1].shape), cells[:-1]], axis=0)
    cur = jnp.where(moves >= 0, cur, 0)
    time = first_visit(problem, cells)
    nb = jnp.clip(cur[..., None] + problem.offsets[None, None, :], 0, n - 1)  # (S, A, 8); off-map moves have W = 0
    lane = jnp.arange(cells.shape[1])[None, :, None]
    t = jnp.arange(cells.shape[0])[:, None, None]
    w = jnp.where(time[lane, nb] > t, weights[cur], 0.0)
    total = jnp.sum(w, axis=-1, keepdims=True)
    p = jnp.where((moves >= 0)[..., None], w / jnp.where(total > 0, total, 1.0), 0.0)
    return cur, p


def score(problem: Any, weights: jax.Array, cells: jax.Array, moves: jax.Array, advantages: jax.Array) -> jax.Array:
    """``Σ_k advantages[k] · ∂ log p(path_k)/∂θ`` as a flat ``(8N,)`` vector, eq. (2).

    ``weights (N, 8)`` are the roulette weights the ants walked with (``exp(θ)·η^β``);
    ``cells``, ``moves`` ``(S, A)`` the recorded walks (:class:`jaco.engine.walk.Tours`).
    """
    n = problem.nbr.shape[0]
    cur, p = step_probabilities(problem, weights, cells, moves)
    used = jax.nn.one_hot(moves, 8, dtype=p.dtype)  # all zero where no move was taken
    contrib = (used - p) * advantages[None, :, None]
    idx = jnp.where((moves >= 0)[..., None], cur[..., None] * 8 + jnp.arange(8)[None, None, :], 8 * n)
    return jnp.zeros((8 * n,), p.dtype).at[idx.ravel()].add(contrib.ravel(), mode="drop")


def advantages(cost: jax.Array, penalty: Any, baseline: str = "all") -> jax.Array:
    """Advantages ``(C_k − b)/L̄`` of eq. (3). L̄ = mean cost of the iteration's successful ants;
    a failed ant costs ``(1 + penalty)·L̄``; the baseline b is the mean cost over all ants
    (``baseline="all"``) or L̄ (``"successful"``). All 0 when no ant (or only zero-cost ants)
    arrived."""
    ok = jnp.isfinite(cost)
    count = jnp.sum(ok)
    mean_ok = jnp.sum(jnp.where(ok, cost, 0.0)) / jnp.maximum(count, 1)
    informative = (count > 0) & (mean_ok > 0)
    scale = jnp.where(informative, mean_ok, 1.0)
    c = jnp.where(ok, cost, (1.0 + penalty) * mean_ok)
    b = jnp.mean(c) if baseline == "all" else mean_ok
    return jnp.where(informative, (c - b) / scale, 0.0)


def _unit(params):
    """α ≡ 1: log τ is the logit of the policy."""
    return params.replace(alpha=jnp.ones_like(jnp.asarray(params.beta)))


def make_pg_colony(optimizer: optax.GradientTransformation, baseline: str = "all", *, slot: str) -> Construct:
    """The construct step of a policy-gradient planner with this optax optimiser (lr 1) and
    baseline (see :func:`advantages`), its logits and optimiser state in the trail's ``slot``."""

    def pg_colony(planner, problem, trail, params, t, n_iters, key, *, n_ants: int, steplimit: int):
        """Walk one colony with policy (1), then one REINFORCE step (3)–(4) on the logits."""
        p1 = _unit(params)
        trail, colony = single_colony(planner, problem, trail, p1, t, n_iters, key, n_ants=n_ants, steplimit=steplimit)
        weights = move_weights(planner, trail, problem, p1, t, n_iters)
        n = problem.nbr.shape[0]
        took = colony.targets < 8 * n
        moves = jnp.where(took, colony.targets % 8, -1)
        adv = advantages(colony.cost, params.penalty, baseline)
        g = score(problem, weights, colony.cells, moves, adv) / colony.cost.shape[0]  # Eq. (3)
        theta, opt = ph.own(trail, slot)
        updates, opt = optimizer.update(g, opt, theta)
        theta = (1.0 - params.rho) * theta + params.q * updates  # Eq. (4)
        theta = jnp.clip(theta, -LOGIT_MAX, LOGIT_MAX)
        return ph.with_own(trail._replace(tau=jnp.exp(theta)), slot, (theta, opt)), colony

    return pg_colony


def pg_init(optimizer: optax.GradientTransformation, slot: str) -> ph.Rule:
    """θ = 0 (τ = 1, the policy is the heuristic alone), fixed bounds [e^−θmax, e^θmax], the
    optimiser's initial state; the logits and the optimiser's state are the trail's ``slot``. The
    update is a no-op: :func:`make_pg_colony` has applied it."""

    def init(trail, problem, params):
        theta = jnp.zeros_like(trail.tau)
        lo, hi = jnp.exp(jnp.float32(-LOGIT_MAX)), jnp.exp(jnp.float32(LOGIT_MAX))
        return ph.with_own(trail._replace(tau=jnp.exp(theta), lo=lo, hi=hi), slot, (theta, optimizer.init(theta)))

    return ph.Rule(init, ph.keep_update)


BASELINES = ("all", "successful")
PG_DEFAULTS = dict(beta=4.0, rho=0.03, q=0.2, penalty=0.3)
_DOC = (
    "Policy-gradient ACO (Meuleau & Dorigo 2002; eqs. (1)-(4), docs/algorithms.md §8): τ = exp(θ), the "
    "logits θ of the ants' policy p_ij ∝ exp(θ_ij)·η_ij^β over the allowed non-tabu moves "
    "(α ≡ 1); after each iteration one optax step (default adam, lr 1, scaled by Q) on the "
    "REINFORCE estimate (1/A)Σ_k ((C_k − b)/L̄)·∇ log p(path_k): L̄ = mean cost of the "
    "successful ants, a failed ant costs (1 + penalty)·L̄, baseline b = mean cost over all "
    "ants; then θ ← clip((1−ρ)θ + Q·u, ±20): ρ shrinks the logits toward the uniform policy. "
    "Heuristic η = 1/(distance of the candidate to the goal) (thesis eq. 3-7). Pheromone on "
    "moves (τ_ij)."
)


def _needs_dying_ants(chosen) -> str | None:
    if chosen["construct"] != "dying":
        return "rule 'pg' steps the logits of ants that die at dead ends: it needs construct 'dying'"
    if chosen["schedule"] != "constant":
        return "rule 'pg' learns with a fixed step: schedule must be 'constant'"
    return None


def _pg_parts(optimizer: optax.GradientTransformation, baseline: str = "all"):
    """The rule's parts that keep the logits and the optimiser's state in its slot."""
    return lambda slot: dict(rule=pg_init(optimizer, slot), construct=make_pg_colony(optimizer, baseline, slot=slot))


PG_RULE = component(
    "rule",
    "pg",
    state=_pg_parts(optax.adam(1.0)),
    pheromone_on="moves",
    fixes=("alpha",),
    params=(ph.RHO.with_default(0.03), ph.Q.with_default(0.2), PENALTY),
    why_not=_needs_dying_ants,
    source="Meuleau & Dorigo 2002 (Artificial Life 8(2)); REINFORCE, Williams 1992",
)


def make_pg_aco(
    optimizer: optax.GradientTransformation | None = None, *, baseline: str = "all", name: str = "pg-aco"
) -> Planner:
    """A policy-gradient ACO planner stepped by ``optimizer``: the composition
    ``compose(rule="pg")`` with this optimiser and baseline.

    ``optimizer`` is an optax ``GradientTransformation`` built with learning rate 1 (default
    ``optax.adam(1.0)``); the step size is the traced parameter ``q``. ``baseline`` is ``"all"``
    (mean cost over all ants, failed ones at their penalty cost; the default) or
    ``"successful"`` (mean cost of the successful ants). Build the planner once and keep it: the
    compiled-run cache is keyed by the planner.

    >>> import optax, jaco
    >>> sgd = make_pg_aco(optax.sgd(1.0), name="pg-aco-sgd")
    >>> grid = jaco.Grid.from_rows(["....", ".##.", "...."])
    >>> r = jaco.solve(grid, (0, 0), (2, 3), sgd, seed=0, n_ants=8, n_iters=5, q=1.0)
    >>> r.success, r.length == r.optimal == 5.0
    (True, True)
    """
    if optimizer is None and baseline == "all":
        base = compose(rule="pg")
    else:
        optimizer = optax.adam(1.0) if optimizer is None else optimizer
        if not (callable(getattr(optimizer, "init", None)) and callable(getattr(optimizer, "update", None))):
            raise JacoError(f"optimizer must be an optax GradientTransformation, got {type(optimizer).__name__}")
        if baseline not in BASELINES:
            raise JacoError(f"baseline must be one of {', '.join(BASELINES)}, got {baseline!r}")
        base = compose(rule="pg")._replace(**_pg_parts(optimizer, baseline)(slot(PG_RULE)))
    return base.named(
        name, source="Meuleau & Dorigo 2002 (Artificial Life 8(2)); REINFORCE, Williams 1992", doc=_DOC, **PG_DEFAULTS
    )


PG_ACO = make_pg_aco()
PLANNERS = (PG_ACO,)
