"""Tests of the ``jaco`` command line: in-process through ``main([...])`` (the JIT cache is shared,
so runs of one shape compile once) plus one real subprocess of the installed console script."""

import csv
import json
import re
import shutil
import subprocess
import sys

import numpy as np
import pytest

import jaco
from jaco.cli import main

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"
SMALL = ["--ants", "10", "--iters", "10"]
MAP = str(jaco.maps.bundled("random-32-32-10.map"))
SCEN = str(jaco.maps.bundled("random-32-32-10-even-10.scen"))


def run(capsys, *argv):
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def assert_user_error(code, err, *needles):
    """Exit 2, exactly one 'jaco: error: ...' line, no traceback, and the given words in it."""
    assert code == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("jaco: error: ")
    assert "Traceback" not in err
    for needle in needles:
        assert needle in lines[0], (needle, lines[0])


def reported_lengths(out):
    """(length, exact optimum) from the 'length ... (exact optimum ...)' report line."""
    m = re.search(r"^length\s+([\d.]+) \(exact optimum ([\d.]+), gap ([+-][\d.]+)%\)", out, re.M)
    assert m, out
    return float(m.group(1)), float(m.group(2))


def test_demo_writes_png_and_reports_length_vs_optimum(tmp_path, capsys):
    png = tmp_path / "sub" / "demo.png"
    code, out, err = run(capsys, "demo", "--out", str(png), *SMALL)
    assert code == 0, err
    assert png.read_bytes()[:8] == PNG_MAGIC
    length, optimum = reported_lengths(out)
    grid = jaco.maps.named("demo")
    exact, _ = jaco.exact.shortest_path(grid, grid.meta["start"], grid.meta["goal"])
    assert optimum == pytest.approx(exact, abs=1e-3)
    assert length >= optimum - 1e-6
    assert "demo (20x30" in out
    assert re.search(r"^planner\s+mmas ", out, re.M)  # one word on screen, as in tables and --by
    assert re.search(r"^success\s+yes", out, re.M)
    assert re.search(r"^best at\s+iteration \d+", out, re.M)
    assert re.search(r"^cells\s+\d+", out, re.M)
    assert re.search(r"^time\s+[\d.]+ s", out, re.M)
    assert f"wrote {png}" in out


def test_solve_scenario_prints_optimum_and_writes_valid_json(tmp_path, capsys):
    k = 5
    sc = jaco.maps.load_scenarios(SCEN)[k]
    out_json = tmp_path / "r.json"
    out_png = tmp_path / "r.png"
    code, out, err = run(capsys, "solve", MAP, "--scen", SCEN, "--index", str(k), *SMALL,
                         "--seed", "3", "--json", str(out_json), "--plot", str(out_png))
    assert code == 0, err
    assert f"optimal length {sc.optimal:.4f}" in out
    length, optimum = reported_lengths(out)
    assert optimum == pytest.approx(sc.optimal, abs=1e-3)

    def no_constants(name):  # strict JSON: no NaN / Infinity
        raise AssertionError(f"non-standard JSON constant {name}")

    doc = json.loads(out_json.read_text(), parse_constant=no_constants)
    path = doc["path"]
    assert isinstance(path, list) and all(isinstance(p, list) and len(p) == 2 for p in path)
    assert tuple(path[0]) == sc.start and tuple(path[-1]) == sc.goal
    grid = jaco.maps.load(MAP)
    assert all(grid.free[r, c] for r, c in path)
    assert doc["success"] is True
    assert doc["length"] >= sc.optimal - 1e-6
    assert doc["length"] == pytest.approx(length, abs=1e-3)
    assert doc["optimal"] == pytest.approx(sc.optimal, abs=1e-4)
    assert doc["seed"] == 3 and doc["n_ants"] == 10 and doc["n_iters"] == 10
    assert doc["metrics"]["valid"] is True
    assert doc["metrics"]["length"] == pytest.approx(doc["length"], abs=1e-4)
    assert doc["planner"] == "mmas" and "variant" not in doc
    assert doc["metrics"]["gap"] == doc["gap"]  # one gap per result, jaco.metrics.gap of its length
    assert doc["scenario"]["optimal"] == pytest.approx(sc.optimal)
    assert out_png.read_bytes()[:8] == PNG_MAGIC


def test_solve_named_map_with_params_and_explicit_start_goal(tmp_path, capsys):
    out_json = tmp_path / "r.json"
    code, out, err = run(capsys, "solve", "demo", "--start", "17,2", "--goal", " 2, 27", *SMALL,
                         "--param", "alpha=1.5", "--param", "rho=0.2", "--json", str(out_json))
    assert code == 0, err
    doc = json.loads(out_json.read_text())
    assert doc["params"]["alpha"] == 1.5 and doc["params"]["rho"] == pytest.approx(0.2)
    assert doc["start"] == [17, 2] and doc["goal"] == [2, 27]
    assert "alpha=1.5" in out


def test_failed_run_gives_null_not_infinity_in_json(tmp_path, capsys):
    out_json = tmp_path / "fail.json"
    code, out, err = run(capsys, "solve", "demo", *SMALL, "--steplimit", "2", "--json", str(out_json))
    assert code == 4, err  # no ant reached the goal
    assert re.search(r"^success\s+no", out, re.M) and re.search(r"^hint\s+no ant reached the goal", out, re.M)
    text = out_json.read_text()
    assert "Infinity" not in text and "NaN" not in text
    doc = json.loads(text)
    assert doc["success"] is False and doc["length"] is None and doc["path"] == []
    assert doc["metrics"]["length"] is None


def test_unknown_param_lists_valid_names(capsys):
    code, _, err = run(capsys, "solve", "demo", *SMALL, "--param", "gamma=1")
    assert_user_error(code, err, "gamma")
    for name in jaco.PLANNERS["mmas"].params:
        assert name in err


@pytest.mark.parametrize(
    "args, needle",
    [
        (["--param", "alpha=-1"], "alpha"),  # out of range
        (["--param", "alpha=abc"], "not a number"),
        (["--param", "alpha"], "NAME=VALUE"),
        (["--param", "alpha=1,2"], "sweep"),
        (["--variant", "nope"], "nope"),
        (["--ants", "0"], "--ants"),
        (["--start", "99,0"], "outside"),
        (["--index", "2"], "--scen"),
    ],
)
def test_user_mistakes_are_one_line_exit_2(capsys, args, needle):
    code, _, err = run(capsys, "solve", "demo", *SMALL, *args)
    assert_user_error(code, err, needle)


def test_start_on_obstacle_is_a_clear_error(capsys):
    grid = jaco.maps.named("demo")
    r, c = (int(v) for v in np.argwhere(~grid.free)[0])
    code, out, err = run(capsys, "solve", "demo", *SMALL, "--start", f"{r},{c}")
    assert_user_error(code, err, "start", f"({r}, {c})", "obstacle")
    assert out == ""


@pytest.mark.parametrize("bad", ["3", "3,x", "1,2,3", ""])
def test_malformed_cell_exits_2(capsys, bad):
    code, _, err = run(capsys, "solve", "demo", *SMALL, "--start", bad)
    assert_user_error(code, err, "--start", "ROW,COL")


def test_unreachable_goal_and_file_errors(tmp_path, capsys):
    split = tmp_path / "split.txt"
    split.write_text("..#..\n..#..\n..#..\n")
    code, _, err = run(capsys, "solve", str(split), "--start", "0,0", "--goal", "0,4", *SMALL)
    assert_user_error(code, err, "cannot be reached")
    code, _, err = run(capsys, "solve", str(split), *SMALL)  # a file map has no default start/goal
    assert_user_error(code, err, "--start")
    code, _, err = run(capsys, "solve", str(tmp_path / "missing.map"), *SMALL)
    assert_user_error(code, err, "missing.map", "not found")
    code, _, err = run(capsys, "solve", "no-such-map", *SMALL)
    assert_user_error(code, err, "no-such-map", "demo")  # lists the named maps
    code, _, err = run(capsys, "solve", MAP, "--scen", str(tmp_path / "none.scen"), *SMALL)
    assert_user_error(code, err, "none.scen")
    code, _, err = run(capsys, "solve", MAP, "--scen", SCEN, "--index", "100000", *SMALL)
    assert_user_error(code, err, "--index", "out of range")
    code, _, err = run(capsys, "solve", "demo", "--scen", SCEN, *SMALL)  # scenario for another map
    assert_user_error(code, err, "32x32")
    code, _, err = run(capsys, "bogus")
    assert_user_error(code, err, "bogus")


def test_sweep_writes_tidy_csv_and_prints_best(tmp_path, capsys):
    out_csv = tmp_path / "sweep.csv"
    code, out, err = run(capsys, "sweep", "demo", "--variant", "mmas", "--param", "alpha=0.5:2:2",
                         "--seeds", "2", *SMALL, "--csv", str(out_csv))
    assert code == 0, err
    with out_csv.open() as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 4
    expected = set(jaco.PLANNERS["mmas"].params) | {
        "seed", "success", "length", "cost", "best_iteration", "optimal", "gap", "coverage"}
    assert expected <= set(rows[0])
    assert sorted({float(r["alpha"]) for r in rows}) == [0.5, 2.0]
    assert sorted({int(r["seed"]) for r in rows}) == [0, 1]
    assert list(rows[0])[0] == "planner" and {r["planner"] for r in rows} == {"mmas"}  # one planner, named
    assert all(float(r["length"]) >= float(r["optimal"]) - 1e-4 for r in rows if r["success"] == "True")
    assert "best: mmas alpha=" in out
    assert "top 2 of 2 configurations" in out


@pytest.mark.slow  # a program per planner (test_sweeps.py sweeps several planners in the normal run)
def test_sweep_over_several_planners_and_a_composition(tmp_path, capsys):
    """Repeated --variant: the planners are a categorical column; beta applies to each, the rows
    of each planner equal a sweep of that planner alone."""
    comp = "compose(construct=backtrack, rule=iaca)"
    out_csv = tmp_path / "sweep.csv"
    code, out, err = run(capsys, "sweep", "demo", "--variant", "acs", "--variant", comp, "--param", "beta=2,6",
                         "--seeds", "2", *SMALL, "--csv", str(out_csv))
    assert code == 0, err
    with out_csv.open() as f:
        rows = list(csv.DictReader(f))
    full = jaco.planners.registry.get_planner(comp).name
    assert sorted({r["planner"] for r in rows}) == sorted(["acs", full]) and len(rows) == 8
    demo = jaco.maps.named("demo")
    alone = jaco.sweep(demo, demo.meta["start"], demo.meta["goal"], "acs", {"beta": [2.0, 6.0]}, 2,
                       n_ants=10, n_iters=10)
    acs = sorted(float(r["length"]) for r in rows if r["planner"] == "acs")
    assert acs == pytest.approx(sorted(alone["length"]), rel=1e-6)
    assert "top 4 of 4 configurations" in out and "best: " in out


def test_sweep_value_syntax_errors(capsys):
    for value, needle in [("alpha=1:2", "START:STOP:COUNT"), ("alpha=1:2:0", "COUNT"),
                          ("alpha=0:30:3", "out of range"), ("zeta=1,2", "zeta")]:
        code, _, err = run(capsys, "sweep", "demo", "--param", value, "--seeds", "1", *SMALL)
        assert_user_error(code, err, needle)


def test_variants_lists_every_registered_variant(capsys):
    code, out, _ = run(capsys, "variants")
    assert code == 0
    lines = out.strip().splitlines()
    assert len(lines) == len(jaco.PLANNERS)
    for line, (name, variant) in zip(lines, jaco.PLANNERS.items()):
        assert line.split()[0] == name
        assert variant.source in line


def test_maps_lists_named_and_bundled(capsys):
    code, out, _ = run(capsys, "maps")
    assert code == 0
    for name in list(jaco.maps.NAMED) + list(jaco.maps.BUNDLED):
        assert name in out


def test_maps_names_the_folders_that_hold_the_bundled_files(capsys):
    """Each folder printed exists and holds the files listed under it (data/movingai, data/ros),
    and every bundled file is listed once."""
    from pathlib import Path

    code, out, _ = run(capsys, "maps")
    assert code == 0
    listed, folder = [], None
    for line in out.splitlines():
        if line.startswith("bundled files"):
            folder = Path(re.fullmatch(r"bundled files in (.+):", line).group(1))
            assert folder.is_dir(), folder
        elif folder is not None and line.startswith("  "):
            assert (folder / line.strip()).is_file(), (folder, line)
            listed.append(line.strip())
        else:
            folder = None
    assert sorted(listed) == sorted(jaco.maps.BUNDLED)
    assert {"movingai", "ros"} <= {Path(p).name for p in re.findall(r"bundled files in (.+):", out)}


@pytest.mark.parametrize("command", [
    ["solve"], ["sweep", "--seeds", "1"], ["search", "--param", "beta=1:3"],
])
@pytest.mark.parametrize("missing, bare", [
    ("/nonexistent/den312d.map", "den312d.map"),
    ("movingai/den312d.map", "den312d.map"),  # the bundled folder's layout is no path either
    ("/nonexistent/arena", "arena.map"),
])
def test_a_path_that_does_not_exist_is_an_error_not_the_bundled_copy(capsys, command, missing, bare):
    """Every command that takes a map resolves it the same way: a path that does not exist is an
    error naming the bundled copy's bare name, the only way to reach it."""
    code, out, err = run(capsys, command[0], missing, *command[1:], *SMALL)
    assert_user_error(code, err, repr(missing), "not found", f"use its bare name {bare}")
    assert out == ""


def test_a_scenario_path_that_does_not_exist_is_an_error_not_the_bundled_copy(capsys):
    scen = "/nonexistent/random-32-32-10-even-10.scen"
    code, _, err = run(capsys, "solve", MAP, "--scen", scen, *SMALL)
    assert_user_error(code, err, repr(scen), "not found", "use its bare name random-32-32-10-even-10.scen")


def test_bare_bundled_names_reach_the_bundled_files(capsys):
    code, out, err = run(capsys, "solve", "random-32-32-10.map", "--scen", "random-32-32-10-even-10.scen",
                         "--index", "0", *SMALL)
    assert code == 0, err
    assert "random-32-32-10-even-10.scen #0" in out


def test_planner_names_are_case_insensitive_and_a_typo_gets_the_closest(capsys):
    code, out, err = run(capsys, "solve", "demo", "--planner", "IACA", *SMALL)
    assert code in (0, 4), err
    assert re.search(r"^(planner|variant)\s+iaca ", out, re.M)
    code, _, err = run(capsys, "solve", "demo", "--planner", "iacaa", *SMALL)
    assert_user_error(code, err, "unknown planner 'iacaa'", "did you mean 'iaca'")
    assert err.index("did you mean") < err.index("registered: acs")
    code, _, err = run(capsys, "sweep", "demo", "--planner", "mmas", "--planner", "ACSS", "--seeds", "1", *SMALL)
    assert_user_error(code, err, "unknown planner 'ACSS'", "did you mean 'acs'")


def test_a_sweep_parameter_that_some_planners_lack_names_the_planners_that_have_it(capsys):
    """q0 belongs to acs: the message says so, as a search's does, and suggests no other name."""
    code, _, err = run(capsys, "sweep", "demo", "--planner", "mmas", "--planner", "acs", "--param", "q0=0.5,0.9",
                       "--seeds", "1", *SMALL)
    assert_user_error(code, err, "parameter 'q0' belongs to acs only, not to mmas", "sweep acs on its own")
    assert "did you mean" not in err
    code, _, err = run(capsys, "search", "demo", "--planner", "mmas", "--planner", "acs", "--param", "q0=0.5:0.9",
                       "--sampler", "grid", *SMALL)
    assert_user_error(code, err, "parameter 'q0' belongs to acs only, not to mmas")
    code, _, err = run(capsys, "search", "demo", "--planner", "mmas", "--planner", "as", "--param", "q0=0.5:0.9",
                       *SMALL)
    assert_user_error(code, err, "parameter 'q0' is not used by any of the planners mmas, as; they use: alpha")


def test_help_returns_zero(capsys):
    assert main(["--help"]) == 0
    assert "solve" in capsys.readouterr().out
    assert main(["sweep", "--help"]) == 0
    assert "a:b:n" in capsys.readouterr().out


def test_console_script_planners_subprocess():
    exe = shutil.which("jaco")
    cmd = [exe, "planners"] if exe else [sys.executable, "-m", "jaco.cli", "planners"]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    names = [line.split()[0] for line in proc.stdout.strip().splitlines()]
    assert names == list(jaco.PLANNERS)


def test_console_script_user_error_subprocess():
    exe = shutil.which("jaco")
    cmd = [exe] if exe else [sys.executable, "-m", "jaco.cli"]
    proc = subprocess.run(cmd + ["solve", "demo", "--start", "3"], capture_output=True, text=True,
                          timeout=120)
    assert proc.returncode == 2
    assert proc.stderr.strip().startswith("jaco: error:") and "Traceback" not in proc.stderr


# -- ROS world coordinates: --start-xy / --goal-xy, --path-csv ---------------------------------
def test_solve_with_world_points_on_a_bundled_ros_map(tmp_path, capsys):
    # lse_arena.yaml: 60x80 cells, resolution 0.05 m, origin [0, 0, 0]. (0.31, 0.52) m lies in
    # column floor(0.31 / 0.05) = 6, row 59 - floor(0.52 / 0.05) = 49; its centre is (0.325, 0.525).
    out_csv, out_json = tmp_path / "path.csv", tmp_path / "r.json"
    code, out, err = run(capsys, "solve", "lse_arena.yaml", "--start-xy", "0.31,0.52", "--goal-xy", "3.51,2.51",
                         "--ants", "8", "--iters", "5", "--path-csv", str(out_csv), "--json", str(out_json))
    assert code == 0, err
    assert "start (49, 6) -> goal (9, 70)" in out
    assert re.search(r"^world\s+start \(0\.325, 0\.525\) m -> goal \(3\.525, 2\.525\) m, length [\d.]+ m", out, re.M)
    with out_csv.open() as f:
        rows = list(csv.DictReader(f))
    assert rows[0] == {"row": "49", "col": "6", "x": "0.325", "y": "0.525"}
    assert rows[-1] == {"row": "9", "col": "70", "x": "3.525", "y": "2.525"}
    grid = jaco.maps.load_bundled("lse_arena")
    cells = np.array([[int(r["row"]), int(r["col"])] for r in rows])
    assert jaco.metrics.validate_path(grid, cells, (49, 6), (9, 70)) == []
    doc = json.loads(out_json.read_text())
    world = doc["world"]
    assert world["start_xy"] == [0.325, 0.525] and world["goal_xy"] == [3.525, 2.525]
    assert world["path_xy"][0] == [0.325, 0.525] and len(world["path_xy"]) == len(rows)
    assert world["length_m"] == pytest.approx(doc["length"] * 0.05)


@pytest.mark.parametrize(
    "mapname, args, needles",
    [
        ("lse_arena.yaml", ["--start-xy", "10,0.5"], ["--start-xy", "outside", "x 0..4 m", "y 0..3 m"]),
        ("lse_arena.yaml", ["--goal-xy", "0.01,0.01"], ["--goal-xy", "cell (59, 0)", "obstacle"]),
        ("map.yaml", ["--start-xy", "-9,-9"], ["--start-xy", "(-9, -9) m", "unknown"]),  # negative X parses
        ("demo", ["--start-xy", "1,1"], ["--start-xy", "resolution", "--start ROW,COL"]),
        ("lse_arena.yaml", ["--start-xy", "1,nan"], ["--start-xy", "X,Y"]),
        ("lse_arena.yaml", ["--start-xy", "1"], ["--start-xy", "X,Y"]),
        ("lse_arena.yaml", ["--start", "49,6", "--start-xy", "0.31,0.52"], ["not both"]),
    ],
)
def test_bad_world_points_are_one_line_exit_2(capsys, mapname, args, needles):
    full = ["--start-xy", "0.31,0.52", "--goal-xy", "3.51,2.51"]
    for i in range(0, len(args), 2):  # the given flags replace the defaults
        if args[i] in full:
            del full[full.index(args[i]):full.index(args[i]) + 2]
    code, out, err = run(capsys, "solve", mapname, *SMALL, *full, *args)
    assert_user_error(code, err, *needles)
    assert out == ""


# -- guidance on failure, sweep summaries, output formats ----------------------------------------
def test_den312d_query_fails_with_a_hint_and_exit_4_and_iaca_solves_it(capsys):
    query = ["solve", "den312d.map", "--scen", "den312d.map.scen", "--index", "289", *SMALL]
    code, out, err = run(capsys, *query)
    assert code == 4, err
    assert re.search(r"^length\s+none: no ant reached the goal", out, re.M)
    hint = out[out.index("\nhint"):]
    assert "--planner iaca" in hint and "--ants 40" in hint and "--param beta=16" in hint
    assert re.search(r"^time\s+[\d.]+ s \(since the command started", out, re.M)
    code, out, err = run(capsys, *query, "--variant", "iaca")
    assert code == 0, err
    assert re.search(r"^success\s+yes", out, re.M) and "hint" not in out


def test_sweep_shows_failed_configurations_as_failed_not_inf(capsys):
    code, out, err = run(capsys, "sweep", "demo", "--param", "alpha=1,2", "--seeds", "2", *SMALL,
                         "--steplimit", "2")
    assert code == 0, err
    table = out[out.index("top 2 of 2"):]
    rows = [line.split() for line in table.splitlines()[2:4]]
    assert all(r[1:-1] == ["0"] + ["failed"] * 6 for r in rows), table
    assert "inf" not in out and "nan" not in out.lower()
    assert "no configuration reached the goal" in out


def test_sweep_table_of_successes_has_numbers(capsys):
    code, out, err = run(capsys, "sweep", "demo", "--param", "alpha=1,2", "--seeds", "2", *SMALL)
    assert code == 0, err
    head, *rows = out[out.index("top 2 of 2"):].splitlines()[1:4]
    assert head.split() == ["alpha", "success_%", "length_median", "length_min", "gap_median_%", "gap_q1_%",
                            "gap_q3_%", "gap_mean_%", "runs"]
    for r in rows:
        cells = r.split()
        assert float(cells[1]) > 0 and float(cells[2]) > 0 and not cells[4].startswith("-0")
        assert cells[-1] == "2" and cells[0] in ("1", "2")  # integers read as integers
    best = out[out.index("\nbest: "):]
    assert re.match(r"\nbest: mmas alpha=[12] \(other parameters at their defaults\)\n      median length [\d.]+ "
                    r"\(optimum [\d.]+\), median gap [\d.]+% \(quartiles", best), best


def test_variants_sources_start_in_one_column(capsys):
    code, out, _ = run(capsys, "variants")
    assert code == 0
    columns = {line.index(v.source) for line, v in zip(out.splitlines(), jaco.PLANNERS.values())}
    assert len(columns) == 1 and "iaaco-printed" in jaco.PLANNERS


def test_json_writes_each_list_on_one_line(tmp_path, capsys):
    out_json = tmp_path / "out.json"
    code, _, err = run(capsys, "solve", MAP, "--scen", SCEN, "--index", "34", *SMALL, "--json", str(out_json))
    assert code == 0, err
    text = out_json.read_text()
    doc = json.loads(text)
    assert len(doc["path"]) > 20
    assert f'"path": {json.dumps(doc["path"])},' in text  # the whole path on one line
    assert f'"best": {json.dumps(doc["history"]["best"])}' in text
    assert len(text.splitlines()) < 80


def test_negative_zero_never_shows():
    from jaco.cli.commands.sweep import _unsigned_zero

    assert _unsigned_zero(f"{-1e-9:.2f}") == "0.00" and _unsigned_zero(f"{-0.0:.4g}") == "0"
    assert _unsigned_zero("-0.5") == "-0.5" and _unsigned_zero("-10") == "-10"


# -- choosing queries: several scenarios in one sweep -----------------------------------------------
def test_sweep_over_a_bucket_of_scenarios_in_one_command(tmp_path, capsys):
    scen = jaco.maps.load_scenarios(SCEN)
    chosen = jaco.maps.select_scenarios(scen, bucket=(8, None), count=3)
    out_csv = tmp_path / "b.csv"
    code, out, err = run(capsys, "sweep", MAP, "--scen", SCEN, "--bucket", "8:", "--count", "3", "--variant", "mmas",
                         "--variant", "compose(construct=backtrack, heuristic=chaos, rule=iaca)", "--param", "beta=4,8",
                         "--seeds", "2", *SMALL, "--csv", str(out_csv))
    assert code == 0, err
    assert f"queries: 3 scenarios of {jaco.maps.bundled(SCEN).name} (#{chosen[0].index}, #{chosen[1].index}, " in out
    table = jaco.research.tables.read_table(out_csv)
    assert len(table) == 2 * 2 * 2 * 3  # planners x beta x seeds x queries
    starts = sorted(set(zip(table.start_row, table.start_col)))
    assert starts == sorted({s.start for s in chosen}) and table.start_row.dtype.kind == "i"
    assert sorted(set(table.optimal.round(3))) == sorted(round(s.optimal, 3) for s in chosen)
    head = out[out.index("top 4 of 4"):].splitlines()[1]
    assert head.split() == ["planner", "beta", "success_%", "gap_median_%", "gap_q1_%", "gap_q3_%", "gap_mean_%", "runs"]
    assert "backtrack/chaos/iaca" in out and f"jaco compare {out_csv} --by planner --by beta" in out
    rows = out[out.index("top 4 of 4"):].splitlines()[2:6]
    assert all(r.split()[-1] == "6" for r in rows)  # 2 seeds x 3 queries per configuration
    assert rows[0].startswith(("mmas ", "backtrack/chaos/iaca ")), rows  # names left-aligned


@pytest.mark.parametrize("selection, indices", [
    (["--index", "3", "--index", "5:7"], [3, 5, 6, 7]),
    (["--index", "3,1"], [3, 1]),
    (["--optimal", "20:25", "--count", "2"], None),
    (["--bucket", "2"], None),
])
def test_selection_flags_pick_the_scenarios(capsys, selection, indices):
    from jaco.cli.parser import build_parser
    from jaco.cli.queries import resolve_queries

    args = build_parser().parse_args(["sweep", MAP, "--scen", SCEN, *selection])
    grid = jaco.maps.load(MAP)
    starts, goals, picked, label = resolve_queries(grid, args)
    scen = jaco.maps.load_scenarios(SCEN)
    if indices is not None:
        assert [s.index for s in picked] == indices
    elif "--bucket" in selection:
        assert [s.index for s in picked] == [s.index for s in scen if s.bucket == 2]
    else:
        assert len(picked) == 2 and all(20 <= s.optimal <= 25 for s in picked)
    assert starts == [s.start for s in picked] and goals == [s.goal for s in picked]


@pytest.mark.parametrize("args, needle", [
    (["--bucket", "7:"], "one query"),  # solve runs one query
    (["--bucket", "99:"], "no scenario has bucket 99.."),
    (["--bucket", "x"], "--bucket"),
    (["--index", "5:2"], "LO <= HI"),
    (["--index", "1000"], "out of range"),
    (["--count", "0"], "--count"),
])
def test_selection_mistakes_are_one_line(capsys, args, needle):
    code, _, err = run(capsys, "solve", MAP, "--scen", SCEN, *args, *SMALL)
    assert_user_error(code, err, needle)
    code, _, err = run(capsys, "solve", "demo", "--bucket", "3", *SMALL)
    assert_user_error(code, err, "--bucket needs --scen")


def _interrupted_after(monkeypatch, module, name, exc=KeyboardInterrupt):
    """``module.name`` runs as it is, then raises ``exc``: a stop after its work was done (and stored)."""
    real = getattr(module, name)

    def stopped(*a, **k):
        stopped.result = real(*a, **k)
        raise exc()

    monkeypatch.setattr(module, name, stopped)
    return stopped


def test_an_interrupted_sweep_says_what_it_kept_and_how_to_resume(tmp_path, capsys, monkeypatch):
    from jaco.cli import Terminated
    from jaco.research import sweeps

    sweep = ["sweep", "demo", "--planner", "acs", "--param", "beta=1,2", "--seeds", "3", *SMALL]
    stopped = _interrupted_after(monkeypatch, sweeps, "sweep")
    code, _, err = run(capsys, *sweep)
    assert code == 130
    assert err.strip().splitlines()[-1] == "jaco: interrupted: nothing was kept (add --store FILE to keep finished chunks)"
    db = str(tmp_path / "s.db")
    code, _, err = run(capsys, *sweep, "--store", db, "--chunk", "2")
    assert code == 130 and len(stopped.result) == 6
    assert err.strip().splitlines()[-1] == f"jaco: interrupted: 6 runs stored in {db}; the same command resumes"
    monkeypatch.undo()
    _interrupted_after(monkeypatch, sweeps, "sweep", Terminated)  # runs again, all 6 found in the store
    code, _, err = run(capsys, *sweep, "--store", db)
    assert code == 143
    assert err.strip().splitlines()[-1] == f"jaco: terminated: 6 runs stored in {db}; the same command resumes"


def test_a_sweep_interrupted_before_a_chunk_finished_says_so(tmp_path, capsys, monkeypatch):
    from jaco.research import sweeps

    def stopped(*a, **k):
        raise KeyboardInterrupt

    monkeypatch.setattr(sweeps, "sweep", stopped)
    db = str(tmp_path / "s.db")
    code, _, err = run(capsys, "sweep", "demo", "--seeds", "1", "--store", db, *SMALL)
    assert code == 130
    assert err.strip().splitlines()[-1] == (
        f"jaco: interrupted: no chunk had finished, nothing new stored in {db}; the same command resumes"
    )


def test_an_interrupted_search_says_what_it_kept_and_how_to_resume(tmp_path, capsys, monkeypatch):
    pytest.importorskip("optuna")
    from jaco.research import search

    args = ["search", "demo", "--planner", "acs", "--param", "beta=1:10:log", "--trials", "3", "--batch", "3",
            "--seeds", "1", "--sampler", "random", *SMALL]
    _interrupted_after(monkeypatch, search, "search")
    code, _, err = run(capsys, *args)
    assert code == 130
    assert err.strip().splitlines()[-1] == (
        "jaco: interrupted: nothing was kept (add --storage FILE.db to keep finished trials)"
    )
    db = str(tmp_path / "study.db")
    code, _, err = run(capsys, *args, "--storage", db)
    assert code == 130
    assert err.strip().splitlines()[-1] == f"jaco: interrupted: 3 trials stored in {db}; the same command resumes"


def test_the_search_history_plot_has_a_log_axis_unless_linear(tmp_path, capsys, monkeypatch):
    """The failures' penalties (over 1000 %) would flatten the successful trials' gaps on a linear
    axis: --plot draws the history on a log axis (symlog where a gap is 0), --linear on a linear one."""
    pytest.importorskip("optuna")
    scales = []
    real = jaco.plot.save
    monkeypatch.setattr(jaco.plot, "save", lambda fig, *a, **k: scales.append(fig.axes[0].get_yscale()) or real(fig, *a, **k))
    args = ["search", "demo", "--planner", "acs", "--param", "beta=1:10:log", "--trials", "3", "--batch", "3",
            "--seeds", "1", "--sampler", "random", *SMALL]
    for extra in ([], ["--linear"]):
        code, _, err = run(capsys, *args, "--plot", str(tmp_path / "h.png"), *extra)
        assert code in (0, 4), err
    assert scales[0] in ("log", "symlog") and scales[1] == "linear"
    code, _, err = run(capsys, *args, "--linear")
    assert_user_error(code, err, "--linear", "--plot")


def test_a_reader_that_leaves_early_ends_the_command_quietly():
    """``jaco planners | head -1``: when the reader closes the pipe, jaco stops without an error
    message, with the shell's status for a writer whose reader left (128 + SIGPIPE)."""
    exe = shutil.which("jaco")
    cmd = [exe, "planners"] if exe else [sys.executable, "-m", "jaco.cli", "planners"]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    proc.stdout.close()  # the reader is gone before jaco writes its first line
    err = proc.stderr.read()
    assert proc.wait(timeout=120) == 141 and err == "", err


# -- one word for the planner; a sweep's compare hint runs as printed ---------------------------------
def test_a_sweep_over_beta_and_rho_suggests_a_compare_command_that_runs_as_printed(tmp_path, capsys):
    """One planner over beta x rho: the CSV names its planner, the suggested command carries every
    swept column, and run as printed it compares; without them the error names them all, as options."""
    import shlex

    out_csv = tmp_path / "den sweep.csv"  # a space: the printed path is quoted for the shell
    code, out, err = run(capsys, "sweep", "demo", "--planner", "acs", "--param", "beta=2,6", "--param", "rho=0.1,0.3",
                         "--seeds", "3", *SMALL, "--csv", str(out_csv))
    assert code == 0, err
    line = next(x for x in out.splitlines() if "jaco compare" in x)
    command = line[line.index("jaco compare"):]
    assert command.endswith("--by planner --by beta --by rho"), command
    argv = shlex.split(command)
    assert argv[2] == str(out_csv)
    code, out, err = run(capsys, *argv[1:], "--boot", "50")
    assert code == 0, err
    assert "4 configurations (planner, beta, rho) compared on gap" in out and "acs, beta=2, rho=0.1" in out
    code, _, err = run(capsys, "compare", str(out_csv), "--boot", "50")  # by planner alone: the hint, as options
    assert_user_error(code, err, "columns 'beta', 'rho' vary", "--by planner --by beta --by rho")
    assert "by=[" not in err
    code, out, err = run(capsys, "compare", str(out_csv), "--by", "variant", "--by", "beta", "--by", "rho", "--boot", "50")
    assert code == 0, err  # --by variant: the planner column's former name


def test_solve_json_loads_as_one_flat_row(tmp_path, capsys):
    """The JSON of jaco solve is nested (a path, a history, metrics): pd.read_json does not read
    it, json.load + pd.json_normalize gives one flat row (docs/results.md)."""
    import pandas as pd

    out_json = tmp_path / "r.json"
    code, _, err = run(capsys, "solve", "demo", *SMALL, "--json", str(out_json))
    assert code == 0, err
    with out_json.open() as f:
        row = pd.json_normalize(json.load(f))
    assert len(row) == 1 and row.loc[0, "planner"] == "mmas"
    assert row.loc[0, "gap"] == row.loc[0, "metrics.gap"]
