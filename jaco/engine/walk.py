"""Ant walks: one colony's tours for one iteration, all ants at once.

The per-step work is kept to the minimum: gather one precomputed row of move weights
``W[cur] (8,)`` per lane, mask the cells in the ant's tabu list, and pick one of 8 by roulette
(inverse CDF of a uniform drawn for the whole iteration in advance). Ants walk on a
pool of lanes in chunks of :data:`CHUNK` steps inside a ``while_loop``; between chunks a lane
whose ant stopped takes the next ant, of any colony or configuration of the batch, so lanes do
not idle until the batch's longest walk ends.
"""

from __future__ import annotations

import functools
from typing import NamedTuple

import jax
import jax.numpy as jnp

from ..moves import MOVE_LENGTHS

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
    ``(S_pad, A)`` uniforms with ``S_pad`` a multiple of :data:`CHUNK` and ≥ ``steplimit``; an
    ant's step s uses ``u[s, a]`` whatever lane walks it. An ant stops on the goal, on a dead end
    (it dies: no allowed move), or at ``steplimit``.

    Under ``vmap`` (colonies, configurations, seeds, problems) the batch axes are merged into one
    pool of ants walked together by :func:`_queue_walk` (a custom batching rule), so a sweep's
    lanes are refilled with the next ant of any configuration instead of idling until the longest
    walk of the batch ends.
    """
    core = _walk_core(steplimit, bool(exploit))
    q0 = jnp.broadcast_to(jnp.asarray(q0, jnp.float32), ())
    moves, visited = core(weights[None], u[None], problem.start[None], problem.goal[None], q0[None], problem.offsets)
    return _tours(moves[0], visited[0], problem.start, problem.goal, problem.offsets)


@functools.lru_cache(maxsize=None)
def _walk_core(steplimit: int, exploit: bool):
    """``core(weights (B,N,8), u (B,S,A), start (B,), goal (B,), q0 (B,), offsets (8,))`` ->
    ``(moves (B,S,A) int8, visited (B,N))``, with a vmap rule that folds the new batch axis into B."""

    @jax.custom_batching.custom_vmap
    def core(weights, u, start, goal, q0, offsets):
        if weights.shape[0] * u.shape[2] <= POOL:  # every ant has its own lane: no refills needed
            walk_one = functools.partial(_lockstep_walk, offsets=offsets, steplimit=steplimit, exploit=exploit)
            return jax.vmap(walk_one)(weights, u, start, goal, q0)
        return _queue_walk(weights, u, start, goal, q0, offsets, steplimit=steplimit, exploit=exploit)

    @core.def_vmap
    def rule(axis_size, in_batched, weights, u, start, goal, q0, offsets):
        if in_batched[5]:  # maps of one shape have the same offsets
            offsets = offsets[0]
        args = [x if b else jnp.broadcast_to(x, (axis_size,) + x.shape)
                for x, b in zip((weights, u, start, goal, q0), in_batched[:5])]
        B = args[0].shape[1]
        moves, visited = core(*(x.reshape((axis_size * B,) + x.shape[2:]) for x in args), offsets)
        out = (moves.reshape((axis_size, B) + moves.shape[1:]), visited.reshape((axis_size, B) + visited.shape[1:]))
        return out, (True, True)

    return core


#: Lanes of the pool. Up to this many ants in a batch, every ant walks on its own lane in lock-step
#: (:func:`_lockstep_walk`, cheaper per step); beyond, POOL lanes take the ants in turn
#: (:func:`_queue_walk`). Fewer lanes idle less, more lanes pay the fixed cost of a loop step less
#: often; 256 measured best on the benchmark sweep (BENCHMARKS.md, experiments/profile_iteration.py).
POOL = 256


def _lockstep_walk(weights, u, start, goal, q0, *, offsets, steplimit: int, exploit: bool):
    """One colony, every ant on its own lane until the last one stops: ``(moves (S, A) int8, visited (N,))``."""
    s_pad, n_ants = u.shape
    n_cells = weights.shape[0]
    lanes = jnp.arange(n_ants)

    def step(carry, xs):
        cur, visited, running = carry
        u_t, t = xs
        nb = jnp.clip(cur[:, None] + offsets[None, :], 0, n_cells - 1)  # off-map moves have weight 0
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
    _, (_, visited, _), moves = jax.lax.while_loop(more, chunk, (jnp.int32(0), carry, moves))
    return moves, jnp.any(visited, axis=0)


def _queue_walk(weights, u, start, goal, q0, offsets, *, steplimit: int, exploit: bool):
    """The pool walk of ``G = B·A`` ants (ant ``g`` belongs to colony ``g // A``) on ``L`` lanes.

    Every :data:`CHUNK` steps, lanes whose ant stopped take the next ants in order. Tabu lists are
    per-lane stamps (``stamp[lane, cell] == g + 1``), so a refill clears nothing. Moves are written
    lane-major, one row per loop step (``code = move``, 8 = no move, +16 on an ant's first row);
    afterwards each ant's moves are gathered back from its first row and lane.
    """
    B, N, _ = weights.shape
    s_pad, A = u.shape[1], u.shape[2]
    G = B * A
    L = POOL
    cap = (-(-G // L) + 1) * (-(-steplimit // CHUNK) + 1) * CHUNK  # ≥ the longest possible queue
    wflat = weights.reshape(B * N, 8)
    uflat = jnp.swapaxes(u, 1, 2).reshape(G * s_pad)
    lane = jnp.arange(L, dtype=jnp.int32)

    def step(carry, t):
        ant, alive, cell, s, base, ubase, g, q, stamp, seen, rec = carry
        nb = jnp.clip(cell[:, None] + offsets[None, :], 0, N - 1)  # off-map moves have weight 0
        w = jnp.where(stamp[lane[:, None], nb] == (ant + 1)[:, None], 0.0, wflat[base + cell])
        k = choose(w, uflat[ubase + jnp.minimum(s, s_pad - 1)], q, exploit)
        ok = alive & (jnp.sum(w, axis=-1) > 0)
        cell = jnp.where(ok, cell + offsets[k], cell)
        code = jnp.where(ok, k, 8) + jnp.where(alive & (s == 0), 16, 0)
        rec = jax.lax.dynamic_update_slice(rec, code.astype(jnp.int8)[None], (t, 0))
        s = s + ok
        alive = ok & (cell != g) & (s < steplimit)
        # XLA's CPU scatter is much faster when told the indices are sorted and unique.
        stamp = stamp.at[lane, cell].set(ant + 1, indices_are_sorted=True, unique_indices=True)
        seen = seen.at[base + cell].set(True)
        return (ant, alive, cell, s, base, ubase, g, q, stamp, seen, rec), None

    def chunk(state):
        t0, nxt, ant, alive, cell, s, base, ubase, g, q, stamp, seen, rec, first, lane_of = state
        free = ~alive
        ant = jnp.where(free, jnp.minimum(nxt + jnp.cumsum(free) - 1, G), ant)
        nxt = nxt + jnp.sum(free)
        fresh = free & (ant < G)
        b = jnp.minimum(ant // A, B - 1)
        cell = jnp.where(free, start[b], cell)
        s = jnp.where(free, 0, s)
        base, ubase, g, q = b * N, jnp.minimum(ant, G - 1) * s_pad, goal[b], q0[b]
        alive = alive | (fresh & (cell != g))  # an ant born on the goal has arrived
        idx = jnp.where(fresh, ant, G)
        first = first.at[idx].set(t0, mode="drop")
        lane_of = lane_of.at[idx].set(lane, mode="drop")
        stamp = stamp.at[lane, cell].set(ant + 1, indices_are_sorted=True, unique_indices=True)
        carry = (ant, alive, cell, s, base, ubase, g, q, stamp, seen, rec)
        carry, _ = jax.lax.scan(step, carry, t0 + jnp.arange(CHUNK), unroll=True)
        ant, alive, cell, s, base, ubase, g, q, stamp, seen, rec = carry
        return t0 + CHUNK, nxt, ant, alive, cell, s, base, ubase, g, q, stamp, seen, rec, first, lane_of

    def more(state):
        return (state[1] < G) | jnp.any(state[3])

    z = jnp.zeros(L, jnp.int32)
    seen = jnp.zeros(B * N, bool).at[jnp.arange(B) * N + start].set(True)
    state = (jnp.int32(0), jnp.int32(0), jnp.full(L, G, jnp.int32), jnp.zeros(L, bool), z, z, z, z, z,
             jnp.zeros(L, jnp.float32), jnp.zeros((L, N), jnp.int32), seen, jnp.full((cap, L), 8, jnp.int8),
             jnp.zeros(G + 1, jnp.int32), jnp.zeros(G + 1, jnp.int32))
    out = jax.lax.while_loop(more, chunk, state)
    seen, rec, first, lane_of = out[11], out[12], out[13], out[14]
    rows = jnp.minimum(first[:G][None, :] + jnp.arange(s_pad)[:, None], cap - 1)
    code = rec[rows, lane_of[:G][None, :]]  # (S_pad, G): ant g's rows from its first one
    moved = ((code & 15) < 8) & ((jnp.arange(s_pad)[:, None] == 0) | (code < 16))
    took = jnp.cumprod(moved, axis=0).astype(bool)  # up to its first non-move or the next ant
    moves = jnp.where(took, code & 15, -1).astype(jnp.int8)
    return jnp.moveaxis(moves.reshape(s_pad, B, A), 1, 0), seen.reshape(B, N)


def _tours(moves, visited, start, goal, offsets) -> Tours:
    """Cells, lengths and arrivals from the moves ``(S, A)``, once per iteration, not per step."""
    lengths = jnp.asarray(MOVE_LENGTHS, jnp.float32)
    moves = moves.astype(jnp.int32)
    took = moves >= 0
    safe = jnp.where(took, moves, 0)
    cells = jnp.where(took, start + jnp.cumsum(jnp.where(took, offsets[safe], 0), axis=0), -1)
    cur = start + jnp.sum(jnp.where(took, offsets[safe], 0), axis=0)
    return Tours(
        cells=cells,
        moves=jnp.where(took, moves, -1),
        step_len=jnp.where(took, lengths[safe], 0.0),
        arrived=cur == goal,
        n_steps=jnp.sum(took, axis=0),
        # Integer counts, so a length is bit-identical however the runs are batched.
        length=jnp.sum(took & (moves < 4), axis=0) + jnp.sqrt(jnp.float32(2)) * jnp.sum(moves >= 4, axis=0),
        visited=visited,
    )



def pad_steps(steplimit: int) -> int:
    """Step buffer size: ``steplimit`` rounded up to a whole number of chunks."""
    return -(-steplimit // CHUNK) * CHUNK
