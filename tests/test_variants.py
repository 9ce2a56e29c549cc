"""The contract every registered variant passes (later variants join automatically)."""

import math

import numpy as np
import pytest

import jaco
from jaco.engine.run import TRACES
from jaco.metrics import validate_path

SMALL = dict(n_ants=16, n_iters=12)


@pytest.fixture(scope="module")
def maps_():
    return [jaco.maps.random_map(12, 0.2, seed=3), jaco.maps.named("utrap-15")]


def _ends(grid):
    return grid.meta["start"], grid.meta["goal"]


#: Compositions of components across the sources (jaco.compose), beyond the registered planners'
#: own: each construct with another source's heuristic and rule. They pass the same contract;
#: one in the normal run, all with the slow checks.
COMPOSITIONS = [
    jaco.compose(**kw).name  # the full name, as results, records and TRACES know it
    for kw in (
        dict(construct="backtrack", heuristic="iaaco", rule="mmas"),
        dict(construct="double", heuristic="chaos", rule="acs"),
        dict(construct="backtrack", heuristic="apf", rule="as", transition="adaptive-q0"),
        dict(construct="dying", heuristic="iaca", rule="iaaco", transition="q0", cost="multi"),
        dict(construct="double", heuristic="distance", rule="ras", schedule="idaca"),
        dict(construct="dying", heuristic="pf", rule="chaos"),
    )
]


#: Dying ants with the q0 rule, backtracking ants and a composition in the normal run (two
#: colonies: tests/test_double.py); every other registered planner and composition with the slow
#: checks (``pytest -m slow``, run by CI), so that the default suite stays within five minutes on
#: two cores.
QUICK = ["acs", "iaca", COMPOSITIONS[0]]
EVERY = sorted(jaco.VARIANTS) + COMPOSITIONS


@pytest.fixture(params=[n if n in QUICK else pytest.param(n, marks=pytest.mark.slow) for n in EVERY])
def name(request):
    return request.param


def test_valid_path_never_an_obstacle_or_a_corner_cut(name, maps_):
    for grid in maps_:
        start, goal = _ends(grid)
        r = jaco.solve(grid, start, goal, name, seed=0, **SMALL)
        assert r.success, (name, grid.name)
        assert validate_path(grid, r.path, start, goal) == []
        assert r.length >= r.optimal - 1e-4
        assert r.gap == pytest.approx((r.length - r.optimal) / r.optimal)
        # Every iteration's best is a real cost or inf, never NaN; best-so-far never rises.
        h = r.history
        assert not np.isnan(h["best"]).any() and not np.isnan(h["mean"]).any()
        finite = h["best"][np.isfinite(h["best"])]
        assert (np.diff(finite) <= 0).all()
        assert 0 <= r.best_iteration < SMALL["n_iters"]


def test_pheromone_finite_and_within_bounds(name, maps_):
    grid = maps_[0]
    r = jaco.solve(grid, *_ends(grid), name, seed=1, keep_pheromone=True, **SMALL)
    tau = r.pheromone
    assert np.isfinite(tau).all() and (tau >= 0).all()
    if name == "mmas":  # τ ≤ τmax = Q/(ρ L_gb) after the last update, and τ ≥ τmin > 0
        assert tau.max() <= r.params["q"] / (r.params["rho"] * r.cost) * (1 + 1e-5)
        assert tau.min() > 0


def test_same_seed_identical_different_seeds_differ(name, maps_):
    grid = maps_[0]
    a = jaco.solve(grid, *_ends(grid), name, seed=5, **SMALL)
    b = jaco.solve(grid, *_ends(grid), name, seed=5, **SMALL)
    assert np.array_equal(a.path, b.path)
    for k in a.history:
        assert np.array_equal(a.history[k], b.history[k])
    others = [jaco.solve(grid, *_ends(grid), name, seed=s, **SMALL) for s in (6, 7, 8)]
    # Other keys, other walks: some history or the cells the ants covered differ (a planner may
    # find the optimum in every iteration of every seed here, so the history alone may not).
    assert any(not np.array_equal(a.history["mean"], o.history["mean"]) or a.coverage != o.coverage for o in others)


def test_sweep_rows_equal_solve(name, maps_):
    grid = maps_[1]
    q = jaco.planners.registry.get_variant(name).default_params().q  # every variant has a deposit constant Q
    table = jaco.sweep(grid, *_ends(grid), name, params={"q": [0.5 * q, q]}, seeds=[0, 3], **SMALL)
    assert len(table) == 4
    for _, row in table.iterrows():
        r = jaco.solve(grid, *_ends(grid), name, seed=int(row.seed), q=row.q, **SMALL)
        assert row.length == r.length and row.best_iteration == r.best_iteration
        assert row.coverage == pytest.approx(r.coverage, abs=0)


def test_compiles_once_for_repeated_calls_of_one_shape(name):
    a = jaco.maps.random_map(12, 0.2, seed=1)
    b = jaco.maps.random_map(12, 0.1, seed=2)
    jaco.solve(a, (0, 0), (11, 11), name, seed=0, **SMALL)
    before = TRACES[name]
    jaco.solve(a, (0, 0), (11, 11), name, seed=1, q=2.0, **SMALL)
    jaco.solve(b, (0, 0), (11, 11), name, seed=2, **SMALL)  # other map, same shape
    jaco.solve(b, (11, 11), (0, 0), name, seed=3, **SMALL)  # other query
    assert TRACES[name] == before


def test_unreachable_goal_is_a_clear_error_before_compiling(name):
    grid = jaco.Grid.from_rows(["..#..", "..#..", "..#.."])
    before = TRACES[name]
    with pytest.raises(jaco.ProblemError, match="cannot be reached"):
        jaco.solve(grid, (0, 0), (0, 4), name, n_ants=4, n_iters=2)
    assert TRACES[name] == before


def test_failed_runs_inside_a_batch_are_inf_never_nan(name):
    grid = jaco.maps.random_map(12, 0.1, seed=0)
    # Two steps can never reach the far corner: every run fails, cleanly.
    table = jaco.sweep(grid, (0, 0), (11, 11), name, params={"rho": [0.2, 0.5]}, seeds=2, n_ants=4, n_iters=3, steplimit=2)
    assert (~table.success).all()
    assert np.isinf(table.length).all() and np.isinf(table.cost).all() and np.isinf(table.gap).all()
    assert not table.select_dtypes("number").isna().any().any()
    assert (table.best_iteration == -1).all()


def test_trivial_query_start_equals_goal(name, maps_):
    grid = maps_[0]  # the shape of the other tests' runs: no compile of its own
    start = _ends(grid)[0]
    r = jaco.solve(grid, start, start, name, **SMALL)
    assert r.success and r.length == 0 and r.path.tolist() == [list(start)]


@pytest.mark.parametrize("name", EVERY)
def test_every_variant_is_documented(name):
    v = jaco.planners.registry.get_variant(name)
    assert v.source and v.doc and set(v.defaults) <= set(v.params)
    assert set(v.default_params().to_dict()) >= set(v.params)
    assert math.isfinite(sum(v.default_params().to_dict()[k] for k in v.params))


def test_pheromone_on_cells_is_supported():
    grid = jaco.maps.random_map(12, 0.2, seed=3)
    on_cells = jaco.VARIANTS["as"]._replace(name="as-cells", pheromone_on="cells")
    r = jaco.solve(grid, (0, 0), (11, 11), on_cells, seed=0, n_ants=16, n_iters=10, keep_pheromone=True)
    assert r.success and validate_path(grid, r.path, (0, 0), (11, 11)) == []
    assert r.pheromone.shape == (grid.n_cells,)
    # Cells on the best path received deposits on top of the evaporated τ0.
    tau = r.pheromone.reshape(grid.shape)
    on_path = tau[r.path[1:, 0], r.path[1:, 1]]
    assert on_path.mean() > np.median(tau[grid.free])
