"""IACA (thesis chapter 4): the variant contract, backtracking on hand-made maps, the pieces
against hand-computed values, backtracking ants against dying ants, and quality."""

import dataclasses
import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaco
from jaco.engine.params import Params
from jaco.engine.pheromone import Trail
from jaco.engine.problem import make_problem, to_device
from jaco.engine.run import TRACES
from jaco.metrics import validate_path
from jaco.planners.iaca import (
    IACA,
    backtrack_walk,
    detour,
    eta_45,
    goal_closeness,
    iaca_init,
    infeasible_cells,
    infeasible_update,
    local_update,
)

SMALL = dict(n_ants=16, n_iters=12, keep_pheromone=True)  # one compiled run per map shape
P = IACA.default_params()


def _ends(grid):
    return grid.meta["start"], grid.meta["goal"]


# -- beyond the shared contract (tests/test_variants.py runs it on "iaca" too) ----------------------
def test_path_is_simple_and_pheromone_within_fixed_bounds():
    grid = jaco.maps.named("utrap-15")
    r = jaco.solve(grid, *_ends(grid), IACA, seed=0, **SMALL)
    assert r.success and validate_path(grid, r.path, *_ends(grid)) == []
    assert len({tuple(c) for c in r.path}) == len(r.path)  # no loop: the stack is a simple path
    tau = r.pheromone
    assert tau.shape == (grid.n_cells,) and np.isfinite(tau).all()
    assert tau.min() >= P.tau_min and tau.max() <= P.tau_max


def test_parameter_order_is_checked_before_compiling():
    grid = jaco.Grid.from_rows(["..#..", "..#..", "..#.."])
    before = TRACES[IACA.name]
    with pytest.raises(jaco.ParamError, match="q1 < q2"):
        jaco.solve(grid, (0, 0), (2, 1), IACA, n_ants=4, n_iters=2, q1=6.0)
    assert TRACES[IACA.name] == before


def test_documented():
    assert IACA.doc.startswith("Hua Lu 2011") and "4-5" in IACA.doc and "4-6" in IACA.doc
    assert IACA.pheromone_on == "cells"


# -- backtracking on a hand-made map ---------------------------------------------------------------
# The greedy ant heads down column 0 toward G and runs into a dead end at (2, 0); it must back
# out twice to S and go round: 2 forward steps, 2 back-steps, then 12 forward steps to G.
SPUR = jaco.Grid.from_rows([".....", ".###.", ".###.", "####.", "....."])
SPUR_START, SPUR_GOAL = (0, 0), (4, 0)
SPUR_PATH = [(0, 0), (0, 1), (0, 2), (0, 3), (0, 4), (1, 4), (2, 4), (3, 4), (4, 4), (4, 3), (4, 2), (4, 1), (4, 0)]
GREEDY = dict(n_ants=1, n_iters=1, q0=1.0)  # argmax only: the walk is deterministic


WALK_LIMIT = 32  # one compiled walk shape for the direct walk tests below
_jit_walk = jax.jit(backtrack_walk, static_argnames=("n_ants", "steplimit", "exploit"))


def _walk(goal=SPUR_GOAL, q0=1.0, n_ants=64):
    """Direct walks of ``n_ants`` ants on SPUR (first iteration's pheromone); ``goal`` may be a
    cell no ant can reach (the problem is built for SPUR_GOAL, then pointed elsewhere)."""
    problem = make_problem(SPUR, SPUR_START, SPUR_GOAL)
    problem = to_device(dataclasses.replace(problem, goal=np.int32(SPUR.index(goal))))
    params = P.replace(q0=q0)
    trail = iaca_init().init(Trail(jnp.zeros(SPUR.n_cells), 0.0, jnp.inf), problem, params)
    return jax.device_get(_jit_walk(problem, trail, params, jax.random.key(0), n_ants=n_ants, steplimit=WALK_LIMIT))


def test_ant_backs_out_of_a_dead_end_and_the_path_has_no_dead_branch():
    r = jaco.solve(SPUR, SPUR_START, SPUR_GOAL, IACA, seed=0, steplimit=16, **GREEDY)
    assert r.success and [tuple(c) for c in r.path] == SPUR_PATH
    assert r.length == pytest.approx(12.0) and r.gap == pytest.approx(0.0, abs=1e-6)
    w = _walk()
    assert w.arrived.all() and (w.actions == 16).all() and (w.sp == 12).all()
    # The dead branch (1,0), (2,0) was entered but is not on the returned stack: eq. 4-6's cells.
    dead = [SPUR.index((1, 0)), SPUR.index((2, 0))]
    assert w.visited[dead].all() and w.infeasible[dead].all() and w.infeasible.sum() == 2
    assert w.stack[0, :13].tolist() == [SPUR.index(c) for c in SPUR_PATH] and (w.stack[0, 13:] == -1).all()


def test_back_steps_count_toward_the_step_limit():
    # 12 forward steps would do, but the 2 back-steps out of the spur count too.
    r = jaco.solve(SPUR, SPUR_START, SPUR_GOAL, IACA, seed=0, steplimit=15, **GREEDY)
    assert not r.success and r.history["success_rate"][0] == 0


def test_ant_dies_back_at_the_start_with_nothing_left():
    # Goal on an obstacle: a depth-first search of all 15 reachable cells (14 steps forward,
    # 14 back), then death at the start with steps to spare.
    w = _walk(goal=(1, 1), q0=0.5)
    assert not w.arrived.any() and (w.sp == 0).all() and (w.actions == 2 * 14).all()
    assert w.visited.sum() == SPUR.n_free and (w.infeasible == w.visited).all()  # every cell of a failed ant


def test_many_random_ants_all_arrive_on_a_simple_path():
    w = _walk(q0=0.3, n_ants=200)
    # Each ant either goes round at once (12 steps) or first backs out of the spur (16); the
    # first move is "right" with probability 0.7 x 7.4 %, so some of 200 ants take it.
    assert w.arrived.all() and set(w.actions.tolist()) == {12, 16}
    for a in range(w.stack.shape[0]):
        assert w.stack[a, : w.sp[a] + 1].tolist() == [SPUR.index(c) for c in SPUR_PATH]  # the only simple path
    assert np.isfinite(w.tau).all() and w.tau.min() >= P.tau_min and w.tau.max() <= P.tau_max


# -- the pieces against hand-computed values ------------------------------------------------------
def test_heuristic_4_5_on_a_hand_computed_example():
    grid = jaco.Grid.from_rows(["...", "...", "..."])
    problem = to_device(make_problem(grid, (0, 0), (2, 2)))
    a = grid.index((1, 1))
    r = np.asarray(detour(problem)[a])
    s2, s5 = math.sqrt(2), math.sqrt(5)
    # Moves up, right, down, left, up-right, down-right, down-left, up-left; goal E = (2, 2).
    expected = [1 + s5, 2, 2, 1 + s5, s2 + 2, s2, s2 + 2, s2 + 2 * s2]
    assert r == pytest.approx(expected, rel=1e-6)
    every = np.ones(8, bool)
    assert np.asarray(eta_45(r, every)) == pytest.approx(1 - np.array(expected) / sum(expected), rel=1e-6)
    # Tabu leaves right and down-right: η = 1 − 2/(2 + √2), 1 − √2/(2 + √2).
    two = np.zeros(8, bool)
    two[[1, 5]] = True
    eta = np.asarray(eta_45(r, two))
    assert eta[[1, 5]] == pytest.approx([1 - 2 / (2 + s2), 1 - s2 / (2 + s2)], rel=1e-6)
    assert (eta[~two] == 0).all()
    one = np.zeros(8, bool)
    one[3] = True  # a single allowed move keeps η = 1 (the formula's 0 would forbid it)
    assert np.asarray(eta_45(r, one)).tolist() == [0, 0, 0, 1, 0, 0, 0, 0]


def test_initialisation_from_the_goal_distance():
    grid = jaco.Grid.from_rows(["....", ".#..", "...."])
    problem = to_device(make_problem(grid, (0, 0), (2, 3)))
    params = P.replace(k_init=10.0, tau_min=0.5, tau_max=8.0)
    trail = iaca_init().init(Trail(jnp.zeros(grid.n_cells), 0.0, jnp.inf), problem, params)
    d = np.hypot(*(np.indices(grid.shape).reshape(2, -1) - np.array([[2], [3]])))
    dmax = d[grid.free.ravel()].max()  # (0, 0)
    expected = np.clip(10 * (1 - d / dmax), 0.5, 8.0)
    free = grid.free.ravel()
    assert np.asarray(trail.tau)[free] == pytest.approx(expected[free], rel=1e-5)
    assert float(trail.lo) == 0.5 and float(trail.hi) == 8.0
    assert np.asarray(goal_closeness(problem))[grid.index((2, 3))] == 1.0


def test_infeasible_update_4_6_four_branches():
    p = Params(q1=1.0, q2=5.0, q3=15.0, rho1=0.7, rho2=0.2, q_step=0.5)
    tau = jnp.array([0.5, 1.0, 3.0, 5.0, 10.0, 15.0, 18.0])
    # P ≤ Q1: P + q; Q1 < P ≤ Q2: ρ1 P; Q2 < P ≤ Q3: ρ2 P; P > Q3: P − q.
    assert np.asarray(infeasible_update(tau, p)) == pytest.approx([1.0, 1.5, 2.1, 3.5, 2.0, 3.0, 17.5])


def test_infeasible_cells_are_dead_branches_and_failed_walks_but_not_good_paths():
    # Two ants on 6 cells. Ant 0 arrived with path 0-1-2 after popping 3; ant 1 failed having
    # visited 0, 1, 4 and 2 (cell 2 is on ant 0's path, so it is spared).
    stack = jnp.array([[0, 1, 2, -1], [0, 1, 4, 2]])  # final paths, -1 padded
    arrived = jnp.array([True, False])
    tabu = jnp.zeros((2, 6), bool).at[0, jnp.array([0, 1, 2, 3])].set(True).at[1, jnp.array([0, 1, 2, 4])].set(True)
    assert np.asarray(infeasible_cells(stack, arrived, tabu)).tolist() == [False, False, False, True, True, False]


def test_local_update_of_several_ants_entering_one_cell_in_one_step():
    p = P.replace(rho_local=0.1, q=3.0)
    tau = jnp.array([5.0, 5.0, 19.0, 7.0])
    # Two ants enter cell 0 by straight moves (Q/d = 3 each), one enters cell 1 diagonally
    # (Q/d = 3/√2) and one cell 2 straight; nobody enters cell 3.
    straight, diagonal = jnp.array([2, 0, 1, 0]), jnp.array([0, 1, 0, 0])
    out = np.asarray(local_update(tau, 0.01, 20.0, straight, diagonal, p))
    sequential = 0.9 * (0.9 * 5.0 + 3.0) + 3.0  # the two updates one after the other: 9.75
    assert out == pytest.approx([sequential, 0.9 * 5.0 + 3.0 / math.sqrt(2), 20.0, 7.0])  # cell 2 clamped to τmax


# -- backtracking ants survive a concave trap where dying ants do not --------------------------------
def test_as_ants_die_in_a_u_trap_where_iaca_ants_back_out():
    grid = jaco.maps.named("utrap-20")
    start, goal = _ends(grid)
    runs = dict(n_ants=50, n_iters=3, steplimit=160)
    for seed in (0, 1):
        dying = jaco.solve(grid, start, goal, "as", seed=seed, beta=8.0, **runs)
        backing = jaco.solve(grid, start, goal, IACA, seed=seed, **runs)
        assert dying.history["success_rate"][0] <= 0.04  # at most 2 of 50 greedy ants escape
        assert backing.history["success_rate"][0] >= 0.5 and backing.success
        assert validate_path(grid, backing.path, start, goal) == []


# -- quality (a small version of the table in docs/planners.md, IACA) ---------------------------------
def test_quality_on_random_maps_median_gap_within_3_percent():
    names = ["random-30-05", "random-30-10", "random-30-30", "random-30-50"]
    grids = [jaco.maps.named(n) for n in names]
    starts, goals = [g.meta["start"] for g in grids], [g.meta["goal"] for g in grids]
    # the step limit of the table (then the default, 4·(H + W); backtracking ants now get more)
    table = jaco.sweep(grids, starts, goals, IACA, seeds=range(6), n_ants=50, n_iters=100, steplimit=240)
    assert table.success.all()
    assert (table.groupby("map").gap.median() <= 0.03).all()
    assert table.gap.max() <= 0.06
