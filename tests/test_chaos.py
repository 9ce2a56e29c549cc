"""Chaos ACO (docs/algorithms.md §7): selection function and Logistic perturbation against hand values."""

import math

import jax.numpy as jnp
import numpy as np
import pytest

import jaco
from jaco.engine import pheromone as ph
from jaco.engine.colony import move_weights
from jaco.engine.problem import make_problem
from jaco.planners import chaos

# 3 x 4, one obstacle at (1, 1); goal in the far corner.
ROWS = ["....", ".#..", "...."]
W = 4


@pytest.fixture(scope="module")
def problem():
    return make_problem(jaco.Grid.from_rows(ROWS), (0, 0), (2, 3))


def at(r, c):
    return r * W + c


def test_free_share_hand_values(problem):
    p = np.asarray(chaos.free_share(problem))
    # (0,0) → (0,1) (move 1): (0,1)'s neighbours in the map are (0,0) (0,2) (1,0) (1,1)# (1,2):
    # 4 free, minus the current cell → 3/7.
    assert p[at(0, 0), 1] == pytest.approx(3 / 7)
    # (0,0) → (1,0) (move 2): (0,0) (0,1) (1,1)# (2,0) (2,1): 4 free → 3/7.
    assert p[at(0, 0), 2] == pytest.approx(3 / 7)
    # (0,3) → (1,3) (move 2): (0,2) (0,3) (1,2) (2,2) (2,3): 5 free → 4/7.
    assert p[at(0, 3), 2] == pytest.approx(4 / 7)
    # (0,2) → (1,2) (move 2): all 8 neighbours in the map except (1,1): 7 free → 6/7.
    assert p[at(0, 2), 2] == pytest.approx(6 / 7)
    # Forbidden moves: into the obstacle, off the map, and a corner cut past (1,1).
    assert p[at(0, 0), 5] == 0 and p[at(0, 0), 0] == 0
    assert p[at(1, 2), 6] == 0  # (1,2) → (2,1) would cut the corner of (1,1)


def test_angle_share_hand_values_and_guard(problem):
    p = np.asarray(chaos.angle_share(problem))
    # From (0,0) the goal direction is (2,3); the two allowed moves are (0,1) and (1,0).
    t1, t2 = math.atan2(2, 3), math.atan2(3, 2)
    assert p[at(0, 0), 1] == pytest.approx(1 - t1 / (t1 + t2), abs=1e-6)
    assert p[at(0, 0), 2] == pytest.approx(1 - t2 / (t1 + t2), abs=1e-6)
    assert p[at(0, 0), [0, 3, 4, 5, 6, 7]].tolist() == [0] * 6
    # From (2,2) the goal is straight along move 1; allowed: 0 (up), 1, 3 (left), 4 (up-right).
    theta = {0: math.pi / 2, 1: 0.0, 3: math.pi, 4: math.pi / 4}
    total = sum(theta.values())
    for k, th in theta.items():
        assert p[at(2, 2), k] == pytest.approx(1 - th / total, abs=1e-6)
    # At the goal every angle is 0 (no direction): the guard gives 1 on every allowed move.
    allowed = np.asarray(problem.nbr[at(2, 3)]) >= 0
    assert (p[at(2, 3)][allowed] == 1).all() and (p[at(2, 3)][~allowed] == 0).all()


def test_selection_is_the_product_and_enters_the_weights_with_gamma(problem):
    sel = np.asarray(chaos.selection(problem))
    expected = np.asarray(chaos.free_share(problem)) * np.asarray(chaos.angle_share(problem))
    np.testing.assert_allclose(sel, expected, rtol=1e-6)
    t1, t2 = math.atan2(2, 3), math.atan2(3, 2)
    assert sel[at(0, 0), 1] == pytest.approx(3 / 7 * (1 - t1 / (t1 + t2)), abs=1e-6)

    v = chaos.CHAOS_ACO
    classic = v._replace(factor=jaco.PLANNERS["as"].factor)  # the same weights without the shares
    trail = ph.Trail(jnp.full(8 * problem.n_cells, 0.5, jnp.float32), 0.0, jnp.inf)
    valid = np.asarray(problem.nbr) >= 0
    for gamma in (0.0, 1.0, 2.5):
        params = v.default_params().replace(gamma=gamma)
        w = np.asarray(move_weights(v, trail, problem, params, 0, 10), np.float64)
        base = np.asarray(move_weights(classic, trail, problem, params, 0, 10), np.float64)
        want = np.where(valid, base * sel**gamma, 0.0)
        rows = valid.any(axis=1)
        want[rows] /= want[rows].max(axis=1, keepdims=True)  # each cell's weights scaled to a top of 1
        want = np.where(valid, np.maximum(want, 1e-30), 0.0)
        np.testing.assert_allclose(w, want, rtol=1e-5)
        assert (w[valid] > 0).all()  # a zero share never kills the only way on
    # At (0,0) with α = β = 0 the roulette odds are the selection function's own.
    params = v.default_params().replace(alpha=0.0, beta=0.0, gamma=1.0)
    w = np.asarray(move_weights(v, trail, problem, params, 0, 10))[at(0, 0)]
    assert w[1] / w[2] == pytest.approx((1 - t1 / (t1 + t2)) / (1 - t2 / (t1 + t2)), rel=1e-5)


def test_logistic_against_hand_iteration():
    def by_hand(h, n, mu=4.0):
        for _ in range(n):
            h = mu * h * (1 - h)
        return h

    for h0 in (0.3, 0.1, 0.77):
        for n in (0, 1, 2, 5):
            assert float(chaos.logistic(h0, 4.0, n)) == pytest.approx(by_hand(h0, n), abs=1e-5)
    assert float(chaos.logistic(0.3, 4.0, 1)) == pytest.approx(0.84)
    assert float(chaos.logistic(0.3, 4.0, 2)) == pytest.approx(0.5376)
    assert float(chaos.logistic(0.3, 4.0, 3)) == pytest.approx(0.99434496, abs=1e-6)
    assert float(chaos.logistic(0.75, 4.0, 9)) == pytest.approx(0.75)  # fixed point 1 − 1/μ
    # Vectorised, with a count that is a traced value.
    got = chaos.logistic(jnp.array([0.3, 0.1]), 4.0, jnp.float32(2.0))
    np.testing.assert_allclose(np.asarray(got), [0.5376, by_hand(0.1, 2)], rtol=1e-5)


def _walks(costs, targets):
    m = 6
    t = np.array(targets, np.int32)
    t = np.where(t < 0, m, t)
    step_len = jnp.asarray((t < m).astype(np.float32))
    return ph.Walks(jnp.asarray(t), step_len, jnp.asarray(costs, jnp.float32), None, None, None)


def test_chaos_perturbation_hand_values():
    # Four ants; steps are rows, -1 = no step. Mean length = (2 + 7 + 9 + 1)/4 = 4.75:
    # ants 1 (7) and 2 (9) are above it (N_L = 2), ants 0 and 3 at or below.
    targets = [[0, 1, 3, 1], [-1, 2, 4, -1], [-1, 3, -1, -1]]
    walks = _walks([2.0, 7.0, 9.0, 1.0], targets)
    tau = jnp.array([1.0, 2.0, 3.0, 4.0, 5.0, 6.0])
    params = jaco.Params(chaos_iters=2.0, chaos_mu=4.0)
    out = chaos.chaos_perturb().update(ph.Trail(tau, 0.0, jnp.inf), walks, None, params)
    # Elements of the N_L paths: {1, 2, 3, 4}, τmin = 2, τmax = 5.
    # Ant 1: τ_l = (2+3+4)/3 = 3, h0 = 1/3 → 8/9 → 32/81;  τ = 2 + 3·32/81.
    # Ant 2: τ_l = (4+5)/2 = 4.5, h0 = 5/6 → 5/9 → 80/81; τ = 2 + 3·80/81.
    new1, new2 = 2 + 3 * 32 / 81, 2 + 3 * 80 / 81
    want = [1.0, 2.0, new1, (new1 + new2) / 2, new2, 6.0]  # element 1 is also on ant 3's path
    np.testing.assert_allclose(np.asarray(out.tau), want, rtol=1e-5)

    # The global update after it: only the ants at or below the mean deposit Q/L.
    amounts = np.asarray(chaos.at_or_below_mean_cycle(walks, jaco.Params(q=2.0)))  # one per ant
    np.testing.assert_allclose(amounts, [1.0, 0.0, 0.0, 2.0])


def test_no_perturbation_when_no_path_is_above_the_mean():
    # Equal lengths and a failed ant; the float32 mean of three x is one ulp above x here.
    x = np.float32(0.17985597)
    walks = _walks([x, x, x, math.inf], [[0, 1, 2, 3], [4, -1, -1, 5]])
    tau = jnp.array([1.0, 2.0, 3.0, 4.0, 5.0, 6.0])
    out = chaos.chaos_perturb().update(ph.Trail(tau, 0.0, jnp.inf), walks, None, jaco.PLANNERS["chaos-aco"].default_params())
    np.testing.assert_array_equal(np.asarray(out.tau), np.asarray(tau))
    amounts = np.asarray(chaos.at_or_below_mean_cycle(walks, jaco.Params(q=1.0)))  # one per ant
    np.testing.assert_allclose(amounts, [1 / x, 1 / x, 1 / x, 0.0], rtol=1e-6)


@pytest.mark.slow  # a sweep of its own parameters (chaos-aco runs the contract in the slow checks)
def test_chaos_aco_is_registered_and_sweeps_its_own_parameters():
    v = jaco.PLANNERS["chaos-aco"]
    assert {"gamma", "chaos_iters", "chaos_mu"} <= set(v.params)
    grid = jaco.maps.random_map(10, 0.2, seed=1)
    table = jaco.sweep(grid, (0, 0), (9, 9), "chaos-aco", params={"gamma": [0.0, 3.0], "chaos_iters": [1, 20]},
                       seeds=1, n_ants=8, n_iters=4)
    assert len(table) == 4 and table.success.all()
    with pytest.raises(jaco.ParamError, match="chaos_mu"):
        jaco.solve(grid, (0, 0), (9, 9), "chaos-aco", chaos_mu=4.5)
