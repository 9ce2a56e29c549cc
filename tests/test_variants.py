"""The contract every registered planner passes (later planners join automatically): the checks of
:mod:`jaco.testing`, which a user runs on a planner of their own with ``check_planner``."""

import numpy as np
import pytest

import jaco
from jaco import testing
from jaco.engine import native
from jaco.metrics import validate_path
from jaco.planners.registry import get_planner, with_local_search

SMALL = testing.SMALL


@pytest.fixture(scope="module")
def maps_():
    return testing.default_maps()


def _ends(grid):
    return grid.meta["start"], grid.meta["goal"]


def _same_run(a, b):
    np.testing.assert_array_equal(a.path, b.path)
    assert a.length == b.length and a.cost == b.cost and a.best_iteration == b.best_iteration
    for k in a.history:
        np.testing.assert_array_equal(a.history[k], b.history[k])


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
EVERY = sorted(jaco.PLANNERS) + COMPOSITIONS


@pytest.fixture(params=[n if n in QUICK else pytest.param(n, marks=pytest.mark.slow) for n in EVERY])
def name(request):
    return request.param


def test_valid_path_never_an_obstacle_or_a_corner_cut(name, maps_):
    testing.check_paths(name, maps_)


def test_pheromone_finite_and_within_bounds(name, maps_):
    testing.check_pheromone(name, maps_[0])
    if name == "mmas":  # τ ≤ τmax = Q/(ρ L_gb) after the last update, and τ ≥ τmin > 0
        r = jaco.solve(maps_[0], *_ends(maps_[0]), name, seed=1, keep_pheromone=True, **SMALL)
        assert r.pheromone.max() <= r.params["q"] / (r.params["rho"] * r.cost) * (1 + 1e-5)
        assert r.pheromone.min() > 0


def test_same_seed_identical_different_seeds_differ(name, maps_):
    testing.check_reproducible_seeds(name, maps_[0])


def test_sweep_rows_equal_solve(name, maps_):
    testing.check_sweep(name, maps_[1])


def test_compiles_once_for_repeated_calls_of_one_shape(name):
    testing.check_compiles_once(name)


def test_unreachable_goal_is_a_clear_error_before_compiling(name):
    testing.check_unreachable(name)


def test_failed_runs_inside_a_batch_are_inf_never_nan(name):
    testing.check_failed_runs(name)


def test_trivial_query_start_equals_goal(name, maps_):
    testing.check_trivial_query(name, maps_[0])


@pytest.mark.slow  # ACS and IACA in the normal run: tests/test_native.py
def test_the_jax_walk_takes_the_native_walks_moves(name, maps_):
    """The native kernel's run equals the JAX walk's bit for bit: path, history and final
    pheromone (the native run is the contract's compiled program; the JAX walk's is one more)."""
    if not native.available():
        pytest.skip("the native walk was not built")
    grid = maps_[1]
    a = jaco.solve(grid, *_ends(grid), name, seed=0, **SMALL, keep_pheromone=True)
    native.set_walk("jax")
    try:
        b = jaco.solve(grid, *_ends(grid), name, seed=0, **SMALL, keep_pheromone=True)
    finally:
        native.set_walk(None)
    _same_run(a, b)
    np.testing.assert_array_equal(a.pheromone, b.pheromone)


@pytest.mark.parametrize("name", EVERY)
def test_every_variant_is_documented(name):
    testing.check_documented(name)


def test_a_check_fails_on_a_planner_that_breaks_the_contract():
    """The contract can fail: a planner whose pheromone turns negative, and one without a source."""
    broken = jaco.PLANNERS["as"]._replace(
        name="as-negative", rule=jaco.engine.pheromone.chain(jaco.PLANNERS["as"].rule, jaco.engine.pheromone.Rule(
            jaco.engine.pheromone.keep_init, lambda trail, walks, problem, params: trail._replace(tau=-trail.tau))))
    with pytest.raises(AssertionError, match="pheromone not finite or negative"):
        testing.check_pheromone(broken)
    with pytest.raises(AssertionError, match="source and doc are required"):
        testing.check_documented(jaco.PLANNERS["as"]._replace(source=""))


@pytest.mark.parametrize("typed, name", [
    ("IACA", "iaca"), ("Mmas", "mmas"), ("ACS+Multi", "acs+multi"), ("IACA+SHORTCUT", "iaca+shortcut"),
])
def test_planner_names_are_case_insensitive(typed, name):
    """Every entry point resolves a name in the registry (get_planner), in any case."""
    assert get_planner(typed) is get_planner(name)
    grid = jaco.maps.named("utrap-15")
    _same_run(jaco.solve(grid, *_ends(grid), typed, n_ants=4, n_iters=2), jaco.solve(grid, *_ends(grid), name, n_ants=4, n_iters=2))


@pytest.mark.parametrize("typed, suggestion", [
    ("iacaa", "'iaca'"), ("IACC", "'iaca'"), ("mmsa", "'mmas'"), ("iaca+shortcutt", "'iaca+shortcut'"),
])
def test_a_misspelt_planner_gets_the_closest_names_before_the_list(typed, suggestion):
    with pytest.raises(jaco.JacoError) as e:
        get_planner(typed)
    text = str(e.value)
    assert text.startswith(f"unknown planner {typed!r} (did you mean {suggestion}")
    assert text.index("did you mean") < text.index("registered: acs") and "\n" not in text
    with pytest.raises(jaco.JacoError) as e:
        get_planner("zzzz")  # nothing close: the list only
    assert "did you mean" not in str(e.value) and "registered: acs" in str(e.value)


def test_pheromone_on_cells_is_supported():
    grid = jaco.maps.random_map(12, 0.2, seed=3)
    on_cells = jaco.PLANNERS["as"]._replace(name="as-cells", pheromone_on="cells")
    r = jaco.solve(grid, (0, 0), (11, 11), on_cells, seed=0, n_ants=16, n_iters=10, keep_pheromone=True)
    assert r.success and validate_path(grid, r.path, (0, 0), (11, 11)) == []
    assert r.pheromone.shape == (grid.n_cells,)
    # Cells on the best path received deposits on top of the evaporated τ0.
    tau = r.pheromone.reshape(grid.shape)
    on_path = tau[r.path[1:, 0], r.path[1:, 1]]
    assert on_path.mean() > np.median(tau[grid.free])


# -- every planner with local search (tests/test_local_search.py tests the search itself) ---------
#: Dying ants with the q0 rule in the normal run; every registered planner with the slow checks.
QUICK_SEARCH = ["acs"]
#: The planners whose run is also compared with the JAX walk's: the search is the same code
#: whatever the planner, but it keeps a shortcut by the planner's cost (length, or IAACO's J).
BOTH_WALKS = ["acs", "iaaco"]


@pytest.mark.parametrize("planner", [n if n in QUICK_SEARCH else pytest.param(n, marks=pytest.mark.slow)
                                     for n in sorted(jaco.PLANNERS)])
def test_every_planner_with_local_search_keeps_the_contract(planner, maps_):
    """Valid paths; in the first iteration (the same walks with and without: nothing has been
    deposited yet) the best is never longer with local search; the same key gives the same run;
    the native kernel gives the JAX definition's run bit for bit (one planner of each cost;
    tests/test_local_search.py compares the kernels' searches on random paths). The normal run's
    planner on both maps, the others on the U-trap; the run without local search is the contract's
    (the same compiled program as check_paths')."""
    v = with_local_search(planner)
    assert v.name == f"{planner}+shortcut" and get_planner(v.name) is v and jaco.PLANNERS[planner].local_search is None
    for grid in maps_ if planner in QUICK_SEARCH else maps_[1:]:
        start, goal = _ends(grid)
        plain = jaco.solve(grid, start, goal, planner, seed=0, **SMALL, keep_pheromone=True)
        a = jaco.solve(grid, start, goal, v, seed=0, **SMALL)
        assert a.success and validate_path(grid, a.path, start, goal) == []
        assert a.length >= a.optimal - 1e-4
        assert a.history["iteration_best"][0] <= plain.history["iteration_best"][0]
        b = jaco.solve(grid, start, goal, v.name, seed=0, **SMALL)
        _same_run(a, b)
    if native.available() and planner in BOTH_WALKS:
        native.set_walk("jax")
        try:
            c = jaco.solve(grid, start, goal, v, seed=0, **SMALL)
        finally:
            native.set_walk(None)
        _same_run(a, c)


def test_the_contract_checks_former_name_warns_and_is_the_same_check():
    """``jaco.testing.check_seeds`` was the reproducibility check's name until it met the sweep's
    ``engine.checks.check_seeds``: it still works, with a DeprecationWarning naming the new one."""
    with pytest.warns(DeprecationWarning, match="check_reproducible_seeds"):
        assert testing.check_seeds is testing.check_reproducible_seeds
