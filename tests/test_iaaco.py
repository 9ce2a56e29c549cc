"""IAACO (Miao et al. 2021) and the multi-objective cost: what the shared contract
(tests/test_variants.py) does not cover — the equations' values by hand, the in-jit cost against
the numpy metrics, and quality against the exact optimum."""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaco
from jaco.engine import cost as costs
from jaco.engine.colony import move_weights
from jaco.engine.heuristics import inverse_goal_distance
from jaco.engine.params import Params
from jaco.engine.pheromone import Trail, Walks
from jaco.engine.problem import make_problem, to_device
from jaco.engine.result import path_cells
from jaco.engine.walk import walk
from jaco.metrics import heading_change, path_length, safety_cost, validate_path
from jaco.moves import MOVES
from jaco.planners import iaaco
from jaco.planners.registry import with_cost

SQ2 = math.sqrt(2.0)
GAP_MAX = {"iaaco": 0.05, "iaaco-printed": 0.15}  # measured: 0 % on all four maps; printed μ up to 10 %
OPEN5 = jaco.Grid.from_rows(["....."] * 5)


def _move(a, b):
    """Move index of the step a → b."""
    return [tuple(m) for m in MOVES.tolist()].index((b[0] - a[0], b[1] - a[1]))


def _at(table, grid, a, b):
    """Entry of an ``(N, 8)`` table for the move a → b."""
    return float(np.asarray(table)[grid.index(a), _move(a, b)])


# -- heuristic (1, 2) ------------------------------------------------------------------------
def test_eps_and_heuristic_by_hand():
    # Nc = t + 1: ε = exp(−2·(5/10)²) = e^(−1/2) at t = 4, e^(−2) at the last iteration.
    assert float(iaaco.adaptive_eps(jnp.int32(4), 10)) == pytest.approx(math.exp(-0.5), rel=1e-6)
    assert float(iaaco.adaptive_eps(jnp.int32(9), 10)) == pytest.approx(math.exp(-2.0), rel=1e-6)
    prob = to_device(make_problem(OPEN5, (0, 0), (4, 4)))
    p = Params(sigma1=0.1, sigma2=0.9)
    eta = iaaco.iaaco_heuristic(prob, p, jnp.int32(4), 10)
    e = math.exp(-0.5)
    # (0,0) → (1,1): d_ij = √2, d_jG = √18; (3,3) → (4,4) is the goal: d_jG = 0.
    assert _at(eta, OPEN5, (0, 0), (1, 1)) == pytest.approx(e / (0.1 * SQ2 + 0.9 * math.sqrt(18)), rel=1e-5)
    assert _at(eta, OPEN5, (3, 3), (4, 4)) == pytest.approx(e / (0.1 * SQ2), rel=1e-5)
    # ε is one factor for all moves of an iteration, so it cancels in the normalised rule (3).
    late = iaaco.iaaco_heuristic(prob, p, jnp.int32(9), 10)
    ratio = np.asarray(eta) / np.asarray(late)
    assert np.allclose(ratio, math.exp(-0.5) / math.exp(-2.0), rtol=1e-5)


# -- angle guidance (4) and obstacle exclusion (5) -------------------------------------------
def test_angle_guidance_printed_and_robust_by_hand():
    prob = to_device(make_problem(OPEN5, (0, 0), (4, 4)))
    p = Params(mu_min=0.1)
    printed, robust = iaaco.mu_printed(prob, p), iaaco.mu_robust(prob, p)
    # Target (0,1): j→G = (4, 3), d_jG = 5; S→G = (4, 4).
    assert _at(printed, OPEN5, (0, 0), (0, 1)) == pytest.approx(4 / 5, rel=1e-6)
    assert _at(robust, OPEN5, (0, 0), (0, 1)) == pytest.approx((16 + 12) / (5 * math.sqrt(32)), rel=1e-6)
    # Target (4,3) on the goal's row: the printed μ vanishes (floored at μ_min), the robust one is cos 45°.
    assert _at(printed, OPEN5, (4, 2), (4, 3)) == pytest.approx(0.1)
    assert _at(robust, OPEN5, (4, 2), (4, 3)) == pytest.approx(1 / SQ2, rel=1e-6)
    # The goal itself: 1 in both forms; a target on the S→G line: robust μ = 1.
    assert _at(printed, OPEN5, (3, 3), (4, 4)) == 1.0 and _at(robust, OPEN5, (3, 3), (4, 4)) == 1.0
    assert _at(robust, OPEN5, (1, 1), (2, 2)) == pytest.approx(1.0, rel=1e-6)
    # Beyond the goal, j→G points back: cos = −1, floored at μ_min.
    beyond = to_device(make_problem(OPEN5, (0, 0), (2, 2)))
    assert _at(iaaco.mu_robust(beyond, p), OPEN5, (2, 2), (3, 3)) == pytest.approx(0.1)


def test_obstacle_exclusion_by_hand():
    grid = jaco.Grid.from_rows([".......", ".......", ".......", "...#...", ".......", ".......", "......."])
    prob = to_device(make_problem(grid, (0, 0), (6, 6)))
    # Clearances: (2,3) next to the pillar 1, (2,2) diagonal √2, (1,3) 2, (0,3) on the map's edge 1.
    def xi(rs, a, b):
        return _at(iaaco.obstacle_exclusion(prob, Params(rs=rs)), grid, a, b)

    assert xi(0.5, (1, 3), (2, 3)) == pytest.approx(0.5)  # Rs ≤ 1 ≤ 2Rs: Rs/d_b
    assert xi(0.5, (1, 2), (2, 2)) == 1.0  # √2 > 2Rs
    assert xi(0.5, (0, 2), (0, 3)) == pytest.approx(0.5)  # the map's edge counts as an obstacle
    assert xi(1.0, (1, 2), (2, 2)) == pytest.approx(1 / SQ2, rel=1e-6)
    assert xi(1.0, (0, 3), (1, 3)) == pytest.approx(0.5)  # d_b = 2 = 2Rs
    assert xi(1.5, (1, 3), (2, 3)) == 0.0  # d_b < Rs: excluded
    assert xi(1.5, (5, 5), (6, 6)) == 1.0  # ... but never the goal (d_b = 1 there)


def test_weights_are_eq3_scaled_per_cell():
    grid = jaco.Grid.from_rows([".....", ".....", "..#..", ".....", "....."])
    prob = to_device(make_problem(grid, (0, 0), (4, 4)))
    v = jaco.PLANNERS["iaaco"]
    p = v.default_params().replace(alpha=1.5, beta=12.0, lam=2.0, rs=1.0)
    n = grid.n_cells
    tau = jnp.asarray(np.random.default_rng(0).uniform(0.01, 3.0, 8 * n), jnp.float32)
    trail = Trail(tau, jnp.float32(0.01), jnp.float32(jnp.inf))
    w = np.asarray(move_weights(v, trail, prob, p, jnp.int32(0), 10), np.float64)
    eta = np.asarray(iaaco.iaaco_heuristic(prob, p, jnp.int32(0), 10), np.float64)
    mu = np.asarray(iaaco.mu_robust(prob, p), np.float64)
    xi = np.asarray(iaaco.obstacle_exclusion(prob, p), np.float64)
    full = np.asarray(tau, np.float64).reshape(n, 8) ** 1.5 * eta**12 * mu**2 * xi  # Eq. (3)
    valid = np.asarray(prob.nbr) >= 0
    full = np.where(valid, full, 0.0)
    rows = valid.any(axis=1)
    want = full[rows] / full[rows].max(axis=1, keepdims=True)
    assert np.allclose(w[rows], want, rtol=1e-4) and (w[~valid] == 0).all()
    # ε (late: e^(−2·12) on η^β) changes no weight: it cancels in every row.
    late = np.asarray(move_weights(v, trail, prob, p, jnp.int32(9), 10))
    assert np.allclose(late, w, rtol=1e-4)


# -- pseudo-random rule (6, 7), ρ (10), best/worst update (8, 9) -----------------------------
def test_q0_schedule_by_hand():
    p = Params(delta0=0.3)
    assert float(iaaco.q0_schedule(p, jnp.int32(9), 10).q0) == pytest.approx(0.3 * math.exp(-0.5), rel=1e-6)
    assert float(iaaco.q0_schedule(p, jnp.int32(0), 100).q0) == pytest.approx(0.3 * math.exp(-0.5e-4), rel=1e-6)


def test_adaptive_rho_by_hand():
    prob = to_device(make_problem(OPEN5, (0, 0), (4, 3)))  # L_SG = 5
    p = Params(k_rho=0.3, rho=0.9)
    assert float(iaaco.adaptive_rho(prob, jnp.float32(6.0), p)) == pytest.approx(0.3 * 5 / 6, rel=1e-6)
    assert float(iaaco.adaptive_rho(prob, jnp.float32(1.0), p)) == pytest.approx(0.9)  # clipped
    assert float(iaaco.adaptive_rho(prob, jnp.float32(jnp.inf), p)) == 0.0


def _walks(targets, cost):
    targets = jnp.asarray(targets, jnp.int32)
    cost = jnp.asarray(cost, jnp.float32)
    return Walks(targets, jnp.ones(targets.shape, jnp.float32), cost, targets[:, 0], jnp.ones(targets.shape[:1]), cost[0])


def test_best_worst_update_by_hand():
    grid = jaco.Grid.from_rows(["...", "...", "..."])
    prob = to_device(make_problem(grid, (0, 0), (2, 2)))  # L_SG = √8
    m = 8 * grid.n_cells
    p = Params(q=2.5, k_rho=0.5, rho=0.9, tau0=1.0, tau_min=0.01)
    rule = iaaco.best_worst()
    trail = Trail(jnp.ones(m, jnp.float32), jnp.float32(0.01), jnp.float32(jnp.inf))
    # Steps as columns: ant 0 uses elements 5, 9 (J = 4), ant 1 uses 5, 20 (J = 6), ant 2 failed.
    walks = _walks([[5, 5, 30], [9, 20, 31]], [4.0, 6.0, np.inf])
    tau = np.asarray(rule.update(trail, walks, prob, p).tau)
    rho = 0.5 * math.sqrt(8) / 4
    best = (1 - rho) + rho * (2.5 / 4) * (4 + 6) / 2  # Eq. (8)
    assert tau[9] == pytest.approx(best, rel=1e-6)
    assert tau[20] == pytest.approx((1 - rho) - rho * 2.5 / 6, rel=1e-6)  # Eq. (9)
    assert tau[5] == pytest.approx((1 - rho) * best - rho * 2.5 / 6, rel=1e-6)  # both, (8) then (9)
    others = np.delete(tau, [5, 9, 20])
    assert (others == 1.0).all()  # elements on neither path (and the failed ant's) keep τ
    # τ ≥ τmin: the worst path of a weak trail is floored.
    weak = trail._replace(tau=jnp.full(m, 0.02, jnp.float32))
    assert float(rule.update(weak, walks, prob, p).tau[20]) == pytest.approx(0.01)
    # No successful ant: nothing changes.
    none = _walks([[5, 5, 30], [9, 20, 31]], [np.inf] * 3)
    assert np.array_equal(np.asarray(rule.update(trail, none, prob, p).tau), np.asarray(trail.tau))


# -- the multi-objective cost ----------------------------------------------------------------
def test_multi_objective_equals_the_numpy_metrics_on_every_ant():
    grid = jaco.maps.random_map(12, 0.2, seed=4)
    prob = make_problem(grid, grid.meta["start"], grid.meta["goal"])
    p = Params(k_len=0.7, k_safe=0.4, k_energy=0.3, rs_cost=1.5)
    steplimit = 60
    # Goal-seeking random walks (η^4, η = 1/goal distance): some arrive, all differ.
    eta = inverse_goal_distance(to_device(prob), p, 0, 1)
    weights = jnp.where(jnp.asarray(prob.nbr) >= 0, eta**4, 0.0)
    tours = jax.jit(lambda pr, k: walk(pr, weights, k, 0.0, n_ants=32, steplimit=steplimit, exploit=False))(
        prob, jax.random.key(0))
    s, e, j = (np.asarray(f(tours, prob, p)) for f in (costs.safety, costs.energy, costs.multi_objective))
    assert 0 < np.asarray(tours.arrived).sum() < 32 and (np.asarray(tours.n_steps) > 2).all()
    for a in range(32):
        path = path_cells(grid, grid.meta["start"], np.asarray(tours.cells)[:, a])
        assert s[a] == pytest.approx(safety_cost(grid, path, rs=1.5), rel=1e-5)
        assert e[a] == pytest.approx(heading_change(path), rel=1e-5, abs=1e-5)
        want = 0.7 * path_length(path) + 0.4 * s[a] + 0.3 * heading_change(path)
        assert j[a] == pytest.approx(want, rel=1e-5)
    assert s.min() < s.max() and e.min() < e.max()  # both actually vary between paths


def test_iaaco_result_cost_and_metrics_agree():
    grid = jaco.maps.random_map(12, 0.2, seed=3)
    r = jaco.solve(grid, *(grid.meta[k] for k in ("start", "goal")), "iaaco", seed=0, n_ants=16, n_iters=10, rs_cost=1.5)
    m = r.metrics()
    assert {"length", "turns", "heading_change", "safety", "coverage", "best_iteration", "cost"} <= set(m)
    assert m["safety"] == pytest.approx(safety_cost(grid, r.path, rs=1.5)) and m["safety"] > 0
    want = 0.7 * r.length + 0.1 * m["safety"] + 0.2 * m["heading_change"]
    assert r.cost == pytest.approx(want, rel=1e-5)
    assert m["coverage"] == r.coverage and m["best_iteration"] == r.best_iteration


def test_with_cost_any_variant_cached():
    acs_multi = with_cost("acs", "multi")
    assert acs_multi is with_cost("acs", "multi") and acs_multi.name == "acs+multi"
    assert acs_multi is jaco.planners.registry.with_cost("acs", "multi")  # the registry by its module path
    assert set(costs.COST_PARAMS) <= set(acs_multi.params)
    assert with_cost("iaaco", "multi") is jaco.PLANNERS["iaaco"]  # already its cost
    with pytest.raises(jaco.ParamError, match="unknown cost"):
        with_cost("acs", "energy")
    grid = jaco.maps.random_map(12, 0.2, seed=3)
    ends = grid.meta["start"], grid.meta["goal"]
    # Also through a variant with its own construct step (IACA's backtracking ants).
    for v in (acs_multi, with_cost("iaca", "multi")):
        r = jaco.solve(grid, *ends, v, seed=1, n_ants=8, n_iters=4, k_energy=0.5)
        m = r.metrics()
        assert r.cost == pytest.approx(0.7 * r.length + 0.1 * m["safety"] + 0.5 * m["heading_change"], rel=1e-5)
    plain = with_cost("iaaco", "length")
    assert plain.name == "iaaco+length" and plain.cost is costs.path_length


def test_bad_parameters_are_clear_errors():
    grid = jaco.maps.random_map(8, 0.1, seed=0)
    for bad in (dict(k_rho=1.0), dict(mu_min=0.0), dict(rs=0.0), dict(k_len=0.0), dict(delta0=1.5)):
        with pytest.raises(jaco.ParamError):
            jaco.solve(grid, (0, 0), (7, 7), "iaaco", n_ants=4, n_iters=2, **bad)


# -- quality ---------------------------------------------------------------------------------
@pytest.mark.parametrize("name", ["iaaco", pytest.param("iaaco-printed", marks=pytest.mark.slow)])
def test_near_the_exact_optimum_on_small_random_maps(name):
    grids = [jaco.maps.random_map(16, p, seed=s) for p, s in ((0.1, 1), (0.2, 2), (0.2, 3), (0.3, 4))]
    gaps = []
    for g in grids:
        r = jaco.solve(g, (0, 0), (15, 15), name, seed=0, n_ants=30, n_iters=40)
        assert r.success and validate_path(g, r.path, (0, 0), (15, 15)) == []
        gaps.append(r.gap)
    assert max(gaps) <= GAP_MAX[name], gaps
