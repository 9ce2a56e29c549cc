"""Local search: the ants' paths shortened before the pheromone update (ACO's "daemon actions").

The ACO literature applies a local search to the ants' solutions inside the loop, so that the
colony learns from the improved solutions: MMAS and ACS with 2-opt/3-opt on the TSP (Stützle &
Hoos 2000; Dorigo & Gambardella 1997), the "daemon actions" of Dorigo & Stützle 2004. Here a
planner's ``local_search`` (:class:`~jaco.engine.planner.Planner`) is a function
``(planner, problem, colony, params) -> colony`` that the run (:mod:`jaco.engine.run`) calls
after the construct step of every iteration: what it returns is what the pheromone rule deposits
and what the best-so-far is chosen from. ``None`` (every published planner) calls nothing.

:func:`shortcut_search` builds the one of the compose vocabulary (``local_search="shortcut"``).
The **octile shortcut** uses nothing but the map's allowed moves and the ant's own path (no
distance from an exact search). One pass walks along the path ``p_0 = start, ..., p_n = goal``:
standing on ``p_i`` it looks for the farthest later cell ``p_j``, ``j ≤ i + window``, that a
*segment* reaches through allowed moves (free cells, no corner cutting) and that is shorter than
the stretch ``p_i .. p_j`` it replaces, writes the segment instead of the stretch and stands on
``p_j`` next; where no later cell qualifies it keeps the path's own step to ``p_{i+1}``. A segment
is a shortest path of the move model in free space: a run of diagonal moves and a run of straight
moves (``m = min(|Δr|, |Δc|)`` and ``max − m`` steps), diagonal run first when it is free, else
straight run first; on a map without diagonal moves (4-connectivity) one straight run per axis,
the rows first when free. Because a segment is a shortest path in free space, it is shorter than
a stretch exactly when the stretch's numbers of straight and diagonal steps differ from the
segment's: the test is on integers, so the JAX definition and the native kernel agree bit for
bit. Passes repeat until one changes nothing, at most ``passes`` times. A path is therefore
never lengthened, keeps the move model, and never has more cells than before (a segment has
``max(|Δr|, |Δc|)`` steps, the stretch at least as many), so it fits the same buffer.

A shortcut may, rarely, cross the path again more than a window away: the shortened path then
passes a cell twice. It is still a valid, strictly shorter path, and the next pass removes such
a loop when it fits in a window (a segment of zero steps replaces it).

On CPU with the native walk active the passes run in the kernel ``JacoShortcut``
(``jaco/engine/local_search.cc``, :func:`jaco.engine.native.shortcut`); the JAX code here is the
definition, used everywhere else.
"""

from __future__ import annotations

import functools
from typing import TYPE_CHECKING, Any, Protocol, cast

import jax
import jax.numpy as jnp
import numpy as np

from ..moves import MOVES
from . import native
from .colony import Colony, step_targets
from .walk import Tours

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

    from ..grid import Grid


class ShortcutSearch(Protocol):
    """What :func:`shortcut_search` returns: a ``Planner.local_search`` that also carries its
    static choices as attributes, for whoever inspects a planner."""

    window: int
    passes: int
    best: int | None

    def __call__(self, planner: Any, problem: Any, colony: Colony, params: Any) -> Colony: ...


#: ``MOVE_OF[(dr + 1)·3 + (dc + 1)]``: the index of the move (dr, dc) in :data:`jaco.moves.MOVES`, -1 for (0, 0).
MOVE_OF = np.full(9, -1, np.int32)
for _k, (_dr, _dc) in enumerate(MOVES):
    MOVE_OF[(_dr + 1) * 3 + (_dc + 1)] = _k

#: The static choices of the compose vocabulary's ``shortcut`` (docs/compose.md, "Local search", says why):
#: path cells looked ahead, passes at most, and how many of each iteration's best paths are searched.
WINDOW = 64
PASSES = 4
BEST = 5

#: Candidates the JAX definition tests at once (a chunk, farthest first); the kernel tests them
#: one by one. Only the speed of the JAX code depends on it.
CHUNK = 16


def allowed_bits(nbr: jax.Array) -> jax.Array:
    """``(N,) uint8``: bit k of cell i set when the map allows move k from i (``nbr[i, k] ≥ 0``)."""
    bits = jnp.zeros(nbr.shape[:-1], jnp.uint8)
    for k in range(8):
        bits = bits | ((nbr[..., k] >= 0).astype(jnp.uint8) << k)
    return bits


def shortcut(
    cells: ArrayLike, start: Any, bits: ArrayLike, offsets: ArrayLike, diagonal: Any, *, window: int, passes: int
) -> jax.Array:
    """The octile shortcut (module docstring) of every column of ``cells (S, C)``: each a path
    from ``start`` (the cells entered, -1 after the goal). ``bits (N,)``: :func:`allowed_bits`;
    ``offsets (8,)``: the flat-index change of each move; ``diagonal``: whether the map allows
    any diagonal move. Returns the shortened paths ``(S, C)``, -1 padded. The native kernel runs
    it where it is active and the program runs on CPU, this module's JAX code everywhere else."""
    args = (
        jnp.asarray(cells, jnp.int32),
        jnp.asarray(bits, jnp.uint8),
        jnp.asarray(start, jnp.int32),
        jnp.asarray(offsets, jnp.int32),
        jnp.asarray(diagonal, bool),
        jnp.asarray(MOVE_OF),
    )
    kw: dict[str, Any] = dict(window=int(window), passes=int(passes))
    return native.dispatch(functools.partial(native.shortcut, **kw), functools.partial(jax_shortcut, **kw), *args)


def jax_shortcut(
    cells: jax.Array,
    bits: jax.Array,
    start: Any,
    offsets: Any,
    diagonal: Any,
    move_of: Any,
    *,
    window: int,
    passes: int,
) -> jax.Array:
    """:func:`shortcut` in JAX: the definition. Columns are independent (vmapped)."""
    one = functools.partial(
        _shortcut_path,
        bits=bits,
        start=start,
        offsets=offsets,
        diagonal=diagonal,
        move_of=move_of,
        window=window,
        passes=passes,
    )
    return jax.vmap(one, in_axes=1, out_axes=1)(cells)


def _shortcut_path(path, *, bits, start, offsets, diagonal, move_of, window, passes):
    """Passes of the shortcut over one path ``(S,)`` until one changes nothing (at most ``passes``)."""

    def more(state):
        p, _, changed = state
        return (p < passes) & changed

    def again(state):
        p, path, _ = state
        path, changed = _one_pass(path, bits, start, offsets, diagonal, move_of, window)
        return p + 1, path, changed

    _, path, _ = jax.lax.while_loop(more, again, (jnp.int32(0), path, jnp.bool_(True)))
    return path


def _segment(ra, ca, rb, cb, diagonal, move_of):
    """The two runs of the segment from (ra, ca) to (rb, cb): moves ``k1, k2``, lengths ``n1, n2``
    (form 0 walks run 1 first, form 1 run 2 first) and its numbers of straight and diagonal steps.
    Octile: a diagonal run of ``m = min(|Δr|, |Δc|)`` steps and a straight run of ``max − m`` along
    the longer axis; without diagonal moves: a run along the rows and one along the columns."""
    dr, dc = rb - ra, cb - ca
    sr, sc = jnp.sign(dr), jnp.sign(dc)
    adr, adc = jnp.abs(dr), jnp.abs(dc)
    m, big = jnp.minimum(adr, adc), jnp.maximum(adr, adc)
    along_rows = move_of[(sr + 1) * 3 + 1]
    along_cols = move_of[4 + sc]
    k1 = jnp.where(diagonal, move_of[(sr + 1) * 3 + (sc + 1)], along_rows)
    n1 = jnp.where(diagonal, m, adr)
    k2 = jnp.where(diagonal, jnp.where(adr > adc, along_rows, along_cols), along_cols)
    n2 = jnp.where(diagonal, big - m, adc)
    straight = jnp.where(diagonal, big - m, adr + adc)
    diag = jnp.where(diagonal, m, 0)
    return jnp.maximum(k1, 0), n1, jnp.maximum(k2, 0), n2, straight, diag


def _walk_segment(a, k1, n1, k2, n2, offsets, t):
    """Cell after ``t`` steps of the segment from ``a`` that walks ``n1`` steps of move ``k1``, then ``n2`` of ``k2``."""
    return a + jnp.minimum(t, n1) * offsets[k1] + jnp.clip(t - n1, 0, n2) * offsets[k2]


def _free_segment(a, k1, n1, k2, n2, bits, offsets, steps):
    """Whether every step of each segment ``(K,)`` is an allowed move (``steps (W,)``: 0 .. W−1)."""
    a, k1, n1, k2, n2 = (x[:, None] for x in (a, k1, n1, k2, n2))
    t = steps[None, :]
    cell = _walk_segment(a, k1, n1, k2, n2, offsets, t)
    move = jnp.where(t < n1, k1, k2)
    ok = (bits[jnp.clip(cell, 0, bits.shape[0] - 1)] >> move.astype(jnp.uint8)) & 1
    return jnp.all((ok == 1) | (t >= n1 + n2), axis=-1)


def _one_pass(path, bits, start, offsets, diagonal, move_of, window):
    """One pass over ``path (S,)``: ``(shortened path, whether anything changed)``."""
    s = path.shape[0]
    width = -offsets[0]  # move 0 is (-1, 0)
    n = jnp.sum(path >= 0)
    full = jnp.concatenate([start[None], path])  # p_0 .. p_n, then -1
    on = jnp.arange(s + 1) <= n
    safe = jnp.where(on, full, 0)
    rows, cols = safe // width, safe % width
    took = on[1:]
    diag_step = took & (rows[1:] != rows[:-1]) & (cols[1:] != cols[:-1])
    zero = jnp.zeros((1,), jnp.int32)
    n_straight = jnp.concatenate([zero, jnp.cumsum((took & ~diag_step).astype(jnp.int32))])
    n_diag = jnp.concatenate([zero, jnp.cumsum(diag_step.astype(jnp.int32))])
    steps = jnp.arange(window, dtype=jnp.int32)
    lanes = jnp.arange(CHUNK, dtype=jnp.int32)

    def chunk(i, top):
        """The farthest qualifying ``d`` among ``top, top − 1, ..., top − CHUNK + 1`` (0: none) and its form."""
        d = top - lanes
        j = jnp.clip(i + d, 0, s)
        k1, n1, k2, n2, st, dg = _segment(rows[i], cols[i], rows[j], cols[j], diagonal, move_of)
        shorter = (st != n_straight[j] - n_straight[i]) | (dg != n_diag[j] - n_diag[i])
        a = jnp.broadcast_to(safe[i], d.shape)
        form0 = _free_segment(a, k1, n1, k2, n2, bits, offsets, steps)
        form1 = _free_segment(a, k2, n2, k1, n1, bits, offsets, steps)
        ok = (d >= 2) & shorter & (form0 | form1)
        first = jnp.argmax(ok)
        return jnp.where(ok[first], d[first], 0), jnp.where(form0[first], 0, 1)

    def stand(state):
        i, o, out, changed = state
        top = jnp.minimum(window, n - i)

        def look(c):
            return (c[1] == 0) & (c[0] >= 2)

        def step(c):
            top, _, _ = c
            d, form = chunk(i, top)
            return top - CHUNK, d, form

        _, d, form = jax.lax.while_loop(look, step, (top, jnp.int32(0), jnp.int32(0)))
        found = d >= 2
        d = jnp.where(found, d, 1)
        form = jnp.where(found, form, 0)
        k1, n1, k2, n2, st, dg = _segment(rows[i], cols[i], rows[i + d], cols[i + d], diagonal, move_of)
        first_k, first_n = jnp.where(form == 0, k1, k2), jnp.where(form == 0, n1, n2)
        second_k, second_n = jnp.where(form == 0, k2, k1), jnp.where(form == 0, n2, n1)
        seg = _walk_segment(safe[i], first_k, first_n, second_k, second_n, offsets, steps + 1)
        out = jax.lax.dynamic_update_slice_in_dim(out, seg, o, axis=0)
        return i + d, o + n1 + n2, out, changed | found

    out = jnp.full((s + window,), -1, jnp.int32)
    _, o, out, changed = jax.lax.while_loop(
        lambda st: st[0] < n, stand, (jnp.int32(0), jnp.int32(0), out, jnp.bool_(False))
    )
    return jnp.where(jnp.arange(s) < o, out[:s], -1), changed


def shorten_path(
    grid: Grid, path: ArrayLike, *, connectivity: int = 8, window: int = WINDOW, passes: int = PASSES
) -> np.ndarray:
    """The octile shortcut of one path on ``grid``, outside any run: ``path`` ``(K, 2)`` (row, col)
    cells, start first, a valid path of the move model (:func:`jaco.metrics.validate_path`);
    returns the shortened path ``(K', 2)``, ``K' ≤ K``, never longer, with the same ends.

    >>> import jaco
    >>> grid = jaco.Grid.from_rows(["....", "....", "...."])
    >>> shorten_path(grid, [(0, 0), (0, 1), (1, 1), (1, 2), (2, 2), (2, 3)]).tolist()
    [[0, 0], [1, 1], [2, 2], [2, 3]]
    """
    from ..errors import ProblemError
    from ..metrics import validate_path
    from ..moves import cached_table

    path = np.asarray(path, np.int64).reshape(-1, 2)
    problems = validate_path(grid, path, connectivity=connectivity)
    if problems:
        raise ProblemError(f"shorten_path needs a valid path: {problems[0]}")
    nbr, _ = cached_table(grid, connectivity)
    w = grid.width
    flat = (path[:, 0] * w + path[:, 1]).astype(np.int32)
    out = _shorten_one(
        jnp.asarray(flat[1:, None]),
        allowed_bits(jnp.asarray(nbr)),
        jnp.int32(flat[0]),
        jnp.asarray((MOVES[:, 0] * w + MOVES[:, 1]).astype(np.int32)),
        jnp.bool_((nbr[:, 4:] >= 0).any()),
        window=int(window),
        passes=int(passes),
        walk=native.active_walk(),
    )
    cells = np.asarray(out)[:, 0]
    cells = np.concatenate([flat[:1], cells[cells >= 0]])
    return np.stack(np.divmod(cells, w), axis=1).astype(np.int64)


@functools.partial(jax.jit, static_argnames=("window", "passes", "walk"))
def _shorten_one(cells, bits, start, offsets, diagonal, *, window, passes, walk):
    """``walk``: the active walk, so that a program traced for one is never reused for the other."""
    return shortcut(cells, start, bits, offsets, diagonal, window=window, passes=passes)


def path_tours(problem: Any, cells: jax.Array, arrived: jax.Array, n_steps: jax.Array, visited: jax.Array) -> Tours:
    """Step-major :class:`~jaco.engine.walk.Tours` of paths given by their cells ``(S, C)``
    (from ``problem.start``, -1 padded): the moves from the cells' coordinates, the step lengths
    and the path lengths from integer counts (as the walks compute them)."""
    took = cells >= 0
    prev = jnp.concatenate([jnp.broadcast_to(problem.start, cells[:1].shape), cells[:-1]], axis=0)
    d = (problem.xy[jnp.where(took, cells, 0)] - problem.xy[jnp.where(took, prev, 0)]).astype(jnp.int32)
    moves = jnp.where(took, jnp.asarray(MOVE_OF)[jnp.clip((d[..., 0] + 1) * 3 + d[..., 1] + 1, 0, 8)], -1)
    diag = took & (moves >= 4)
    straight = took & (moves >= 0) & (moves < 4)
    n_diag = jnp.sum(diag, axis=0)
    return Tours(
        cells=cells,
        moves=moves,
        step_len=jnp.where(diag, jnp.sqrt(jnp.float32(2)), jnp.where(straight, 1.0, 0.0)).astype(jnp.float32),
        arrived=arrived,
        n_steps=n_steps,
        length=jnp.sum(straight, axis=0) + jnp.sqrt(jnp.float32(2)) * n_diag,
        visited=visited,
    )


def shortcut_search(*, window: int, passes: int, best: int | None) -> ShortcutSearch:
    """A ``Planner.local_search``: the octile shortcut (``window`` path cells ahead, at most
    ``passes`` passes) of the ``best`` lowest-cost successful candidates of each iteration
    (``None``: every candidate). A candidate takes its shortened path where its cost (the
    planner's ``cost``) is not higher: always with the length as the cost."""

    def local_search(planner, problem, colony: Colony, params) -> Colony:
        c = colony.cost.shape[0]
        pick = (
            jnp.arange(c) if best is None or best >= c else jnp.argsort(colony.cost)[:best]
        )  # stable: ties to the lower index
        arrived = jnp.isfinite(colony.cost[pick])
        cells = shortcut(
            colony.cells[:, pick],
            problem.start,
            allowed_bits(problem.nbr),
            problem.offsets,
            jnp.any(problem.nbr[:, 4:] >= 0),
            window=window,
            passes=passes,
        )
        tours = path_tours(problem, cells, arrived, colony.n_steps[pick], colony.visited)
        cost = planner.cost(tours, problem, params)
        keep = arrived & (cost <= colony.cost[pick])
        targets = step_targets(planner.pheromone_on, cells, tours.moves, problem.start, problem.nbr.shape[0])

        def put(old, new):
            mine = old[..., pick]
            return old.at[..., pick].set(jnp.where(keep, new, mine))

        return colony._replace(
            cells=put(colony.cells, cells),
            targets=put(colony.targets, targets),
            step_len=put(colony.step_len, tours.step_len),
            cost=put(colony.cost, cost),
            length=put(colony.length, tours.length),
        )

    search = cast(ShortcutSearch, local_search)
    search.window, search.passes, search.best = window, passes, best
    return search
