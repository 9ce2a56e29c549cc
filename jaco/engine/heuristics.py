"""Heuristic information η for every move ``(N, 8)``, recomputed once per iteration.

A heuristic is a pure function ``(problem, params, t, n_iters) -> eta`` with ``eta > 0`` on
allowed moves (the engine masks the rest). ``t`` is the iteration (traced), so adaptive
heuristics of later planners are plain functions of it.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import jax.numpy as jnp

from .problem import Problem

if TYPE_CHECKING:
    from .params import Params


def _targets_xy(problem: Problem):
    """Coordinates ``(N, 8, 2)`` of the cell each move leads to (own cell where not allowed)."""
    safe = jnp.where(problem.nbr >= 0, problem.nbr, jnp.arange(problem.nbr.shape[0])[:, None])
    return problem.xy[safe]


def goal_distance(problem: Problem) -> jnp.ndarray:
    """Euclidean distance ``(N, 8)`` from each move's target cell to the goal."""
    d = _targets_xy(problem) - problem.xy[problem.goal][None, None, :]
    return jnp.sqrt(jnp.sum(d * d, axis=-1))


def inverse_step(problem: Problem, params: Params, t: Any, n_iters: int) -> jnp.ndarray:
    """Classic η_ij = 1/d_ij (thesis eq. 2-1): only 1 or 1/√2 on a grid, i.e. no goal guidance."""
    return 1.0 / jnp.maximum(problem.step, 1.0)


def inverse_goal_distance(problem: Problem, params: Params, t: Any, n_iters: int) -> jnp.ndarray:
    """η_B = 1/L_B, L_B the Euclidean distance from candidate B to the goal (thesis eq. 3-7).

    L_B = 0 at the goal itself; it is floored at 0.5 so that the goal gets the largest finite η.
    """
    return 1.0 / jnp.maximum(goal_distance(problem), 0.5)
