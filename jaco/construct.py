"""Ant walks: one colony's tours for one iteration, all ants at once.

The per-step work is what DESIGN.md's speed section asks for: gather one precomputed row of
move weights ``W[cur] (A, 8)``, mask the cells in the ant's tabu list, and pick one of 8 by
roulette (inverse CDF of a uniform drawn for the whole iteration in advance). Steps run in
chunks of :data:`CHUNK` inside a ``while_loop`` that stops as soon as no ant is still walking,
so finished ants cost at most one chunk of wasted steps.
"""

from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp

from .problem import MOVE_LENGTHS

CHUNK = 8


class Tours(NamedTuple):
    """Step-major record ``(S, A)`` of one colony's walks.

    ``cells[t, a]``: the cell ant a entered at step t, or -1 when it took no step;
    ``moves[t, a]``: the move index (0..7) of that step, or -1; ``step_len`` its length.
    ``arrived[a]``: reached the goal; ``n_steps[a]``: steps taken; ``length[a]``: path length.
    ``visited``: cells visited by any ant (coverage).
    """

    cells: jax.Array
    moves: jax.Array
    step_len: jax.Array
    arrived: jax.Array
    n_steps: jax.Array
    length: jax.Array
    visited: jax.Array


def choose(w, u, q0, exploit: bool):
    """Pick a move index from weights ``w (A, 8)`` (zero = not allowed) with uniforms ``u (A,)``.

    Roulette wheel: the first index whose cumulative weight exceeds ``u·Σw`` (thesis 2-1); the
    target is kept strictly below Σw, so a move of weight 0 can never be picked, even when
    ``u·Σw`` rounds up. With ``exploit`` (ACS's pseudo-random proportional rule, eq. 2-14) the
    ant takes the argmax when ``u < q0`` and otherwise spins the wheel with
    ``(u − q0)/(1 − q0)``, again uniform on [0, 1), so one uniform per step serves both draws.
    """
    c = jnp.cumsum(w, axis=-1)
    total = c[:, -1]
    if exploit:
        greedy = u < q0
        u = jnp.where(greedy, 0.0, (u - q0) / jnp.maximum(1.0 - q0, 1e-12))
    x = jnp.minimum(u * total, jnp.nextafter(total, jnp.float32(0)))
    k = jnp.sum(c <= x[:, None], axis=-1)
    if exploit:
        k = jnp.where(greedy, jnp.argmax(w, axis=-1), k)
    return k


def walk(problem, weights, u, q0, *, steplimit: int, exploit: bool) -> Tours:
    """Walk ``A = u.shape[1]`` ants from ``problem.start`` with move weights ``weights (N, 8)``.

    ``weights`` must be 0 exactly on the moves the map forbids and > 0 elsewhere. ``u`` is
    ``(S_pad, A)`` uniforms with ``S_pad`` a multiple of :data:`CHUNK` and ≥ ``steplimit``.
    An ant stops on the goal, on a dead end (it dies: no allowed move), or at ``steplimit``.
    """
    s_pad, n_ants = u.shape
    n_cells = weights.shape[0]
    lanes = jnp.arange(n_ants)
    offsets = problem.offsets
    lengths = jnp.asarray(MOVE_LENGTHS, jnp.float32)
    start, goal = problem.start, problem.goal

    def step(carry, xs):
        cur, visited, running = carry
        u_t, t = xs
        # Neighbours by index arithmetic; off-map moves have weight 0, so clipping is harmless.
        nb = jnp.clip(cur[:, None] + offsets[None, :], 0, n_cells - 1)
        w = jnp.where(visited[lanes[:, None], nb], 0.0, weights[cur])
        ok = running & (jnp.sum(w, axis=-1) > 0) & (t < steplimit)
        k = choose(w, u_t, q0, exploit)
        cur = jnp.where(ok, cur + offsets[k], cur)
        # XLA's CPU scatter is much faster when told the indices are sorted and unique.
        visited = visited.at[lanes, cur].set(True, indices_are_sorted=True, unique_indices=True)
        running = ok & (cur != goal)  # a dead-end ant or one at the step limit stops
        return (cur, visited, running), jnp.where(ok, k, -1).astype(jnp.int8)

    def chunk(state):
        t0, carry, moves = state
        xs = (jax.lax.dynamic_slice_in_dim(u, t0, CHUNK), t0 + jnp.arange(CHUNK))
        carry, m = jax.lax.scan(step, carry, xs, unroll=True)
        return t0 + CHUNK, carry, jax.lax.dynamic_update_slice_in_dim(moves, m, t0, axis=0)

    def more(state):
        t0, (_, _, running), _ = state
        return (t0 < steplimit) & jnp.any(running)

    visited = jnp.zeros((n_ants, n_cells), bool).at[:, start].set(True)
    carry = (jnp.full((n_ants,), start, jnp.int32), visited, jnp.full((n_ants,), start != goal))
    moves = jnp.full((s_pad, n_ants), -1, jnp.int8)
    _, (cur, visited, _), moves = jax.lax.while_loop(more, chunk, (jnp.int32(0), carry, moves))
    # Cells and step lengths follow from the moves, computed once per iteration, not per step.
    moves = moves.astype(jnp.int32)
    took = moves >= 0
    safe = jnp.where(took, moves, 0)
    cells = jnp.where(took, start + jnp.cumsum(jnp.where(took, offsets[safe], 0), axis=0), -1)
    step_len = jnp.where(took, lengths[safe], 0.0)
    return Tours(
        cells=cells,
        moves=jnp.where(took, moves, -1),
        step_len=step_len,
        arrived=cur == goal,
        n_steps=jnp.sum(took, axis=0),
        # Integer counts, so a length is bit-identical however the runs are batched.
        length=jnp.sum(took & (moves < 4), axis=0) + jnp.sqrt(jnp.float32(2)) * jnp.sum(moves >= 4, axis=0),
        visited=jnp.any(visited, axis=0),
    )


def pad_steps(steplimit: int) -> int:
    """Step buffer size: ``steplimit`` rounded up to a whole number of chunks."""
    return -(-steplimit // CHUNK) * CHUNK
