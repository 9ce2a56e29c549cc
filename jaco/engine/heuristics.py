"""Heuristic information η for every move ``(N, 8)``, recomputed once per iteration.

A heuristic is a pure function ``(problem, params, t, n_iters) -> eta`` with ``eta > 0`` on
allowed moves (the engine masks the rest). ``t`` is the iteration (traced), so adaptive
heuristics of later planners are plain functions of it.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import jax.numpy as jnp

from ..moves import MOVES
from .problem import Problem

if TYPE_CHECKING:
    from .params import Params


def _targets_xy(problem: Problem):
    """Coordinates ``(N, 8, 2)`` of the cell each move leads to (own cell where not allowed): the
    cell's own plus the move's (row, column) change, which is what ``nbr`` holds, as arithmetic
    (XLA:CPU gathers ``xy[nbr]`` an element at a time: 40 µs of fixed cost in every solve)."""
    moved = problem.xy[:, None, :] + jnp.asarray(MOVES, jnp.float32)[None]
    return jnp.where((problem.nbr >= 0)[..., None], moved, problem.xy[:, None, :])


def goal_distance(problem: Problem) -> jnp.ndarray:
    """Euclidean distance ``(N, 8)`` from each move's target cell to the goal."""
    d = _targets_xy(problem) - problem.xy[problem.goal][None, None, :]
    # The two squares added as one elementwise operation, not summed over an axis of 2: XLA:CPU
    # gives such a sum to a separate reduction library, which took 0.1 ms of a 6 ms solve. The
    # coordinates are whole numbers, so every order of adding gives the same bits.
    return jnp.sqrt(d[..., 0] * d[..., 0] + d[..., 1] * d[..., 1])


def inverse_step(problem: Problem, params: Params, t: Any, n_iters: int) -> jnp.ndarray:
    """Classic η_ij = 1/d_ij (thesis eq. 2-1): only 1 or 1/√2 on a grid, i.e. no goal guidance."""
    return 1.0 / jnp.maximum(problem.step, 1.0)


def inverse_goal_distance(problem: Problem, params: Params, t: Any, n_iters: int) -> jnp.ndarray:
    """η_B = 1/L_B, L_B the Euclidean distance from candidate B to the goal (thesis eq. 3-7).

    L_B = 0 at the goal itself; it is floored at 0.5 so that the goal gets the largest finite η.
    """
    return 1.0 / jnp.maximum(goal_distance(problem), 0.5)
