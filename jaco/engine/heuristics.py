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


def target_coordinate(problem: Problem, axis: int) -> jnp.ndarray:
    """Row (axis 0) or column (axis 1) ``(N, 8)`` of the cell each move leads to (the cell's own
    where the move is not allowed): the cell's own plus the move's change, which is what ``nbr``
    holds, as arithmetic (XLA:CPU gathers ``xy[nbr]`` an element at a time: 40 µs of fixed cost in
    every solve)."""
    own = problem.xy[:, axis][:, None]
    return jnp.where(problem.nbr >= 0, own + jnp.asarray(MOVES, jnp.float32)[None, :, axis], own)


def goal_distance(problem: Problem) -> jnp.ndarray:
    """Euclidean distance ``(N, 8)`` from each move's target cell to the goal."""
    # Each axis its own (N, 8) array, the two squares added elementwise: XLA:CPU then computes the
    # distance (and the log of η after it) in vectors, where one (N, 8, 2) array, sliced, took an
    # element at a time (about 65 µs of a solve's fixed cost on the benchmark's 30x30 map, 22 µs
    # now), and no sum over an axis of 2 goes to a separate reduction library. The coordinates
    # are whole numbers, so every order of adding gives the same bits.
    goal = problem.xy[problem.goal]
    dr, dc = (target_coordinate(problem, axis) - goal[axis] for axis in (0, 1))
    return jnp.sqrt(dr * dr + dc * dc)


def inverse_step(problem: Problem, params: Params, t: Any, n_iters: int) -> jnp.ndarray:
    """Classic η_ij = 1/d_ij (thesis eq. 2-1): only 1 or 1/√2 on a grid, i.e. no goal guidance."""
    return 1.0 / jnp.maximum(problem.step, 1.0)


def inverse_goal_distance(problem: Problem, params: Params, t: Any, n_iters: int) -> jnp.ndarray:
    """η_B = 1/L_B, L_B the Euclidean distance from candidate B to the goal (thesis eq. 3-7).

    L_B = 0 at the goal itself; it is floored at 0.5 so that the goal gets the largest finite η.
    """
    return 1.0 / jnp.maximum(goal_distance(problem), 0.5)
