"""The improved artificial potential field as a planner of its own (Dong & Zhao 2021).

Dong Xuanliang, Zhao Guiqing, *Robot navigation path planning based on ant colony algorithm guided
by artificial potential field*, Machinery Design & Manufacture 2021(6):169–173, 3.1 (intermediate
points, eqs. 3, 4) and 3.2 (attraction-only local moves, eq. 5): :func:`plan` returns one path as a
:class:`jaco.Result`; :func:`trace` and :func:`intermediate_points` inspect the walk. Plain numpy,
one query at a time; it is also the reference the per-cell tables of :mod:`jaco.potential` (the
heuristic of ``apf-aco`` and ``pf-aco``, :mod:`jaco.planners.apf_guided`) are tested against.
``kind="classic"`` walks the classic APF (attraction plus repulsion) of the paper's PF-ACO
baseline instead.

Interpretations (equations in ``docs/algorithms.md`` §6; also in ``docs/planners.md``, section
APF-ACO):

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
  stuck, the Euclidean distance from j to the goal (the fallback of ``docs/algorithms.md`` §6).
* **Classic APF (PF-ACO).** U = ½·k_att·ρ_g² + ½·k_rep·(1/d − 1/d0)² for d ≤ d0 (Khatib's
  quadratic attraction, k_att = 1; ρ_g the Euclidean distance to the goal, d the distance from
  the cell centre to the nearest blocked cell centre, :func:`jaco.potential.obstacle_distance`; the map's
  outside does not repel, or every goal on the border, as in the paper's maps, would be
  unreachable). The walker descends: it moves to the allowed neighbour of lowest U if that is
  lower than U here, else it is in a local minimum ("stuck", fallback as above). Strict descent
  cannot loop. Defaults k_rep = 100, d0 = 3 (not printed; :data:`jaco.potential.K_REP`,
  :data:`jaco.potential.D0`).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from .engine.params import check_values
from .engine.problem import make_problem
from .engine.result import Result
from .errors import JacoError, ParamError
from .grid import Cell, Grid
from .metrics import gap
from .moves import MOVES
from .potential import D0, K_REP, MOVE_LEN, classic_next

__all__ = ["Trace", "trace", "intermediate_points", "plan", "ARRIVED", "LOOP", "STUCK", "MAX_STEPS"]

# Walk outcomes (:class:`Trace`.status).
ARRIVED, LOOP, STUCK, MAX_STEPS = "arrived", "loop", "stuck", "max_steps"

_classic_next_jit = jax.jit(classic_next)


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
        score = np.where(allowed, dot / MOVE_LEN, -np.inf)
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
    check_values({"k_rep": k_rep, "d0": d0}, ("k_rep", "d0"), "the classic APF")
    if np.ndim(k_rep) or np.ndim(d0):
        raise ParamError("k_rep and d0 must be single numbers")


def _trace(grid, start, goal, max_steps, kind, connectivity, k_rep, d0):
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


def trace(
    grid: Grid,
    start: Cell,
    goal: Cell,
    *,
    max_steps: int | None = None,
    kind: str = "improved",
    connectivity: int = 8,
    k_rep: float = K_REP,
    d0: float = D0,
) -> Trace:
    """Walk the APF planner from ``start`` to ``goal`` and say how it ended (:class:`Trace`).

    ``kind="improved"``: the paper's improved APF (intermediate points + attraction only);
    ``kind="classic"``: descent on the classic potential (attraction + repulsion, PF-ACO; its
    local minima end the walk as "stuck"). Inputs are validated by
    :func:`jaco.engine.problem.make_problem` first (clear errors, an unreachable goal included).
    ``max_steps`` defaults to the number of free cells (a walk that has not revisited a cell can
    be no longer).
    """
    return _trace(grid, start, goal, max_steps, kind, connectivity, k_rep, d0)[0]


def intermediate_points(grid: Grid, cell: Cell, goal: Cell, *, connectivity: int = 8) -> list | None:
    """The chain of intermediate points (3.1) the improved APF computes at ``cell``: a list of
    ``(row, col)`` from the goal to the local target (``[goal]`` when the segment is clear), or
    None when no intermediate point exists."""
    problem = make_problem(grid, cell, goal, connectivity=connectivity)
    ref = _Ref(grid, goal, np.asarray(problem.nbr))
    return ref.targets((int(cell[0]), int(cell[1])))


def plan(
    grid: Grid,
    start: Cell,
    goal: Cell,
    *,
    max_steps: int | None = None,
    kind: str = "improved",
    connectivity: int = 8,
    k_rep: float = K_REP,
    d0: float = D0,
) -> Result:
    """Plan one path with the APF alone (Dong & Zhao 2021, 3.1–3.2) and return a :class:`jaco.Result`.

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
    t, problem = _trace(grid, start, goal, max_steps, kind, connectivity, k_rep, d0)
    ok = t.status == ARRIVED
    cost = t.length if ok else math.inf
    length = cost * grid.cell_size
    optimal = float(problem.optimal) * grid.cell_size
    one = lambda x: np.array([x], np.float32)  # noqa: E731
    params = {} if kind == "improved" else {"k_rep": float(k_rep), "d0": float(d0)}
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
        connectivity=connectivity,
    )
