"""Run records (jaco.research.records): save -> load -> rerun is bit for bit, the record carries versions
and the map hash, tampering and version changes are reported, sweeps round-trip, and paths are
written in ROS world coordinates."""

import csv
import hashlib
import json
import warnings
from pathlib import Path

import numpy as np
import pytest

import jaco
from jaco.cli import main
from jaco.research.records import RecordError, RecordWarning, load_run, map_hash, save_sweep

SMALL = dict(n_ants=8, n_iters=6)
CLI_SMALL = ["--ants", "8", "--iters", "6"]


@pytest.fixture(scope="module")
def demo():
    return jaco.maps.named("demo")


def solve_demo(grid, variant, **kw):
    return jaco.solve(grid, grid.meta["start"], grid.meta["goal"], variant, **{**SMALL, **kw})


def assert_same_result(a, b):
    assert np.array_equal(a.path, b.path)
    assert a.length == b.length and a.cost == b.cost and a.success == b.success
    assert a.best_iteration == b.best_iteration and a.coverage == b.coverage
    assert set(a.history) == set(b.history)
    for k in a.history:
        assert a.history[k].dtype == b.history[k].dtype
        assert a.history[k].tobytes() == b.history[k].tobytes(), k


@pytest.mark.parametrize(
    "variant, kw",
    [("mmas", dict(seed=3, connectivity=4, alpha=1.5)), ("acs", dict(seed=5, keep_pheromone=True))],
)
def test_save_load_rerun_is_bit_identical(tmp_path, demo, variant, kw):
    result = solve_demo(demo, variant, **kw)
    assert result.success
    path = result.save(tmp_path / "run.json")
    rec = load_run(path)
    # the loaded record holds the result exactly as it was
    assert_same_result(rec.result, result)
    assert rec.result.params == result.params
    assert rec.call["connectivity"] == kw.get("connectivity", 8)
    assert rec.call["keep_pheromone"] is kw.get("keep_pheromone", False)
    assert map_hash(rec.grid) == map_hash(demo) and np.array_equal(rec.grid.free, demo.free)
    assert rec.warnings == []
    rerun = rec.rerun()
    assert rerun.matched, rerun.summary()
    assert rerun.differences == []
    assert_same_result(rerun.result, result)
    assert "matched the record bit for bit" in rerun.summary()
    if kw.get("connectivity") == 4:  # the rerun used the recorded move set
        steps = np.abs(np.diff(rerun.result.path, axis=0)).sum(axis=1)
        assert set(steps.tolist()) == {1}


def test_record_contains_versions_map_hash_and_call(tmp_path, demo):
    import jax

    result = solve_demo(demo, "mmas", seed=3, connectivity=4, alpha=1.5)
    doc = json.loads(result.save(tmp_path / "run.json").read_text())
    assert doc["format"] == "jaco-record" and doc["kind"] == "run"
    assert doc["versions"]["jaco"] == jaco.__version__
    assert doc["versions"]["jax"] == jax.__version__
    # the documented hash recipe, recomputed here independently of jaco.research.records
    header = json.dumps(
        {"shape": [20, 30], "cell_size": 1.0, "resolution": None, "origin": None},
        sort_keys=True, separators=(",", ":"),
    ).encode()
    expected = hashlib.sha256(header + b"\n" + demo.free.astype(np.uint8).tobytes()).hexdigest()
    assert doc["map"]["sha256"] == expected == map_hash(demo)
    assert doc["map"]["source"] == {"named": "demo"}
    assert doc["map"]["rows"] == demo.to_rows()  # embedded: re-runnable without any file
    call = doc["call"]
    assert (call["variant"], call["seed"], call["n_ants"], call["n_iters"]) == ("mmas", 3, 8, 6)
    assert call["steplimit"] == result.steplimit and call["connectivity"] == 4
    assert call["params"]["alpha"] == 1.5 and set(call["params"]) == set(jaco.PLANNERS["mmas"].params)
    assert call["start"] == [17, 2] and call["goal"] == [2, 27]
    assert doc["result"]["path"] == result.path.tolist()
    assert doc["result"]["length"] == result.length
    assert len(doc["result"]["history"]["best"]) == 6


def test_large_map_is_embedded_packed_and_comes_back_exactly():
    from jaco.research.records import grid_from_entry, map_entry

    rng = np.random.default_rng(0)
    grid = jaco.Grid(rng.random((301, 257)) > 0.3, name="big", cell_size=10.0, resolution=0.1,
                     origin=(-3.0, 2.5, 0.0))
    entry = map_entry(grid)
    assert "packed" in entry and "rows" not in entry and entry["source"] is None
    back, notes = grid_from_entry(json.loads(json.dumps(entry)), "test")
    assert notes == []
    assert np.array_equal(back.free, grid.free)
    assert (back.cell_size, back.resolution, back.origin) == (10.0, 0.1, (-3.0, 2.5, 0.0))


def test_modified_map_hash_and_modified_call_are_reported(tmp_path, demo):
    result = solve_demo(demo, "mmas", seed=3)
    path = result.save(tmp_path / "run.json")
    doc = json.loads(path.read_text())

    bad_hash = dict(doc, map=dict(doc["map"], sha256="0" * 64))
    (tmp_path / "hash.json").write_text(json.dumps(bad_hash))
    rec = load_run(tmp_path / "hash.json")
    assert any("sha256" in w and "modified" in w for w in rec.warnings), rec.warnings
    with pytest.warns(RecordWarning, match="sha256"):
        rerun = rec.rerun()
    assert rerun.matched  # the embedded map itself is intact, so the run still reproduces

    # an edited embedded map: the hash no longer fits, and the rerun differs
    rows = list(doc["map"]["rows"])
    r, c = result.path[len(result.path) // 2]
    rows[r] = rows[r][:c] + "@" + rows[r][c + 1:]
    (tmp_path / "map.json").write_text(json.dumps(dict(doc, map=dict(doc["map"], rows=rows))))
    rec = load_run(tmp_path / "map.json")
    assert any("embedded map has sha256" in w for w in rec.warnings), rec.warnings
    with pytest.warns(RecordWarning):
        rerun = rec.rerun()
    assert not rerun.matched and any(d.startswith("path") for d in rerun.differences)

    # an edited seed: same map, different run -> not matched, history named
    (tmp_path / "seed.json").write_text(json.dumps(dict(doc, call=dict(doc["call"], seed=4))))
    rerun = load_run(tmp_path / "seed.json").rerun()
    assert not rerun.matched
    assert "did NOT match" in rerun.summary()


def test_version_mismatch_is_reported_with_both_versions(tmp_path, demo, monkeypatch):
    result = solve_demo(demo, "mmas", seed=3)
    monkeypatch.setattr(jaco, "__version__", "0.0.1-old")
    path = result.save(tmp_path / "run.json")
    assert json.loads(path.read_text())["versions"]["jaco"] == "0.0.1-old"
    monkeypatch.undo()
    rec = load_run(path)
    assert len(rec.warnings) == 1
    assert "jaco 0.0.1-old" in rec.warnings[0] and f"jaco {jaco.__version__}" in rec.warnings[0]
    with pytest.warns(RecordWarning, match="0.0.1-old"):
        rerun = rec.rerun()
    assert rerun.matched  # reported, and here (same jax) still identical
    assert "warning: record written with jaco 0.0.1-old" in rerun.summary()


def test_jax_version_mismatch_is_reported(tmp_path, demo, monkeypatch):
    import jax

    real = jax.__version__
    path = solve_demo(demo, "mmas", seed=3).save(tmp_path / "run.json")
    monkeypatch.setattr(jax, "__version__", "9.9.9")
    rec = load_run(path)
    assert rec.warnings == [
        f"record written with jax {real}, this is jax 9.9.9: the rerun may differ in floating point rounding"
    ]


def test_cli_rerun_matches_and_exits_0(tmp_path, capsys):
    rec = tmp_path / "run.json"
    assert main(["solve", "demo", *CLI_SMALL, "--seed", "3", "--record", str(rec)]) == 0
    assert f"wrote {rec}" in capsys.readouterr().out
    code = main(["rerun", str(rec)])
    out, err = capsys.readouterr()
    assert code == 0, err
    assert "matched the record bit for bit" in out and err == ""
    assert "mmas on demo (20x30)" in out


def test_cli_rerun_reports_versions_and_mismatch(tmp_path, capsys, demo):
    path = solve_demo(demo, "mmas", seed=3).save(tmp_path / "run.json")
    doc = json.loads(path.read_text())
    doc["versions"]["jax"] = "0.0.0"
    path.write_text(json.dumps(doc))
    code = main(["rerun", str(path)])
    out, err = capsys.readouterr()
    assert code == 0 and "matched" in out
    (line,) = err.strip().splitlines()
    assert line.startswith("jaco: warning: record written with jax 0.0.0, this is jax ")

    doc["call"]["seed"] = 4
    path.write_text(json.dumps(doc))
    code = main(["rerun", str(path)])
    out, err = capsys.readouterr()
    assert code == 1 and "did NOT match" in out


def test_cli_rerun_bad_record_is_one_line_exit_2(tmp_path, capsys):
    for text, needle in [(None, "not found"), ("{", "not a JSON record"), ('{"a": 1}', "not a jaco record")]:
        p = tmp_path / "r.json"
        if text is not None:
            p.write_text(text)
        code = main(["rerun", str(p if text is not None else tmp_path / "missing.json")])
        _, err = capsys.readouterr()
        assert code == 2 and len(err.strip().splitlines()) == 1 and needle in err, err


def test_sweep_record_reruns_and_checks_its_arguments(tmp_path, demo):
    start, goal = demo.meta["start"], demo.meta["goal"]
    axes = {"alpha": [1.0, 2.0]}
    table = jaco.sweep(demo, start, goal, "mmas", axes, 2, **SMALL)
    sidecar = save_sweep(table, tmp_path / "s.csv", demo, start, goal, "mmas", axes, 2, **SMALL)
    assert sidecar == tmp_path / "s.json"
    doc = json.loads(sidecar.read_text())
    assert doc["kind"] == "sweep" and doc["versions"]["jaco"] == jaco.__version__
    assert doc["call"]["params"] == axes and doc["call"]["seeds"] == 2 and doc["call"]["n_ants"] == 8
    assert doc["call"]["grid"]["sha256"] == map_hash(demo)
    rec = load_run(tmp_path / "s.csv")  # the table's path finds the sidecar
    assert len(rec.table) == 4  # the CSV holds float32 values, the precision jaco computes in
    assert rec.table["length"].to_numpy(np.float32).tobytes() == table["length"].to_numpy(np.float32).tobytes()
    text = (tmp_path / "s.csv").read_text()
    shortest = str(np.float32(table["length"].iloc[0]))  # e.g. 56.76955, not 56.76955032348633
    assert f",{shortest}," in text and f",{table['length'].iloc[0]!r}," not in text
    rerun = rec.rerun()
    assert rerun.matched, rerun.summary()
    # the sweep rows are the solves: the recorded rows equal solve bit for bit
    r = table.iloc[3]
    single = solve_demo(demo, "mmas", seed=int(r["seed"]), alpha=float(r["alpha"]))
    assert single.length == r["length"]

    with pytest.raises(RecordError, match="rows"):
        save_sweep(table, tmp_path / "x.csv", demo, start, goal, "mmas", axes, 3, **SMALL)
    with pytest.raises(RecordError, match=".csv"):
        save_sweep(table, tmp_path / "x.json", demo, start, goal, "mmas", axes, 2, **SMALL)

    doc["call"]["seeds"] = [5, 6]  # a different call (same shapes): the table no longer matches
    sidecar.write_text(json.dumps(doc))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        rerun = load_run(sidecar).rerun()
    assert not rerun.matched and "rows differ" in rerun.differences[0]


OLD = Path(__file__).parent / "data" / "sweep-record-v1"


@pytest.mark.parametrize("name, rows", [("sweep", 16), ("single", 6)])
def test_a_record_in_the_older_table_layout_still_reruns_and_matches(tmp_path, name, rows):
    """Records written before start/goal became integer columns and floats float32 decimals
    (tests/data/sweep-record-v1, made by that jaco) rerun and match, value by value."""
    for suffix in (".csv", ".json"):
        (tmp_path / f"{name}{suffix}").write_bytes((OLD / f"{name}{suffix}").read_bytes())
    text = (tmp_path / f"{name}.csv").read_text()
    assert "." in text and ("17.899494171142578" in text or "29.899494171142578" in text)  # float64 decimals
    rec = load_run(tmp_path / f"{name}.json")
    assert rec.warnings == [] and len(rec.table) == rows
    if name == "sweep":
        assert '"(0, 0)"' in text  # the query as text, read back as integer columns
        assert list(rec.table.columns[2:6]) == ["start_row", "start_col", "goal_row", "goal_col"]
        assert rec.table["start_row"].dtype.kind == "i" and set(rec.table["goal_row"]) == {0, 11}
    rerun = rec.rerun()
    assert rerun.matched, rerun.summary()
    # one recorded length off by one float32 step is found, in its row and column
    lines = text.splitlines()
    k = lines[0].split(",").index("length")
    row = next(i for i, line in enumerate(lines[1:], start=1) if _csv_split(line)[k] != "inf")
    parts = _csv_split(lines[row])
    parts[k] = repr(float(np.nextafter(np.float32(float(parts[k])), np.float32(np.inf))))
    lines[row] = ",".join(f'"{p}"' if "," in p else p for p in parts)
    (tmp_path / f"{name}.csv").write_text("\n".join(lines) + "\n")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RecordWarning)  # the table's hash no longer matches the sidecar
        rerun = load_run(tmp_path / f"{name}.json").rerun()
    assert not rerun.matched and rerun.differences == [f"1 of {rows} rows differ (first rows [{row - 1}]; columns ['length'])"]


def _csv_split(line):
    return next(csv.reader([line]))


def test_latin_hypercube_sweep_record_reruns(tmp_path, demo):
    start, goal = demo.meta["start"], demo.meta["goal"]
    design = jaco.research.designs.latin_hypercube(1, 3, {"alpha": (0.5, 3.0), "beta": (1.0, 8.0)})
    table = jaco.sweep(demo, start, goal, "as", design, 2, **SMALL)
    sidecar = save_sweep(table, tmp_path / "lhs.csv", demo, start, goal, "as", design, 2, **SMALL)
    recorded = json.loads(sidecar.read_text())["call"]["params"]["design"]
    np.testing.assert_array_equal(recorded["alpha"], design.values["alpha"])
    rerun = load_run(sidecar).rerun()
    assert rerun.matched, rerun.summary()


def test_cli_sweep_record_and_rerun(tmp_path, capsys):
    out = tmp_path / "sw.csv"
    code = main(["sweep", "demo", "--param", "alpha=1,2", "--seeds", "2", *CLI_SMALL, "--record", str(out)])
    assert code == 0, capsys.readouterr().err
    capsys.readouterr()
    with out.open() as f:
        assert len(list(csv.DictReader(f))) == 4
    assert main(["rerun", str(tmp_path / "sw.json")]) == 0
    assert "matched the record bit for bit (4 rows" in capsys.readouterr().out


# -- world coordinates (ROS maps) -----------------------------------------------------------
def test_world_round_trip_on_bundled_ros_map():
    grid = jaco.maps.load_bundled("map.yaml")  # resolution 0.05, origin [-10, -10, 0], 384x384
    assert (grid.resolution, grid.origin, grid.shape) == (0.05, (-10.0, -10.0, 0.0), (384, 384))
    cells = np.argwhere(grid.free)
    xy = grid.cell_to_world(cells)
    assert np.array_equal(grid.world_to_cell(xy), cells)
    # hand check: x = -10 + (150 + 0.5) * 0.05, y = -10 + (383 - 200 + 0.5) * 0.05
    assert grid.cell_to_world((200, 150)) == pytest.approx([-2.475, -0.825], abs=1e-12)
    assert tuple(grid.world_to_cell((-2.47, -0.83))) == (200, 150)


def test_path_csv_and_json_hold_metres(tmp_path):
    grid = jaco.maps.load_bundled("lse_arena")  # 60x80, resolution 0.05, origin [0, 0, 0]
    r = jaco.solve(grid, (49, 6), (9, 70), "mmas", seed=0, n_ants=8, n_iters=5)
    assert r.success
    xy = r.to_world()
    assert xy.shape == (len(r.path), 2)
    # start cell (49, 6): x = 6.5 * 0.05, y = (59 - 49 + 0.5) * 0.05; goal (9, 70): 70.5, 50.5
    assert xy[0] == pytest.approx([0.325, 0.525]) and xy[-1] == pytest.approx([3.525, 2.525])

    with r.save_path(tmp_path / "p.csv").open() as f:
        rows = list(csv.DictReader(f))
    assert list(rows[0]) == ["row", "col", "x", "y"] and len(rows) == len(r.path)
    assert rows[0] == {"row": "49", "col": "6", "x": "0.325", "y": "0.525"}
    assert rows[-1] == {"row": "9", "col": "70", "x": "3.525", "y": "2.525"}
    for row, (x, y) in zip(rows, xy):
        assert (float(row["x"]), float(row["y"])) == pytest.approx((x, y), abs=1e-9)

    doc = json.loads(r.save_path(tmp_path / "p.json").read_text())
    assert doc["frame"] == "world" and doc["resolution"] == 0.05 and doc["origin"] == [0.0, 0.0, 0.0]
    assert doc["xy"][0] == [0.325, 0.525] and doc["cells"][0] == [49, 6]
    assert doc["length_m"] == pytest.approx(r.length * 0.05)

    with (r.save_path(tmp_path / "c.csv", frame="cells")).open() as f:
        assert f.readline().strip() == "row,col"
    demo = jaco.maps.named("demo")
    rd = jaco.solve(demo, demo.meta["start"], demo.meta["goal"], "mmas", seed=0, **SMALL)
    with pytest.raises(jaco.ProblemError, match="resolution"):
        rd.save_path(tmp_path / "d.csv", frame="world")
    with pytest.raises(jaco.ProblemError):
        rd.to_world()


def test_waypoint_trip_record_reruns_bit_for_bit(tmp_path):
    grid = jaco.maps.named("utrap-15")
    start, goal = grid.meta["start"], grid.meta["goal"]
    via = [tuple(int(v) for v in c) for c in np.argwhere(grid.free)[[3, -20]]]
    result = jaco.solve(grid, start, goal, "acs", seed=2, waypoints=via, **SMALL)
    assert result.waypoints == tuple(via)
    rec = load_run(result.save(tmp_path / "trip.json"))
    assert [tuple(c) for c in rec.call["waypoints"]] == via
    rerun = rec.rerun()
    assert rerun.matched, rerun.summary()
    assert_same_result(rerun.result, result)


def test_a_record_of_format_1_says_why_its_rerun_no_longer_matches():
    """A record written by jaco before counter-based random numbers (format 1, kept in
    tests/data): it still loads and reruns, does not match, and the warning says why."""
    path = Path(__file__).parent / "data" / "record-format-1.json"
    with pytest.warns(RecordWarning, match=r"record format 1, this jaco writes format \d+: .*Threefry"):
        rerun = jaco.load_run(path).rerun()
    assert not rerun.matched and rerun.differences
    assert "record format 1" in rerun.summary()
