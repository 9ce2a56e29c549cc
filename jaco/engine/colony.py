"""One iteration's construction step: the candidate paths a colony offers to the pheromone rule.

A planner's ``construct`` is a pure function
``(planner, problem, trail, params, t, n_iters, key, *, n_ants, steplimit) -> (trail, Colony)``.
The default, :func:`single_colony`, walks one colony from start to goal; planners with two
colonies and path crossover, or with backtracking ants that update the pheromone while they walk,
provide their own. Everything after construction (best-so-far, pheromone rule, history) is shared.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, NamedTuple

import jax
import jax.numpy as jnp

from . import weights
from .native import entered_cells
from .params import Param, declare
from .walk import walk

if TYPE_CHECKING:
    from .params import Params
    from .pheromone import Trail

ALPHA, BETA, Q0 = declare(
    Param("alpha", 1.0, 0, 20, "pheromone exponent α of a move's weight τ^α·η^β (thesis eq. 2-1)"),
    Param("beta", 2.0, 0, 20, "heuristic exponent β of a move's weight τ^α·η^β (thesis eq. 2-1)"),
    Param("q0", 0.9, 0, 1, "exploitation probability q0 of the pseudo-random proportional rule (thesis eq. 2-14)"),
)


class Colony(NamedTuple):
    """Candidate paths of one iteration, step-major ``(S, C)`` for C candidates.

    ``cells[t, c]``: the cell candidate c entered at step t (-1 when none); ``targets``: the
    pheromone element of that step (``M``, dropped by scatters, when none); ``step_len``: its
    length; ``cost[c]``: the objective (inf for a failed candidate); ``length[c]``: path length;
    ``n_steps[c]``; ``visited (N,)``: cells visited by any ant (coverage).
    """

    cells: jax.Array
    targets: jax.Array
    step_len: jax.Array
    cost: jax.Array
    length: jax.Array
    n_steps: jax.Array
    visited: jax.Array


def eta_factor(planner: Any, trail: Trail, problem: Any, params: Params, t: Any, n_iters: int) -> jax.Array:
    """log(η^β) of every move ``(N, 8)``: the part of a move's weight besides the pheromone, for
    a planner whose ``heuristic`` is an η table (thesis eq. 2-1). Planners whose weights have
    more factors (angle guidance, selection shares, potential fields) provide their own."""
    valid = problem.nbr >= 0
    return params.beta * jnp.log(jnp.where(valid, planner.heuristic(problem, params, t, n_iters), 1.0))


def move_weights(planner: Any, trail: Trail, problem: Any, params: Params, t: Any, n_iters: int) -> jax.Array:
    """The roulette weights ``(N, 8)``: τ^α times the planner's factor (``planner.factor``, by
    default η^β), :func:`jaco.engine.weights.scaled` per cell (:func:`jaco.engine.weights.move_weights`).

    Computed in log space, α·log τ + log factor: XLA:CPU's ``pow`` costs eight times as much, and
    a factor that does not change between iterations is computed once per run (XLA hoists it
    out of the iteration loop). τ = 0 counts as the smallest normal float. On CPU with the native
    walk, a kernel computes the same weights bit for bit."""
    factor = planner.factor(planner, trail, problem, params, t, n_iters)
    return weights.move_weights(trail.tau, problem.nbr, params.alpha, factor, cells=planner.pheromone_on == "cells")


def step_targets(
    pheromone_on: str, cells: jax.Array, moves: jax.Array, start: Any, n_cells: int, edges: jax.Array | None = None
) -> jax.Array:
    """Pheromone element of every step: the entered cell (cells) or ``from·8 + move`` (moves);
    out of range (``N`` or ``8N``) where no step was taken. ``edges``, where the walk gave them,
    are the latter already (no pass over every step slot)."""
    if pheromone_on == "cells":
        return jnp.where(cells >= 0, cells, n_cells)
    if edges is not None:
        return edges
    prev = jnp.concatenate([jnp.broadcast_to(start, cells[:1].shape), cells[:-1]], axis=0)
    return jnp.where(moves >= 0, prev * 8 + moves, 8 * n_cells)


def step_cells(pheromone_on: str, targets: jax.Array, offsets: Any, n_cells: int) -> jax.Array:
    """The cells entered, from the steps' pheromone elements (the inverse of :func:`step_targets`):
    -1 where no step was taken."""
    if pheromone_on == "cells":
        return jnp.where(targets < n_cells, targets, -1)
    return entered_cells(targets, offsets, n_cells)


def single_colony(
    planner: Any,
    problem: Any,
    trail: Trail,
    params: Params,
    t: Any,
    n_iters: int,
    key: jax.Array,
    *,
    n_ants: int,
    steplimit: int,
) -> tuple[Trail, Colony]:
    """One colony walks start → goal with the random-proportional (or q0) rule; dead ants fail.
    Its steps are written over the last iteration's (``trail.steps``)."""
    weights = move_weights(planner, trail, problem, params, t, n_iters)
    exploit = planner.transition == "pseudo-random"
    # q0 is read only by the q0 rule (a roulette planner has no q0; the walk ignores the value then)
    q0 = params.q0 if exploit else 0.0
    tours = walk(problem, weights, key, q0, n_ants=n_ants, steplimit=steplimit, exploit=exploit, previous=trail.steps)
    return trail._replace(steps=tours.edges), colony_of(planner, problem, params, tours)


def colony_of(planner: Any, problem: Any, params: Params, tours: Any) -> Colony:
    """The :class:`Colony` of one colony's walks start → goal, with the planner's cost."""
    cost = jnp.where(tours.arrived, planner.cost(tours, problem, params), jnp.inf)
    targets = step_targets(
        planner.pheromone_on, tours.cells, tours.moves, problem.start, problem.nbr.shape[0], tours.edges
    )
    return Colony(tours.cells, targets, tours.step_len, cost, tours.length, tours.n_steps, tours.visited)
