"""What a path costs: a ``Planner.cost`` is ``(tours, problem, params) -> cost per ant``.

The default is the path length (thesis eq. 3-2). The multi-objective cost
J = kL·L + kS·S + kE·E of Miao et al. 2021 (its §3.4; ``docs/algorithms.md`` §5) weighs in the
safety cost S and the heading change E; IAACO uses it, and any planner can
(``jaco.planners.registry.with_cost("acs", "multi")``). S and E are computed by the same formulas as
:func:`jaco.metrics.safety_cost` and :func:`jaco.metrics.heading_change`, so a run's cost and the
metrics of its path never disagree.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import jax
import jax.numpy as jnp
import numpy as np

from .. import metrics
from ..moves import MOVES
from .params import INF, Param, declare

if TYPE_CHECKING:
    from .params import Params
    from .walk import Tours

__all__ = ["path_length", "TURN", "safety", "energy", "multi_objective", "COST_PARAMS", "MULTI_PARAMS"]


def path_length(tours: Tours, problem: Any, params: Params) -> jax.Array:
    """Cost = path length (thesis eq. 3-2); multi-objective costs replace this function."""
    return tours.length


def _turn_table() -> np.ndarray:
    """``TURN[a, b]``: heading change (radians) of move a followed by move b, by
    :func:`jaco.metrics.heading_change` itself, so the two can never disagree."""
    out = np.zeros((8, 8), np.float32)
    for a in range(8):
        for b in range(8):
            out[a, b] = metrics.heading_change([(0, 0), MOVES[a], MOVES[a] + MOVES[b]])
    return out


#: Heading change of every pair of consecutive moves ``(8, 8)``.
TURN = _turn_table()


def safety(tours: Tours, problem: Any, params: Params) -> jax.Array:
    """S per ant ``(A,)``: :func:`jaco.metrics.safety_terms` with radius ``rs_cost`` summed over
    the start and every cell entered (the same cells and formula as :func:`jaco.metrics.safety_cost`)."""
    took = tours.cells >= 0
    d = problem.clearance[jnp.where(took, tours.cells, 0)]
    terms = jnp.where(took, metrics.safety_terms(d, params.rs_cost, xp=jnp), 0.0)
    return jnp.sum(terms, axis=0) + metrics.safety_terms(problem.clearance[problem.start], params.rs_cost, xp=jnp)


def energy(tours: Tours, problem: Any, params: Params) -> jax.Array:
    """E per ant ``(A,)``: total absolute heading change in radians (:func:`jaco.metrics.heading_change`)."""
    prev, nxt = tours.moves[:-1], tours.moves[1:]
    both = (prev >= 0) & (nxt >= 0)
    turn = jnp.asarray(TURN)[jnp.where(both, prev, 0), jnp.where(both, nxt, 0)]
    return jnp.sum(jnp.where(both, turn, 0.0), axis=0)


def multi_objective(tours: Tours, problem: Any, params: Params) -> jax.Array:
    """J = kL·L + kS·S + kE·E (Miao et al. 2021, §3.4; ``docs/algorithms.md`` §5): L the path
    length (cells), S :func:`safety`, E :func:`energy`; a ``Planner.cost`` for any planner."""
    return (
        params.k_len * tours.length
        + params.k_safe * safety(tours, problem, params)
        + params.k_energy * energy(tours, problem, params)
    )


#: The multi-objective cost's weights and safety radius (Miao et al. 2021 §3.4).
MULTI_PARAMS = declare(
    Param(
        "k_len",
        0.7,
        0,
        INF,
        "multi-objective cost J = kL·L + kS·S + kE·E: weight kL of the length",
        lo_open=True,
        hi_open=True,
    ),
    Param("k_safe", 0.1, 0, INF, "multi-objective cost: weight kS of the safety cost S", hi_open=True),
    Param("k_energy", 0.2, 0, INF, "multi-objective cost: weight kE of the heading change E (radians)", hi_open=True),
    Param(
        "rs_cost",
        1.0,
        0,
        INF,
        "multi-objective cost: radius (cells) of S = Σ max(0, 2r − d_b)/(2r)",
        lo_open=True,
        hi_open=True,
    ),
)
COST_PARAMS = tuple(p.name for p in MULTI_PARAMS)
