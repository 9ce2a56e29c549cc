"""Double colony with complete crossover (jaco.planners.double), IDACA/DACA and their schedules."""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaco
from jaco.engine import schedules
from jaco.engine.params import Params
from jaco.engine.pheromone import Trail
from jaco.engine.problem import make_problem
from jaco.engine.schedules import IDACA_PARAMS
from jaco.metrics import validate_path
from jaco.moves import MOVES
from jaco.planners.double import DACA, IDACA, SPLICED, assemble, best_population, crossover, double_walk, mean_feasible

SMALL = dict(n_ants=16, n_iters=12)
# The 12x12 map's runs all keep the pheromone, so they share one compiled run per variant.
KEEP = dict(SMALL, keep_pheromone=True)
PLANNERS = {"idaca": IDACA, "daca": DACA}
SQRT2 = math.sqrt(2.0)


@pytest.fixture(scope="module")
def maps_():
    return [jaco.maps.random_map(12, 0.2, seed=3), jaco.maps.named("utrap-15")]


@pytest.fixture(params=sorted(PLANNERS))
def variant(request):
    return PLANNERS[request.param]


def _ends(grid):
    return grid.meta["start"], grid.meta["goal"]


# -- beyond the shared contract (tests/test_variants.py runs it on "daca" and "idaca" too) -------
def test_spliced_paths_are_valid_and_simple(variant, maps_):
    for grid, sizes in zip(maps_, (KEEP, SMALL)):
        start, goal = _ends(grid)
        r = jaco.solve(grid, start, goal, variant, seed=0, **sizes)
        assert r.success and validate_path(grid, r.path, start, goal) == []
        assert len({tuple(c) for c in r.path}) == len(r.path)  # crossover never leaves a loop


def test_pheromone_on_cells_within_bounds(variant, maps_):
    grid = maps_[0]
    r = jaco.solve(grid, *_ends(grid), variant, seed=1, **KEEP)
    tau = r.pheromone
    assert tau.shape == (grid.n_cells,)  # node pheromone
    assert np.isfinite(tau).all() and (tau >= 0).all()
    if variant is IDACA:
        assert tau.min() >= r.params["tau_min"] and tau.max() <= r.params["tau_max"]
        assert tau.min() < tau.max()  # the trail did move away from τmax


@pytest.mark.slow  # a sweep of both double-colony planners
def test_schedule_constants_sweep_like_any_parameter(maps_):
    grid = maps_[1]
    axes = {"break_iter": [3.0, 83.0], "rho": [0.5, 0.7]}
    table = jaco.sweep(grid, *_ends(grid), IDACA, params=axes, seeds=[0, 3], **SMALL)
    assert len(table) == 8
    for _, row in table.iterrows():
        r = jaco.solve(grid, *_ends(grid), IDACA, seed=int(row.seed), **{k: row[k] for k in axes}, **SMALL)
        assert row.length == r.length and row.best_iteration == r.best_iteration


# -- crossover on hand-made walks ----------------------------------------------------------------
W = 5  # a 5x5 open grid


def _walks(paths, steps=8):
    """(S, A) entered cells and move indices of walks given as lists of (row, col), first cell first."""
    cells = np.full((steps, len(paths)), -1, np.int32)
    moves = np.full((steps, len(paths)), -1, np.int32)
    for a, path in enumerate(paths):
        for t, (p, q) in enumerate(zip(path[:-1], path[1:])):
            d = (q[0] - p[0], q[1] - p[1])
            cells[t, a] = q[0] * W + q[1]
            moves[t, a] = int(np.flatnonzero((MOVES == d).all(axis=1))[0])
    return jnp.asarray(cells), jnp.asarray(moves)


_crossover_jit = jax.jit(crossover, static_argnums=6)


def _crossover(c1, m1, c2, m2, start, goal):
    return _crossover_jit(c1, m1, c2, m2, start, goal, W * W)


def _as_path(start_cell, cells):
    flat = [start_cell] + [int(c) for c in np.asarray(cells) if c >= 0]
    return np.array([divmod(c, W) for c in flat])


def test_crossover_takes_the_shortest_common_cell_and_is_valid():
    start, goal = 0, 24  # (0, 0) and (4, 4)
    a0 = [(0, 0), (1, 1), (2, 2), (3, 2), (4, 2), (4, 3)]  # meets b1 at (2, 2) and at (4, 3)
    a1 = [(0, 0), (0, 1), (0, 2)]  # meets no colony-2 walk
    b0 = [(4, 4), (3, 4), (2, 4)]
    b1 = [(4, 4), (4, 3), (3, 3), (2, 2)]
    c1, m1 = _walks([a0, a1])
    c2, m2 = _walks([b0, b1])
    sp = _crossover(c1, m1, c2, m2, start, goal)
    # Via (2, 2): 2√2 + (1 + 1 + √2); via (4, 3): (2√2 + 3) + 1. The first is shorter.
    assert float(sp.length[0]) == pytest.approx(3 * SQRT2 + 2, abs=1e-5)
    assert int(sp.partner[0]) == 1 and int(sp.s1[0]) == 2 and int(sp.s2[0]) == 3
    assert math.isinf(float(sp.length[1]))  # no shared cell, no splice

    cells, moves = jax.jit(assemble)(c1, m1, sp.s1 * 0, sp.s1, c2, m2, sp.partner, sp.s2, goal)
    assert cells.shape == (2 * c1.shape[0], 2)
    path = _as_path(start, cells[:, 0])
    assert path.tolist() == [[0, 0], [1, 1], [2, 2], [3, 3], [4, 3], [4, 4]]
    grid = jaco.Grid.from_rows(["....."] * 5)
    assert validate_path(grid, path, (0, 0), (4, 4)) == []
    # The moves of the spliced path are those of its cells (the colony-2 part reversed).
    steps = np.diff(path, axis=0)
    assert [MOVES[k].tolist() for k in np.asarray(moves[: len(steps), 0])] == steps.tolist()
    # Its length is the sum of the two parts.
    lengths = np.hypot(*steps.T).sum()
    assert lengths == pytest.approx(2 * SQRT2 + (2 + SQRT2))


def test_crossover_meets_at_start_and_goal():
    # A colony-1 walk that arrives meets every colony-2 walk at the goal, so its splice is at most
    # itself; an arrived colony-2 walk meets every colony-1 walk at the start.
    start, goal = 0, 24
    b0 = [(4, 4), (3, 4), (2, 4), (1, 3), (0, 2), (1, 1), (1, 0), (0, 0)]  # arrives, with a detour
    c1, m1 = _walks([[(0, 0), (1, 1), (2, 2), (3, 3), (4, 4)], [(0, 0), (0, 1), (0, 2)]])
    c2, m2 = _walks([b0])
    sp = _crossover(c1, m1, c2, m2, start, goal)
    assert float(sp.length[0]) == pytest.approx(4 * SQRT2, abs=1e-5)  # its own straight diagonal
    assert int(sp.s1[0]) == 4 and int(sp.s2[0]) == 0
    # Ant 1 cuts b0's detour: (0,0)→(0,2) along itself, then b0 backwards from (0,2).
    assert int(sp.s1[1]) == 2 and int(sp.s2[1]) == 4
    assert float(sp.length[1]) == pytest.approx(2 + (2 + 2 * SQRT2), abs=1e-5)
    whole = 3 + 3 * SQRT2 + 2  # b0's length, the splice through the start
    assert float(sp.length[1]) < whole


def test_best_population_lowest_mean_feasible_cost():
    inf = math.inf
    costs = jnp.array([[10.0, inf, inf], [9.0, 12.0, 12.0], [11.0, 13.0, inf]])
    assert np.allclose(mean_feasible(costs), [10.0, 11.0, 12.0])
    assert int(best_population(costs)) == 0  # one feasible ant of 10 beats a mean of 11
    assert int(best_population(jnp.array([[inf, inf], [inf, inf], [7.0, 9.0]]))) == 2
    assert int(best_population(jnp.array([[8.0, 8.0], [8.0, inf], [9.0, 7.0]]))) == 0  # ties: first
    assert int(best_population(jnp.full((3, 4), inf))) == 0  # nothing feasible: colony 1, no deposit


def test_double_walk_populations(maps_):
    grid = maps_[1]
    start, goal = _ends(grid)
    problem = jax.tree.map(jnp.asarray, make_problem(grid, start, goal))
    params = IDACA.schedule(IDACA.default_params(), jnp.int32(0), 10)
    trail = IDACA.rule.init(Trail(jnp.zeros(grid.n_cells), jnp.float32(0), jnp.float32(jnp.inf)), problem, params)
    x = jax.jit(lambda k: double_walk(IDACA, problem, trail, params, 0, 10, k, n_ants=24, steplimit=60))(jax.random.key(0))
    cost = np.asarray(x.cost)
    assert np.isfinite(cost[SPLICED]).any()
    len2 = np.asarray(x.tours2.length)[np.asarray(x.tours2.arrived)]
    for a in range(24):
        # A splice is never longer than the ant's own arrived walk, nor than any arrived colony-2 walk.
        if np.isfinite(cost[0, a]):
            assert cost[SPLICED, a] <= cost[0, a] + 1e-5
        if len2.size:
            assert cost[SPLICED, a] <= len2.min() + 1e-5
    cells = np.asarray(x.candidates.cells)
    flat = cost.ravel()
    for c in np.flatnonzero(np.isfinite(flat)):
        path = _path_on(grid, start, cells[:, c])
        assert validate_path(grid, path, start, goal) == [], c
        assert len({tuple(p) for p in path}) == len(path)
        steps = np.diff(path, axis=0)
        assert np.hypot(*steps.T).sum() == pytest.approx(flat[c], abs=1e-4)
    means = mean_feasible(jnp.asarray(cost))
    assert int(x.population) == int(np.argmin(np.asarray(means)))


def _path_on(grid, start, cells):
    flat = [grid.index(start)] + [int(c) for c in cells if c >= 0]
    return np.array([divmod(c, grid.width) for c in flat])


# -- schedules -----------------------------------------------------------------------------------
IDACA_DEFAULTS = Params(**{p.name: p.default for p in IDACA_PARAMS})  # the thesis's printed values


def _at(schedule, i, params=None, n_iters=100):
    return schedule(params or IDACA_DEFAULTS, jnp.int32(i - 1), n_iters)  # the sources count from i = 1


def test_alpha_beta_schedule_hand_values():
    assert float(_at(schedules.alpha_beta, 10).alpha) == pytest.approx(0.3)
    assert float(_at(schedules.alpha_beta, 10).beta) == pytest.approx(2.85)
    assert float(_at(schedules.alpha_beta, 83).alpha) == pytest.approx(2.49)
    assert float(_at(schedules.alpha_beta, 83).beta) == pytest.approx(1.755)
    assert float(_at(schedules.alpha_beta, 84).alpha) == pytest.approx(2.5)
    assert float(_at(schedules.alpha_beta, 100).alpha) == pytest.approx(2.5)
    assert float(_at(schedules.alpha_beta, 100).beta) == pytest.approx(2.0)
    p = IDACA_DEFAULTS.replace(alpha_slope=0.1, beta_start=1.0, beta_slope=0.2, break_iter=50.0)
    assert float(_at(schedules.alpha_beta, 10, p).beta) == 0.0  # β never turns negative


def test_rho_schedule_hand_values():
    p = Params(rho=0.7, rho_min=0.3, rho_decay=2.0)
    rho = [float(_at(schedules.rho_decay, i, p).rho) for i in range(1, 30)]
    assert rho[0] == pytest.approx(0.7)
    assert rho[1] == pytest.approx(0.7 * 2 ** (-1 / 100))
    assert rho[2] == pytest.approx(0.7 * 2 ** (-3 / 100))
    # The recursion ρ(i+1) = ρ(i)·a^(−i/Nc) while above ρmin, then ρmin.
    r = 0.7
    for i in range(1, 29):
        r = r * 2 ** (-i / 100) if r > 0.3 else 0.3
        assert rho[i] == pytest.approx(max(r, 0.3), rel=1e-5)
    assert rho[-1] == pytest.approx(0.3) and (np.diff(rho) <= 0).all()


def test_idaca_schedule_composes_and_is_branch_free_under_vmap():
    p = IDACA.default_params()
    out = schedules.idaca(p, jnp.int32(9), 100)
    assert float(out.alpha) == pytest.approx(0.3) and float(out.rho) < 0.7
    grid = p.replace(break_iter=jnp.array([5.0, 20.0, 83.0]), rho=jnp.array([0.4, 0.7, 0.9]))
    axes = Params(**{k: (0 if k in ("break_iter", "rho") else None) for k in p.to_dict()})
    f = jax.jit(jax.vmap(schedules.idaca, in_axes=(axes, None, None)), static_argnums=2)
    got = f(grid, jnp.int32(9), 100)  # i = 10: past the first break only
    assert np.allclose(got.alpha, [2.5, 0.3, 0.3]) and np.allclose(got.beta, [2.0, 2.85, 2.85])
    assert np.allclose(got.rho, np.maximum(0.3, np.array([0.4, 0.7, 0.9]) * 2 ** (-45 / 100)))
    # ... and over the iteration axis too.
    ts = jax.vmap(lambda t: schedules.idaca(p, t, 100).alpha)(jnp.arange(100, dtype=jnp.int32))
    assert np.allclose(ts[:83], 0.03 * np.arange(1, 84)) and np.allclose(ts[83:], 2.5)


# -- quality -------------------------------------------------------------------------------------
@pytest.mark.parametrize("name", ["random-20-10", "random-30-10"])
def test_idaca_quality_on_named_random_maps(name):
    grid = jaco.maps.named(name)
    start, goal = _ends(grid)
    r = jaco.solve(grid, start, goal, IDACA, seed=0, n_ants=20, n_iters=100)
    assert r.success and validate_path(grid, r.path, start, goal) == []
    assert r.gap <= 0.10, r.gap
