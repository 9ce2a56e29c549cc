"""Ant walks: one colony's tours for one iteration, all ants at once.

The walk is defined here in JAX (:func:`jax_walk`): every ant starts on the start cell with its
own tabu list; at each step it reads the precomputed move weights of its cell ``W[cur] (8,)``,
zeroes the moves into cells of its tabu list and picks one of the rest by roulette (or by ACS's
q0 rule); it stops on the goal, at a dead end (it dies) or at the step limit.

Random numbers are counter-based: the uniform of ant ``a`` at step ``s`` is a pure function of
the iteration's key, ``a`` and ``s`` (:func:`step_uniforms`: Threefry-2x32, the hash behind
``jax.random``, on the counter ``(a, s // 2)``, one 32-bit word per step). No table of uniforms
is drawn, and the same key gives the same walks however the ants are batched, split over
devices or walked.

On CPU the same walk runs as a C++ kernel (:mod:`jaco.engine.native`) inside the same jitted program
when the kernel was built at install time: same weights (computed here, in JAX), same uniforms,
the roulette's sums added in the same order, so the same moves bit for bit.
"""

from __future__ import annotations

import functools
from typing import Any, NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from ..errors import JacoError
from ..moves import MOVE_LENGTHS
from . import native

CHUNK = 8


class Tours(NamedTuple):
    """Step-major record ``(S, A)`` of one colony's walks.

    ``cells[t, a]``: the cell ant a entered at step t, or -1 when it took no step;
    ``moves[t, a]``: the move index (0..7) of that step, or -1; ``step_len`` its length;
    ``edges[t, a]``: ``from·8 + move`` of that step, ``8N`` where none (the pheromone element of
    the step when the pheromone is on moves), or None where the walk did not give them.
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
    edges: jax.Array | None = None


_ROTATIONS = ((13, 15, 26, 6), (17, 29, 16, 24))


def threefry2x32(k0: jax.Array, k1: jax.Array, x0: jax.Array, x1: jax.Array) -> tuple[jax.Array, jax.Array]:
    """Threefry-2x32 with 20 rounds (Salmon et al. 2011) of the counters ``(x0, x1)`` under the key
    ``(k0, k1)``, all uint32: the hash of ``jax.random``'s default keys (``threefry2x32_p``), the
    same bits. Unrolled, so XLA fuses it with what reads it; on CPU jax lowers its own as a loop of
    5 trips of several operations each, which made the JAX walk's every step a loop (the walk ran
    twice as long) and cost a loop per iteration for the key's words."""
    ks = (k0, k1, k0 ^ k1 ^ jnp.uint32(0x1BD11BDA))
    x0, x1 = x0 + ks[0], x1 + ks[1]
    for i in range(5):
        for r in _ROTATIONS[i % 2]:
            x0 = x0 + x1
            x1 = x0 ^ ((x1 << jnp.uint32(r)) | (x1 >> jnp.uint32(32 - r)))
        x0, x1 = x0 + ks[(i + 1) % 3], x1 + ks[(i + 2) % 3] + jnp.uint32(i + 1)
    return x0, x1


def key_words(key: jax.Array) -> jax.Array:
    """The two 32-bit words ``(2,) uint32`` the walk's uniforms are hashed with, from a key:
    ``jax.random.bits(key, (2,), uint32)``, computed by :func:`threefry2x32` where that is how
    jax computes it (its default keys, with ``jax_threefry_partitionable``, jax's default)."""
    typed = jnp.issubdtype(key.dtype, jax.dtypes.prng_key)
    partitionable = jax.config.jax_threefry_partitionable  # type: ignore[attr-defined]  # not in jax's stubs
    if not (typed and str(jax.random.key_impl(key)) == "threefry2x32" and partitionable):
        return jax.random.bits(key, (2,), jnp.uint32)
    k = jax.random.key_data(key)
    y0, y1 = threefry2x32(k[0], k[1], jnp.zeros(2, jnp.uint32), jnp.arange(2, dtype=jnp.uint32))
    return y0 ^ y1


def step_uniforms(words: jax.Array, ants: jax.Array, t: Any) -> jax.Array:
    """Uniforms on [0, 1) of ants ``ants`` at step ``t``: word ``t % 2`` of
    Threefry-2x32(``words``; ``ants``, ``t // 2``), its top 23 bits as the mantissa (as
    ``jax.random.uniform`` makes a float from bits)."""
    x0 = jnp.asarray(ants).astype(jnp.uint32)
    x1 = jnp.broadcast_to(jnp.asarray(t).astype(jnp.uint32) >> 1, x0.shape)
    k0, k1 = (jnp.broadcast_to(words[i], x0.shape) for i in range(2))
    y0, y1 = threefry2x32(k0, k1, x0, x1)
    bits = jnp.where((jnp.asarray(t) & 1) == 1, y1, y0)
    return jax.lax.bitcast_convert_type((bits >> 9) | jnp.uint32(0x3F800000), jnp.float32) - 1.0


def choose(w: jax.Array, u: jax.Array, q0: jax.Array | float, exploit: bool) -> jax.Array:
    """Pick a move index from weights ``w (A, 8)`` (zero = not allowed) with uniforms ``u (A,)``.

    Roulette wheel: the first index whose cumulative weight exceeds ``u·Σw`` (thesis 2-1); the
    target is kept strictly below Σw, so a move of weight 0 can never be picked, even when
    ``u·Σw`` rounds up. The cumulative sums are added left to right, as the native kernel adds
    them, so both pick the same move. With ``exploit`` (ACS's pseudo-random proportional rule,
    eq. 2-14) the ant takes the argmax when ``u < q0`` and otherwise spins the wheel with
    ``(u − q0)/(1 − q0)``, again uniform on [0, 1), so one uniform per step serves both draws.
    """
    sums = [w[:, 0]]
    for j in range(1, 8):
        sums.append(sums[-1] + w[:, j])
    c = jnp.stack(sums, axis=1)
    total = sums[-1]
    if exploit:
        greedy = u < q0
        u = jnp.where(greedy, 0.0, (u - q0) / jnp.maximum(1.0 - q0, 1e-12))
    x = jnp.minimum(u * total, jnp.nextafter(total, jnp.float32(0)))
    k = jnp.sum(c <= x[:, None], axis=-1)
    if exploit:
        k = jnp.where(greedy, jnp.argmax(w, axis=-1), k)
    return k


def walk(
    problem: Any,
    weights: jax.Array,
    key: jax.Array,
    q0: jax.Array | float,
    *,
    n_ants: int,
    steplimit: int,
    exploit: bool,
    previous: jax.Array | None = None,
) -> Tours:
    """Walk ``n_ants`` ants from ``problem.start`` with move weights ``weights (N, 8)``.

    ``weights`` must be 0 exactly on the moves the map forbids and > 0 elsewhere; ``key`` is the
    iteration's key. An ant stops on the goal, on a dead end (it dies: no allowed move), or at
    ``steplimit``. The native kernel walks when it is active (:func:`jaco.engine.native.active_walk`)
    and the program runs on CPU; the JAX walk everywhere else.

    ``previous``: the ``edges`` of this walk's last call (a run's loop keeps them in
    :attr:`Trail.steps <jaco.engine.pheromone.Trail>`), or None (:func:`jaco.engine.native.no_steps`). The native
    walk writes its steps over them in place, so no iteration clears all ``steplimit × n_ants``
    step slots; the JAX walk writes a new buffer. The moves are the same either way.
    """
    if previous is not None and jnp.shape(previous) != (steplimit, n_ants):
        raise JacoError(
            f"walk: previous must be the (steplimit, n_ants) = {(steplimit, n_ants)} edges of the last walk, "
            f"got shape {jnp.shape(previous)}"
        )
    q0 = jnp.asarray(q0, jnp.float32)
    args = (weights, key_words(key), problem.start, problem.goal, q0, problem.offsets, previous)
    kw: dict[str, Any] = dict(n_ants=n_ants, steplimit=steplimit, exploit=bool(exploit))
    return _tours(*native.dispatch(functools.partial(native.walk, **kw), functools.partial(jax_walk, **kw), *args))


def jax_walk(
    weights: jax.Array,
    words: jax.Array,
    start: Any,
    goal: Any,
    q0: jax.Array | float,
    offsets: Any,
    previous: jax.Array | None = None,
    *,
    n_ants: int,
    steplimit: int,
    exploit: bool,
) -> tuple[jax.Array, ...]:
    """The walk in JAX, every ant on its own lane until the last one stops (``previous`` is not
    read: the native walk's buffer to write over, :func:`walk`).

    Returns ``edges (steplimit, A)``, ``from·8 + move`` of every step (``8N`` where no step), and
    ``cells (steplimit, A)``, the cell entered (-1 where no step), ``n_steps (A,)``, ``n_diagonal (A,)`` (its diagonal steps), ``arrived (A,)``
    and ``visited (N,)``. Steps run in chunks of :data:`CHUNK` inside a while loop that ends when
    every ant has stopped."""
    s_pad = pad_steps(steplimit)
    n_cells = weights.shape[0]
    lanes = jnp.arange(n_ants)

    def step(carry, t):
        cur, visited, running, n_steps, n_diagonal = carry
        nb = jnp.clip(cur[:, None] + offsets[None, :], 0, n_cells - 1)  # off-map moves have weight 0
        w = jnp.where(visited[lanes[:, None], nb], 0.0, weights[cur])
        ok = running & jnp.any(w > 0, axis=-1) & (t < steplimit)
        k = choose(w, step_uniforms(words, lanes, t), q0, exploit)
        edge = jnp.where(ok, cur * 8 + k, 8 * n_cells)
        cur = jnp.where(ok, cur + offsets[k], cur)
        # XLA's CPU scatter is much faster when told the indices are sorted and unique.
        visited = visited.at[lanes, cur].set(True, indices_are_sorted=True, unique_indices=True)
        running = ok & (cur != goal)  # a dead-end ant or one at the step limit stops
        carry = (cur, visited, running, n_steps + ok, n_diagonal + (ok & (k >= 4)))
        return carry, (edge, jnp.where(ok, cur, -1))

    def chunk(state):
        t0, carry, edges, cells = state
        carry, (e, c) = jax.lax.scan(step, carry, t0 + jnp.arange(CHUNK), unroll=True)
        put = lambda buf, rows: jax.lax.dynamic_update_slice_in_dim(buf, rows, t0, axis=0)  # noqa: E731
        return t0 + CHUNK, carry, put(edges, e), put(cells, c)

    def more(state):
        return (state[0] < steplimit) & jnp.any(state[1][2])

    visited = jnp.zeros((n_ants, n_cells), bool).at[:, start].set(True)
    zero = jnp.zeros((n_ants,), jnp.int32)
    carry = (jnp.full((n_ants,), start, jnp.int32), visited, jnp.full((n_ants,), start != goal), zero, zero)
    edges = jnp.full((s_pad, n_ants), 8 * n_cells, jnp.int32)
    cells = jnp.full((s_pad, n_ants), -1, jnp.int32)
    _, (cur, visited, _, n_steps, n_diagonal), edges, cells = jax.lax.while_loop(
        more, chunk, (jnp.int32(0), carry, edges, cells)
    )
    return edges[:steplimit], cells[:steplimit], n_steps, n_diagonal, cur == goal, jnp.any(visited, axis=0)


def _tours(edges, cells, n_steps, n_diagonal, arrived, visited) -> Tours:
    """The walks as :class:`Tours`: the moves and step lengths from the edges (computed only
    where a planner uses them), the path lengths from the counts."""
    # A step was taken where its edge is in range (8N: none); not `cells >= 0`, which would bring
    # the native walk's derivation of the cells (8 selects a slot) into every reader of the moves.
    moves = jnp.where(edges < 8 * visited.shape[-1], edges & 7, -1)
    # Moves 0-3 are straight, 4-7 diagonal (jaco.moves.MOVES): two selects, not a gather per step.
    straight, diagonal = (np.float32(MOVE_LENGTHS[k]) for k in (0, 4))
    return Tours(
        cells=cells,
        moves=moves,
        step_len=jnp.where(moves >= 4, diagonal, jnp.where(moves >= 0, straight, np.float32(0))),
        arrived=arrived,
        n_steps=n_steps,
        # Integer counts, so a length is bit-identical however the runs are batched.
        length=(n_steps - n_diagonal) + jnp.sqrt(jnp.float32(2)) * n_diagonal,
        visited=visited,
        edges=edges,
    )


def pad_steps(steplimit: int) -> int:
    """The JAX walk's step buffer: ``steplimit`` rounded up to a whole number of chunks."""
    return -(-steplimit // CHUNK) * CHUNK
