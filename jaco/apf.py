"""APF-ACO: ant colony optimisation guided by an improved artificial potential field (seed 003).

Dong Xuanliang, Zhao Guiqing, *Robot navigation path planning based on ant colony algorithm guided
by artificial potential field*, Machinery Design & Manufacture 2021(6):169–173: the improved APF
planner (3.1 intermediate points, eqs. 3, 4; 3.2 attraction-only local moves, eq. 5), the heuristic
built on the APF path length (eq. 10) and the best-half, fitness-weighted pheromone update (eqs. 11,
12). ``pf-aco`` is the paper's baseline (its ref. 10, Wang, Yang & Zhang 2018): the same scheme
with the path length of the *classic* APF (attraction plus repulsion), which has local minima.

Three things live here:

* :func:`plan` — the improved APF as a planner of its own (one path, a :class:`jaco.run.Result`),
  and :func:`trace` / :func:`intermediate_points` to inspect it. Plain numpy, per query.
* :func:`apf_next` / :func:`classic_next` / :func:`apf_distance` / :func:`classic_distance` — the
  APF distance table r_jg for every cell at once, in JAX, traced from the
  :class:`~jaco.problem.Problem`'s arrays (no static map size is needed, so one compiled run
  serves every map and start/goal pair of one shape).
* the variants ``apf-aco`` and ``pf-aco`` (:data:`APF_ACO`, :data:`PF_ACO`).

Interpretations (ALGORITHMS.md §7; also in ``docs/variants.md``, section APF-ACO):

* **Geometry.** Cell (row, col) is the unit square centred on (row, col). A segment between cell
  centres *crosses* every cell whose closed square it touches (a closed supercover: through a
  grid vertex it touches all four cells, the rule of :func:`jaco.metrics.line_of_sight`).
  "Effective obstacles" (3.1) are the blocked cells the segment crosses; the **last** one is the
  one whose centre projects farthest along the segment (ties: the larger flat index).
* **An obstacle** is a connected group of blocked cells (8-connected: two blocked cells touching
  at a corner cannot be passed between without cutting a corner). "The last effective
  obstacle" is the group holding the last effective obstacle cell.
* **Intermediate point (eq. 4).** Candidates: the free cells 8-adjacent to that obstacle, other
  than the current cell p and the current target T, that lie *beside* it as seen from p: the
  direction p→c is outside the angle the obstacle's squares subtend at p (their corners'
  extreme directions), so p→c never crosses it. Read literally ("the free neighbour nearest the
  line"), the cells on the segment just in front of or behind the obstacle would win at
  distance 0 and the chain would never leave it. "Nearest the segment" is measured as the angle
  at p between p→c and p→T (eq. 4's distance divided by |p−c|; the raw distance prefers cells
  next to p, whichever side the obstacle is easier to pass): the winner is the tangent cell on
  the side where the obstacle ends nearer the line. Ties: nearer to p, then the lower flat
  index. Angles are compared as an exact pseudo-angle (one float32 division of integers, the
  same bits in numpy and JAX). Then T := c and repeat until p→T is clear, at most H + W levels;
  no candidate, a target seen before in the chain (it would repeat forever), or the level bound
  is a failure ("stuck"). An obstacle that surrounds p more than half-way (p inside a U) has no
  cell beside it on one side, and the chain may alternate between its two ends.
* **Re-planning at every cell.** The paper plans start → intermediate point, then "repeats
  until the goal is reached". Here the chain of intermediate points is recomputed from the
  current cell at every step (toward the goal), so the next cell depends on the current cell
  only. This keeps the planner a function ``next(cell)``: a revisited cell means a loop for
  certain, and the path length from *every* cell follows from one table (pointer doubling).
* **Local move (eq. 5).** Attraction only: move k scores ``e_k · (T − p)/|e_k|`` (the component
  of the attraction along the move's unit vector; its magnitude does not change the argmax);
  moves the problem's neighbour table forbids (blocked, off the map, corner cuts) score −∞;
  the best wins, ties to the first in the move order. No allowed move: "stuck".
* **Loops.** A revisited cell ends the walk with status "loop"; the plan fails (success False,
  length inf), like an ACO run whose ants never arrive.
* **APF distance r_jg** = length of the APF path from j to the goal; where that path loops or is
  stuck, the Euclidean distance from j to the goal (the fallback of ALGORITHMS.md §7.2).
* **Classic APF (PF-ACO).** U = ½·k_att·ρ_g² + ½·k_rep·(1/d − 1/d0)² for d ≤ d0 (Khatib's
  quadratic attraction, k_att = 1; ρ_g the Euclidean distance to the goal, d the distance from
  the cell centre to the nearest blocked cell centre, :func:`obstacle_distance`; the map's
  outside does not repel, or every goal on the border, as in the paper's maps, would be
  unreachable). The walker descends: it moves to the allowed neighbour of lowest U if that is
  lower than U here, else it is in a local minimum ("stuck", fallback as above). Strict descent
  cannot loop. Defaults k_rep = 100, d0 = 3 (not printed; :data:`K_REP`, :data:`D0`).
* **Heuristic (10)** ``η_ij = 1/(d_ij + r_jg) · (Nmax − Nc + 1)/Nmax`` with Nc = t + 1. The time
  factor is common to every move of an iteration, so it cancels in the normalised rule (6):
  computed as printed, it changes no choice.
* **Update (11, 12).** No deposit while walking; after the iteration the best ⌈k/2⌉ of the k
  successful ants (ranked by cost, ties to the lower ant index) deposit
  ``s_i·Δτ_i = (fit_i/Σ fit)·Q/L_i`` on their moves (Δτ = Q/L of eq. 8, fit = 1/L), after the
  evaporation ``(1 − ρ)τ`` of every move. No successful ant: evaporation only.
* **τ0** (not printed) = 1: with Q = 1 and ρ = 0.7 a smaller τ0 lets the first iteration's
  deposits decide the run (docs/variants.md has the sweep).
* **Weights in log space.** At ρ = 0.7 an unused move's τ falls below float32's range within
  about 70 iterations (0.3^70 ≈ 1e-37), and τ^α long before: ``τ^α η^β`` would then be 0 (or the
  engine's floor) for every unused move and η would stop guiding the ants. The construct step
  computes ``α·log τ + β·log η`` (τ floored at the smallest normal float32), subtracts each
  cell's maximum and exponentiates: the same probabilities (6), without underflow.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from . import pheromone as ph
from .colony import Colony, step_targets
from .construct import pad_steps, walk
from .errors import JacoError, ParamError
from .problem import MOVES
from .variant import make_variant

__all__ = [
    "K_ATT",
    "K_REP",
    "D0",
    "Trace",
    "trace",
    "intermediate_points",
    "plan",
    "apf_next",
    "classic_next",
    "obstacle_distance",
    "chain_lengths",
    "apf_distance",
    "classic_distance",
    "apf_eta",
    "APFTrail",
    "apf_init",
    "deposit_best_half",
    "log_weights",
    "apf_colony",
    "APF_ACO",
    "PF_ACO",
    "PAPER_PARAMS",
]

#: Classic APF (PF-ACO baseline): attraction gain (fixed: only k_rep/k_att matters), default
#: repulsion gain and range (cells). The sources print none of them; see docs/variants.md.
K_ATT = 1.0
K_REP = 100.0
D0 = 3.0

_SQRT2 = np.float32(np.sqrt(2.0))
#: |e_k| of the eight moves, float32 (the local-move scores are computed alike in numpy and JAX).
_MOVE_LEN = np.where(np.abs(MOVES).sum(axis=1) == 2, _SQRT2, np.float32(1.0)).astype(np.float32)

# Walk outcomes (:class:`Trace`.status).
ARRIVED, LOOP, STUCK, MAX_STEPS = "arrived", "loop", "stuck", "max_steps"


# ============================================================================================
# The improved APF, numpy reference (one query at a time): plan, trace, intermediate_points
# ============================================================================================
def _touches(a, b, o) -> np.ndarray:
    """Whether the closed segment between cell centres ``a`` and ``b`` touches the closed unit
    square of cell(s) ``o (..., 2)``: the separating-axis test in exact integer arithmetic."""
    o = np.asarray(o, np.int64)
    (ar, ac), (br, bc) = a, b
    dr, dc = br - ar, bc - ac
    orr, occ = o[..., 0], o[..., 1]
    box = (min(ar, br) <= orr) & (orr <= max(ar, br)) & (min(ac, bc) <= occ) & (occ <= max(ac, bc))
    cross = dr * (occ - ac) - dc * (orr - ar)
    return box & (2 * np.abs(cross) <= abs(dr) + abs(dc))


def _dia(x, y):
    """Pseudo-angle of the vector (x, y) from the x axis, in (−2, 2]: a monotone, exactly
    reproducible stand-in for atan2 (one float32 division; ±2 = straight behind)."""
    s = np.abs(x) + np.abs(y)
    f = y / s
    return np.where(x >= 0, f, np.where(y >= 0, np.float32(2) - f, np.float32(-2) - f)).astype(np.float32)


_CORNERS = np.array([(-1, -1), (-1, 1), (1, -1), (1, 1)], np.int64)


class _Ref:
    """The improved APF on one grid and goal, in numpy (the reference the JAX table is tested
    against, and the engine of :func:`plan`)."""

    def __init__(self, grid, goal, nbr):
        from scipy.ndimage import label

        self.free = grid.free
        self.h, self.w = grid.shape
        self.goal = (int(goal[0]), int(goal[1]))
        self.nbr = nbr
        self.blocked = np.argwhere(~grid.free).astype(np.int64)  # (B, 2) row-major order
        lab, _ = label(~grid.free, structure=np.ones((3, 3), int))  # obstacles: 8-connected
        self.lab = lab.ravel()  # 0 on free cells
        self.rc = np.argwhere(np.ones(grid.shape, bool)).astype(np.int64)  # (N, 2), flat order
        padded = np.pad(lab, 1)
        self.nb_lab = np.stack(
            [padded[1 + dr : 1 + dr + self.h, 1 + dc : 1 + dc + self.w].ravel() for dr, dc in MOVES], axis=1
        )

    def last_blocked(self, a, b):
        """The last effective obstacle of the segment a→b (max centre projection, then max flat
        index), or None when the segment is clear."""
        if len(self.blocked) == 0:
            return None
        hit = self.blocked[_touches(a, b, self.blocked)]
        if len(hit) == 0:
            return None
        d = np.array([b[0] - a[0], b[1] - a[1]])
        proj = (hit - np.array(a)) @ d
        flat = hit[:, 0] * self.w + hit[:, 1]
        i = np.lexsort((flat, proj))[-1]
        return int(hit[i, 0]), int(hit[i, 1])

    def pick(self, p, t, o):
        """Eq. (4): the intermediate point beside obstacle o's component for the line p–t, or None."""
        k = self.lab[o[0] * self.w + o[1]]
        u = np.array([t[0] - p[0], t[1] - p[1]], np.int64)
        v = 2 * (self.rc - np.array(p))  # doubled offsets of every cell centre from p
        corners = v[:, None, :] + _CORNERS[None]  # (N, 4, 2): the cells' square corners
        in_k = self.lab == k

        def angle(vec):
            x = (vec[..., 0] * u[0] + vec[..., 1] * u[1]).astype(np.float32)
            y = (u[0] * vec[..., 1] - u[1] * vec[..., 0]).astype(np.float32)
            with np.errstate(invalid="ignore", divide="ignore"):
                return _dia(x, y)

        ca = angle(corners[in_k])
        lo, hi = ca.min(), ca.max()
        phi = angle(v)
        idx = np.arange(len(self.rc))
        cand = self.free.ravel() & np.any(self.nb_lab == k, axis=1) & ((phi > hi) | (phi < lo))
        cand &= (idx != p[0] * self.w + p[1]) & (idx != t[0] * self.w + t[1])
        if not cand.any():
            return None
        c = np.flatnonzero(cand)
        dev = np.abs(phi[c])  # angle between p→c and p→t
        near = np.sum((self.rc[c] - np.array(p)) ** 2, axis=1)
        best = c[np.lexsort((c, near, dev))[0]]
        return int(self.rc[best, 0]), int(self.rc[best, 1])

    def targets(self, p):
        """The chain of intermediate points from cell p toward the goal: ``[T_1, ..., T_k]``,
        T_k the local target (p→T_k clear); the goal alone when p→goal is clear; None if stuck."""
        t = self.goal
        chain = [t]
        o = self.last_blocked(p, t)
        level = 0
        while o is not None and level < self.h + self.w:
            c = self.pick(p, t, o)
            if c is None or c in chain:  # a repeated target repeats forever: stuck
                return None
            t = c
            chain.append(t)
            o = self.last_blocked(p, t)
            level += 1
        return chain if o is None else None

    def next(self, p):
        """The next cell of the improved APF from p (eq. 5), or None when stuck."""
        if p == self.goal:
            return p
        chain = self.targets(p)
        if chain is None:
            return None
        t = chain[-1]
        i = p[0] * self.w + p[1]
        allowed = self.nbr[i] >= 0
        if not allowed.any():
            return None
        dot = (MOVES[:, 0] * (t[0] - p[0]) + MOVES[:, 1] * (t[1] - p[1])).astype(np.float32)
        score = np.where(allowed, dot / _MOVE_LEN, -np.inf)
        k = int(np.argmax(score))
        return p[0] + int(MOVES[k, 0]), p[1] + int(MOVES[k, 1])


class Trace(NamedTuple):
    """One APF walk: ``path (K, 2)`` of the cells walked from the start (the goal last when
    ``status == "arrived"``), ``status`` ("arrived", "loop": a cell would be revisited, "stuck":
    no intermediate point / no allowed move / a local minimum, "max_steps"), and ``length``
    (cell units; inf unless arrived)."""

    path: np.ndarray
    status: str
    length: float


def _length(path) -> float:
    d = np.abs(np.diff(np.asarray(path, np.int64), axis=0))
    diag = int(np.sum((d[:, 0] == 1) & (d[:, 1] == 1)))
    return float(len(d) - diag + np.sqrt(2.0) * diag)


def _follow(step, start, goal, max_steps: int) -> Trace:
    cur = start
    path, seen = [cur], {cur}
    status = ARRIVED
    while cur != goal:
        if len(path) - 1 >= max_steps:
            status = MAX_STEPS
            break
        nxt = step(cur)
        if nxt is None:
            status = STUCK
            break
        if nxt in seen:
            status = LOOP
            break
        path.append(nxt)
        seen.add(nxt)
        cur = nxt
    arr = np.array(path, dtype=np.int64).reshape(-1, 2)
    return Trace(arr, status, _length(arr) if status == ARRIVED else math.inf)


def _check_kind(kind):
    if kind not in ("improved", "classic"):
        raise JacoError(f"kind must be 'improved' or 'classic', got {kind!r}")


def _check_classic(k_rep, d0):
    from .params import check_values

    check_values({"k_rep": k_rep, "d0": d0}, ("k_rep", "d0"), "the classic APF")
    if np.ndim(k_rep) or np.ndim(d0):
        raise ParamError("k_rep and d0 must be single numbers")


def _trace(grid, start, goal, max_steps, kind, connectivity, k_rep, d0):
    from .problem import make_problem

    _check_kind(kind)
    problem = make_problem(grid, start, goal, connectivity=connectivity)  # clear errors first
    if max_steps is None:
        max_steps = grid.n_free
    if isinstance(max_steps, bool) or not isinstance(max_steps, (int, np.integer)) or max_steps < 0:
        raise JacoError(f"max_steps must be a non-negative integer, got {max_steps!r}")
    s = (int(start[0]), int(start[1]))
    g = (int(goal[0]), int(goal[1]))
    if kind == "improved":
        ref = _Ref(grid, g, np.asarray(problem.nbr))
        return _follow(ref.next, s, g, int(max_steps)), problem
    _check_classic(k_rep, d0)
    nxt = np.asarray(_classic_next_jit(problem, jnp.float32(k_rep), jnp.float32(d0)))
    w = grid.width

    def step(p):
        j = int(nxt[p[0] * w + p[1]])
        return None if j < 0 else divmod(j, w)

    return _follow(step, s, g, int(max_steps)), problem


def trace(grid, start, goal, *, max_steps=None, kind: str = "improved", connectivity: int = 8,
          k_rep: float = K_REP, d0: float = D0) -> Trace:
    """Walk the APF planner from ``start`` to ``goal`` and say how it ended (:class:`Trace`).

    ``kind="improved"``: the paper's improved APF (intermediate points + attraction only);
    ``kind="classic"``: descent on the classic potential (attraction + repulsion, PF-ACO; its
    local minima end the walk as "stuck"). Inputs are validated by
    :func:`jaco.problem.make_problem` first (clear errors, an unreachable goal included).
    ``max_steps`` defaults to the number of free cells (a walk that has not revisited a cell can
    be no longer).
    """
    return _trace(grid, start, goal, max_steps, kind, connectivity, k_rep, d0)[0]


def intermediate_points(grid, cell, goal, *, connectivity: int = 8) -> list | None:
    """The chain of intermediate points (3.1) the improved APF computes at ``cell``: a list of
    ``(row, col)`` from the goal to the local target (``[goal]`` when the segment is clear), or
    None when no intermediate point exists."""
    from .problem import make_problem

    problem = make_problem(grid, cell, goal, connectivity=connectivity)
    ref = _Ref(grid, goal, np.asarray(problem.nbr))
    return ref.targets((int(cell[0]), int(cell[1])))


def plan(grid, start, goal, *, max_steps=None, kind: str = "improved", connectivity: int = 8,
         k_rep: float = K_REP, d0: float = D0):
    """Plan one path with the APF alone (seed 003, 3.1–3.2) and return a :class:`jaco.run.Result`.

    ``variant`` is ``"apf"`` (improved) or ``"apf-classic"``; a walk that loops, gets stuck or
    runs out of steps fails like an ACO run whose ants never arrive: ``success`` False, length,
    cost and gap inf, an empty path (:func:`trace` returns the partial walk and the reason).
    ``history`` has one entry (one "iteration"), ``coverage`` is the share of free cells the walk
    visited, ``n_ants = n_iters = 1``, ``steplimit = max_steps``, ``seed = 0`` (deterministic).

    >>> import jaco
    >>> grid = jaco.Grid.from_rows(["......", "..#...", "..#...", "......"])
    >>> r = jaco.apf.plan(grid, (2, 0), (2, 5))
    >>> r.success, round(r.length, 3), round(r.optimal, 3)
    (True, 5.828, 5.828)
    """
    from .run import Result, gap

    t, problem = _trace(grid, start, goal, max_steps, kind, connectivity, k_rep, d0)
    ok = t.status == ARRIVED
    cost = t.length if ok else math.inf
    length = cost * grid.cell_size
    optimal = float(problem.optimal) * grid.cell_size
    one = lambda x: np.array([x], np.float32)  # noqa: E731
    params = {} if kind == "improved" else {"k_rep": float(k_rep), "d0": float(d0)}
    kw = dict(connectivity=connectivity) if "connectivity" in Result.__dataclass_fields__ else {}
    return Result(
        variant="apf" if kind == "improved" else "apf-classic",
        path=t.path if ok else np.empty((0, 2), np.int64),
        length=length,
        success=ok,
        cost=cost,
        optimal=optimal,
        gap=gap(length, optimal),
        best_iteration=0 if ok else -1,
        history={"best": one(cost), "iteration_best": one(cost), "mean": one(cost), "success_rate": one(float(ok))},
        coverage=len(t.path) / grid.n_free,
        seed=0,
        params=params,
        n_ants=1,
        n_iters=1,
        steplimit=int(grid.n_free if max_steps is None else max_steps),
        start=tuple(int(v) for v in start),
        goal=tuple(int(v) for v in goal),
        grid=grid,
        **kw,
    )


# ============================================================================================
# The APF distance table in JAX: every cell at once, traced from the Problem's arrays
# ============================================================================================
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
    """:func:`_dia` in JAX (same float32 operations, so the same bits)."""
    f = y / (jnp.abs(x) + jnp.abs(y))
    return jnp.where(x >= 0, f, jnp.where(y >= 0, jnp.float32(2) - f, jnp.float32(-2) - f))


class _Map(NamedTuple):
    """What the improved APF needs of a map, computed once per problem (all traced)."""

    w: jax.Array
    h: jax.Array
    rc: jax.Array  # (N, 2) int32 (row, col)
    free: jax.Array  # (N,) bool
    lab: jax.Array  # (N,) obstacle component (smallest flat index in it), −1 on free cells
    nb_lab: jax.Array  # (N, 8) component of each 8-neighbour, −1 for free or off-map


def _map(problem) -> _Map:
    """Obstacle components (8-connected blocked cells) by min-label propagation with pointer
    jumping, and each cell's neighbours' components."""
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
    return _Map(w, h, rc, free, lab, nb_lab)


_CORNERS_J = np.array([(-1, -1), (-1, 1), (1, -1), (1, 1)], np.int32)


def _pick_j(m: _Map, pi, p, t, o):
    """Eq. (4) in JAX (see :meth:`_Ref.pick`): ``(cell (2,), found)``."""
    k = m.lab[o]
    u = t - p
    v = 2 * (m.rc - p[None, :])
    # Rotated frame: x = u·v, y = u×v, exact integers (held exactly in float32); a corner's
    # coordinates are the centre's plus one of four per-walker offsets.
    x = (v[:, 0] * u[0] + v[:, 1] * u[1]).astype(jnp.float32)
    y = (u[0] * v[:, 1] - u[1] * v[:, 0]).astype(jnp.float32)
    cr = jnp.asarray(_CORNERS_J)
    dx = (cr[:, 0] * u[0] + cr[:, 1] * u[1]).astype(jnp.float32)
    dy = (u[0] * cr[:, 1] - u[1] * cr[:, 0]).astype(jnp.float32)
    ca = _dia_j(x[:, None] + dx[None, :], y[:, None] + dy[None, :])  # (N, 4)
    in_k = (m.lab == k)[:, None]
    hi = jnp.max(jnp.where(in_k, ca, -jnp.inf))
    lo = jnp.min(jnp.where(in_k, ca, jnp.inf))
    phi = _dia_j(x, y)
    idx = jnp.arange(m.rc.shape[0], dtype=jnp.int32)
    ti = t[0] * m.w + t[1]
    cand = m.free & jnp.any(m.nb_lab == k, axis=1) & ((phi > hi) | (phi < lo)) & (idx != pi) & (idx != ti)
    dev = jnp.where(cand, jnp.abs(phi), jnp.inf)
    tie = cand & (dev == jnp.min(dev))
    near = jnp.sum((m.rc - p[None, :]) ** 2, axis=1)
    best = jnp.argmin(jnp.where(tie, near, jnp.iinfo(jnp.int32).max))
    return m.rc[best], jnp.any(cand)


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
    score = jnp.where(allowed, dot / jnp.asarray(_MOVE_LEN), -jnp.inf)
    k = jnp.argmax(score)
    nxt = jnp.where(ok & jnp.any(allowed), problem.nbr[i, k], -1)
    return jnp.where(i == problem.goal, i, jnp.where(live, nxt, -1))


#: Walkers per vmapped batch of :func:`apf_next` (each holds a few ``(N, 8)`` temporaries, and
#: a batch runs as many levels as its slowest walker needs).
_WALKERS = 256
_WALKER_CELLS = 1 << 24


def apf_next(problem) -> jax.Array:
    """``next (N,)`` of the improved APF for every cell (one walker per cell, vmapped in
    batches): the cell it moves to, −1 where it is stuck or blocked, the goal at the goal."""
    m = _map(problem)
    n = problem.nbr.shape[0]
    cells = jnp.arange(n, dtype=jnp.int32)
    batch = max(1, min(n, _WALKERS, _WALKER_CELLS // max(n, 1)))
    return jax.lax.map(lambda i: _apf_next_cell(problem, m, i), cells, batch_size=batch)


def obstacle_distance(problem) -> jax.Array:
    """Distance ``(N,)`` from each cell centre to the nearest blocked cell centre, the map's
    outside **not** counting (inf on a map without obstacles): brute force over the blocked
    cells, in batches of cells (``problem.clearance`` counts the outside, which would make every
    goal on the border a local maximum of the repulsion)."""
    blocked = problem.clearance <= 0
    n = problem.nbr.shape[0]

    def one(xy):
        d2 = jnp.sum((problem.xy - xy[None, :]) ** 2, axis=1)
        return jnp.sqrt(jnp.min(jnp.where(blocked, d2, jnp.inf)))

    return jax.lax.map(one, problem.xy, batch_size=max(1, min(n, (1 << 22) // max(n, 1))))


def classic_next(problem, k_rep, d0, k_att=K_ATT) -> jax.Array:
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


_classic_next_jit = jax.jit(classic_next)


def chain_lengths(problem, nxt):
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


def apf_distance(problem, params=None) -> jax.Array:
    """r_jg (N,) of the improved APF (seed 003, 3.1–3.2), Euclidean where it fails."""
    return chain_lengths(problem, apf_next(problem))[0]


def classic_distance(problem, params) -> jax.Array:
    """r_jg (N,) of the classic APF with ``params.k_rep``, ``params.d0`` (PF-ACO, ref. 10),
    Euclidean where it ends in a local minimum."""
    return chain_lengths(problem, classic_next(problem, params.k_rep, params.d0))[0]


# ============================================================================================
# APF-ACO and PF-ACO
# ============================================================================================
def apf_eta(problem, r, t, n_iters) -> jax.Array:
    """Eq. (10): ``η_ij = 1/(d_ij + r_jg) · (Nmax − Nc + 1)/Nmax`` ``(N, 8)``, Nc = t + 1
    (0 where the map forbids the move)."""
    valid = problem.nbr >= 0
    rj = r[jnp.where(valid, problem.nbr, 0)]
    factor = (n_iters - jnp.asarray(t).astype(jnp.float32)) / n_iters
    return jnp.where(valid, factor / jnp.maximum(problem.step + rj, 1e-6), 0.0)


def _heuristic(table):
    def heuristic(problem, params, t, n_iters):
        """Eq. (10) with the table computed on the spot (for tools that want one (N, 8) table;
        the variants' construct step reads the table computed once per run instead)."""
        return apf_eta(problem, table(problem, params), t, n_iters)

    return heuristic


class APFTrail(NamedTuple):
    """:class:`jaco.pheromone.Trail`'s ``(tau, lo, hi)`` plus the APF distance ``r (N,)``,
    computed once per run by :func:`apf_init` and carried unchanged through the iterations."""

    tau: jax.Array
    lo: jax.Array
    hi: jax.Array
    r: jax.Array


def apf_init(table) -> ph.Rule:
    """τ = τ0 everywhere and ``r = table(problem, params)`` (once per run, inside the run)."""

    def init(trail, problem, params):
        tau = jnp.full_like(trail.tau, params.tau0)
        return APFTrail(tau, trail.lo, trail.hi, table(problem, params).astype(jnp.float32))

    return ph.Rule(init, ph._keep_update)


def deposit_best_half() -> ph.Rule:
    """Eqs. (11, 12): the best ⌈k/2⌉ of the k successful ants deposit ``s_i·Q/L_i`` on each
    move they took, ``s_i = fit_i / Σ_{depositors} fit``, fit = 1/L (evaporation is a separate
    piece)."""

    def update(trail, walks, problem, params):
        fit = ph.inverse(walks.cost)
        ok = fit > 0
        k = jnp.sum(ok)
        rank = jnp.argsort(jnp.argsort(walks.cost, stable=True), stable=True)  # 0 = best
        dep = ok & (rank < (k + 1) // 2)
        fit = jnp.where(dep, fit, 0.0)
        s = fit / jnp.maximum(jnp.sum(fit), 1e-30)
        per_ant = s * params.q * fit
        amounts = jnp.broadcast_to(per_ant[None, :], walks.targets.shape)
        return trail._replace(tau=ph._scatter_add(trail.tau, walks.targets, amounts))

    return ph.Rule(ph._keep_init, update)


_TINY = float(np.finfo(np.float32).tiny)


def log_weights(tau, eta, valid, params):
    """``τ^α η^β`` per move, scaled per cell by its largest allowed value (log space, no
    underflow); exactly 0 where ``valid`` is False, in [1e-30, 1] elsewhere."""
    lw = params.alpha * jnp.log(jnp.maximum(tau, _TINY)) + params.beta * jnp.log(jnp.maximum(eta, _TINY))
    lw = jnp.where(valid, lw, -jnp.inf)
    top = jnp.max(lw, axis=1, keepdims=True)
    top = jnp.where(jnp.isfinite(top), top, 0.0)
    return jnp.where(valid, jnp.clip(jnp.exp(lw - top), 1e-30, 1.0), 0.0)


def apf_colony(variant, problem, trail, params, t, n_iters, key, *, n_ants: int, steplimit: int):
    """One APF-ACO iteration: the random-proportional rule (6) with η of eq. (10) from the table
    the rule's init stored in the trail (``trail.r``); dead ants fail (cost inf)."""
    n = problem.nbr.shape[0]
    valid = problem.nbr >= 0
    eta = apf_eta(problem, trail.r, t, n_iters)
    weights = log_weights(trail.tau.reshape(n, 8), eta, valid, params)
    u = jax.random.uniform(key, (pad_steps(steplimit), n_ants), jnp.float32)
    tours = walk(problem, weights, u, params.q0, steplimit=steplimit, exploit=variant.transition == "pseudo-random")
    cost = jnp.where(tours.arrived, variant.cost(tours, problem, params), jnp.inf)
    targets = step_targets("moves", tours.cells, tours.moves, problem.start, n)
    return trail, Colony(tours.cells, targets, tours.step_len, cost, tours.length, tours.n_steps, tours.visited)


_APF_BASE = ("alpha", "beta", "rho", "q", "tau0")
#: The paper prints α = 2, β = 6, ρ = 0.7, Q = 1 (``PAPER_PARAMS``). The defaults move β to 20 and
#: ρ to 0.3: with β = 6 no ant of 50 × 100 ever reached the goal on two dense 30 % maps and the
#: maze of tests/test_quality.py (before the first arrival only β steers), and ρ = 0.7 locks in
#: the first iterations' paths (docs/variants.md, APF-ACO).
PAPER_PARAMS = dict(alpha=2.0, beta=6.0, rho=0.7, q=1.0)
_APF_DEFAULTS = dict(alpha=2.0, beta=20.0, rho=0.3, q=1.0, tau0=1.0)

APF_ACO = make_variant(
    "apf-aco",
    "Dong & Zhao 2021 (seed 003): 3.1, 3.2, eqs. 4, 5, 6, 10, 11, 12",
    "Dong & Zhao 2021, Machinery Design & Manufacture 2021(6):169–173, eqs. 4, 5 (improved APF), "
    "6, 10, 11, 12: ACO guided by the improved artificial potential field. η_ij = 1/(d_ij + r_jg)·"
    "(Nmax − Nc + 1)/Nmax with r_jg the length of the improved APF's path from j to the goal "
    "(intermediate points beside the last obstacle the straight line crosses, attraction-only "
    "moves; Euclidean where it loops or is stuck), computed once per run for every cell; roulette "
    "rule; no deposit while walking; after each iteration τ ← (1−ρ)τ and the best half of the "
    "successful ants deposit (fit_i/Σfit)·Q/L_i. Pheromone on moves. Interpretations: jaco.apf "
    "and docs/variants.md (APF-ACO).",
    _APF_BASE,
    _APF_DEFAULTS,
    ph.chain(apf_init(apf_distance), ph.evaporate(), deposit_best_half()),
    heuristic=_heuristic(apf_distance),
    construct=apf_colony,
)

PF_ACO = make_variant(
    "pf-aco",
    "Dong & Zhao 2021 (seed 003), baseline of its ref. 10 (Wang, Yang & Zhang 2018)",
    "The PF-ACO baseline of Dong & Zhao 2021 (their ref. 10): APF-ACO with r_jg from the classic "
    "artificial potential field, U = ½ρ_g² + ½k_rep(1/d − 1/d0)² within d0 (descent to the lowest "
    "neighbour; Euclidean where it ends in a local minimum). Everything else as apf-aco "
    "(eqs. 6, 10, 11, 12). Interpretations: jaco.apf and docs/variants.md (APF-ACO).",
    _APF_BASE + ("k_rep", "d0"),
    dict(_APF_DEFAULTS, k_rep=K_REP, d0=D0),
    ph.chain(apf_init(classic_distance), ph.evaporate(), deposit_best_half()),
    heuristic=_heuristic(classic_distance),
    construct=apf_colony,
)
