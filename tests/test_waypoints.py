"""Several targets (docs/algorithms.md §7): ``jaco.solve(..., waypoints=[...])`` for every variant."""

import numpy as np
import pytest

import jaco
from jaco import exact, waypoints
from jaco.engine.checks import default_steplimit, resolve_params
from jaco.engine.run import TRACES
from jaco.engine.shape import RunShape
from jaco.metrics import path_length, validate_path

SMALL = dict(n_ants=8, n_iters=4)
START, GOAL = (0, 0), (9, 9)
VIA = [(1, 9), (9, 1)]


@pytest.fixture(scope="module")
def grid():
    return jaco.maps.random_map(10, 0.2, seed=1)


def _visits_in_order(path, targets):
    """Index of each target in the path, searching forward from the previous one."""
    cells = [tuple(c) for c in path.tolist()]
    at, found = 0, []
    for t in targets:
        at = cells.index(tuple(t), at)
        found.append(at)
    return found


@pytest.mark.parametrize("name", ["iaca"] + [pytest.param(n, marks=pytest.mark.slow) for n in ("mmas", "idaca", "chaos-aco")])
def test_path_visits_every_waypoint_in_order_and_is_valid(grid, name):
    r = jaco.solve(grid, START, GOAL, name, seed=0, waypoints=VIA, **SMALL)
    assert r.success
    assert validate_path(grid, r.path, START, GOAL) == []
    idx = _visits_in_order(r.path, [START, *VIA, GOAL])
    assert idx[0] == 0 and idx[-1] == len(r.path) - 1 and idx == sorted(idx)
    optima = [exact.shortest_path(grid, a, b)[0] for a, b in zip([START, *VIA], [*VIA, GOAL])]
    assert r.optimal == pytest.approx(sum(optima), rel=1e-6)
    assert r.length == pytest.approx(path_length(r.path), rel=1e-6)
    assert r.length >= r.optimal - 1e-4
    assert r.gap == pytest.approx((r.length - r.optimal) / r.optimal)
    assert (r.start, r.goal) == (START, GOAL)


def test_combined_result_is_the_sum_of_its_legs(grid):
    r = jaco.solve(grid, START, GOAL, "mmas", seed=4, waypoints=VIA, keep_pheromone=True, **SMALL)
    v = jaco.PLANNERS["mmas"]
    points = waypoints.check_waypoints(grid, START, GOAL, VIA)
    shape = RunShape(n_ants=8, n_iters=4, steplimit=default_steplimit(grid), connectivity=8, keep_pheromone=True)
    legs = waypoints.run_legs(grid, points, v, seed=4, shape=shape, values=resolve_params(v, {}, where="t"))
    assert len(legs) == 3 and all(leg.success for leg in legs)
    assert r.length == pytest.approx(sum(leg.length for leg in legs))
    assert r.optimal == pytest.approx(sum(leg.optimal for leg in legs))
    assert len(r.path) == sum(len(leg.path) for leg in legs) - 2  # junction cells once
    np.testing.assert_allclose(r.history["best"], sum(leg.history["best"] for leg in legs), rtol=1e-6)
    rates = np.prod([leg.history["success_rate"] for leg in legs], axis=0)
    np.testing.assert_allclose(r.history["success_rate"], rates)
    assert r.best_iteration == max(leg.best_iteration for leg in legs)
    assert r.pheromone.shape == (3, 8 * grid.n_cells)
    # Leg 0 uses key(seed) itself: it is exactly the plain solve from the start to the first waypoint.
    plain = jaco.solve(grid, START, VIA[0], "mmas", seed=4, **SMALL)
    np.testing.assert_array_equal(legs[0].path, plain.path)
    np.testing.assert_array_equal(legs[0].history["mean"], plain.history["mean"])


def test_same_seed_same_path_and_no_retrace(grid):
    a = jaco.solve(grid, START, GOAL, "as", seed=7, waypoints=VIA, **SMALL)
    before = TRACES["as"]
    b = jaco.solve(grid, START, GOAL, "as", seed=7, waypoints=VIA, **SMALL)
    np.testing.assert_array_equal(a.path, b.path)
    for k in a.history:
        np.testing.assert_array_equal(a.history[k], b.history[k])
    other = jaco.maps.random_map(10, 0.1, seed=2)  # same shape, other map, other targets and values
    c = jaco.solve(other, (9, 9), (0, 0), "as", seed=8, waypoints=[(5, 6), (0, 9)], q=2.0, **SMALL)
    assert c.success
    assert TRACES["as"] == before
    others = [jaco.solve(grid, START, GOAL, "as", seed=s, waypoints=VIA, **SMALL) for s in (8, 9)]
    assert any(not np.array_equal(a.history["mean"], o.history["mean"]) for o in others)


def test_bad_waypoints_are_clear_errors_before_compiling():
    grid = jaco.Grid.from_rows(["..#..", "..#..", "..#..", "....."])
    walled = jaco.Grid.from_rows(["..#..", "..#..", "..#.."])
    before = TRACES["mmas"]
    cases = [
        (grid, [(1, 1), (0, 2)], r"waypoints\[1\] \(0, 2\) is on an obstacle"),
        (grid, [(3, 7)], r"waypoints\[0\] \(3, 7\) is outside the 4x5 map"),
        (grid, [(1, 1), "x"], r"waypoints\[1\] must be a \(row, col\) pair"),
        (grid, (1, 1), "must be a list of"),
        (walled, [(0, 4)], r"waypoints\[0\] \(0, 4\) cannot be reached from start \(0, 0\)"),
    ]
    for g, via, message in cases:
        with pytest.raises(jaco.ProblemError, match=message):
            jaco.solve(g, (0, 0), (0, 1), "mmas", waypoints=via, **SMALL)
    with pytest.raises(jaco.ProblemError, match=r"goal \(0, 4\) cannot be reached from waypoints\[0\] \(1, 1\)"):
        jaco.solve(walled, (0, 0), (0, 4), "mmas", waypoints=[(1, 1)], **SMALL)
    assert TRACES["mmas"] == before


def test_repeated_and_empty_waypoints(grid):
    # A waypoint equal to the start is an empty leg; no waypoints at all is one leg.
    r = jaco.solve(grid, START, GOAL, "mmas", seed=0, waypoints=[START, VIA[1]], **SMALL)
    assert r.success and r.path[0].tolist() == list(START) and validate_path(grid, r.path, START, GOAL) == []
    legs = exact.shortest_path(grid, START, VIA[1])[0] + exact.shortest_path(grid, VIA[1], GOAL)[0]
    assert r.optimal == pytest.approx(legs, rel=1e-6)
    one = jaco.solve(grid, START, VIA[0], "mmas", seed=3, waypoints=[], **SMALL)
    plain = jaco.solve(grid, START, VIA[0], "mmas", seed=3, **SMALL)
    np.testing.assert_array_equal(one.path, plain.path)
    assert one.length == plain.length


def test_cli_waypoint_option(tmp_path, capsys):
    import json

    from jaco.cli import main

    out = tmp_path / "trip.json"
    argv = ["solve", "demo", "--waypoint", "3,3", "--waypoint", "18,15", "--variant", "as", "--ants", "8",
            "--iters", "3", "--json", str(out)]
    assert main(argv) == 0
    doc = json.loads(out.read_text())
    grid = jaco.maps.named("demo")
    start, goal = grid.meta["start"], grid.meta["goal"]
    path = np.array(doc["path"])
    assert validate_path(grid, path, start, goal) == []
    _visits_in_order(path, [start, (3, 3), (18, 15), goal])  # raises ValueError if one is missing
    # The reported optimum is the exact trip through the waypoints.
    assert doc["optimal"] == pytest.approx(waypoints.exact_trip(grid, [start, (3, 3), (18, 15), goal])[0])
    assert main(["solve", "demo", "--waypoint", "8,13", "--ants", "2", "--iters", "1"]) == 2
    assert "waypoints[0] (8, 13) is on an obstacle" in capsys.readouterr().err
