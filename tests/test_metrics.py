"""Tests of jaco.metrics: path validity, lengths, turns, clearance, line of sight, indices."""

import math
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from jaco.errors import ParamError
from jaco.grid import Grid
from jaco.metrics import (
    DEFAULT_WEIGHTS,
    any_angle_length,
    clearance_stats,
    gap,
    heading_change,
    line_of_sight,
    path_length,
    path_metrics,
    performance_indices,
    safety_cost,
    shortcut,
    turns,
    validate_path,
)

SQ2 = math.sqrt(2.0)
OPEN5 = Grid.from_rows(["....."] * 5)
PILLAR5 = Grid.from_rows([".....", ".....", "..#..", ".....", "....."])


def _has(problems, *parts):
    """True if one message contains every part (index text and kind)."""
    return any(all(p in m for p in parts) for m in problems)


# -- validate_path -----------------------------------------------------------------------------
def test_valid_path_has_no_problems():
    g = Grid.from_rows(["....", ".##.", "...."])
    path = [(0, 0), (0, 1), (0, 2), (0, 3), (1, 3), (2, 3), (2, 2), (2, 1), (2, 0)]
    assert validate_path(g, path, start=(0, 0), goal=(2, 0)) == []
    assert validate_path(g, np.array(path)) == []


def test_single_cell_path_with_start_equal_goal_is_valid():
    assert validate_path(OPEN5, [(2, 3)], start=(2, 3), goal=(2, 3)) == []


def test_empty_path_is_reported():
    assert validate_path(OPEN5, []) == ["path is empty"]
    assert validate_path(OPEN5, None) == ["path is empty"]


def test_corner_cut_is_reported_with_index():
    g = Grid.from_rows(["...", "#..", "..."])
    # (0,0) -> (1,1) passes the blocked (1,0).
    probs = validate_path(g, [(0, 1), (0, 0), (1, 1), (2, 2)])
    assert len(probs) == 1
    assert _has(probs, "path[1] -> path[2]", "corner cut", "(1, 0)")
    # The same diagonal the other way round is cut too.
    assert _has(validate_path(g, [(1, 1), (0, 0)]), "path[0] -> path[1]", "corner cut")
    # The other diagonal on the same square has both orthogonals free.
    assert validate_path(g, [(0, 1), (1, 2)]) == []


def test_jump_and_repeated_cell_are_reported():
    probs = validate_path(OPEN5, [(0, 0), (0, 1), (0, 3), (0, 4)])
    assert probs and _has(probs, "path[1] -> path[2]", "jump")
    probs = validate_path(OPEN5, [(0, 0), (0, 1), (0, 1), (0, 2)])
    assert _has(probs, "path[1] -> path[2]", "jump", "repeated")


def test_blocked_and_out_of_bounds_cells_are_reported():
    probs = validate_path(PILLAR5, [(2, 0), (2, 1), (2, 2), (2, 3)])
    assert _has(probs, "path[2]", "(2, 2)", "blocked")
    probs = validate_path(OPEN5, [(0, 0), (-1, 0)])
    assert _has(probs, "path[1]", "(-1, 0)", "out of bounds")
    probs = validate_path(OPEN5, [(4, 4), (4, 5)])
    assert _has(probs, "path[1]", "out of bounds")


def test_wrong_ends_are_reported():
    path = [(0, 0), (0, 1), (0, 2)]
    probs = validate_path(OPEN5, path, start=(1, 0), goal=(0, 2))
    assert probs == [p for p in probs if "path[0]" in p and "start" in p] and len(probs) == 1
    probs = validate_path(OPEN5, path, start=(0, 0), goal=(4, 4))
    assert len(probs) == 1 and _has(probs, "path[2]", "goal")


def test_connectivity_4_rejects_diagonals():
    path = [(0, 0), (1, 1)]
    assert validate_path(OPEN5, path) == []
    assert _has(validate_path(OPEN5, path, connectivity=4), "path[0] -> path[1]", "diagonal")
    assert validate_path(OPEN5, [(0, 0), (1, 0), (1, 1)], connectivity=4) == []
    with pytest.raises(ValueError):
        validate_path(OPEN5, path, connectivity=6)


def test_malformed_path_is_a_problem_not_a_crash():
    assert _has(validate_path(OPEN5, [[0, 0, 0]]), "(K, 2)")
    assert _has(validate_path(OPEN5, [(0.5, 0.0)]), "integer")


# -- lengths, turns ----------------------------------------------------------------------------
def test_path_length_straight_and_diagonal():
    path = [(0, 0), (0, 1), (0, 2), (0, 3), (1, 4), (2, 5)]  # 3 straight + 2 diagonal
    assert path_length(path) == pytest.approx(3 + 2 * SQ2, abs=1e-12)
    assert path_length(path, cell_size=10) == pytest.approx(30 + 20 * SQ2, abs=1e-12)
    assert path_length([(3, 3)]) == 0.0
    assert path_length([]) == 0.0


def test_turns_on_l_shape_zigzag_and_reversal():
    l_shape = [(0, 0), (0, 1), (0, 2), (1, 2), (2, 2)]
    assert turns(l_shape) == 1
    assert heading_change(l_shape) == pytest.approx(math.pi / 2)
    zigzag = [(0, 0), (0, 1), (1, 2), (1, 3), (2, 4)]  # right, diag, right, diag
    assert turns(zigzag) == 3
    assert heading_change(zigzag) == pytest.approx(3 * math.pi / 4)
    straight = [(0, 0), (1, 1), (2, 2), (3, 3)]
    assert turns(straight) == 0 and heading_change(straight) == 0.0
    back = [(0, 0), (0, 1), (0, 0)]
    assert turns(back) == 1 and heading_change(back) == pytest.approx(math.pi)
    # A repeated cell has no heading and is not a turn.
    assert turns([(0, 0), (0, 1), (0, 1), (0, 2)]) == 0


# -- clearance and safety ----------------------------------------------------------------------
def test_clearance_and_safety_by_hand():
    # On an open 5x5 map (outside = blocked) clearances are 1 on the border, 2 inside, 3 at the centre.
    path = [(0, 0), (1, 1), (2, 2), (2, 3), (2, 4)]
    mn, mean = clearance_stats(OPEN5, path)
    assert mn == pytest.approx(1.0) and mean == pytest.approx(9 / 5)
    # rs = 1: each cell adds max(0, 2 - d)/2 -> 0.5 + 0 + 0 + 0 + 0.5.
    assert safety_cost(OPEN5, path, rs=1.0) == pytest.approx(1.0)
    # rs = 1.5: max(0, 3 - d)/3 -> 2/3 + 1/3 + 0 + 1/3 + 2/3.
    assert safety_cost(OPEN5, path, rs=1.5) == pytest.approx(2.0)
    # rs = 0.5: free cells are >= 1 from an obstacle, so S = 0.
    assert safety_cost(OPEN5, path, rs=0.5) == 0.0
    with pytest.raises(ValueError):
        safety_cost(OPEN5, path, rs=0.0)


def test_clearance_next_to_a_pillar():
    # (1,1) is sqrt(2) from the pillar (2,2); (1,2) is 1 from it.
    mn, mean = clearance_stats(PILLAR5, [(1, 1), (1, 2)])
    assert mn == pytest.approx(1.0) and mean == pytest.approx((SQ2 + 1) / 2, rel=1e-6)
    assert safety_cost(PILLAR5, [(1, 1)], rs=1.0) == pytest.approx((2 - SQ2) / 2, rel=1e-6)
    # A blocked cell adds 1 whatever rs is.
    assert safety_cost(PILLAR5, [(2, 2)], rs=0.5) == pytest.approx(1.0)


# -- line of sight -----------------------------------------------------------------------------
def test_line_of_sight_rules():
    g = Grid.from_rows(["...", "#..", "..."])
    assert line_of_sight(g, (0, 1), (1, 2))  # allowed diagonal
    assert not line_of_sight(g, (0, 0), (1, 1))  # corner cut
    assert not line_of_sight(g, (0, 0), (2, 0))  # through the wall
    assert line_of_sight(g, (0, 0), (0, 2)) and line_of_sight(g, (2, 2), (2, 2))
    assert not line_of_sight(g, (1, 0), (1, 2))  # starts in a blocked cell
    assert not line_of_sight(g, (0, 0), (0, 3))  # off the map


def test_line_of_sight_through_a_vertex_is_conservative():
    # (0,0) -> (1,3) passes exactly through the grid vertex at x = 2, y = 1 (cell corners), which
    # is shared by (0,1), (0,2), (1,1), (1,2): one blocked cell there is enough to block sight.
    for blocked in [(0, 2), (1, 1)]:
        free = np.ones((2, 4), bool)
        free[blocked] = False
        g = Grid.from_array(free)
        assert not line_of_sight(g, (0, 0), (1, 3))
        assert not line_of_sight(g, (1, 3), (0, 0))
    # A cell the segment only passes near (not touching) does not block it.
    free = np.ones((2, 4), bool)
    free[0, 3] = False
    assert line_of_sight(Grid.from_array(free), (0, 0), (1, 3))


def _reference_los(grid, a, b):
    """Closed supercover by exact enumeration of the crossings (Fractions): slow but obvious."""
    (r0, c0), (r1, c1) = a, b
    x0, y0 = Fraction(2 * c0 + 1, 2), Fraction(2 * r0 + 1, 2)
    dx, dy = c1 - c0, r1 - r0
    ts = {Fraction(0), Fraction(1)}
    for d, s0 in ((dx, x0), (dy, y0)):
        if d:
            lo, hi = sorted((s0, s0 + d))
            for k in range(math.ceil(lo), math.floor(hi) + 1):
                ts.add((k - s0) / d)
    ts = sorted(ts)
    points = ts + [(u + v) / 2 for u, v in zip(ts, ts[1:])]
    cells = set()
    for t in points:
        x, y = x0 + t * dx, y0 + t * dy
        xs = [int(x) - 1, int(x)] if x.denominator == 1 else [math.floor(x)]
        ys = [int(y) - 1, int(y)] if y.denominator == 1 else [math.floor(y)]
        cells.update((r, c) for r in ys for c in xs)
    return all(grid.is_free(c) for c in cells)


# -- shortcut ----------------------------------------------------------------------------------
def test_shortcut_on_open_map_is_one_segment():
    g = Grid.from_rows(["......"] * 4)
    path = [(0, 0), (0, 1), (1, 2), (2, 3), (2, 4), (3, 5)]
    sc = shortcut(g, path)
    assert sc.tolist() == [[0, 0], [3, 5]]
    assert any_angle_length(g, path) == pytest.approx(math.hypot(3, 5))
    assert any_angle_length(g, path, cell_size=10) == pytest.approx(10 * math.hypot(3, 5))
    assert any_angle_length(g, path) <= path_length(path)


def test_shortcut_around_a_wall_keeps_sight_and_ends():
    g = Grid.from_rows([
        ".......",
        "...#...",
        "...#...",
        "...#...",
        ".......",
    ])
    path = [(2, 0), (3, 1), (4, 2), (4, 3), (4, 4), (3, 5), (2, 6)]
    assert validate_path(g, path) == []
    sc = shortcut(g, path)
    assert tuple(sc[0]) == (2, 0) and tuple(sc[-1]) == (2, 6)
    assert len(sc) >= 3  # the wall forbids the straight line
    for u, v in zip(sc, sc[1:]):
        assert line_of_sight(g, u, v)
    assert math.hypot(0, 6) < any_angle_length(g, path) < path_length(path)


def test_shortcut_of_short_paths_is_the_path():
    assert shortcut(OPEN5, [(1, 1)]).tolist() == [[1, 1]]
    assert shortcut(OPEN5, []).shape == (0, 2)
    assert any_angle_length(OPEN5, []) == 0.0


# -- gap, path_metrics -------------------------------------------------------------------------
def test_gap():
    assert gap(12.0, 10.0) == pytest.approx(0.2)
    assert gap(10.0, 10.0) == 0.0
    assert gap(0.0, 0.0) == 0.0
    assert gap(math.inf, 10.0) == math.inf
    assert gap(1.0, 0.0) == math.inf
    with pytest.raises(ValueError):
        gap(1.0, -1.0)
    # a Python number, a numpy scalar and a 0-d array give one gap; an array gives one per length
    assert gap(12, 10) == gap(np.float32(12.0), 10.0) == gap(np.array(12.0), np.float64(10.0)) == pytest.approx(0.2)
    assert gap(np.array([12.0, math.inf]), 10.0).tolist() == pytest.approx([0.2, math.inf])
    for bad in (math.nan, -1.0, np.float32("nan")):
        with pytest.raises(ValueError):
            gap(bad, 10.0)


def test_path_metrics_dict():
    g = Grid.from_rows(["....", "....", "...."], cell_size=10.0)
    path = [(0, 0), (0, 1), (0, 2), (1, 3), (2, 3)]
    m = path_metrics(g, path)
    assert "gap" not in m
    assert m["valid"] is True and m["problems"] == []
    assert m["length"] == pytest.approx(10 * (3 + SQ2))
    assert m["turns"] == 2 and m["heading_change"] == pytest.approx(math.pi / 2)
    assert m["min_clearance"] == pytest.approx(1.0)
    assert m["any_angle_length"] <= m["length"] + 1e-9
    assert m["safety"] == pytest.approx(2.5)  # five cells on the map's edge, 0.5 each (SAFETY_RADIUS = 1)
    m = path_metrics(g, path, optimal=10 * (2 + 2 * SQ2), rs=0.5)
    assert m["gap"] == pytest.approx((3 + SQ2) / (2 + 2 * SQ2) - 1)
    assert m["safety"] == 0.0  # Miao et al. 2021's Rs = 0.5 scores every free cell 0
    bad = path_metrics(g, [(0, 0), (2, 2)])
    assert bad["valid"] is False and _has(bad["problems"], "jump")
    assert all(not (isinstance(v, float) and math.isnan(v)) for v in m.values())


# -- performance indices -----------------------------------------------------------------------
def test_a_result_has_one_gap():
    """``Result.metrics()["gap"]`` (``metrics.gap`` of ``jaco solve --json``) is the result's own gap,
    :func:`gap` of its length: 0 exactly on an optimal path, never a second value from the path's
    float64 length (which would read -2.6e-08 or 2.3e-08 beside 0)."""
    import jaco

    g = jaco.maps.named("demo")
    r = jaco.solve(g, g.meta["start"], g.meta["goal"], "acs", seed=1, n_ants=10, n_iters=10, beta=6, rho=0.1,
                   progress=False)
    assert r.success and r.gap == gap(r.length, r.optimal) == 0.0  # this run finds the optimum
    assert path_metrics(g, r.path, optimal=r.optimal)["gap"] != 0.0  # the float64 re-sum of the path differs
    assert r.metrics()["gap"] == r.gap and r.to_dict()["gap"] == r.gap
    failed = jaco.solve(g, g.meta["start"], g.meta["goal"], "acs", n_ants=2, n_iters=1, steplimit=3, progress=False)
    assert not failed.success and failed.metrics()["gap"] == failed.gap == math.inf


def test_performance_indices_by_hand():
    out = performance_indices(
        best_lengths=[10.0, 12.0, math.inf, 14.0],
        optimal=10.0,
        iters_to_converge=[20, 30, 40, 10],
        time_per_iter=[0.1, 0.2, 0.1, 0.2],
        max_iters=100,
        weights=(0.4, 0.2, 0.4),
    )
    # c_b = 10 (inf excluded), c_a = 12, I_a = 25, T0 = 0.15.
    assert out["E0"] == pytest.approx(0.0)
    assert out["Er"] == pytest.approx(0.2)
    assert out["Et"] == pytest.approx(25 * 0.15 / 100)
    assert out["E"] == pytest.approx(0.4 * 0.0 + 0.2 * 0.0375 + 0.4 * 0.2)
    assert out["success_rate"] == pytest.approx(0.75)


def test_performance_indices_defaults_and_failures():
    assert sum(DEFAULT_WEIGHTS) == pytest.approx(1.0)
    out = performance_indices([11.0, 13.0], 10.0, 5, 0.02, 50)
    assert out["E0"] == pytest.approx(0.1) and out["Er"] == pytest.approx(0.2)
    assert out["Et"] == pytest.approx(5 * 0.02 / 50)
    a, b, c = DEFAULT_WEIGHTS
    assert out["E"] == pytest.approx(a * 0.1 + b * 0.002 + c * 0.2)
    failed = performance_indices([math.inf, math.inf], 10.0, [50, 50], [0.1, 0.1], 50)
    assert failed["E0"] == math.inf and failed["Er"] == math.inf and failed["E"] == math.inf
    only_time = performance_indices([math.inf], 10.0, 50, 0.1, 50, weights=(0, 1, 0))
    assert only_time["E"] == pytest.approx(0.1)


@pytest.mark.parametrize("weights", [(0.5, 0.3, 0.3), (0.2, 0.2, 0.2), (1.2, -0.1, -0.1), (0.5, 0.5)])
def test_performance_indices_bad_weights_raise(weights):
    with pytest.raises(ValueError):
        performance_indices([10.0], 10.0, 1, 1.0, 10, weights=weights)
    with pytest.raises(ParamError):
        performance_indices([10.0], 10.0, 1, 1.0, 10, weights=weights)


# -- property tests ----------------------------------------------------------------------------
DIRS8 = [(-1, -1), (-1, 0), (-1, 1), (0, -1), (0, 1), (1, -1), (1, 0), (1, 1)]
PROPS = settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])


def _moves(free, cell, connectivity=8):
    """Allowed moves, written independently of jaco.metrics: in bounds, free, no corner cut."""
    H, W = free.shape
    r, c = cell
    out = []
    for dr, dc in DIRS8:
        if connectivity == 4 and dr and dc:
            continue
        nr, nc = r + dr, c + dc
        if not (0 <= nr < H and 0 <= nc < W and free[nr, nc]):
            continue
        if dr and dc and not (free[nr, c] and free[r, nc]):
            continue
        out.append((nr, nc))
    return out


@st.composite
def grids(draw, min_side=2, max_side=9):
    H = draw(st.integers(min_side, max_side))
    W = draw(st.integers(min_side, max_side))
    # About one cell in four blocked.
    cells = draw(st.lists(st.integers(0, 3), min_size=H * W, max_size=H * W))
    return np.array(cells, dtype=int).reshape(H, W) > 0


def _walk(data, free, start, connectivity=8, max_steps=25):
    path = [tuple(start)]
    for _ in range(data.draw(st.integers(0, max_steps))):
        options = _moves(free, path[-1], connectivity)
        if not options:
            break
        path.append(data.draw(st.sampled_from(options)))
    return path


def _free_cells(free):
    return [tuple(int(v) for v in rc) for rc in np.argwhere(free)]


@PROPS
@given(free=grids(), data=st.data(), connectivity=st.sampled_from([4, 8]))
def test_random_walks_are_valid(free, data, connectivity):
    cells = _free_cells(free)
    assume(cells)
    g = Grid.from_array(free)
    path = _walk(data, free, data.draw(st.sampled_from(cells)), connectivity)
    assert validate_path(g, path, start=path[0], goal=path[-1], connectivity=connectivity) == []
    # Every allowed step has line of sight, both ways.
    for u, v in zip(path, path[1:]):
        assert line_of_sight(g, u, v) and line_of_sight(g, v, u)
    sc = shortcut(g, path)
    assert tuple(sc[0]) == path[0] and tuple(sc[-1]) == path[-1]
    for u, v in zip(sc, sc[1:]):
        assert line_of_sight(g, u, v)
    assert any_angle_length(g, path) <= path_length(path) + 1e-9


@PROPS
@given(free=grids(), data=st.data())
def test_inserted_jump_is_detected(free, data):
    cells = _free_cells(free)
    assume(cells)
    g = Grid.from_array(free)
    first = _walk(data, free, data.draw(st.sampled_from(cells)))
    a = first[-1]
    far = [c for c in cells if max(abs(c[0] - a[0]), abs(c[1] - a[1])) != 1]  # includes a itself
    second = _walk(data, free, data.draw(st.sampled_from(far)))
    path = first + second
    i = len(first) - 1
    assert _has(validate_path(g, path), f"path[{i}] -> path[{i + 1}]", "jump")


@PROPS
@given(free=grids(), data=st.data())
def test_inserted_corner_cut_is_detected(free, data):
    H, W = free.shape
    free = free.copy()
    dr, dc = data.draw(st.sampled_from([(-1, -1), (-1, 1), (1, -1), (1, 1)]))
    ar = data.draw(st.integers(max(0, -dr), H - 1 - max(0, dr)))
    ac = data.draw(st.integers(max(0, -dc), W - 1 - max(0, dc)))
    a, b = (ar, ac), (ar + dr, ac + dc)
    free[a] = free[b] = True
    free[ar + dr, ac] = False  # the corner the diagonal b -> a would cut
    g = Grid.from_array(free)
    to_b = _walk(data, free, b)[::-1]  # ends at b
    from_a = _walk(data, free, a)
    path = to_b + from_a
    i = len(to_b) - 1
    probs = validate_path(g, path)
    assert _has(probs, f"path[{i}] -> path[{i + 1}]", "corner cut")
    assert validate_path(g, to_b) == [] and validate_path(g, from_a) == []


@PROPS
@given(free=grids(max_side=8), data=st.data())
def test_line_of_sight_matches_exact_reference(free, data):
    g = Grid.from_array(free)
    H, W = free.shape
    a = (data.draw(st.integers(0, H - 1)), data.draw(st.integers(0, W - 1)))
    b = (data.draw(st.integers(0, H - 1)), data.draw(st.integers(0, W - 1)))
    los = line_of_sight(g, a, b)
    assert los == _reference_los(g, a, b)
    assert los == line_of_sight(g, b, a)
    if los:  # every point of the segment lies in a free cell
        t = np.linspace(0.0, 1.0, 257)
        x = a[1] + 0.5 + t * (b[1] - a[1])
        y = a[0] + 0.5 + t * (b[0] - a[0])
        assert free[np.floor(y).astype(int), np.floor(x).astype(int)].all()
