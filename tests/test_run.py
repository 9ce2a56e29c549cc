"""solve / sweep API: validation before compiling, results, batching of queries, chunking."""

import json
import math
import re

import numpy as np
import pytest

import jaco
from jaco.engine.run import TRACES

GRID = jaco.Grid.from_rows(["......", ".##...", "...#..", "......"])


@pytest.mark.parametrize(
    "kw,match",
    [
        (dict(alpha=float("nan")), "NaN"),
        (dict(rho=0.0), "out of range"),
        (dict(rho=1.5), "out of range"),
        (dict(q0=-0.1), "unknown parameter 'q0'"),  # mmas has no q0
        (dict(betta=2.0), "valid: alpha, beta"),
        (dict(beta="x"), "must be a number"),
        (dict(beta=[1.0, 2.0]), "use jaco.sweep"),
        (dict(n_ants=0), "n_ants must be a positive integer"),
        (dict(n_iters=2.5), "n_iters must be a positive integer"),
        (dict(seed="a"), "seed must be an integer"),
    ],
)
def test_bad_parameters_are_clear_errors_before_compiling(kw, match):
    before = sum(TRACES.values())
    with pytest.raises(jaco.JacoError, match=match):
        jaco.solve(GRID, (0, 0), (3, 5), "mmas", **kw)
    assert sum(TRACES.values()) == before


def test_unknown_variant_lists_the_registered_ones():
    with pytest.raises(jaco.JacoError, match="registered: acs, apf-aco, as, "):
        jaco.solve(GRID, (0, 0), (3, 5), "nope")


def test_result_fields_and_json():
    r = jaco.solve(GRID, (0, 0), (3, 5), "acs", seed=2, n_ants=10, n_iters=8)
    assert r.path[0].tolist() == [0, 0] and r.path[-1].tolist() == [3, 5]
    assert r.length == pytest.approx(jaco.metrics.path_length(r.path))
    assert r.optimal == pytest.approx(jaco.exact.shortest_path(GRID, (0, 0), (3, 5))[0])
    assert set(r.history) == {"best", "iteration_best", "mean", "success_rate"}
    assert all(len(v) == 8 for v in r.history.values())
    assert 0 < r.coverage <= 1
    d = json.loads(json.dumps(r.to_dict(), allow_nan=False))
    assert d["path"][-1] == [3, 5] and d["planner"] == "acs" and d["params"]["q0"] == pytest.approx(0.8)


def test_a_path_is_the_start_then_the_cells_entered_until_the_padding():
    from jaco.engine.result import path_cells

    grid = jaco.Grid.from_rows(["....", "....", "...."])  # width 4: cell 6 is (1, 2)
    path = path_cells(grid, (0, 1), np.array([6, 11, -1, -1], np.int32))
    assert path.dtype == np.int64 and path.tolist() == [[0, 1], [1, 2], [2, 3]]
    assert path_cells(grid, np.array([2, 0]), np.full(5, -1, np.int32)).tolist() == [[2, 0]]  # start on the goal


def test_cell_size_scales_reported_lengths_only():
    big = GRID.replace(cell_size=10.0)
    a = jaco.solve(GRID, (0, 0), (3, 5), "as", seed=0, n_ants=10, n_iters=5)
    b = jaco.solve(big, (0, 0), (3, 5), "as", seed=0, n_ants=10, n_iters=5)
    assert np.array_equal(a.path, b.path)
    assert b.length == pytest.approx(10 * a.length) and b.optimal == pytest.approx(10 * a.optimal)


def test_sweep_over_several_queries_and_maps_in_one_batch():
    other = jaco.Grid.from_rows(["......", "...#..", "...#..", "......"])
    table = jaco.sweep([GRID, other], (0, 0), [(3, 5), (0, 5)], "as", params={"beta": [1.0, 3.0]}, seeds=2, n_ants=8, n_iters=5)
    assert len(table) == 2 * 2 * 2
    assert set(table["map"]) == {GRID.name, other.name} or len(set(table["goal_col"])) == 2
    for _, row in table.iterrows():
        start, goal = (row.start_row, row.start_col), (row.goal_row, row.goal_col)  # integer columns
        g = GRID if goal == (3, 5) else other
        r = jaco.solve(g, start, goal, "as", seed=int(row.seed), beta=row.beta, n_ants=8, n_iters=5)
        assert r.length == row.length


def test_sweep_chunks_under_a_small_memory_budget_and_matches_one_chunk():
    kw = dict(params={"alpha": [0.5, 1.0, 2.0]}, seeds=3, n_ants=8, n_iters=4)
    whole = jaco.sweep(GRID, (0, 0), (3, 5), "ras", **kw)
    chunked = jaco.sweep(GRID, (0, 0), (3, 5), "ras", memory_budget=1, **kw)  # one run per chunk
    assert whole.equals(chunked)


def test_sweep_validates_values_and_shapes():
    with pytest.raises(jaco.ParamError, match="out of range"):
        jaco.sweep(GRID, (0, 0), (3, 5), "as", params={"rho": [0.5, 2.0]}, seeds=1)
    with pytest.raises(jaco.JacoError, match="one shape"):
        jaco.sweep([GRID, jaco.Grid.from_rows(["..", ".."])], (0, 0), (1, 1), "as")
    with pytest.raises(jaco.JacoError, match="expected 1 or 3"):
        jaco.sweep(GRID, [(0, 0), (0, 1)], [(3, 5), (3, 4), (3, 3)], "as")


def test_summarize_aggregates_over_seeds():
    table = jaco.sweep(GRID, (0, 0), (3, 5), "as", params={"beta": [1.0, 3.0]}, seeds=3, n_ants=8, n_iters=4)
    summary = jaco.summarize(table)
    assert len(summary) == 2 and (summary["runs"] == 3).all()
    first = table[table.beta == 1.0]
    assert summary.loc[0, "length_min"] == pytest.approx(first.length.min())
    assert summary.loc[0, "success_rate"] == pytest.approx(first.success.mean())
    assert math.isfinite(summary.loc[0, "gap_mean"])


# -- progress bars and the hint on failure ------------------------------------------------------
def test_solve_progress_bar_changes_nothing_and_compiles_once(capsys, monkeypatch):
    from jaco import progress

    assert progress.enabled(None) is False  # auto: stderr is no terminal under pytest
    monkeypatch.setattr(progress, "SOLVE_DELAY", 0.0)  # show the bar at once, not after two seconds
    callbacks = []  # the host callbacks the run made (none with the native walk: the host reads its count)
    real_report = progress.report
    monkeypatch.setattr(progress, "report", lambda done: (callbacks.append(done), real_report(done)))
    kw = dict(seed=5, n_ants=6, n_iters=30, steplimit=40)
    plain = jaco.solve(GRID, (0, 0), (3, 5), "acs", progress=False, **kw)
    assert capsys.readouterr().err == ""
    before = TRACES["acs"]
    shown = [jaco.solve(GRID, (0, 0), (3, 5), "acs", progress=True, **kw) for _ in range(2)]
    err = capsys.readouterr().err
    assert "solve acs" in err and "30/30" in err and err.count("30/30") >= 2
    assert len(callbacks) == (0 if jaco.engine.native.active_walk() == "native" else 2 * 15), callbacks
    assert TRACES["acs"] == before + 1  # the reporting run: compiled once, reused
    for r in shown:  # bit for bit the run without a bar
        assert np.array_equal(r.path, plain.path) and r.length == plain.length
        assert r.best_iteration == plain.best_iteration and r.coverage == plain.coverage
        for k, v in plain.history.items():
            assert np.array_equal(r.history[k], v), k
    jaco.solve(GRID, (0, 0), (3, 5), "acs", progress=False, **kw)
    assert TRACES["acs"] == before + 1 and capsys.readouterr().err == ""


def test_a_failed_run_explains_what_usually_helps():
    trap = jaco.maps.named("utrap-15")
    start, goal = trap.meta["start"], trap.meta["goal"]
    r = jaco.solve(trap, start, goal, "as", n_ants=4, n_iters=2, steplimit=3)
    assert not r.success and r.path.shape == (0, 2)
    hint = r.hint
    assert hint.startswith("no ant reached the goal")
    # the shortest path is longer than the step limit: that tip comes first, then backtracking
    assert hint.index("steplimit=6") < hint.index("planner='iaca'") < hint.index("n_ants=16")
    assert "beta=8" in hint  # twice the variant's β = 4
    ok = jaco.solve(trap, start, goal, "iaca", n_ants=8, n_iters=5)
    assert ok.success and ok.hint == ""
    from jaco.engine.result import failure_hint

    cli = failure_hint(r, cli=True)
    assert "--planner iaca" in cli and "--steplimit 6" in cli and "--ants 16" in cli
    stuck = jaco.solve(trap, start, goal, "iaca", n_ants=2, n_iters=1, steplimit=3)
    assert not stuck.success and "backtracking" not in stuck.hint  # it backtracks already
    # What the planner's construct declares decides, not its name: a backtracking composition under
    # a name of its own gets no such tip, a dying-ant one named like IACA does.
    stepper = jaco.compose(construct="backtrack", rule="mmas").named("stepper", source="test", doc="test")
    dying = jaco.compose(rule="mmas").named("iaca-like", source="test", doc="test")
    for planner, tip in ((stepper, False), (dying, True)):
        failed = jaco.solve(trap, start, goal, planner, n_ants=2, n_iters=1, steplimit=3)
        assert not failed.success and ("a backtracking planner" in failed.hint) is tip


def test_a_solves_key_is_jax_random_key_of_its_seed_at_every_width_of_the_seed():
    import jax

    from jaco.engine.run import seed_key

    for seed in (0, 1, 7, 2**16 + 3, 2**31, 2**32 - 1):
        np.testing.assert_array_equal(jax.random.key_data(seed_key(seed)), jax.random.key_data(jax.random.key(seed)))
        a, b = jax.random.uniform(seed_key(seed), (4,)), jax.random.uniform(jax.random.key(seed), (4,))
        np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("planner", ["as", "mmas"])
def test_a_solves_loop_has_no_fusion_that_xla_splits_between_threads(planner):
    """A fusion that XLA:CPU cuts into parts wakes its pool's second thread every iteration of a
    solve (on a 2-core machine the benchmark's solve took 10.5 ms of CPU for 6.4 ms of wall time).
    The best path's cells were one (its column fused with the cells of every step slot); they
    are now derived once, after the loop. A map of the benchmark's size, 50 ants."""
    import jax

    import jaco.engine.checks as jc
    from jaco.engine.run import make_run

    grid = jaco.maps.random_map(30, 0.25, seed=0)
    problem = jaco.make_problem(grid, (0, 0), (29, 29))
    variant = jaco.PLANNERS[planner]
    params = jc.params_from(jc.resolve_params(variant, {}, where=planner))
    run = jax.jit(make_run(variant, n_ants=50, n_iters=10, steplimit=jc.default_steplimit(grid)))
    text = run.lower(jax.random.key(0), problem, params).compile().as_text()
    # The computations that run every iteration: the bodies of the while loops (what XLA hoisted
    # out of them, such as η, runs once a call and may be split).
    blocks = re.split(r"\n(?=%|ENTRY )", text)
    name = lambda block: block.split(" ", 1)[0].lstrip("%")  # noqa: E731
    bodies = [block for block in blocks if name(block) in set(re.findall(r"body=%([\w.\-]+)", text))]
    assert any('"jaco_walk"' in block or " while(" in block for block in bodies)  # the iteration's walk is in one
    split = [line.split("=")[0].strip() for block in bodies for line in block.splitlines()
             if 'outer_dimension_partitions":["' in line]  # fmt: skip
    assert split == [], f"fusions of the loop that XLA splits between threads: {split}"


def _loop_bodies(text: str) -> list[str]:
    """The computations of a compiled program's while loops' bodies (what runs every iteration)."""
    blocks = re.split(r"\n(?=%|ENTRY )", text)
    bodies = set(re.findall(r"body=%([\w.\-]+)", text))
    return [block for block in blocks if block.split(" ", 1)[0].lstrip("%") in bodies]


@pytest.mark.parametrize("planner", ["as", "idaca"])
def test_a_runs_walks_write_over_the_last_iterations_steps_in_place(planner):
    """No iteration fills the ``steplimit × ants`` step slots: the walk takes the last
    iteration's step buffer (``Trail.steps``) straight from the loop's carry, aliased to its own
    edges, and nothing else in the loop makes a buffer of that shape (no fill, no copy). One
    colony (AS) and two (IDACA, both colonies' buffers in one)."""
    import jax

    import jaco.engine.checks as jc
    from jaco.engine import native
    from jaco.engine.run import make_run

    if native.active_walk() != "native":
        pytest.skip("the native walk was not built")
    grid = jaco.maps.random_map(30, 0.25, seed=0)
    problem = jaco.make_problem(grid, (0, 0), (29, 29))
    variant = jaco.PLANNERS[planner]
    params = jc.params_from(jc.resolve_params(variant, {}, where=planner))
    steplimit = jc.default_steplimit(grid)
    run = jax.jit(make_run(variant, n_ants=50, n_iters=10, steplimit=steplimit))
    bodies = _loop_bodies(run.lower(jax.random.key(0), problem, params).compile().as_text())
    walks = [(body, line) for body in bodies for line in body.splitlines() if '"jaco_walk"' in line]
    assert len(walks) == 1
    body, line = walks[0]
    assert "output_to_operand_aliasing={{0}: (6, {})}" in line
    operands = re.sub(r"/\*index=\d+\*/", "", line.split("custom-call(", 1)[1].split(")", 1)[0]).split(",")
    previous = operands[6].strip()
    parameter = re.search(r"%([\w.\-]+) = [^\n]*? parameter\(0\)", body).group(1)
    assert re.search(rf"{re.escape(previous)} = \S+ get-tuple-element\(%{re.escape(parameter)}\)", body)
    shape = rf"s32\[(2,)?{steplimit},50\]"
    made = [ln.split("=", 1)[1].split("(", 1)[0].split()[-1] for b in bodies for ln in b.splitlines()
            if re.match(rf"\s*(ROOT )?%\S+ = {shape}", ln)]  # fmt: skip
    assert made and set(made) <= {"get-tuple-element"}, made


def test_a_runs_outputs_are_fetched_as_jax_device_get_gives_them():
    """``fetched`` (what a solve reads its run's outputs with) skips ``jax.device_get``'s
    asynchronous copies on the CPU; it must give the same values, dtypes, shapes and structure,
    None where the run keeps no pheromone."""
    import jax

    from jaco.engine.run import RunShape, compiled_run, fetched, seed_key

    grid = jaco.maps.random_map(12, 0.2, seed=3)
    problem = jaco.make_problem(grid, (0, 0), (11, 11))
    params = jaco.engine.checks.params_from(jaco.engine.checks.resolve_params(jaco.PLANNERS["as"], {}, where="as"))
    for keep in (False, True):
        run = compiled_run(jaco.PLANNERS["as"], RunShape(6, 4, 48, 8, keep), batched=False)
        out = run(seed_key(5), problem, params)
        got, want = fetched(out), jax.device_get(out)
        assert type(got) is type(want) and (got.tau is None) is (not keep)
        assert jax.tree.structure(got) == jax.tree.structure(want)
        for a, b in zip(jax.tree.leaves(got), jax.tree.leaves(want), strict=True):
            assert type(a) is np.ndarray and a.dtype == b.dtype and a.shape == b.shape
            np.testing.assert_array_equal(a, b)
        assert np.isfinite(got.best_cost) and got.best_cells[0] >= 0  # a path was found: real values compared
