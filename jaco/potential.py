"""The artificial potential fields of :mod:`jaco.apf` as per-cell tables, in JAX.

For every cell at once: the next cell of the improved APF (:func:`apf_next`, Dong & Zhao 2021,
3.1–3.2) and of the classic APF (:func:`classic_next`, attraction plus repulsion), and
the length r_jg of the walk from each cell to the goal (:func:`chain_lengths`,
:func:`apf_distance`, :func:`classic_distance`; the Euclidean distance where the walk loops or
is stuck). The tables are traced from the :class:`~jaco.engine.problem.Problem`'s arrays (no
static map size is needed, so one compiled run serves every map and start/goal pair of one shape).
They are the heuristic of the guided planners ``apf-aco`` and ``pf-aco``
(:mod:`jaco.planners.apf_guided`); :mod:`jaco.apf` holds the same improved APF as a planner of
its own, in numpy, with the interpretations of the paper both follow, and the tests compare the
two cell by cell.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any, NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from .engine.params import INF, Param, declare
from .moves import MOVES

if TYPE_CHECKING:
    from .engine.params import Params

__all__ = [
    "K_ATT",
    "K_REP",
    "D0",
    "MOVE_LEN",
    "apf_next",
    "jax_apf_next",
    "classic_next",
    "obstacle_distance",
    "chain_lengths",
    "apf_distance",
    "classic_distance",
]

#: Classic APF (PF-ACO baseline): attraction gain (fixed: only k_rep/k_att matters), default
#: repulsion gain and range (cells). The sources print none of them; see docs/planners.md.
K_ATT = 1.0
K_REP = 100.0
D0 = 3.0
#: The classic field's parameters (PF-ACO's, and the classic APF planner's).
K_REP_PARAM, D0_PARAM = declare(
    Param(
        "k_rep",
        K_REP,
        0,
        INF,
        "classic APF: repulsion gain k_rep, U_rep = ½k_rep(1/d − 1/d0)² (attraction ½ρ²)",
        hi_open=True,
    ),
    Param("d0", D0, 0, INF, "classic APF: range d0 (cells) of the repulsion", lo_open=True, hi_open=True),
)

_SQRT2 = np.float32(np.sqrt(2.0))
#: |e_k| of the eight moves, float32 (the local-move scores are computed alike in numpy and JAX).
MOVE_LEN = np.where(np.abs(MOVES).sum(axis=1) == 2, _SQRT2, np.float32(1.0)).astype(np.float32)


def _dims(problem):
    """Width and height (traced int32): move 0 is (−1, 0), so ``offsets[0] = −W``."""
    w = -problem.offsets[0]
    return w, problem.nbr.shape[0] // w


def _last_blocked_j(free, w, a, b):
    """The last effective obstacle (flat index, −1 if none) of the segment between cells
    ``a, b ((2,) int32)``: walk the closed supercover with an exact integer DDA (at a grid vertex
    the two side cells are touched too) and keep the blocked cell of largest (projection, index)."""
    dr, dc = b[0] - a[0], b[1] - a[1]
    sy, sx = jnp.sign(dr), jnp.sign(dc)
    adr, adc = jnp.abs(dr), jnp.abs(dc)

    def consider(best, r, c, ok):
        proj = (r - a[0]) * dr + (c - a[1]) * dc
        idx = r * w + c
        ok = ok & ~free[jnp.clip(idx, 0, free.shape[0] - 1)]
        better = ok & ((proj > best[0]) | ((proj == best[0]) & (idx > best[1])))
        return jnp.where(better, proj, best[0]), jnp.where(better, idx, best[1])

    def body(s):
        i, j, r, c, best = s
        lhs, rhs = (2 * i + 1) * adr, (2 * j + 1) * adc
        vx, vy = lhs <= rhs, lhs >= rhs  # both: through a vertex
        vertex = vx & vy
        best = consider(best, r, c + sx, vertex)
        best = consider(best, r + sy, c, vertex)
        r, c = r + jnp.where(vy, sy, 0), c + jnp.where(vx, sx, 0)
        best = consider(best, r, c, jnp.bool_(True))
        return i + vx, j + vy, r, c, best

    def more(s):
        return (s[0] < adc) | (s[1] < adr)

    init = (jnp.int32(0), jnp.int32(0), a[0], a[1], (jnp.int32(-(2**31) + 1), jnp.int32(-1)))
    *_, best = jax.lax.while_loop(more, body, init)
    return best[1]


def _dia_j(x, y):
    """:func:`jaco.apf._dia` in JAX (same float32 operations, so the same bits)."""
    f = y / (jnp.abs(x) + jnp.abs(y))
    return jnp.where(x >= 0, f, jnp.where(y >= 0, jnp.float32(2) - f, jnp.float32(-2) - f))


class _Map(NamedTuple):
    """What the improved APF needs of a map, computed once per problem (all traced)."""

    w: jax.Array
    h: jax.Array
    rc: jax.Array  # (N, 2) int32 (row, col)
    free: jax.Array  # (N,) bool
    lab: jax.Array  # (N,) obstacle component (smallest flat index in it), −1 on free cells
    edge: jax.Array  # (N,) the component's outline cells (blocked, a free or off-map 8-neighbour), by component
    edge_key: jax.Array  # (N,) their components, sorted (N past the outline)
    beside: jax.Array  # (8N,) free cells 8-adjacent to a component, by component (repeats allowed)
    beside_key: jax.Array  # (8N,) that component, sorted (N past the end)


def _sorted_by(key, values, n):
    """``values`` ordered by ``key`` (stable), and the sorted keys; ``key == n`` marks unused."""
    order = jnp.argsort(key, stable=True)
    return values[order], key[order]


def _map(problem) -> _Map:
    """Obstacle components (8-connected blocked cells) by min-label propagation with pointer
    jumping; each component's outline cells and the free cells beside it, sorted by component
    so that eq. (4) reads one component's cells, not the whole map."""
    w, h = _dims(problem)
    n = problem.nbr.shape[0]
    rc = problem.xy.astype(jnp.int32)
    free = problem.clearance > 0
    moves = jnp.asarray(MOVES)
    nr, nc = rc[:, None, 0] + moves[None, :, 0], rc[:, None, 1] + moves[None, :, 1]
    inb = (nr >= 0) & (nr < h) & (nc >= 0) & (nc < w)
    nb = jnp.where(inb, nr * w + nc, 0)
    link = inb & ~free[nb] & ~free[:, None]  # blocked cell next to a blocked cell
    idx = jnp.arange(n, dtype=jnp.int32)
    big = jnp.int32(n)

    def body(state):
        lab, _ = state
        new = jnp.minimum(lab, jnp.min(jnp.where(link, lab[nb], big), axis=1))
        new = jnp.where(new < big, jnp.minimum(new, new[jnp.minimum(new, n - 1)]), big)
        return new, jnp.any(new != lab)

    lab, _ = jax.lax.while_loop(lambda s: s[1], body, (jnp.where(free, big, idx), jnp.bool_(True)))
    lab = jnp.where(free, -1, lab)
    nb_lab = jnp.where(inb, lab[nb], -1)
    outline = ~free & jnp.any(~inb | free[nb], axis=1)
    edge, edge_key = _sorted_by(jnp.where(outline, lab, big), idx, n)
    pair = free[:, None] & (nb_lab >= 0)
    beside, beside_key = _sorted_by(jnp.where(pair, nb_lab, big).ravel(), jnp.repeat(idx, 8), n)
    return _Map(w, h, rc, free, lab, edge, edge_key, beside, beside_key)


_CORNERS_J = np.array([(-1, -1), (-1, 1), (1, -1), (1, 1)], np.int32)
#: Cells per step of eq. (4)'s loops over one component's cells.
_CHUNK = 64


def _frame(p, u, cells_rc):
    """Cell centres in the frame of the line p→t: ``x = u·v``, ``y = u×v`` with v the doubled
    offset from p of ``cells_rc (C, 2)`` (exact integers, held exactly in float32)."""
    v = 2 * (cells_rc - p[None, :])
    x = (v[..., 0] * u[0] + v[..., 1] * u[1]).astype(jnp.float32)
    y = (u[0] * v[..., 1] - u[1] * v[..., 0]).astype(jnp.float32)
    return x, y


def _corner_angles(p, u, cells_rc):
    """Pseudo-angles ``(C, 4)`` of the four corners of each cell's square seen from p."""
    x, y = _frame(p, u, cells_rc)
    cr = jnp.asarray(_CORNERS_J)
    dx = (cr[:, 0] * u[0] + cr[:, 1] * u[1]).astype(jnp.float32)
    dy = (u[0] * cr[:, 1] - u[1] * cr[:, 0]).astype(jnp.float32)
    return _dia_j(x[:, None] + dx[None, :], y[:, None] + dy[None, :])


def _chunks(keys, k, fold, init):
    """Fold ``fold(state, ids (C,), ok (C,))`` over the positions of key k in the sorted
    ``keys``, _CHUNK at a time."""
    lo = jnp.searchsorted(keys, k, side="left").astype(jnp.int32)
    hi = jnp.searchsorted(keys, k, side="right").astype(jnp.int32)
    step = jnp.arange(_CHUNK, dtype=jnp.int32)

    def body(s):
        j, state = s
        ids = j + step
        return j + _CHUNK, fold(state, jnp.minimum(ids, keys.shape[0] - 1), ids < hi)

    return jax.lax.while_loop(lambda s: s[0] < hi, body, (lo, init))[1]


def _span(m: _Map, p, u, k):
    """``(lo, hi)``: the least and greatest pseudo-angle of the corners of component k seen from
    p (relative to u), exactly as over all its cells, reading only its outline and the cells of
    it near the ray behind p.

    A corner whose four cells all lie in k is the centre of a 2×2 block of k's squares; p lies
    outside the block, so unless the block meets the ray from p away from t (where the
    pseudo-angle jumps from 2 to −2) some corner of the block lies strictly further round on
    either side, and the extremes are reached on the outline. Cells whose centres are within
    1.5 (max-norm) of that ray hold every corner of such a block; they are visited along the
    ray, at most H + W steps."""

    def fold(s, ids, ok):
        lo, hi = s
        ca = _corner_angles(p, u, m.rc[m.edge[ids]])
        return (
            jnp.minimum(lo, jnp.min(jnp.where(ok[:, None], ca, jnp.inf))),
            jnp.maximum(hi, jnp.max(jnp.where(ok[:, None], ca, -jnp.inf))),
        )

    lo, hi = _chunks(m.edge_key, k, fold, (jnp.float32(jnp.inf), jnp.float32(-jnp.inf)))

    # The band along the ray p − s·u (s ≥ 0): step along its major axis; at each step the cells
    # within 3 of the ray across it (max-norm 1.5 plus 1.5 of slope ≤ 1).
    d = -u
    swap = jnp.abs(d[0]) > jnp.abs(d[1])
    pm_, pn_ = jnp.where(swap, p[0], p[1]), jnp.where(swap, p[1], p[0])
    dm_, dn_ = jnp.where(swap, d[0], d[1]), jnp.where(swap, d[1], d[0])
    size = jnp.where(swap, m.h, m.w)
    sm = jnp.where(dm_ < 0, -1, 1)  # never 0: a masked-off walker (u = 0) must leave the map too
    across = jnp.arange(-3, 4, dtype=jnp.int32)

    def more(s):
        j = s[0]
        a = pm_ + sm * j
        return (j < 0) | ((a >= 0) & (a < size))

    def body(s):
        j, lo, hi = s
        a = pm_ + sm * j
        b = pn_ + jnp.floor_divide(jnp.maximum(j, 0) * dn_, jnp.maximum(jnp.abs(dm_), 1)) + across
        r, c = jnp.where(swap, a, b), jnp.where(swap, b, a)
        inside = (r >= 0) & (r < m.h) & (c >= 0) & (c < m.w)
        ok = inside & (m.lab[jnp.where(inside, r * m.w + c, 0)] == k)
        ca = _corner_angles(p, u, jnp.stack([r, c], axis=-1))
        lo = jnp.minimum(lo, jnp.min(jnp.where(ok[:, None], ca, jnp.inf)))
        hi = jnp.maximum(hi, jnp.max(jnp.where(ok[:, None], ca, -jnp.inf)))
        return j + 1, lo, hi

    _, lo, hi = jax.lax.while_loop(more, body, (jnp.int32(-2), lo, hi))
    return lo, hi


def _pick_j(m: _Map, pi, p, t, o):
    """Eq. (4) in JAX (see :meth:`jaco.apf._Ref.pick`): ``(cell (2,), found)``. Reads the cells
    of the obstacle's component only (:func:`_span`) and the free cells beside it."""
    k = m.lab[o]
    u = t - p
    lo, hi = _span(m, p, u, k)
    ti = t[0] * m.w + t[1]
    imax = jnp.iinfo(jnp.int32).max

    def fold(best, ids, ok):
        cells = m.beside[ids]
        x, y = _frame(p, u, m.rc[cells])
        phi = _dia_j(x, y)
        cand = ok & ((phi > hi) | (phi < lo)) & (cells != pi) & (cells != ti)
        dev = jnp.where(cand, jnp.abs(phi), jnp.inf)
        near = jnp.where(cand, jnp.sum((m.rc[cells] - p[None, :]) ** 2, axis=1), imax)
        # the least (dev, near, index), as the brute force's argmin over all cells
        key = (dev, near, jnp.where(cand, cells, imax))
        d0 = jnp.min(key[0])
        n0 = jnp.min(jnp.where(key[0] == d0, key[1], imax))
        i0 = jnp.min(jnp.where((key[0] == d0) & (key[1] == n0), key[2], imax))
        better = (d0 < best[0]) | ((d0 == best[0]) & ((n0 < best[1]) | ((n0 == best[1]) & (i0 < best[2]))))
        return tuple(jnp.where(better, new, old) for new, old in zip((d0, n0, i0), best))

    _, _, best = _chunks(m.beside_key, k, fold, (jnp.float32(jnp.inf), imax, imax))
    found = best < imax
    return m.rc[jnp.where(found, best, 0)], found


def _apf_next_cell(problem, m: _Map, i):
    """``next(i)`` of the improved APF (flat index, −1 when stuck; the goal maps to itself)."""
    p, g = m.rc[i], m.rc[problem.goal]
    maxlev = m.h + m.w
    live = m.free[i] & (i != problem.goal)

    def more(s):
        t, o, level, ok, _ = s
        return (o >= 0) & ok & (level < maxlev)

    def body(s):
        t, o, level, ok, (saved, power, lam) = s
        c, found = _pick_j(m, i, p, t, o)
        t = jnp.where(found, c, t)
        o = jnp.where(found, _last_blocked_j(m.free, m.w, p, t), o)
        # Brent's cycle detection: the chain is a function of T alone, so a repeated T repeats
        # forever; stop at once instead of running to the level bound.
        ok = found & ~jnp.all(t == saved)
        lam = lam + 1
        reset = lam == power
        saved = jnp.where(reset, t, saved)
        return t, o, level + 1, ok, (saved, jnp.where(reset, 2 * power, power), jnp.where(reset, 0, lam))

    o0 = jnp.where(live, _last_blocked_j(m.free, m.w, p, g), -1)
    brent = (g, jnp.int32(1), jnp.int32(0))
    t, o, _, ok, _ = jax.lax.while_loop(more, body, (g, o0, jnp.int32(0), jnp.bool_(True), brent))
    ok = ok & (o < 0)
    d = t - p
    allowed = problem.nbr[i] >= 0
    dot = (jnp.asarray(MOVES[:, 0]) * d[0] + jnp.asarray(MOVES[:, 1]) * d[1]).astype(jnp.float32)
    score = jnp.where(allowed, dot / jnp.asarray(MOVE_LEN), -jnp.inf)
    k = jnp.argmax(score)
    nxt = jnp.where(ok & jnp.any(allowed), problem.nbr[i, k], -1)
    return jnp.where(i == problem.goal, i, jnp.where(live, nxt, -1))


#: Walkers per vmapped batch of :func:`apf_next` (each holds a few ``(_CHUNK, 4)`` temporaries,
#: and a batch runs as many loop steps as its slowest walker needs).
_WALKERS = 256


def native_apf_next(free: jax.Array, nbr: jax.Array, goal: Any, offsets: Any) -> jax.Array:
    """The C++ kernel's table of the improved APF's next cells (``jaco_apf_next`` of
    ``jaco/potential.cc``, through :func:`jaco.engine.native.ffi_call`); same result as
    :func:`jax_apf_next` (``free (N,)``, ``nbr (N, 8)``, -1 where not allowed)."""
    from .engine import native

    call = native.ffi_call("jaco_apf_next", jax.ShapeDtypeStruct(free.shape, jnp.int32))
    return call(free, nbr, goal, offsets, jnp.asarray(MOVES, jnp.int32))


def apf_next(problem: Any) -> jax.Array:
    """``next (N,)`` of the improved APF for every cell: the cell it moves to, −1 where it is
    stuck or blocked, the goal at the goal. On CPU with the native walk active
    (:func:`jaco.engine.native.active_walk`) the C++ kernel computes it, the same integers as
    :func:`jax_apf_next` (which defines it) walker for walker, on the threads of XLA's pool."""
    from .engine import native

    return native.dispatch(
        native_apf_next,
        lambda *a: jax_apf_next(problem),
        problem.clearance > 0,
        problem.nbr,
        problem.goal,
        problem.offsets,
    )


def jax_apf_next(problem: Any) -> jax.Array:
    """:func:`apf_next` in JAX: one walker per free cell, vmapped in batches of free cells only
    (a batch runs as many loop steps as its slowest walker)."""
    m = _map(problem)
    n = problem.nbr.shape[0]
    batch = min(n, _WALKERS)
    order = jnp.argsort(~m.free, stable=True).astype(jnp.int32)  # the free cells first
    n_free = jnp.sum(m.free, dtype=jnp.int32)
    lanes = jnp.arange(batch, dtype=jnp.int32)

    def one_batch(b, out):
        ids = b * batch + lanes
        cells = order[jnp.minimum(ids, n - 1)]
        nxt = jax.vmap(lambda i: _apf_next_cell(problem, m, i))(cells)
        return out.at[jnp.where(ids < n_free, cells, n)].set(nxt, mode="drop")

    return jax.lax.fori_loop(0, (n_free + batch - 1) // batch, one_batch, jnp.full((n,), -1, jnp.int32))


def obstacle_distance(problem: Any) -> jax.Array:
    """Distance ``(N,)`` from each cell centre to the nearest blocked cell centre, the map's
    outside **not** counting (inf on a map without obstacles; ``problem.clearance`` counts the
    outside, which would make every goal on the border a local maximum of the repulsion).

    An exact Euclidean distance transform in two separable passes:
    the distance ``g`` to the nearest blocked cell of the same column (prefix max/min of blocked
    rows by pointer doubling, ⌈log2 N⌉ rounds), then ``d² = min_δ g(col + δ)² + δ²`` along the
    row, for δ = 0, 1, … only while δ² is below the largest d² found so far. O(N · (log N + the
    largest distance)) instead of every cell against every blocked cell; the squared distances
    are the same integers, so the result is the brute force's bit for bit."""
    blocked = problem.clearance <= 0
    w, h = _dims(problem)
    n = problem.nbr.shape[0]
    rc = problem.xy.astype(jnp.int32)
    row, col = rc[:, 0], rc[:, 1]
    idx = jnp.arange(n, dtype=jnp.int32)
    big = jnp.int32(2**30)
    up = jnp.where(blocked, row, -big)  # row of the nearest blocked cell at or above, same column
    down = jnp.where(blocked, row, big)  # ... at or below
    for k in range(max(1, math.ceil(math.log2(max(n, 2))))):
        shift = jnp.minimum(jnp.int32(2**k), h) * w  # never overflows: at most N
        above, below = idx - shift, idx + shift
        up = jnp.maximum(up, jnp.where(above >= 0, up[jnp.maximum(above, 0)], -big))
        down = jnp.minimum(down, jnp.where(below < n, down[jnp.minimum(below, n - 1)], big))
    g = jnp.minimum(row - up, down - row)
    g2 = jnp.where(g < big // 2, g.astype(jnp.float32) ** 2, jnp.inf)

    def more(s):
        d, best = s
        dd = (d * d).astype(jnp.float32)
        return (d < w) & jnp.any(blocked) & (jnp.any(jnp.isinf(best)) | (dd < jnp.max(best)))

    def body(s):
        d, best = s
        dd = (d * d).astype(jnp.float32)
        left = jnp.where(col - d >= 0, g2[jnp.maximum(idx - d, 0)], jnp.inf)
        right = jnp.where(col + d < w, g2[jnp.minimum(idx + d, n - 1)], jnp.inf)
        return d + 1, jnp.minimum(best, jnp.minimum(left, right) + dd)

    _, d2 = jax.lax.while_loop(more, body, (jnp.int32(0), jnp.full((n,), jnp.inf, jnp.float32)))
    return jnp.sqrt(d2)


def classic_next(problem: Any, k_rep: jax.Array | float, d0: jax.Array | float, k_att: float = K_ATT) -> jax.Array:
    """``next (N,)`` of the classic APF: the allowed neighbour of lowest
    ``U = ½k_att·ρ_g² + ½k_rep(1/d − 1/d0)²·[d ≤ d0]`` if lower than U here, else −1 (a local
    minimum); the goal maps to itself. ``d`` = :func:`obstacle_distance` (ρ_g and d Euclidean,
    in cells)."""
    free = problem.clearance > 0
    diff = problem.xy - problem.xy[problem.goal][None, :]
    d = jnp.maximum(obstacle_distance(problem), 1e-6)
    rep = jnp.where(d <= d0, 0.5 * k_rep * (1.0 / d - 1.0 / d0) ** 2, 0.0)
    u = jnp.where(free, 0.5 * k_att * jnp.sum(diff * diff, axis=1) + rep, jnp.inf)
    valid = problem.nbr >= 0
    un = jnp.where(valid, u[jnp.where(valid, problem.nbr, 0)], jnp.inf)
    k = jnp.argmin(un, axis=1)
    best = jnp.take_along_axis(un, k[:, None], axis=1)[:, 0]
    nxt = jnp.where(best < u, jnp.take_along_axis(problem.nbr, k[:, None], axis=1)[:, 0], -1)
    cells = jnp.arange(problem.nbr.shape[0], dtype=jnp.int32)
    return jnp.where(cells == problem.goal, cells, jnp.where(free, nxt, -1))


def chain_lengths(problem: Any, nxt: jax.Array) -> tuple[jax.Array, jax.Array]:
    """Length of the walk ``j, next(j), next(next(j)), …`` to the goal for every cell j, by
    pointer doubling (⌈log2 N⌉ rounds of every walker jumping 2^k steps at once): ``(r (N,),
    reached (N,))``; r is ``n_straight + √2·n_diagonal`` where the walk reaches the goal and the
    Euclidean distance to the goal elsewhere (loops, stuck walkers, blocked cells)."""
    n = problem.nbr.shape[0]
    cells = jnp.arange(n, dtype=jnp.int32)
    ok = (nxt >= 0) & (cells != problem.goal)
    jump = jnp.where(ok, nxt, cells)
    rc = problem.xy.astype(jnp.int32)
    diag = jnp.all(jnp.abs(rc[jump] - rc) == 1, axis=1)
    n1 = (ok & ~diag).astype(jnp.int32)
    n2 = (ok & diag).astype(jnp.int32)
    for _ in range(max(1, math.ceil(math.log2(max(n, 2))))):
        n1, n2, jump = n1 + n1[jump], n2 + n2[jump], jump[jump]
    reached = jump == problem.goal
    euclid = jnp.sqrt(jnp.sum((problem.xy - problem.xy[problem.goal][None, :]) ** 2, axis=1))
    r = n1.astype(jnp.float32) + jnp.float32(_SQRT2) * n2.astype(jnp.float32)
    return jnp.where(reached, r, euclid), reached


def apf_distance(problem: Any, params: Params | None = None) -> jax.Array:
    """r_jg (N,) of the improved APF (Dong & Zhao 2021, 3.1–3.2), Euclidean where it fails."""
    return chain_lengths(problem, apf_next(problem))[0]


def classic_distance(problem: Any, params: Params) -> jax.Array:
    """r_jg (N,) of the classic APF with ``params.k_rep``, ``params.d0`` (PF-ACO, ref. 10),
    Euclidean where it ends in a local minimum."""
    return chain_lengths(problem, classic_next(problem, params.k_rep, params.d0))[0]
