"""Local search (``compose(..., local_search="shortcut")``, ``"<planner>+shortcut"``): the octile
shortcut keeps the move model and never lengthens a path; the native kernel gives the JAX
definition's paths bit for bit; names, sweeps, records and the shell take it. Every planner with it
plans valid paths, never worse than without in the iteration both runs share: tests/test_variants.py,
beside the contract whose compiled runs it shares. The published planners are unchanged (no local search)."""

import doctest
import functools
import json

import jax
import jax.numpy as jnp
import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

import jaco
from jaco.engine import local_search as ls
from jaco.engine import native
from jaco.engine.checks import default_steplimit, legacy_steplimit
from jaco.engine.problem import make_problem
from jaco.engine.run import TRACES
from jaco.metrics import validate_path
from jaco.moves import MOVE_LENGTHS, MOVES, neighbour_table
from jaco.planners.registry import get_planner, with_local_search
from jaco.research.records import load_run, save_sweep

needs_kernel = pytest.mark.skipif(not native.available(), reason="the native walk was not built")


@pytest.fixture
def walk_choice():
    yield native.set_walk
    native.set_walk(None)


# -- the shortcut on hand-made paths -------------------------------------------------------------
def _shorten(rows, path, connectivity=8, window=64, passes=4, kind="jax"):
    """The shortcut of one path of (row, col) cells (start first) on a map of text rows."""
    grid = jaco.Grid.from_rows(rows)
    nbr, _ = neighbour_table(grid.free, connectivity)
    w = grid.width
    flat = [r * w + c for r, c in path]
    cells = np.full((len(path) - 1, 1), -1, np.int32)
    cells[:, 0] = flat[1:]
    fn = ls.jax_shortcut if kind == "jax" else native.shortcut
    out = fn(jnp.asarray(cells), ls.allowed_bits(jnp.asarray(nbr)), jnp.int32(flat[0]),
             jnp.asarray((MOVES[:, 0] * w + MOVES[:, 1]).astype(np.int32)), jnp.bool_((nbr[:, 4:] >= 0).any()),
             jnp.asarray(ls.MOVE_OF), window=window, passes=passes)
    col = np.asarray(out)[:, 0]
    return [tuple(path[0])] + [divmod(int(x), w) for x in col[col >= 0]]


OPEN = ["....."] * 5
STAIRS = [(0, 0), (0, 1), (1, 1), (1, 2), (2, 2), (2, 3), (3, 3), (3, 4), (4, 4)]


@pytest.mark.parametrize("kind", ["jax", pytest.param("native", marks=needs_kernel)])
def test_a_staircase_becomes_the_diagonal(kind):
    assert _shorten(OPEN, STAIRS, kind=kind) == [(0, 0), (1, 1), (2, 2), (3, 3), (4, 4)]


@pytest.mark.parametrize("kind", ["jax", pytest.param("native", marks=needs_kernel)])
def test_the_window_bounds_how_far_a_shortcut_reaches(kind):
    """Two path cells ahead at most: each stand replaces a two-step corner by one diagonal step."""
    assert _shorten(OPEN, STAIRS, window=2, passes=1, kind=kind) == [(0, 0), (1, 1), (2, 2), (3, 3), (4, 4)]
    # along a straight line nothing is shorter, whatever the window
    line = [(0, c) for c in range(5)]
    assert _shorten(OPEN, line, window=2, kind=kind) == line


@pytest.mark.parametrize("kind", ["jax", pytest.param("native", marks=needs_kernel)])
def test_no_shortcut_cuts_a_corner_or_enters_an_obstacle(kind):
    """Around a single obstacle every diagonal shortcut would cut its corner: the path (already
    optimal in the move model) stays as it is."""
    rows = ["...", ".#.", "..."]
    path = [(0, 0), (0, 1), (0, 2), (1, 2), (2, 2)]
    assert _shorten(rows, path, kind=kind) == path
    # a detour around a wall: the shortcut goes around it, never through
    rows = [".....", "..#..", "..#..", "....."]
    detour = [(0, 0), (0, 1), (0, 2), (0, 3), (0, 4), (1, 4), (2, 4), (3, 4), (3, 3), (3, 2), (3, 1), (3, 0)]
    out = _shorten(rows, detour, kind=kind)
    grid = jaco.Grid.from_rows(rows)
    assert validate_path(grid, out, (0, 0), (3, 0)) == []
    assert _length(out) < _length(detour)


@pytest.mark.parametrize("kind", ["jax", pytest.param("native", marks=needs_kernel)])
def test_without_diagonal_moves_the_segments_are_two_straight_runs(kind):
    """4-connectivity: a segment is a run along the rows, then one along the columns (the
    columns first where the rows' run is blocked)."""
    detour = [(0, 0), (0, 1), (0, 2), (1, 2), (1, 1), (2, 1), (2, 2)]
    assert _shorten(["...", "...", "..."], detour, connectivity=4, kind=kind) == [(0, 0), (1, 0), (2, 0), (2, 1), (2, 2)]
    assert _shorten(["...", "#..", "..."], detour, connectivity=4, kind=kind) == [(0, 0), (0, 1), (0, 2), (1, 2), (2, 2)]


def test_shorten_path_outside_a_run_and_the_doctests():
    grid = jaco.Grid.from_rows(OPEN)
    assert ls.shorten_path(grid, STAIRS).tolist() == [[0, 0], [1, 1], [2, 2], [3, 3], [4, 4]]
    with pytest.raises(jaco.ProblemError, match="needs a valid path: .*not neighbours"):
        ls.shorten_path(grid, [(0, 0), (2, 2)])
    assert doctest.testmod(ls).failed == 0 and doctest.testmod(jaco.planners.registry).failed == 0


def _length(cells) -> float:
    d = np.abs(np.diff(np.asarray(cells), axis=0)).sum(axis=1)
    return float(np.sum(np.where(d == 2, MOVE_LENGTHS[4], 1.0)))


# -- random paths on random maps: valid, never longer, the kernel equals the definition ------------
FRAME, PATHS = 9, 6


@functools.lru_cache(maxsize=None)
def _compiled(kind, window, passes):
    fn = ls.jax_shortcut if kind == "jax" else native.shortcut
    return jax.jit(functools.partial(fn, window=window, passes=passes))


def _random_paths(seed, density, connectivity):
    """Self-avoiding random walks (``PATHS`` of them) on a random map in a 9x9 frame: the
    paths' cells ``(S, PATHS)``, their starts, the map and its neighbour table."""
    rng = np.random.default_rng(seed)
    free = rng.random((FRAME, FRAME)) >= density
    free.flat[rng.integers(FRAME * FRAME)] = True
    nbr, _ = neighbour_table(free, connectivity)
    cells = np.full((FRAME * FRAME, PATHS), -1, np.int32)
    starts = []
    for a in range(PATHS):
        cur = int(rng.choice(np.flatnonzero(free.ravel())))
        starts.append(cur)
        seen = {cur}
        for t in range(int(rng.integers(0, FRAME * FRAME))):
            options = [n for n in nbr[cur] if n >= 0 and n not in seen]
            if not options:
                break
            cur = int(rng.choice(options))
            seen.add(cur)
            cells[t, a] = cur
    return cells, starts, free, nbr


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.integers(0, 2**31 - 1), st.sampled_from([0.0, 0.2, 0.4]), st.sampled_from([4, 8]),
       st.sampled_from([(2, 1), (5, 2), (64, 4)]))
@example(0, 0.0, 8, (64, 4))
def test_random_paths_stay_valid_never_get_longer_and_the_kernel_agrees(seed, density, connectivity, choice):
    cells, starts, free, nbr = _random_paths(seed, density, connectivity)
    grid = jaco.Grid(free)
    offsets = jnp.asarray((MOVES[:, 0] * FRAME + MOVES[:, 1]).astype(np.int32))
    bits, diagonal = ls.allowed_bits(jnp.asarray(nbr)), jnp.bool_((nbr[:, 4:] >= 0).any())
    outs = {}
    for kind in ("jax", "native") if native.available() else ("jax",):
        # one start per path: the paths as the columns of separate calls batched by vmap
        fn = jax.vmap(_compiled(kind, *choice), in_axes=(1, None, 0, None, None, None), out_axes=1)
        outs[kind] = np.asarray(fn(jnp.asarray(cells)[:, :, None], bits, jnp.asarray(starts, jnp.int32), offsets,
                                   diagonal, jnp.asarray(ls.MOVE_OF)))[:, :, 0]
    if "native" in outs:
        np.testing.assert_array_equal(outs["native"], outs["jax"])
    for a in range(PATHS):
        before = [divmod(starts[a], FRAME)] + [divmod(int(x), FRAME) for x in cells[:, a] if x >= 0]
        after = [divmod(starts[a], FRAME)] + [divmod(int(x), FRAME) for x in outs["jax"][:, a] if x >= 0]
        assert validate_path(grid, after, before[0], before[-1], connectivity=connectivity) == []
        assert len(after) <= len(before) and _length(after) <= _length(before) + 1e-9
        assert (outs["jax"][len(after) - 1:, a] == -1).all()  # -1 after the goal


# -- planners with local search (every planner: tests/test_variants.py) ---------------------------
SMALL = dict(n_ants=16, n_iters=12)


@pytest.fixture(scope="module")
def maps_():
    return [jaco.maps.random_map(12, 0.2, seed=3), jaco.maps.named("utrap-15")]


def _same_run(a, b):
    np.testing.assert_array_equal(a.path, b.path)
    assert a.length == b.length and a.cost == b.cost and a.best_iteration == b.best_iteration
    for k in a.history:
        np.testing.assert_array_equal(a.history[k], b.history[k])


def test_each_candidate_of_an_iteration_is_never_longer_after_the_search(maps_):
    """One construct step of IACA's ants, then the local search on every candidate: each path
    valid, each cost at most its walk's, the failed ants untouched."""
    grid = maps_[1]
    start, goal = grid.meta["start"], grid.meta["goal"]
    v = jaco.PLANNERS["iaca"]
    problem = jax.tree.map(jnp.asarray, make_problem(grid, start, goal))
    params = jaco.engine.checks.params_from(jaco.engine.checks.resolve_params(v, {}, where="test"))
    trail = v.rule.init(jaco.engine.pheromone.Trail(jnp.zeros(grid.n_cells), jnp.float32(0), jnp.float32(jnp.inf)),
                        problem, params)
    _, colony = v.construct(v, problem, trail, params, 0, 5, jax.random.key(1), n_ants=20, steplimit=200)
    search = ls.shortcut_search(window=ls.WINDOW, passes=ls.PASSES, best=None)
    after = search(v, problem, colony, params)
    cost0, cost1 = np.asarray(colony.cost), np.asarray(after.cost)
    assert np.isfinite(cost0).sum() >= 10 and (cost1 <= cost0).all() and (cost1 < cost0).any()
    np.testing.assert_array_equal(np.isfinite(cost0), np.isfinite(cost1))
    cells = np.asarray(after.cells)
    for a in np.flatnonzero(np.isfinite(cost0)):
        path = [start] + [divmod(int(x), grid.width) for x in cells[:, a] if x >= 0]
        assert validate_path(grid, path, start, goal) == []
        assert _length(path) == pytest.approx(float(after.length[a]))
    failed = ~np.isfinite(cost0)
    np.testing.assert_array_equal(cells[:, failed], np.asarray(colony.cells)[:, failed])


@pytest.mark.slow  # one program per k
def test_the_best_k_are_searched_and_a_cost_that_would_rise_keeps_the_walk(maps_):
    """``best=2`` touches at most the two cheapest candidates; with the multi-objective cost a
    shorter path whose cost J would be higher is not taken (the cost never rises)."""
    grid = maps_[1]
    start, goal = grid.meta["start"], grid.meta["goal"]
    for name in ("iaca", "iaaco"):
        v = get_planner(name)
        problem = jax.tree.map(jnp.asarray, make_problem(grid, start, goal))
        params = jaco.engine.checks.params_from(jaco.engine.checks.resolve_params(v, {}, where="test"))
        trail = v.rule.init(jaco.engine.pheromone.Trail(jnp.zeros(8 * grid.n_cells if v.pheromone_on == "moves" else grid.n_cells),
                                                        jnp.float32(0), jnp.float32(jnp.inf)), problem, params)
        params = v.schedule(params, 0, 5)  # the first iteration's parameters, as the run hands them (IAACO's q0)
        _, colony = v.construct(v, problem, trail, params, 0, 5, jax.random.key(2), n_ants=20, steplimit=200)
        after = ls.shortcut_search(window=ls.WINDOW, passes=ls.PASSES, best=2)(v, problem, colony, params)
        changed = np.flatnonzero(np.any(np.asarray(after.cells) != np.asarray(colony.cells), axis=0))
        cheapest = np.argsort(np.asarray(colony.cost), kind="stable")[:2]
        assert set(changed) <= set(cheapest)
        assert (np.asarray(after.cost) <= np.asarray(colony.cost)).all()


def test_repeated_runs_with_local_search_compile_once():
    a = jaco.maps.random_map(12, 0.2, seed=1)
    b = jaco.maps.random_map(12, 0.1, seed=2)
    v = with_local_search("acs")
    jaco.solve(a, (0, 0), (11, 11), v, seed=0, **SMALL)
    before = TRACES[v.name]
    jaco.solve(a, (0, 0), (11, 11), v, seed=1, q=2.0, **SMALL)
    jaco.solve(b, (11, 11), (0, 0), v.name, seed=2, **SMALL)
    assert TRACES[v.name] == before


# -- names, compositions, sweeps, records, the shell ----------------------------------------------
def test_names_resolve_to_one_object_and_published_planners_have_no_local_search():
    c = jaco.compose(construct="backtrack", heuristic="chaos", rule="iaca", local_search="shortcut")
    assert c.name == ("compose(construct=backtrack, heuristic=chaos, rule=iaca, transition=q0, schedule=constant, "
                      "cost=length, local_search=shortcut)")
    plain = jaco.compose(construct="backtrack", heuristic="chaos", rule="iaca")
    assert "local_search" not in plain.name and plain.local_search is None
    assert plain is jaco.compose(construct="backtrack", heuristic="chaos", rule="iaca", local_search="none")
    assert get_planner(c.name) is c is get_planner(plain.name + "+shortcut") is with_local_search(plain)
    assert with_local_search(c, "none") is plain
    assert all(v.local_search is None for v in jaco.PLANNERS.values())
    assert get_planner("acs+multi+shortcut").cost is jaco.engine.cost.multi_objective
    with pytest.raises(jaco.JacoError, match="unknown local_search 'two-opt'; local searches: none, shortcut"):
        jaco.compose(local_search="two-opt")
    with pytest.raises(jaco.JacoError, match=r"unknown planner 'iaca\+two-opt'.*\+shortcut"):
        get_planner("iaca+two-opt")
    with pytest.raises(jaco.JacoError, match="has a local search already"):
        with_local_search(get_planner("iaca+shortcut+multi"))


@pytest.mark.slow  # two planners, their sweep and solves and a record rerun
def test_a_sweep_takes_local_search_as_a_categorical_axis_and_its_record_reruns(tmp_path, maps_):
    grid = maps_[0]
    ends = grid.meta["start"], grid.meta["goal"]
    names = ["iaca", "iaca+shortcut"]
    table = jaco.sweep(grid, *ends, names, params={"beta": [4.0, 8.0]}, seeds=2, **SMALL)
    assert list(table.planner.unique()) == names and len(table) == 8
    for _, row in table[table.planner == "iaca+shortcut"].iterrows():
        r = jaco.solve(grid, *ends, "iaca+shortcut", seed=int(row.seed), beta=row.beta, **SMALL)
        assert row.length == r.length and row.best_iteration == r.best_iteration
    save_sweep(table, tmp_path / "s.csv", grid, *ends, names, {"beta": [4.0, 8.0]}, 2, **SMALL)
    assert load_run(tmp_path / "s.csv").rerun().matched
    run = jaco.solve(grid, *ends, jaco.compose(construct="backtrack", heuristic="chaos", rule="iaca",
                                               local_search="shortcut"), seed=3, **SMALL)
    check = load_run(run.save(tmp_path / "run.json")).rerun()
    assert check.matched, check.summary()


def test_the_shell_takes_a_planner_with_local_search(capsys):
    code = jaco.cli.main(["solve", "demo", "--variant", "iaca+shortcut", "--ants", "10", "--iters", "10"])
    out = capsys.readouterr().out
    assert code == 0 and "iaca+shortcut" in out


# -- the default step limit ----------------------------------------------------------------------
def test_backtracking_ants_get_twice_the_default_step_limit_stretched_on_mazes():
    """Dying ants: 4·(H + W) at most the free cells. Backtracking ants: 8·max(H + W, the free
    cells' extent) at most twice the free cells; on a snake-shaped corridor the extent is its
    length, exactly."""
    berlin = jaco.maps.load(jaco.maps.bundled("Berlin_1_256.map"))
    assert jaco.exact.free_extent(berlin) < 512
    assert default_steplimit(berlin) == legacy_steplimit(berlin) == 4 * 512
    for name in ("iaca", "iaca+shortcut", jaco.compose(construct="backtrack", rule="mmas").name):
        assert default_steplimit(berlin, get_planner(name)) == 8 * 512
    assert default_steplimit(berlin, get_planner("acs")) == default_steplimit(berlin, get_planner("idaca")) == 4 * 512
    maze = jaco.maps.load(jaco.maps.bundled("maze-128-128-1.map"))
    assert jaco.exact.free_extent(maze) == 1208  # a perfect maze: the double sweep is exact, 4.7 × (H + W)
    assert default_steplimit(maze) == 1024 and default_steplimit(maze, get_planner("iaca")) == 8 * 1208
    snake = jaco.Grid.from_rows(["#....", "#.##.", "#..#.", "##.#.", "...#."])  # one corridor, 14 steps end to end
    assert jaco.exact.free_extent(snake) == 14 and default_steplimit(snake, get_planner("iaca")) == 2 * snake.n_free
    tiny = jaco.Grid.from_rows(["..", ".."])
    assert default_steplimit(tiny) == 4 and default_steplimit(tiny, get_planner("iaca")) == 8
    assert jaco.exact.free_extent(jaco.Grid.from_rows(["#.#"])) == 0


def test_a_sweep_record_without_a_step_limit_reruns_with_the_default_of_its_format(tmp_path, monkeypatch):
    """A sweep record stores ``steplimit: null`` for the default. One written before format 3
    meant the old default for every planner, one of format 3 twice that for backtracking ants, and
    each reruns with its own bit for bit."""
    grid = jaco.maps.named("utrap-20")
    ends = grid.meta["start"], grid.meta["goal"]
    old, new = legacy_steplimit(grid), default_steplimit(grid, get_planner("iaca"))
    assert new == 2 * old
    kw = dict(seeds=2, n_ants=30, n_iters=3)
    then = jaco.sweep(grid, *ends, "iaca", steplimit=old, **kw)
    now = jaco.sweep(grid, *ends, "iaca", **kw)
    assert not then.equals(now)  # the limit matters on this map
    assert then.attrs["sweep"]["steplimit"] == old and now.attrs["sweep"]["steplimit"] == new
    sidecar = save_sweep(then, tmp_path / "old.csv", grid, *ends, "iaca", **kw)
    doc = json.loads(sidecar.read_text())
    assert doc["call"]["steplimit"] is None and doc["format_version"] == 4
    assert not load_run(sidecar).rerun().matched  # read as format 4: today's default
    doc["format_version"] = 2
    sidecar.write_text(json.dumps(doc))
    check = load_run(sidecar).rerun()
    assert check.matched, check.summary()
    pd.testing.assert_frame_equal(check.result, then)
    # Format 3: twice the old default for backtracking ants, 8·(H + W) before the free cells' extent
    # counted; on a maze the two differ, and a list of planners reruns each with its own.
    maze = jaco.maps.load(jaco.maps.bundled("maze-128-128-1.map"))
    three = legacy_steplimit(maze, get_planner("iaca"), 3)
    assert (three, legacy_steplimit(maze, get_planner("acs"), 3)) == (8 * 256, 4 * 256)
    assert three < default_steplimit(maze, get_planner("iaca"))
    doc.update(format_version=3, call={**doc["call"], "variant": ["iaca", "acs"]})
    sidecar.write_text(json.dumps(doc))
    rec = load_run(sidecar)
    rec.grids = maze
    seen = []

    def spy(**k):  # the sweep each planner would run, without running it
        seen.append((get_planner(k["planner"]).name, k["steplimit"]))
        table = then.iloc[:0].copy()
        table.attrs["sweep"] = {}
        return table

    monkeypatch.setattr(jaco.research.sweeps, "sweep", spy)
    assert not rec.rerun(warn=False).matched
    assert seen == [("iaca", three), ("acs", 4 * 256)]
