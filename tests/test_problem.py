"""Grid -> problem: neighbour table, no corner cutting, and validation errors before any compile."""

import math
import pickle

import numpy as np
import pytest

import jaco
from jaco.engine.problem import make_problem, stack
from jaco.moves import MOVES, neighbour_table


def test_neighbour_table_forbids_corner_cuts_and_leaving_the_map():
    grid = jaco.Grid.from_rows(["...", ".#.", "..."])
    nbr, step = neighbour_table(grid.free)
    centre_left = grid.index((1, 0))
    # From (1,0): up (0,0), down (2,0) allowed; right is the obstacle; left leaves the map.
    allowed = {tuple(MOVES[k]) for k in range(8) if nbr[centre_left, k] >= 0}
    assert allowed == {(-1, 0), (1, 0)}  # both diagonals pass the obstacle's corner
    corner = grid.index((0, 0))
    assert {tuple(MOVES[k]) for k in range(8) if nbr[corner, k] >= 0} == {(0, 1), (1, 0)}
    assert set(np.unique(step[nbr >= 0])) <= {1.0, math.sqrt(2)}
    assert (nbr[grid.index((1, 1))] == -1).all()  # an obstacle has no moves


def test_four_connectivity_keeps_fixed_degree_with_straight_moves_only():
    grid = jaco.Grid.from_rows(["...", "...", "..."])
    nbr, _ = neighbour_table(grid.free, connectivity=4)
    assert nbr.shape == (9, 8)
    assert (nbr[:, 4:] == -1).all() and (nbr[grid.index((1, 1)), :4] >= 0).all()


def test_problem_carries_optimum_and_offsets_match_the_table():
    grid = jaco.maps.named("utrap-15")
    p = make_problem(grid, grid.meta["start"], grid.meta["goal"])
    assert float(p.optimal) == pytest.approx(jaco.exact.shortest_path(grid, grid.meta["start"], grid.meta["goal"])[0], rel=1e-6)
    i = np.arange(grid.n_cells)[:, None]
    ok = p.nbr >= 0
    assert (p.nbr[ok] == (i + p.offsets[None, :])[ok]).all()


@pytest.mark.parametrize(
    "start,goal,match",
    [
        ((-1, 0), (2, 3), "outside"),
        ((0, 0), (3, 9), "outside"),
        ((1, 1), (2, 3), "obstacle"),
        ((0, 0), (1, 2), "obstacle"),
        ((0, 0), (0, 3), "cannot be reached"),
        (("a", 0), (2, 3), "pair of integers"),
        ((0.5, 0), (2, 3), "pair of integers"),
    ],
)
def test_bad_queries_are_clear_errors(start, goal, match):
    grid = jaco.Grid.from_rows(["..#.", ".##.", "...#"])
    with pytest.raises(jaco.ProblemError, match=match):
        make_problem(grid, start, goal)


def test_bad_grids_are_clear_errors():
    with pytest.raises(jaco.ProblemError, match="2-D"):
        jaco.Grid(np.ones(4, bool))
    with pytest.raises(jaco.ProblemError, match="boolean"):
        jaco.Grid(np.full((2, 2), 0.5))
    with pytest.raises(jaco.ProblemError, match="no free cell"):
        make_problem(jaco.Grid(np.zeros((2, 2), bool)), (0, 0), (1, 1))
    with pytest.raises(jaco.MapFormatError, match="unknown map symbol"):
        jaco.Grid.from_rows(["..x"])
    assert issubclass(jaco.ProblemError, ValueError)


def test_problems_of_one_shape_stack_and_other_shapes_do_not():
    a = jaco.Grid.from_rows(["...", "..."])
    b = jaco.Grid.from_rows(["..#", "..."])
    batch = stack([make_problem(a, (0, 0), (1, 2)), make_problem(b, (0, 0), (1, 2))])
    assert batch.nbr.shape == (2, 6, 8) and batch.start.shape == (2,)
    with pytest.raises(jaco.ProblemError, match="one map shape"):
        stack([make_problem(a, (0, 0), (1, 2)), make_problem(jaco.Grid.from_rows([".."]), (0, 0), (0, 1))])


def test_world_coordinates_round_trip():
    grid = jaco.Grid(np.ones((4, 6), bool), resolution=0.5, origin=(-1.0, 2.0, 0.0))
    xy = grid.cell_to_world((3, 0))
    assert xy == pytest.approx([-0.75, 2.25])  # the bottom-left cell's centre
    cells = np.array([(0, 0), (3, 5), (2, 1)])
    assert (grid.world_to_cell(grid.cell_to_world(cells)) == cells).all()


def test_a_repeated_query_reuses_its_read_only_problem_and_device_copy():
    """A grid keeps its last queries' problems: the same arrays again (read-only, so no caller can
    change another's), the device copy shared by the queries of one grid, and the oldest query
    dropped once more than QUERIES_KEPT were asked."""
    from jaco.engine.problem import QUERIES_KEPT, device_problem

    grid = jaco.Grid.from_rows(["....", ".##.", "...."])
    first = make_problem(grid, (0, 0), (2, 3))
    again = make_problem(grid, [0, 0], np.array([2, 3]))  # the same cells, spelt otherwise
    assert again is first and not first.goal_dist.flags.writeable and not first.step.flags.writeable
    with pytest.raises(ValueError, match="read-only"):
        first.goal_dist[0] = 0.0
    numpy_problem, on_device = device_problem(grid, (0, 0), (2, 3))
    assert numpy_problem is first and device_problem(grid, (0, 0), (2, 3))[1] is on_device
    np.testing.assert_array_equal(np.asarray(on_device.goal_dist), first.goal_dist)
    assert int(on_device.goal) == grid.index((2, 3)) and float(on_device.optimal) == float(first.optimal)
    other = device_problem(grid, (2, 0), (0, 3))[1]
    assert other.nbr is on_device.nbr and other.goal_dist is not on_device.goal_dist  # the map's arrays, copied once
    free = [c for c in zip(*np.nonzero(grid.free)) if c not in ((2, 3), (0, 0))]
    for cell in free[:QUERIES_KEPT]:  # QUERIES_KEPT newer queries push the first one out
        make_problem(grid, cell, (2, 3))
    assert make_problem(grid, (0, 0), (2, 3)) is not first
    with pytest.raises(jaco.ProblemError, match="cannot be reached"):  # still checked, never cached
        make_problem(jaco.Grid.from_rows(["..#.."]), (0, 0), (0, 4))


def test_device_parameters_are_kept_by_their_bits():
    """The device copies of a solve's parameters are kept per set of float32 bits: 0.0 and -0.0
    are different sets (a kept 0.0 must not stand in for -0.0), a repeated set is the same copy."""
    from jaco.engine.run import device_params

    plus = device_params({"alpha": np.float32(1.0), "xi": np.float32(0.0)})
    minus = device_params({"alpha": np.float32(1.0), "xi": np.float32(-0.0)})
    assert not np.signbit(np.asarray(plus.xi)) and np.signbit(np.asarray(minus.xi))
    assert device_params({"alpha": np.float32(1.0), "xi": np.float32(0.0)}) is plus


def test_a_solve_checks_a_repeated_call_once_and_only_its_seed_again(monkeypatch):
    """A grid keeps the solves' checked calls (jaco.engine.run.prepared_solve): the same call with
    another seed runs no check but the seed's and gives the result of an unkept call. The key
    tells apart what equality does not (1 and True, 0.0 and -0.0) and holds the memory budget,
    so a call that the first one does not cover is checked in full."""
    import jaco.engine.checks as checks
    import jaco.engine.run as run

    grid = jaco.maps.random_map(12, 0.2, seed=1)
    kw = dict(n_ants=8, n_iters=5, beta=1.0)
    first = jaco.solve(grid, (0, 0), (11, 11), "as", seed=0, **kw)
    calls = []
    monkeypatch.setattr(run, "prepare", lambda *a, **k: calls.append(k) or checks.prepare(*a, **k))
    again = jaco.solve(grid, (0, 0), (11, 11), "as", seed=3, **kw)
    assert calls == []
    fresh = jaco.solve(grid.replace(), (0, 0), (11, 11), "as", seed=3, **kw)  # a copy keeps no checked calls
    assert len(calls) == 1 and again.path.tolist() == fresh.path.tolist() and again.history.keys() == fresh.history.keys()
    for name, row in again.history.items():
        np.testing.assert_array_equal(row, fresh.history[name])
    assert first.seed == 0 and again.seed == 3
    with pytest.raises(jaco.JacoError, match="seed"):
        jaco.solve(grid, (0, 0), (11, 11), "as", seed=-1, **kw)
    jaco.solve(grid, (0, 0), (11, 11), "as", seed=0, n_ants=1, n_iters=5)
    with pytest.raises(jaco.JacoError, match="got bool True"):  # n_ants=True is not n_ants=1
        jaco.solve(grid, (0, 0), (11, 11), "as", seed=0, n_ants=True, n_iters=5)
    monkeypatch.setenv("JACO_MEMORY_BUDGET", "1000")
    with pytest.raises(jaco.ResourceError):
        jaco.solve(grid, (0, 0), (11, 11), "as", seed=0, **kw)
    monkeypatch.delenv("JACO_MEMORY_BUDGET")
    ready = dict(seed=0, n_ants=8, n_iters=5, steplimit=None, connectivity=8, keep_pheromone=False)
    plus = run.prepared_solve(grid, (0, 0), (11, 11), jaco.PLANNERS["as"], params={"alpha": 0.0}, **ready)[-1]
    minus = run.prepared_solve(grid, (0, 0), (11, 11), jaco.PLANNERS["as"], params={"alpha": -0.0}, **ready)[-1]
    assert not np.signbit(np.asarray(plus.alpha)) and np.signbit(np.asarray(minus.alpha))
    calls.clear()
    jaco.solve(grid, [0, 0], (11, 11), "as", seed=0, **kw)  # a list cannot be a key: checked in full
    assert len(calls) == 1
    grid.meta["note"] = "mine"
    copy = pickle.loads(pickle.dumps(again)).grid  # a Result pickles: its grid without jaco's caches
    assert copy.meta["note"] == "mine" and "_solves" in grid.meta and np.array_equal(copy.free, grid.free)
    assert copy.meta == {k: v for k, v in grid.meta.items() if not k.startswith("_")}


def test_a_replaced_mask_gets_its_own_problems_not_the_old_grids():
    """jaco keeps a grid's problems in its meta; ``grid.replace(free=...)`` keeps the user's meta
    entries but not those: the new mask's query has its own optimum (here a wall makes the path
    longer) and its own reachability."""
    grid = jaco.Grid.from_rows(["....", "....", "...."], meta={"note": "kept"})
    assert jaco.make_problem(grid, (0, 0), (0, 3)).optimal == 3.0
    walled = grid.replace(free=np.array([[1, 1, 0, 1], [1, 1, 0, 1], [1, 1, 1, 1]], bool))
    assert walled.meta == {"note": "kept"}
    assert jaco.make_problem(walled, (0, 0), (0, 3)).optimal > 4.0
    with pytest.raises(jaco.ProblemError, match="cannot be reached"):
        jaco.make_problem(grid.replace(free=np.array([[1, 1, 0, 1], [1, 1, 0, 1], [1, 1, 0, 1]], bool)), (0, 0), (0, 3))
    assert jaco.make_problem(grid, (0, 0), (0, 3)).optimal == 3.0  # the first grid's own, unchanged
