"""APF-ACO (Dong & Zhao 2021): the improved APF planner, the APF distance table, the heuristic (10), the
best-half update (11, 12) and the variants apf-aco / pf-aco. The contract every variant passes is
in tests/test_variants.py (``-k apf``)."""

import doctest
import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaco
from jaco import apf, potential
from jaco.engine import pheromone as ph
from jaco.engine.problem import make_problem
from jaco.metrics import line_of_sight, validate_path
from jaco.planners import apf_guided

SQ2 = math.sqrt(2.0)

# A vertical wall between start and goal: the chain of intermediate points goes over its top end.
WALL = jaco.Grid.from_rows([
    ".........",
    ".........",
    "....#....",
    "....#....",
    "....#....",
    ".........",
    ".........",
])


def octile(a, b):
    dr, dc = abs(a[0] - b[0]), abs(a[1] - b[1])
    return max(dr, dc) + (SQ2 - 1) * min(dr, dc)


@pytest.fixture(scope="module")
def maps12():
    """Three 12x12 maps (one shape, so every jitted table compiles once)."""
    return [jaco.maps.random_map(12, 0.15, seed=0), jaco.maps.random_map(12, 0.3, seed=3), jaco.maps.utrap(12)]


_next = jax.jit(potential.jax_apf_next)  # the definition (tests/test_native.py: the kernel equals it)
_lengths = jax.jit(potential.chain_lengths)


# -- geometry ----------------------------------------------------------------------------------
def test_segment_crossing_matches_line_of_sight_and_the_jax_dda(maps12):
    """The supercover the intermediate points are built on is metrics.line_of_sight's, and the
    JAX DDA finds the same last effective obstacle as the numpy reference."""
    grid = maps12[1]
    prob = make_problem(grid, grid.meta["start"], grid.meta["goal"])
    ref = apf._Ref(grid, grid.meta["goal"], np.asarray(prob.nbr))
    free = jnp.asarray(grid.free.ravel())
    rng = np.random.default_rng(0)
    cells = np.argwhere(grid.free)
    pairs = cells[rng.integers(0, len(cells), size=(300, 2))]  # (300, 2 ends, 2)
    last = jax.jit(jax.vmap(lambda a, b: potential._last_blocked_j(free, jnp.int32(12), a, b)))(
        jnp.asarray(pairs[:, 0], jnp.int32), jnp.asarray(pairs[:, 1], jnp.int32)
    )
    seen_blocked = 0
    for (a, b), got in zip(pairs, np.asarray(last)):
        a, b = tuple(int(x) for x in a), tuple(int(x) for x in b)
        o = ref.last_blocked(a, b)
        assert (o is None) == line_of_sight(grid, a, b)
        assert got == (-1 if o is None else o[0] * 12 + o[1])
        seen_blocked += o is not None
    assert 50 < seen_blocked < 290  # both kinds of segment were exercised


# -- the planner ---------------------------------------------------------------------------------
def test_empty_map_straight_line_and_octile_length():
    grid = jaco.Grid.from_array(np.ones((12, 12), bool))
    # Along a row, a column and a diagonal the path is exactly the straight line.
    assert apf.trace(grid, (5, 1), (5, 10)).path.tolist() == [[5, c] for c in range(1, 11)]
    assert apf.trace(grid, (0, 7), (9, 7)).path.tolist() == [[r, 7] for r in range(10)]
    assert apf.trace(grid, (1, 1), (8, 8)).path.tolist() == [[i, i] for i in range(1, 9)]
    # Any other query: the greedy attraction takes min(|dr|, |dc|) diagonals and the rest straight,
    # i.e. the octile distance, which is the exact optimum on an empty map.
    rng = np.random.default_rng(1)
    for _ in range(20):
        s, g = (tuple(int(v) for v in rng.integers(0, 12, 2)) for _ in range(2))
        r = apf.plan(grid, s, g)
        assert r.success and validate_path(grid, r.path, s, g) == []
        assert r.length == pytest.approx(octile(s, g), abs=1e-9) and r.gap == pytest.approx(0, abs=1e-6)


def test_empty_map_distance_table_is_the_octile_distance():
    grid = jaco.Grid.from_array(np.ones((12, 12), bool))
    goal = (4, 9)
    prob = make_problem(grid, (0, 0), goal)
    r, reached = _lengths(prob, _next(prob))
    assert bool(jnp.all(reached))
    want = np.array([octile(divmod(i, 12), goal) for i in range(144)], np.float32)
    np.testing.assert_allclose(np.asarray(r), want, rtol=1e-6)


def test_intermediate_point_beside_the_wall_and_path_around_it():
    # From (3, 1) the line to (3, 7) crosses the wall {(2..4, 4)}. Seen from (3, 1) the wall's
    # squares span 31.0° either side of the line (corners (1.5, 3.5) and (5.5, 3.5)); the free
    # cells next to it outside that span nearest the line are (1, 4) and (5, 4) at atan(2/3) =
    # 33.7°; equally far from (3, 1), the lower flat index (1, 4) wins.
    assert apf.intermediate_points(WALL, (3, 1), (3, 7)) == [(3, 7), (1, 4)]
    assert apf.intermediate_points(WALL, (1, 4), (3, 7)) == [(3, 7)]  # clear line: no point
    r = apf.plan(WALL, (3, 1), (3, 7))
    assert r.success and validate_path(WALL, r.path, (3, 1), (3, 7)) == []
    assert r.path.tolist() == [[3, 1], [2, 2], [1, 3], [1, 4], [1, 5], [2, 6], [3, 7]]
    assert r.length == pytest.approx(2 + 4 * SQ2) and r.length == pytest.approx(r.optimal)
    assert r.variant == "apf" and r.best_iteration == 0 and r.n_ants == r.n_iters == 1
    assert r.coverage == pytest.approx(7 / WALL.n_free)
    assert r.metrics()["valid"] and r.to_dict()["length"] == pytest.approx(r.length)


def test_u_trap_loops_and_fails_cleanly():
    grid = jaco.maps.utrap(15)
    s, g = grid.meta["start"], grid.meta["goal"]
    t = apf.trace(grid, s, g)
    # It walks to the mouth of the U, where the tangents above and below the arms alternate.
    assert t.status == "loop" and math.isinf(t.length)
    assert validate_path(grid, t.path) == [] and tuple(t.path[0]) == s and len(set(map(tuple, t.path))) == len(t.path)
    r = apf.plan(grid, s, g)
    assert not r.success and math.isinf(r.length) and math.isinf(r.cost) and math.isinf(r.gap)
    assert r.path.shape == (0, 2) and r.best_iteration == -1 and r.history["success_rate"].tolist() == [0.0]
    # The classic potential gets stuck in a local minimum at the U's back wall.
    c = apf.trace(grid, s, g, kind="classic")
    assert c.status == "stuck" and c.path[-1].tolist() == [7, 9]
    assert not apf.plan(grid, s, g, kind="classic").success


def test_max_steps_and_trivial_query():
    grid = WALL
    t = apf.trace(grid, (3, 1), (3, 7), max_steps=3)
    assert t.status == "max_steps" and len(t.path) == 4
    r = apf.plan(grid, (2, 2), (2, 2))
    assert r.success and r.length == 0 and r.path.tolist() == [[2, 2]]


def test_clear_errors_before_anything_runs():
    blocked = jaco.Grid.from_rows(["..#..", "..#..", "..#.."])
    with pytest.raises(jaco.ProblemError, match="cannot be reached"):
        apf.plan(blocked, (0, 0), (0, 4))
    with pytest.raises(jaco.ProblemError, match="obstacle"):
        apf.plan(WALL, (3, 4), (3, 7))
    with pytest.raises(jaco.JacoError, match="max_steps"):
        apf.plan(WALL, (3, 1), (3, 7), max_steps=-1)
    with pytest.raises(jaco.JacoError, match="kind"):
        apf.plan(WALL, (3, 1), (3, 7), kind="repulsive")
    with pytest.raises(jaco.ParamError, match="k_rep"):
        apf.plan(WALL, (3, 1), (3, 7), kind="classic", k_rep=-1.0)


# -- the distance table ----------------------------------------------------------------------------
def _assert_table_equals_reference(grid, goal, prob):
    """Every cell's next step in the JAX table equals the numpy planner's (-1 where it has none)."""
    nxt = np.asarray(_next(prob))
    ref = apf._Ref(grid, goal, np.asarray(prob.nbr))
    for i in range(grid.n_cells):
        p = divmod(i, grid.width)
        q = ref.next(p) if grid.free[p] else None
        assert nxt[i] == (-1 if q is None else q[0] * grid.width + q[1]), (grid.name, p, goal)
    return nxt


def test_jax_table_equals_the_numpy_reference_everywhere(maps12):
    """One walker per cell, vmapped and jitted, takes the same step as the numpy planner from
    every free cell; the table's length from the start equals the planner's path length."""
    for grid in maps12:
        s, g = grid.meta["start"], grid.meta["goal"]
        prob = make_problem(grid, s, g)
        nxt = _assert_table_equals_reference(grid, g, prob)
        r, reached = (np.asarray(x) for x in _lengths(prob, nxt))
        t = apf.trace(grid, s, g)
        if t.status == "arrived":
            assert reached[prob.start] and r[prob.start] == pytest.approx(t.length, rel=1e-6)
        else:  # the fallback: the Euclidean distance to the goal
            assert not reached[prob.start] and r[prob.start] == pytest.approx(math.dist(s, g), rel=1e-6)


def _ringed_maps():
    """Three 9x13 maps (not square: both axes of the ray band are walked), random obstacles plus
    a ring or a U around part of the map, so some walkers sit inside an obstacle's hull."""
    rng = np.random.default_rng(7)
    out = []
    for p in (0.15, 0.3, 0.45):
        free = rng.random((9, 13)) > p
        free[1:7, 3] = free[1, 3:10] = free[6, 3:10] = False
        free[2:6, 9] = p < 0.3  # a closed ring on the first map, a U on the others
        cells = np.argwhere(free)
        out.append((jaco.Grid.from_array(free), tuple(int(v) for v in cells[rng.integers(len(cells))])))
    return out


def test_jax_table_equals_the_brute_force_reference_on_ringed_maps():
    """Eq. (4) reads only the obstacle's outline and the cells near the ray behind p; the numpy
    reference reads every cell of the map (the brute force). Every cell's next step agrees."""
    for grid, goal in _ringed_maps():
        _assert_table_equals_reference(grid, goal, make_problem(grid, goal, goal))


def test_obstacle_distance_equals_the_brute_force():
    """The separable distance transform gives, bit for bit, the distance from every cell centre
    to every blocked cell centre minimised over the blocked cells (the map's outside not
    counting; inf without obstacles)."""
    rng = np.random.default_rng(3)
    dist = jax.jit(potential.obstacle_distance)
    for shape in ((7, 11), (16, 16)):
        for p in (0.0, 0.03, 0.25, 0.6):
            free = rng.random(shape) > p
            free.flat[0] = True
            prob = make_problem(jaco.Grid.from_array(free), (0, 0), (0, 0))
            xy = np.argwhere(np.ones(shape, bool)).astype(np.float32)
            blocked = xy[~free.ravel()]
            d2 = ((xy[:, None, :] - blocked[None]) ** 2).sum(-1).min(1) if len(blocked) else np.full(len(xy), np.inf)
            np.testing.assert_array_equal(np.asarray(dist(prob)), np.sqrt(d2.astype(np.float32)))


def test_chain_lengths_by_hand():
    """A 1x4 corridor: next = [1, 2, 3, 3] reaches the goal 3; next = [1, 0, ...] loops."""
    grid = jaco.Grid.from_rows(["...."])
    prob = make_problem(grid, (0, 0), (0, 3))
    r, reached = _lengths(prob, jnp.array([1, 2, 3, 3], jnp.int32))
    assert np.asarray(r).tolist() == [3.0, 2.0, 1.0, 0.0] and bool(jnp.all(reached))
    r, reached = _lengths(prob, jnp.array([1, 0, -1, 3], jnp.int32))
    assert np.asarray(reached).tolist() == [False, False, False, True]
    assert np.asarray(r).tolist() == [3.0, 2.0, 1.0, 0.0]  # Euclidean fallback


def test_classic_potential_descent_by_hand():
    """U = ½ρ² + ½k(1/d − 1/d0)² for d ≤ d0 (d: distance to the nearest obstacle cell); the walker
    moves to the lowest neighbour if that is lower."""
    grid = jaco.Grid.from_rows(["......", "......", ".###..", "......"])
    goal = (0, 2)
    prob = make_problem(grid, (3, 2), goal)
    k, d0 = 10.0, 2.0
    nxt = np.asarray(potential.classic_next(prob, k, d0))
    blocked = np.argwhere(~grid.free)  # the map's outside does not repel

    def u(c):
        d = np.min(np.hypot(*(blocked - np.array(c)).T))
        rep = 0.5 * k * (1 / d - 1 / d0) ** 2 if d <= d0 else 0.0
        return 0.5 * ((c[0] - goal[0]) ** 2 + (c[1] - goal[1]) ** 2) + rep

    for i in np.flatnonzero(grid.free.ravel()):
        p = divmod(int(i), 6)
        if p == goal:
            assert nxt[i] == i
            continue
        nb = [int(j) for j in np.asarray(prob.nbr)[i] if j >= 0]
        best = min(nb, key=lambda j: u(divmod(j, 6)))
        want = best if u(divmod(best, 6)) < u(p) else -1
        assert nxt[i] == want, p
    assert nxt[3 * 6 + 2] == -1  # right below the wall: a local minimum
    assert apf.trace(grid, (3, 2), goal, kind="classic").status == "stuck"
    assert apf.trace(grid, (3, 5), goal, kind="classic").status == "arrived"


# -- heuristic (10) and update (11, 12) ------------------------------------------------------------
def test_heuristic_eq10_by_hand():
    grid = jaco.Grid.from_rows(["...", "..."])
    prob = make_problem(grid, (1, 0), (0, 2))
    r = jnp.arange(6, dtype=jnp.float32) + 1.0  # r_jg = flat index + 1
    eta = np.asarray(apf_guided.apf_eta(prob, r, 0, 10))
    # From cell 3 = (1, 0): up → cell 0 (d = 1, r = 1), right → cell 4 (1, r = 5), up-right →
    # cell 1 (√2, r = 2); factor (10 − 1 + 1)/10 = 1 at the first iteration.
    assert eta[3, 0] == pytest.approx(1 / 2) and eta[3, 1] == pytest.approx(1 / 6)
    assert eta[3, 4] == pytest.approx(1 / (SQ2 + 2)) and eta[3, 2] == 0 and eta[3, 3] == 0
    # Last iteration (Nc = Nmax = 10): factor 1/10, so the last iteration keeps some guidance.
    assert np.asarray(apf_guided.apf_eta(prob, r, 9, 10))[3, 0] == pytest.approx(0.05)


def test_best_half_fitness_weighted_deposit_by_hand():
    # 5 ants, one failed: k = 4 successful, the best ceil(4/2) = 2 deposit (lengths 2 and 4):
    # fit = 1/2, 1/4, s = 2/3, 1/3, deposits s·Q/L = 2/3·1/2 = 1/3 and 1/3·1/4 = 1/12 (Q = 1).
    cost = jnp.array([4.0, jnp.inf, 2.0, 5.0, 8.0])
    targets = jnp.array([[0, 9, 2, 3, 4], [5, 9, 6, 7, 8]])  # two steps each; 9 = no element
    walks = ph.Walks(targets, jnp.ones((2, 5)), cost, targets[:, 0], jnp.ones(2), cost[2])
    trail = ph.Trail(jnp.zeros(9), 0.0, jnp.inf)
    tau = np.asarray(apf_guided.deposit_best_half().update(trail, walks, None, jaco.Params(q=1.0)).tau)
    want = np.zeros(9)
    want[[2, 6]] = 1 / 3
    want[[0, 5]] = 1 / 12
    np.testing.assert_allclose(tau, want, rtol=1e-6)
    # With 3 successful ants, ceil(3/2) = 2 deposit; with one, that one (s = 1, Q/L).
    one = walks._replace(cost=jnp.array([jnp.inf, jnp.inf, 2.0, jnp.inf, jnp.inf]))
    tau = np.asarray(apf_guided.deposit_best_half().update(trail, one, None, jaco.Params(q=3.0)).tau)
    assert tau[2] == pytest.approx(1.5) and tau[6] == pytest.approx(1.5) and tau.sum() == pytest.approx(3.0)
    none = walks._replace(cost=jnp.full(5, jnp.inf))
    assert not np.asarray(apf_guided.deposit_best_half().update(trail, none, None, jaco.Params(q=1.0)).tau).any()


def test_weights_give_the_probabilities_of_eq6_without_underflow():
    from jaco.engine.weights import _TINY, scaled

    valid = jnp.array([[True, True, True, False, False, False, False, False]])
    eta = jnp.array([[0.1, 0.05, 0.2, 0, 0, 0, 0, 0]])
    for scale in (1.0, 1e-30, 1e-60):  # 1e-60 is 0 in float32: τ floored at the smallest normal
        tau = jnp.array([[0.5, 1.0, 0.25, 1, 1, 1, 1, 1]]) * scale
        log_w = 2.0 * jnp.log(jnp.maximum(tau, _TINY)) + 6.0 * jnp.log(jnp.maximum(eta, _TINY))  # α = 2, β = 6
        w = np.asarray(scaled(log_w, valid))[0]
        assert (w[3:] == 0).all() and np.isfinite(w).all()
        t = np.array([0.5, 1.0, 0.25]) if scale > 1e-38 else np.ones(3)  # the scale cancels
        raw = t**2 * np.array([0.1, 0.05, 0.2]) ** 6
        np.testing.assert_allclose(w[:3] / w[:3].sum(), raw / raw.sum(), rtol=1e-4)


def test_table_is_computed_once_per_run_not_per_iteration():
    """The rule's init computes r once and the trail carries it: the table function is traced
    once for a whole run (a table computed in the construct step would be traced in the loop)."""
    calls = []

    def counting(problem, params):
        calls.append(1)
        return potential.apf_distance(problem)

    v = jaco.PLANNERS["apf-aco"]
    v = v._replace(name="apf-aco-count", rule=ph.chain(apf_guided.apf_init(counting, "apf"), ph.evaporate(), apf_guided.deposit_best_half()))
    grid = jaco.Grid.from_rows(["......", "..#...", "..#...", "......"])
    prob = make_problem(grid, (2, 0), (2, 5))
    out = jax.eval_shape(jaco.make_run(v, n_ants=4, n_iters=3, steplimit=10), jax.random.key(0), prob, v.default_params())
    assert len(calls) == 1 and out.best_cost.shape == ()


# -- the variants ---------------------------------------------------------------------------------
def test_variants_defaults_and_sources():
    a, c = jaco.PLANNERS["apf-aco"], jaco.PLANNERS["pf-aco"]
    for v in (a, c):
        d = v.default_params()
        assert (d.alpha, d.beta, d.rho, d.q) == (2.0, 20.0, 0.3, 1.0)  # tuned (docs/planners.md)
        assert apf_guided.PAPER_PARAMS == dict(alpha=2.0, beta=6.0, rho=0.7, q=1.0)  # the paper's
        assert v.doc.startswith("Dong & Zhao 2021") or "Dong & Zhao 2021" in v.doc
    assert set(c.params) - set(a.params) == {"k_rep", "d0"}
    assert (c.default_params().k_rep, c.default_params().d0) == (potential.K_REP, potential.D0)


def test_apf_aco_paths_near_the_optimum_on_small_random_maps():
    """Best of 2 seeds, 30 ants x 30 iterations, on three 16x16 maps with 20 % obstacles; the
    gap to the exact optimum is printed and bounded (measured: docs/planners.md, APF-ACO)."""
    gaps = {}
    for seed in (1, 2, 4):
        grid = jaco.maps.random_map(16, 0.2, seed=seed)
        s, g = grid.meta["start"], grid.meta["goal"]
        runs = [jaco.solve(grid, s, g, "apf-aco", seed=k, n_ants=30, n_iters=30) for k in (0, 1)]
        for r in runs:
            assert r.success and validate_path(grid, r.path, s, g) == []
        gaps[seed] = min(r.gap for r in runs)
    print("apf-aco best-of-2 gaps (%):", {k: round(100 * v, 2) for k, v in gaps.items()})
    assert max(gaps.values()) <= 0.08  # measured: 4.7, 0 and 0 %


def test_doctests():
    assert doctest.testmod(apf).failed == 0
