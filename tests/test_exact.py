"""The exact optimum reproduces the MovingAI scenario optima (the benchmark's own numbers)."""

import math

import numpy as np
import pytest

import jaco
from jaco import exact, maps
from jaco.metrics import path_length, validate_path

SMALL = [
    ("random-32-32-10.map", "random-32-32-10-even-10.scen"),
    ("maze-32-32-2.map", "maze-32-32-2-even-10.scen"),
    ("room-32-32-4.map", "room-32-32-4-even-10.scen"),
    ("empty-16-16.map", "empty-16-16-even-10.scen"),
]
LARGE = [
    ("arena.map", "arena.map.scen"),
    ("den312d.map", "den312d.map.scen"),
    ("bloodvenomfalls.map", "bloodvenomfalls.map.scen"),
]


def _check(map_name, scen_name, every):
    grid = maps.load(maps.bundled(map_name))
    rows = maps.load_scenarios(maps.bundled(scen_name))[::every]
    assert rows
    for s in rows:
        length, path = exact.shortest_path(grid, s.start, s.goal)
        assert abs(length - s.optimal) < 1e-6, (map_name, s)
        assert validate_path(grid, path, s.start, s.goal) == []
        assert abs(path_length(path) - length) < 1e-9
    return len(rows)


@pytest.mark.parametrize("map_name,scen_name", SMALL)
def test_every_scenario_row_of_the_small_maps(map_name, scen_name):
    assert _check(map_name, scen_name, every=1) > 40


@pytest.mark.parametrize("map_name,scen_name", LARGE)
def test_a_sample_of_the_large_maps(map_name, scen_name):
    assert _check(map_name, scen_name, every=37) >= 3


def test_distance_field_agrees_with_point_queries():
    grid = maps.load(maps.bundled("room-32-32-4.map"))
    goal = (31, 31) if grid.free[31, 31] else tuple(np.argwhere(grid.free)[-1])
    field = exact.distance_field(grid, goal)
    rng = np.random.default_rng(0)
    for r, c in np.argwhere(grid.free)[rng.choice(grid.n_free, 20, replace=False)]:
        length, _ = exact.shortest_path(grid, (r, c), goal)
        assert field[r, c] == pytest.approx(length, abs=1e-9)
    assert np.isinf(field[~grid.free]).all()


def test_distance_fields_of_recent_goals_are_kept_read_only_and_the_oldest_dropped():
    grid = maps.load(maps.bundled("room-32-32-4.map"))
    goals = [tuple(int(v) for v in c) for c in np.argwhere(grid.free)[: exact.FIELDS_KEPT + 1]]
    first = exact.distance_field(grid, goals[0])
    assert not first.flags.writeable
    assert exact.distance_field(grid, goals[0]) is first  # kept: no second search
    assert exact.distance_field(grid, goals[0], connectivity=4) is not first  # per connectivity
    for goal in goals[1:]:  # FIELDS_KEPT other goals push the first one out
        exact.distance_field(grid, goal)
    again = exact.distance_field(grid, goals[0])
    assert again is not first and np.array_equal(again, first)
    assert len(grid.meta["_fields8"]) == exact.FIELDS_KEPT


def test_corner_cutting_is_forbidden_and_4_connectivity_is_an_option():
    grid = jaco.Grid.from_rows([".#", "#."])
    assert exact.shortest_path(grid, (0, 0), (1, 1))[0] == math.inf
    open_ = jaco.Grid.from_rows(["...", "...", "..."])
    assert exact.shortest_path(open_, (0, 0), (2, 2))[0] == pytest.approx(2 * math.sqrt(2))
    assert exact.shortest_path(open_, (0, 0), (2, 2), connectivity=4)[0] == pytest.approx(4.0)


def test_cell_size_scales_lengths_and_reachable_mask():
    grid = jaco.Grid.from_rows(["..#.", "..#.", "..#."], cell_size=10)
    assert exact.shortest_path(grid, (0, 0), (2, 1))[0] == pytest.approx(10 * (1 + math.sqrt(2)))
    mask = exact.reachable(grid, (0, 0))
    assert mask[:, :2].all() and not mask[:, 3].any()
