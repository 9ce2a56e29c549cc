"""Native reference for the throughput benchmark: classic ant-cycle AS as plain numba loops.

This is the same algorithm as jaco's ``as`` variant (``jaco.planners.classic.AS``), written the way one
would write it by hand for one core, so that ``experiments/bench_throughput.py`` can compare
jaco's batched JAX engine against a fair native baseline measured in the same run:

* pheromone on moves ``tau (N, 8)``, initialised to ``tau0``;
* once per iteration the move weights ``w = tau^alpha * eta^beta`` on the moves the map allows
  (``eta = 1/max(|target - goal|, 0.5)``, :func:`jaco.engine.heuristics.inverse_goal_distance`),
  clipped to ``[1e-30, 1e30]`` like jaco; ``eta^beta`` is constant and is computed once per
  colony (a hand-written loop would do the same);
* every ant starts on ``start`` with a tabu list (an int "stamp" array, so it is never cleared);
  at each step the allowed moves are the valid moves into unvisited cells; with none it dies;
  otherwise roulette: the first move whose cumulative weight exceeds ``u * total``; it stops on
  the goal (success) or after ``steplimit`` steps (failure);
* then ``tau *= (1 - rho)`` and every successful ant adds ``q / L`` on every move it used.

Random numbers come from numba's own generator (``np.random.seed`` inside the jitted code), so
runs are reproducible but not the same draws as jaco's; compare distributions, not paths.
Requires numba (the ``bench`` extra: ``pip install -e .[bench]``).
"""

from __future__ import annotations

import numba
import numpy as np

#: Move lengths in jaco's move order (``jaco.moves.MOVES``: 4 straight moves, then diagonals).
MOVE_LENGTHS = np.array([1.0, 1.0, 1.0, 1.0] + [np.sqrt(2.0)] * 4, dtype=np.float64)


def goal_eta(nbr: np.ndarray, width: int, goal: int) -> np.ndarray:
    """``eta (N, 8)`` = 1/max(euclidean distance of each move's target to the goal, 0.5), as
    :func:`jaco.engine.heuristics.inverse_goal_distance` (own cell where the move is not allowed)."""
    nbr = np.asarray(nbr)
    n = nbr.shape[0]
    safe = np.where(nbr >= 0, nbr, np.arange(n)[:, None])
    r, c = np.divmod(safe, width)
    gr, gc = divmod(int(goal), width)
    d = np.hypot(r - gr, c - gc)
    return 1.0 / np.maximum(d, 0.5)


def problem_arrays(grid, start, goal):
    """``(nbr, eta, start_index, goal_index)`` for a :class:`jaco.Grid` and two ``(row, col)``
    cells, with jaco's own neighbour table (8-connected, no corner cutting)."""
    from jaco.moves import neighbour_table

    nbr, _ = neighbour_table(grid.free, 8)
    s = int(start[0]) * grid.width + int(start[1])
    g = int(goal[0]) * grid.width + int(goal[1])
    return np.ascontiguousarray(nbr, np.int32), goal_eta(nbr, grid.width, g), s, g


@numba.njit(cache=False, nogil=True)
def as_colony(nbr, weights_eta, start, goal, alpha, beta, rho, q, tau0, n_ants, n_iters, steplimit, seed):
    """One ant-cycle AS run. Returns ``(best_length, best_path_cells, real_steps)``.

    ``best_path_cells`` holds the flat cells from ``start`` to ``goal`` (empty, with
    ``best_length = inf``, when no ant ever arrived); ``real_steps`` counts the steps ants
    actually took (a dead or arrived ant takes no more).
    """
    L, path, steps, _ = as_colony_stats(
        nbr, weights_eta, start, goal, alpha, beta, rho, q, tau0, n_ants, n_iters, steplimit, seed
    )
    return L, path, steps


@numba.njit(cache=False, nogil=True)
def as_colony_stats(nbr, weights_eta, start, goal, alpha, beta, rho, q, tau0, n_ants, n_iters, steplimit, seed):
    """:func:`as_colony` plus the number of ant walks that reached the goal (of ``n_ants * n_iters``)."""
    np.random.seed(seed)
    n = nbr.shape[0]
    tau = np.full((n, 8), tau0)
    etab = np.zeros((n, 8))
    for i in range(n):
        for k in range(8):
            if nbr[i, k] >= 0:
                etab[i, k] = weights_eta[i, k] ** beta
    w = np.zeros((n, 8))
    mark = np.zeros(n, np.int64)  # tabu list: mark[c] == stamp <=> visited by the current ant
    stamp = 0
    cells = np.empty((n_ants, steplimit + 1), np.int64)  # cells[a, 0] = start
    moves = np.empty((n_ants, steplimit), np.int64)
    n_steps = np.zeros(n_ants, np.int64)
    length = np.empty(n_ants)
    arrived = np.zeros(n_ants, np.bool_)
    cw = np.empty(8)
    best_length = np.inf
    best_path = np.empty(0, np.int64)
    if start == goal:
        best_length = 0.0
        best_path = np.full(1, start, np.int64)
    real_steps = 0
    arrivals = 0

    for _ in range(n_iters):
        # move weights, once per iteration
        for i in range(n):
            for k in range(8):
                if nbr[i, k] >= 0:
                    x = tau[i, k] ** alpha * etab[i, k]
                    if not (x >= 1e-30):  # also NaN, as jaco's nan_to_num + clip
                        x = 1e-30
                    elif x > 1e30:
                        x = 1e30
                    w[i, k] = x
        # the ants walk one after the other
        for a in range(n_ants):
            stamp += 1
            cur = start
            mark[cur] = stamp
            cells[a, 0] = cur
            s = 0
            L = 0.0
            while cur != goal and s < steplimit:
                total = 0.0
                for k in range(8):
                    j = nbr[cur, k]
                    if j >= 0 and mark[j] != stamp:
                        total += w[cur, k]
                    cw[k] = total
                if total <= 0.0:
                    break  # dead end: the ant dies
                x = np.random.random() * total
                pick = -1
                for k in range(8):
                    if cw[k] > x:
                        pick = k
                        break
                if pick < 0:  # u*total rounded up to total: take the last allowed move
                    for k in range(7, -1, -1):
                        j = nbr[cur, k]
                        if j >= 0 and mark[j] != stamp:
                            pick = k
                            break
                moves[a, s] = pick
                cur = nbr[cur, pick]
                mark[cur] = stamp
                s += 1
                cells[a, s] = cur
                L += MOVE_LENGTHS[pick]
            n_steps[a] = s
            length[a] = L
            arrived[a] = cur == goal
            arrivals += arrived[a]
            real_steps += s
        # evaporation, then every successful ant deposits q/L on every move it used
        keep = 1.0 - rho
        for i in range(n):
            for k in range(8):
                tau[i, k] *= keep
        for a in range(n_ants):
            if arrived[a] and length[a] > 0.0:
                d = q / length[a]
                for t in range(n_steps[a]):
                    tau[cells[a, t], moves[a, t]] += d
                if length[a] < best_length:
                    best_length = length[a]
                    best_path = cells[a, : n_steps[a] + 1].copy()
    return best_length, best_path, real_steps, arrivals


@numba.njit(cache=False, nogil=True)
def _sweep(nbr, eta, start, goal, configs, q, tau0, n_ants, n_iters, steplimit, seed):
    c = configs.shape[0]
    lengths = np.empty(c)
    steps = np.empty(c, np.int64)
    for i in range(c):
        L, _, s, _ = as_colony_stats(
            nbr, eta, start, goal, configs[i, 0], configs[i, 1], configs[i, 2],
            q, tau0, n_ants, n_iters, steplimit, seed + i,
        )
        lengths[i] = L
        steps[i] = s
    return lengths, steps


def sweep_native(configs, nbr, eta, start, goal, *, q=1.0, tau0=0.1, n_ants=50, n_iters=100, steplimit=240, seed=0):
    """Run the configurations ``configs (C, 3)`` of ``(alpha, beta, rho)`` one after the other
    on one core (configuration i uses seed ``seed + i``).

    Returns ``(best_lengths (C,), real_steps (C,))``.
    """
    configs = np.ascontiguousarray(np.asarray(configs, np.float64).reshape(-1, 3))
    return _sweep(
        np.ascontiguousarray(nbr, np.int32), np.ascontiguousarray(eta, np.float64), int(start), int(goal),
        configs, float(q), float(tau0), int(n_ants), int(n_iters), int(steplimit), int(seed),
    )
