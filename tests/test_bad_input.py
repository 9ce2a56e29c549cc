"""Bad input, generated (hypothesis) and by example: every call ends in a valid result or one
:class:`jaco.JacoError` line, never another exception, and never changes a file that was there.

The generated inputs stop before anything compiles (loaders, validation, writers), so the module
stays fast; the few runs it needs are of one tiny shape and compile once.
"""

import json
import math
import os
import resource
import stat
import struct
import tempfile
import warnings
import zlib
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import jaco
from jaco import maps
from jaco.cli import main
from jaco.engine.checks import prepare
from jaco.engine.memory import memory_budget
from jaco.engine.params import SPECS
from jaco.engine.problem import make_problem
from jaco.planners.registry import get_planner
from jaco.research.records import RecordError, load_run

FAST = settings(max_examples=40, deadline=None,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
GRID = jaco.Grid.from_rows(["......", ".@@...", "...@..", "......"])
SMALL = dict(n_ants=4, n_iters=3)


def outcome(call):
    """``call()``'s value, or None after a JacoError whose message is one non-empty line."""
    try:
        return call()
    except jaco.JacoError as e:
        text = str(e)
        assert text.strip() and "\n" not in text, repr(text)
        return None


def snapshot(folder: Path) -> dict:
    """Every entry: a file's bytes, a link's target, a node's type and device number."""
    out = {}
    for p in sorted(folder.iterdir()):
        if p.is_symlink():
            out[p.name] = ("link", os.readlink(p))
        elif p.is_file():
            out[p.name] = p.read_bytes()
        elif not p.is_dir():
            out[p.name] = ("node", stat.S_IFMT(p.lstat().st_mode), p.lstat().st_rdev)
    return out


@pytest.fixture(scope="module")
def result():
    return jaco.solve(GRID, (0, 0), (3, 5), "acs", seed=3, **SMALL)


@pytest.fixture(autouse=True)
def small_budget(monkeypatch):
    monkeypatch.setenv("JACO_MEMORY_BUDGET", "2G")  # the same limits on every machine


# -- maps ----------------------------------------------------------------------------------------
TEXT = st.text(alphabet=".#@ \r\n\tGSTWOx\x00é", max_size=60)


@FAST
@given(body=TEXT, suffix=st.sampled_from([".txt", ".map"]))
def test_text_and_movingai_files(body, suffix):
    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / f"m{suffix}"
        header = "type octile\nheight 3\nwidth 4\nmap\n" if suffix == ".map" and body[:1] == "." else ""
        path.write_text(header + body, encoding="utf-8")
        grid = outcome(lambda: maps.load(path))
        if grid is not None:
            assert grid.height >= 1 and grid.width >= 1 and grid.free.dtype == bool


@FAST
@given(rows=st.lists(st.text(alphabet=".#@", min_size=3, max_size=3), min_size=1, max_size=5),
       crlf=st.booleans(), blank=st.integers(0, 3))
def test_valid_text_maps_load_with_any_line_ends_and_trailing_blank_lines(rows, crlf, blank):
    end = "\r\n" if crlf else "\n"
    text = end.join(rows) + end * (1 + blank)
    expected = np.array([[c == "." for c in r] for r in rows])
    np.testing.assert_array_equal(jaco.Grid.from_rows(text).free, expected)
    with tempfile.TemporaryDirectory() as d:
        (Path(d) / "m.txt").write_bytes(text.encode())
        np.testing.assert_array_equal(maps.load(Path(d) / "m.txt").free, expected)


SCEN_LINE = st.lists(st.sampled_from(["0", "3", "-1", "x", "1e9", "nan", "m.map", "", "2.5", "99999999999999999999"]),
                     min_size=0, max_size=10).map("\t".join)


@FAST
@given(head=st.sampled_from(["version 1", "version 1.0", "version 2", "", "v"]), lines=st.lists(SCEN_LINE, max_size=4))
def test_scenario_files(head, lines):
    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "s.scen"
        path.write_text("\n".join([head, *lines]) + "\n")
        rows = outcome(lambda: maps.load_scenarios(path))
        for sc in rows or []:
            assert 0 <= sc.start[0] < sc.height and 0 <= sc.start[1] < sc.width and sc.optimal >= 0


YAML_VALUE = st.one_of(st.none(), st.booleans(), st.integers(-5, 5), st.floats(allow_nan=True), st.text(max_size=5),
                       st.lists(st.floats(-5, 5), max_size=4))


@FAST
@given(
    fields=st.fixed_dictionaries({}, optional={k: YAML_VALUE for k in (
        "resolution", "origin", "occupied_thresh", "free_thresh", "negate", "mode")}),
    pgm=st.one_of(
        st.binary(max_size=40),
        st.tuples(st.sampled_from([b"P5", b"P2", b"P6", b"P7"]), st.integers(-1, 5), st.integers(-1, 5),
                  st.integers(0, 70000), st.binary(max_size=40)).map(
            lambda t: t[0] + b"\n%d %d\n%d\n" % t[1:4] + t[4]),
    ),
)
def test_ros_yaml_and_pgm_pairs(fields, pgm):
    doc = {"image": "m.pgm", "resolution": 0.05, "origin": [0.0, 0.0, 0.0], "occupied_thresh": 0.65,
           "free_thresh": 0.196, **fields}
    with tempfile.TemporaryDirectory() as d:
        import yaml

        (Path(d) / "m.yaml").write_text(yaml.safe_dump(doc))
        (Path(d) / "m.pgm").write_bytes(pgm)
        grid = outcome(lambda: maps.load(Path(d) / "m.yaml"))
        if grid is not None:
            assert grid.resolution > 0 and len(grid.origin) == 3


@FAST
@given(magic=st.sampled_from([b"P2", b"P3"]), w=st.integers(1, 4), h=st.integers(1, 4), extra=st.integers(-4, 4),
       maxval=st.sampled_from([1, 100, 255, 65535]), comment=st.booleans())
def test_plain_pgm_value_counts(magic, w, h, extra, maxval, comment):
    """A plain (ascii) PGM/PPM loads only with exactly width x height (x 3) values; any other count is
    a MapFormatError naming the count found and expected, whatever the maxval (Pillow or not)."""
    n = w * h * (3 if magic == b"P3" else 1)
    k = max(0, n + extra)
    body = b" ".join(b"%d" % (i % (maxval + 1)) for i in range(k)) + (b"\n# a comment 1 2 3\n" if comment else b"\n")
    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "m.pgm"
        path.write_bytes(magic + b"\n%d %d\n%d\n" % (w, h, maxval) + body)
        if k == n:
            assert maps.load(path).shape == (h, w)
        else:
            with pytest.raises(jaco.MapFormatError, match=rf"m\.pgm: .*PGM pixel .*: {w}x{h} needs {n} values.*, found {k}$"):
                maps.load(path)


@FAST
@given(text=st.text(alphabet="image:resolution origin[]{},-0.5\n \t'\"&*!|>#", max_size=80))
def test_ros_yaml_text(text):
    with tempfile.TemporaryDirectory() as d:
        (Path(d) / "m.yaml").write_text(text)
        assert outcome(lambda: maps.load(Path(d) / "m.yaml")) is None  # no image beside it: never a grid


@FAST
@given(shape=st.lists(st.integers(0, 3), max_size=3),
       dtype=st.sampled_from(["bool", "int8", "uint16", "float32", "complex64", "U1"]), fill=st.integers(-1, 2))
def test_npy_arrays(shape, dtype, fill):
    with tempfile.TemporaryDirectory() as d:
        np.save(Path(d) / "m.npy", np.full(shape, fill).astype(dtype))
        grid = outcome(lambda: maps.load(Path(d) / "m.npy"))
        if grid is not None:
            assert grid.shape == tuple(shape)


def png_header(w: int, h: int) -> bytes:
    """A PNG that only declares its size (no pixel data)."""
    chunk = lambda t, d: struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d))  # noqa: E731
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 0, 0, 0, 0)) + chunk(b"IEND", b"")


@FAST
@given(data=st.one_of(st.binary(max_size=60), st.tuples(st.integers(1, 30000), st.integers(1, 30000)).map(
    lambda wh: png_header(*wh))))
def test_png_files(data):
    with tempfile.TemporaryDirectory() as d:
        (Path(d) / "m.png").write_bytes(data)
        assert outcome(lambda: maps.load(Path(d) / "m.png")) is None  # no pixels: never a grid


# -- grids, cells, parameters, sizes ----------------------------------------------------------------
ANY = st.recursive(
    st.one_of(st.none(), st.booleans(), st.integers(-3, 3), st.sampled_from([2**32, 2**64, 10**30, -(2**40)]),
              st.floats(allow_nan=True), st.text(".#@\r\n12", max_size=4)),
    lambda inner: st.lists(inner, max_size=4),
    max_leaves=12,
)


@FAST
@given(free=ANY, cell_size=ANY)
def test_grid_constructors(free, cell_size):
    for build in (lambda: jaco.Grid.from_array(free, cell_size=cell_size if cell_size is not None else 1.0),
                  lambda: jaco.Grid.from_rows(free)):
        grid = outcome(build)
        if grid is not None:
            assert grid.free.ndim == 2 and grid.free.dtype == bool and grid.cell_size > 0


@FAST
@given(start=ANY, goal=ANY, connectivity=ANY)
def test_cells_and_connectivity(start, goal, connectivity):
    problem = outcome(lambda: make_problem(GRID, start, goal, connectivity=connectivity))
    if problem is not None:
        assert math.isfinite(problem.optimal)


DEPOT = maps.load_bundled("depot.yaml")
CALLS = {
    "maps.load": lambda v: maps.load(v),
    "maps.load threshold": lambda v: maps.load(maps.bundled("arena.map"), threshold=v),
    "maps.load_scenarios": lambda v: maps.load_scenarios(v),
    "load_run": lambda v: load_run(v),
    "random_map size": lambda v: maps.random_map(v, 0.1, seed=0),
    "random_map p": lambda v: maps.random_map(6, v, seed=0),
    "random_map seed": lambda v: maps.random_map(6, 0.1, seed=v),
    "random_map start": lambda v: maps.random_map(6, 0.1, seed=0, start=v),
    "exact.shortest_path": lambda v: jaco.exact.shortest_path(GRID, v, (3, 5)),
    "exact.distance_field": lambda v: jaco.exact.distance_field(GRID, v),
    "Grid.check_cell": lambda v: GRID.check_cell(v),
    "Grid.cell_to_world": lambda v: DEPOT.cell_to_world(v),
    "Grid.world_to_cell": lambda v: DEPOT.world_to_cell(v),
    "plot.plot_map": lambda v: jaco.plot.plot_map(v),
    "plot.plot_paths": lambda v: jaco.plot.plot_paths(GRID, v),
    "plot.plot_pheromone": lambda v: jaco.plot.plot_pheromone(GRID, v),
    "summarize": lambda v: jaco.summarize(v),
    "make_run": lambda v: jaco.make_run("as", n_ants=v, n_iters=2, steplimit=3),
}


@settings(FAST, max_examples=200)
@given(call=st.sampled_from(sorted(CALLS)), value=ANY)
def test_any_argument_of_the_api(call, value):
    outcome(lambda: CALLS[call](value))


PARAM_NAMES = st.sampled_from(sorted(SPECS) + ["nope", ""])


@FAST
@given(values=st.dictionaries(PARAM_NAMES, ANY, max_size=4), variant=st.sampled_from(["mmas", "acs", "iaca", "pg-aco"]),
       sizes=st.tuples(*[st.one_of(st.integers(-2, 40), st.sampled_from([2**31, 10**9, 2**64]), ANY)] * 3),
       seed=st.one_of(st.integers(-2, 2**33), ANY))
def test_parameter_sets_sizes_and_seeds(values, variant, sizes, seed):
    v = get_planner(variant)
    n_ants, n_iters, steplimit = sizes
    prepared = outcome(lambda: prepare(GRID, v, seed=seed, n_ants=n_ants, n_iters=n_iters, steplimit=steplimit,
                                       params=values))
    if prepared is not None:
        limit, resolved = prepared
        assert 0 <= seed < 2**32 and limit >= 1
        for name, value in resolved.items():
            assert SPECS[name].contains(value), name


class Valid(Exception):
    """Raised in place of compiling: the arguments passed every check."""


def stop(*args, **kwargs):
    raise Valid


@FAST
@given(variant=st.one_of(ANY, st.sampled_from(["as", ["as", "acs"]])), seeds=ANY,
       grid=st.sampled_from(["demo", None, 3, GRID, [GRID, GRID]]), start=st.sampled_from([(0, 0), [(0, 0)], "0,0", 5]))
def test_sweep_arguments_before_compiling(variant, seeds, grid, start):
    try:
        with pytest.MonkeyPatch.context() as mp:
            mp.setattr(jaco.research.chunks, "_plan", stop)  # where the sweep would compile
            outcome(lambda: jaco.plan_sweep(grid, start, (3, 5), variant, None, seeds, **SMALL))
    except Valid:
        assert isinstance(seeds, int) or all(isinstance(s, int) and 0 <= s < 2**32 for s in seeds)


# -- records -------------------------------------------------------------------------------------
def paths_of(doc, prefix=()):
    if isinstance(doc, dict):
        for k, v in doc.items():
            yield prefix + (k,)
            yield from paths_of(v, prefix + (k,))


@FAST
@given(which=st.integers(0, 10**6), value=ANY)
def test_records_with_any_field_changed(result, which, value):
    with tempfile.TemporaryDirectory() as d:
        path = result.save(Path(d) / "run.json")
        doc = json.loads(path.read_text())
        fields = sorted(paths_of(doc))
        field = fields[which % len(fields)]
        target = doc
        for k in field[:-1]:
            target = target[k]
        target[field[-1]] = value
        path.write_text(json.dumps(doc))
        rec = outcome(lambda: load_run(path))
        if rec is not None:
            assert isinstance(rec.call["seed"], int) and rec.grid.shape == (4, 6)


# -- output paths --------------------------------------------------------------------------------
def private_null(folder: Path):
    """A character device like /dev/null in ``folder`` (root only), or None."""
    try:
        os.mknod(folder / "null", 0o666 | stat.S_IFCHR, os.makedev(1, 3))
        os.close(os.open(folder / "null", os.O_WRONLY))
        return folder / "null"
    except OSError:
        return None


@FAST
@given(kind=st.sampled_from(["dir", "existing", "missing", "under-file", "suffix", "empty", "link", "link-chain",
                             "dangling", "dangling-nowhere", "link-to-dir", "link-loop", "device", "new-in-dev", "stdout"]),
       writer=st.sampled_from(["record", "path-csv", "path-json", "figure", "text-map", "sweep-record"]))
def test_output_paths(result, kind, writer):
    from jaco import plot

    suffix = {"record": ".json", "path-csv": ".csv", "path-json": ".json", "figure": ".svg", "text-map": ".txt",
              "sweep-record": ".csv"}[writer]
    with tempfile.TemporaryDirectory() as d:
        d = Path(d)
        (d / "existing" / "").mkdir()
        (d / "file").write_text("keep")
        (d / f"old{suffix}").write_text("keep")
        (d / f"link{suffix}").symlink_to(f"old{suffix}")
        (d / f"chain{suffix}").symlink_to(d / f"link{suffix}")
        (d / f"dangling{suffix}").symlink_to(f"new{suffix}")
        (d / f"nowhere{suffix}").symlink_to(f"gone/new{suffix}")
        (d / f"to-dir{suffix}").symlink_to("existing")
        (d / f"loop{suffix}").symlink_to(f"loop{suffix}")
        null = private_null(d) if kind == "device" else None
        if kind == "device" and null is None:
            return  # not root: no private device
        target = {"dir": d / "existing", "existing": d / f"old{suffix}", "missing": d / "a" / "b" / f"x{suffix}",
                  "under-file": d / "file" / f"x{suffix}", "suffix": d / "x.weird", "empty": "",
                  "link": d / f"link{suffix}", "link-chain": d / f"chain{suffix}", "dangling": d / f"dangling{suffix}",
                  "dangling-nowhere": d / f"nowhere{suffix}", "link-to-dir": d / f"to-dir{suffix}",
                  "link-loop": d / f"loop{suffix}", "device": null, "new-in-dev": f"/dev/jaco-new{suffix}",
                  "stdout": "-"}[kind]
        before = snapshot(d)
        write = {
            "record": lambda: result.save(target),
            "path-csv": lambda: result.save_path(target, frame="cells"),
            "path-json": lambda: result.save_path(target, frame="cells"),
            "figure": lambda: plot.save(plot.plot_map(GRID), target),
            "text-map": lambda: maps.save_text(GRID, target),
            "sweep-record": lambda: jaco.research.records.save_sweep(
                jaco.sweep(GRID, (0, 0), (3, 5), "acs", None, 1, **SMALL), target, GRID, (0, 0), (3, 5), "acs", None, 1,
                **SMALL),
        }[writer]
        written = outcome(write)
        after = snapshot(d)
        assert not [n for n in after if ".tmp" in n], after  # no temporary file left behind
        assert not os.path.lexists(f"/dev/jaco-new{suffix}")  # nothing is ever created in /dev
        links = {k: v for k, v in before.items() if isinstance(v, tuple)}
        assert {k: after.get(k) for k in links} == links  # links stay links, devices devices
        # a record takes any name; a device's has no suffix: only the writers of one format write there
        assert (written is not None) == (kind in ("existing", "missing", "link", "link-chain", "dangling") or (
            kind == "suffix" and writer == "record") or (kind in ("device", "stdout") and writer in ("record", "text-map")))
        if written is None:
            assert after == before
        elif kind in ("device", "stdout"):
            assert after == before  # written in place: nothing beside it
        else:
            assert Path(written).is_file() and Path(written).stat().st_size > 0
            real = Path(os.path.realpath(target))  # a link's target is what changed
            new = {Path(written).name, Path(target).name, real.name}  # a sweep record: the table and its sidecar
            assert {k: v for k, v in after.items() if k in before and k not in new} == {
                k: v for k, v in before.items() if k not in new}


# -- the examples of each kind, explicitly ---------------------------------------------------------
def run_cli(capsys, *argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def one_error_line(code, err, *needles, exit_code=2):
    assert code == exit_code, err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in err, err
    for needle in needles:
        assert needle in lines[0], (needle, lines[0])


@pytest.fixture
def text_map(tmp_path):
    path = tmp_path / "m.txt"
    path.write_bytes(b"......\r\n.@@...\r\n...@..\r\n......\r\n\r\n")  # CRLF and a trailing blank line
    return path


QUERY = ["--start", "0,0", "--goal", "3,5", "--variant", "acs", "--ants", "4", "--iters", "3"]


def test_crlf_text_map_loads_on_the_command_line(capsys, text_map, tmp_path):
    code, out, err = run_cli(capsys, "solve", text_map, *QUERY, "--plot", tmp_path / "p.svg",
                             "--json", tmp_path / "r.pdf.json")
    assert code == 0, err
    assert (tmp_path / "p.svg").read_text().startswith("<?xml")  # the format the suffix names
    assert json.loads((tmp_path / "r.pdf.json").read_text())["success"] is True


def test_plot_formats_follow_the_suffix(capsys, text_map, tmp_path):
    code, _, err = run_cli(capsys, "solve", text_map, *QUERY, "--plot", tmp_path / "p.pdf")
    assert code == 0, err
    assert (tmp_path / "p.pdf").read_bytes()[:5] == b"%PDF-"
    code, _, err = run_cli(capsys, "solve", text_map, *QUERY, "--plot", tmp_path / "p.xyz")
    one_error_line(code, err, "--plot", "unsupported suffix '.xyz'", ".svg")


@pytest.mark.parametrize("flag", ["--json", "--plot", "--record", "--path-csv"])
def test_solve_outputs_are_checked_before_the_run(capsys, text_map, tmp_path, flag):
    name = {"--plot": "x.png", "--path-csv": "x.csv"}.get(flag, "x.json")
    folder = tmp_path / f"dir{Path(name).suffix}"
    folder.mkdir()
    (tmp_path / "file").write_text("keep")
    for bad, needle in ((folder, "is a directory"), (tmp_path / "file" / name, "is not a folder")):
        code, out, err = run_cli(capsys, "solve", text_map, *QUERY, flag, bad)
        one_error_line(code, err, flag, needle)
        assert out == ""  # nothing ran
    code, _, err = run_cli(capsys, "solve", text_map, *QUERY, flag, tmp_path / "new" / "sub" / name)
    assert code == 0 and (tmp_path / "new" / "sub" / name).is_file(), err  # missing folders are created


def test_sweep_outputs_are_checked_before_the_run(capsys, text_map, tmp_path):
    (tmp_path / "dir").mkdir()
    code, out, err = run_cli(capsys, "sweep", text_map, "--start", "0,0", "--goal", "3,5", "--csv", tmp_path / "dir")
    one_error_line(code, err, "--csv", "is a directory")
    code, out, err = run_cli(capsys, "sweep", text_map, "--start", "0,0", "--goal", "3,5",
                             "--csv", tmp_path / "t.csv", "--record", tmp_path / "t.csv")
    one_error_line(code, err, "same file")


def test_read_only_folder(capsys, text_map, tmp_path):
    if os.geteuid() == 0:
        pytest.skip("root writes into read-only folders")
    folder = tmp_path / "ro"
    folder.mkdir()
    folder.chmod(0o555)
    try:
        code, out, err = run_cli(capsys, "solve", text_map, *QUERY, "--json", folder / "x.json")
        one_error_line(code, err, "not writable")
    finally:
        folder.chmod(0o755)


def test_record_may_not_name_an_input(capsys, text_map, tmp_path):
    before = text_map.read_bytes()
    code, out, err = run_cli(capsys, "solve", text_map, *QUERY, "--record", text_map)
    one_error_line(code, err, "--record", "is an input of this run")
    assert text_map.read_bytes() == before
    ros = maps.bundled("depot.yaml")
    code, out, err = run_cli(capsys, "solve", ros, "--start-xy", "1,1", "--goal-xy", "2,2", "--json",
                             ros.parent / "depot.pgm")
    one_error_line(code, err, "is an input of this run")


def test_a_failed_run_leaves_existing_outputs_untouched(capsys, text_map, tmp_path):
    out_json = tmp_path / "out.json"
    out_json.write_text("keep")
    code, _, err = run_cli(capsys, "solve", text_map, "--start", "0,0", "--goal", "1,1", "--json", out_json)
    one_error_line(code, err, "obstacle")
    assert out_json.read_text() == "keep"


def test_a_write_that_fails_midway_keeps_the_old_file_and_leaves_no_partial_one(result, tmp_path):
    old = tmp_path / "run.json"
    old.write_text("keep")
    soft, hard = resource.getrlimit(resource.RLIMIT_FSIZE)
    resource.setrlimit(resource.RLIMIT_FSIZE, (1024, hard))  # as `ulimit -f 1`
    try:
        with pytest.raises(jaco.OutputError, match=r"record '.*run\.json': cannot write: File too large$"):
            result.save(old)
    finally:
        resource.setrlimit(resource.RLIMIT_FSIZE, (soft, hard))
    assert old.read_text() == "keep"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.json"]


@pytest.mark.parametrize("seed", [2**32, 2**64, 10**30, -1, 1.0, "3", True])
def test_seeds_outside_32_bits_are_errors_not_aliases(seed):
    with pytest.raises(jaco.JacoError, match="seed"):
        jaco.solve(GRID, (0, 0), (3, 5), seed=seed, **SMALL)
    with pytest.raises(jaco.JacoError, match="seed"):
        jaco.tune(GRID, (0, 0), (3, 5), "as", tune=("beta",), steps=1, population=2, seed=seed, **SMALL)
    with pytest.raises(jaco.JacoError, match="seeds"):
        jaco.sweep(GRID, (0, 0), (3, 5), "as", None, [seed], **SMALL)


def test_seed_limits_on_the_command_line_and_in_records(capsys, text_map, result, tmp_path):
    code, _, err = run_cli(capsys, "solve", text_map, *QUERY, "--seed", 2**32)
    one_error_line(code, err, "--seed", "2**32")
    path = result.save(tmp_path / "run.json")
    doc = json.loads(path.read_text())
    doc["call"]["seed"] = 2**64
    path.write_text(json.dumps(doc))
    code, _, err = run_cli(capsys, "rerun", path)
    one_error_line(code, err, "call.seed", "[0, 2**32)")


@pytest.mark.parametrize("args, needles", [
    (["--ants", "1000000000"], ["32-bit"]),
    (["--steplimit", "1000000000"], ["32-bit"]),
    (["--steplimit", "10000000"], ["memory", "budget of 2 GiB"]),
    (["--iters", "1000000000"], ["memory", "GiB", "budget of 2 GiB", "JACO_MEMORY_BUDGET"]),
])
def test_sizes_beyond_the_memory_budget_are_refused_before_compiling(capsys, text_map, args, needles):
    code, out, err = run_cli(capsys, "solve", text_map, "--start", "0,0", "--goal", "3,5", *args)
    one_error_line(code, err, *needles)


def test_sweep_axes_and_seeds_beyond_the_budget(capsys, text_map):
    code, _, err = run_cli(capsys, "sweep", text_map, "--start", "0,0", "--goal", "3,5",
                           "--param", "alpha=0:5:100000000")
    one_error_line(code, err, "100000000 configurations", "memory")
    code, _, err = run_cli(capsys, "sweep", text_map, "--start", "0,0", "--goal", "3,5",
                           "--param", "alpha=0:5:100000", "--param", "beta=0:5:100000")
    one_error_line(code, err, "10000000000 configurations")
    with pytest.raises(jaco.ResourceError, match="seeds"):
        jaco.sweep(GRID, (0, 0), (3, 5), "as", None, 10**12, **SMALL)


def test_the_budget_can_be_set(monkeypatch):
    monkeypatch.setenv("JACO_MEMORY_BUDGET", "512M")
    assert memory_budget() == 512 << 20
    monkeypatch.setenv("JACO_MEMORY_BUDGET", "lots")
    with pytest.raises(jaco.JacoError, match="JACO_MEMORY_BUDGET"):
        memory_budget()
    monkeypatch.delenv("JACO_MEMORY_BUDGET")
    assert memory_budget() > 0


@pytest.mark.parametrize("change, field", [
    (lambda d: d.update(format_version="1"), "format_version"),
    (lambda d: d.update(format_version=None), "format_version"),
    (lambda d: d["result"].update(history=[1, 2]), "result.history"),
    (lambda d: d["call"].update(start=None), "call.start"),
    (lambda d: d["call"].update(n_ants=1.5), "call.n_ants"),
    (lambda d: d["map"].update(shape="4x6"), "map.shape"),
    (lambda d: d.update(call=[]), "call"),
])
def test_malformed_records_name_the_field(capsys, result, tmp_path, change, field):
    path = result.save(tmp_path / "run.json")
    doc = json.loads(path.read_text())
    change(doc)
    path.write_text(json.dumps(doc))
    with pytest.raises(RecordError, match=f"field {field}"):
        load_run(path)
    code, _, err = run_cli(capsys, "rerun", path)
    one_error_line(code, err, field)


def test_deeply_nested_record(tmp_path):
    path = tmp_path / "deep.json"
    path.write_text('{"format": "jaco-record", "kind": "run", "call": ' + "[" * 100000 + "]" * 100000 + "}")
    with pytest.raises(RecordError, match="nested too deeply"):
        load_run(path)


@pytest.mark.parametrize("call, needle", [
    (lambda: jaco.Grid.from_array([[1, 0], [1]]), "rows have different lengths"),
    (lambda: jaco.Grid.from_array(np.ones((2, 2), bool), cell_size="2"), "cell_size must be a positive number"),
    (lambda: jaco.Grid.from_array(np.ones((2, 2), bool), cell_size=2**64), "below 2**63"),  # np.isfinite raised
    (lambda: jaco.Grid.from_rows([1, 2]), "list of str rows"),
    (lambda: jaco.Grid.from_rows(None), "a str or a list of str rows"),
    (lambda: jaco.solve("demo", (0, 0), (1, 1)), "expected a jaco.Grid, got str"),
    (lambda: jaco.solve(GRID, (0, 0), (3, 5), planner=["mmas"]), "a planner must be a name (str) or a Planner, got list"),
    (lambda: jaco.solve(GRID, (math.inf, 0), (3, 5)), "start must be a (row, col) pair of integers"),
    (lambda: jaco.solve(GRID, (0, 0), (3, 5), alpha="1"), "must be a number"),
    (lambda: jaco.solve(GRID, (0, 0), (3, 5), connectivity="8"), "connectivity must be 4 or 8"),
    (lambda: jaco.sweep("demo", (0, 0), (1, 1)), "grid must be a jaco.Grid"),
])
def test_api_types_say_what_was_expected(call, needle):
    with pytest.raises(jaco.JacoError) as e:
        call()
    assert needle in str(e.value) and "\n" not in str(e.value)


@pytest.mark.parametrize("call, suggestion, listed", [
    (lambda: jaco.solve(GRID, (0, 0), (3, 5), n_ant=10), "'n_ants'", "valid: alpha, beta"),
    (lambda: jaco.solve(GRID, (0, 0), (3, 5), "acs", betta=2.0), "'beta'", "keywords of jaco.solve: seed, n_ants"),
    (lambda: jaco.solve(GRID, (0, 0), (3, 5), seeds=3), "'seed'", "valid: alpha"),
    (lambda: jaco.sweep(GRID, (0, 0), (3, 5), n_ant=10), "'n_ants'", "its keywords: grid, start, goal"),
    (lambda: jaco.sweep(GRID, (0, 0), (3, 5), "as", memory=10), "'memory_budget'", "seeds"),
    (lambda: jaco.sweep(GRID, (0, 0), (3, 5), "as", {"rhoo": [0.1]}), "'rho'", "valid: alpha, beta, q, rho, tau0"),
    (lambda: jaco.tune(GRID, (0, 0), (3, 5), n_iter=3), "'n_iters'", "population"),
    (lambda: jaco.tune(GRID, (0, 0), (3, 5), "as", tune=("alpah",)), "'alpha'", "tunable for 'as'"),
])
def test_a_misspelt_keyword_is_answered_with_the_closest_names(call, suggestion, listed):
    """Every keyword the call takes is a candidate: a parameter or one of the call's own."""
    with pytest.raises(jaco.JacoError) as e:
        call()
    text = str(e.value)
    assert f"(did you mean {suggestion}" in text and listed in text and "\n" not in text


def test_a_parameter_some_planners_lack_names_the_planners_that_have_it():
    """A sweep over several planners: q0 is acs's, not a misspelt q of mmas; a search says the
    same in the same words (jaco.engine.params.owners)."""
    with pytest.raises(jaco.JacoError) as e:
        jaco.sweep(GRID, (0, 0), (3, 5), ["mmas", "acs"], {"q0": [0.5, 0.9]}, 1)
    text = str(e.value)
    assert text.startswith("parameter 'q0' belongs to acs only, not to mmas: ") and "did you mean" not in text
    assert "sweep acs on its own" in text and "\n" not in text
    with pytest.raises(jaco.JacoError) as e:
        jaco.sweep(GRID, (0, 0), (3, 5), ["mmas", "acs", "iaca"], {"q0": [0.5]}, 1)
    assert str(e.value).startswith("parameter 'q0' belongs to acs and iaca only, not to mmas: ")
    assert "sweep acs and iaca on their own" in str(e.value)
    with pytest.raises(jaco.JacoError, match=r"^parameter 'q0' is not used by planner 'mmas'; it uses: alpha"):
        jaco.research.space.parse_space({"q0": (0.5, 0.9)}, "mmas")


def test_keyword_checks_keep_the_signature():
    import inspect

    assert list(inspect.signature(jaco.sweep).parameters)[:6] == ["grid", "start", "goal", "planner", "params", "seeds"]
    assert "population" in inspect.signature(jaco.tune).parameters


def test_the_former_keyword_variant_is_the_planner_keyword():
    """``variant=`` (the keyword's name before planners had one name) still works everywhere a
    planner is named, with a DeprecationWarning at the caller's line, and giving both is one
    clear error."""
    a = jaco.solve(GRID, (0, 0), (3, 5), planner="as", seed=2, **SMALL)
    with pytest.warns(DeprecationWarning, match="variant= is the former name of planner=") as caught:
        b = jaco.solve(GRID, (0, 0), (3, 5), variant="as", seed=2, **SMALL)
    assert caught[0].filename == __file__
    assert a.path.tolist() == b.path.tolist() and a.variant == b.variant == "as"
    with pytest.warns(DeprecationWarning, match="write planner="):
        assert jaco.planners.registry.with_cost(variant="as").name == "as+multi"
    with pytest.warns(DeprecationWarning):
        t = jaco.sweep(GRID, (0, 0), (3, 5), variant=["as", "acs"], seeds=1, **SMALL)
    assert list(t["planner"]) == ["as", "acs"]  # the table's column is "planner" (docs/records.md)
    with pytest.raises(jaco.JacoError, match="variant= and planner= are the same argument"):
        jaco.sweep(GRID, (0, 0), (3, 5), variant="as", planner="acs", seeds=1, **SMALL)
    with pytest.raises(jaco.JacoError, match="variant= and planner= are the same argument"):
        jaco.solve(GRID, (0, 0), (3, 5), variant="as", planner="acs", **SMALL)
    assert jaco.VARIANTS is jaco.PLANNERS and jaco.Variant is jaco.Planner


def test_a_list_of_variants_is_still_a_sweep_axis():
    table = jaco.sweep(GRID, (0, 0), (3, 5), ["as", "acs"], None, 1, **SMALL)
    assert list(table["planner"]) == ["as", "acs"]


def test_huge_png_is_a_clear_error(tmp_path):
    for side in (14000, 9500):  # above Pillow's bomb error, and above its warning limit
        path = tmp_path / f"m{side}.png"
        path.write_bytes(png_header(side, side))
        with pytest.raises(jaco.MapFormatError, match="image too large for a map"):
            maps.load(path)


def test_absurd_world_point_is_one_line_without_a_numpy_warning(capsys):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        code, _, err = run_cli(capsys, "solve", "depot", "--start-xy", "1e300,0", "--goal-xy", "1,1")
        one_error_line(code, err, "--start-xy", "is outside map 'depot'")
        row, col = maps.load_bundled("depot.yaml").world_to_cell((1e300, -1e300))
        assert row > 307 and col > 604


@pytest.mark.parametrize("cells", [(math.inf, 0), (0, math.nan), [(1, 1), (-math.inf, 2)], (1e308, -1e308)])
def test_cells_without_world_coordinates_are_one_error_without_a_numpy_warning(cells):
    depot = maps.load_bundled("depot.yaml")
    depot = depot.replace(resolution=100.0)  # metres a cell: 1e308 cells overflow a float
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(jaco.ProblemError, match="finite numbers|too far from map 'depot'"):
            depot.cell_to_world(cells)
        np.testing.assert_allclose(depot.world_to_cell(depot.cell_to_world([(3, 4), (10, 20)])), [(3, 4), (10, 20)])


def test_internal_errors_are_one_line_and_exit_3(capsys, monkeypatch):
    def broken(args):
        raise RuntimeError("boom\nsecond line")

    monkeypatch.setattr("jaco.cli.parser.cmd_planners", broken)
    code, _, err = run_cli(capsys, "planners")
    one_error_line(code, err, "jaco: internal error: RuntimeError: boom second line", "report", "--debug",
                   exit_code=3)
    code, _, err = run_cli(capsys, "--debug", "variants")  # the command's former name
    assert code == 3 and "Traceback" in err and "boom" in err


@pytest.mark.parametrize(
    "param, match",
    [
        (("two words", 1.0, 0, 2, "d"), "must be an identifier"),
        (("kappa_bad", 3.0, 0, 2, "d"), "default 3 is outside its range \\[0, 2\\]"),
        (("kappa_bad", 1.0, 2, 0, "d"), "range \\[2, 0\\] is empty"),
        (("rho", 0.5, 0, 2, "d"), "declared with range \\(0, 1\\] already"),
    ],
)
def test_a_component_parameter_is_checked_when_declared(param, match):
    """A new component's parameter is checked once, when it is declared: a clear one-line error,
    and nothing is registered."""
    from jaco.engine.params import SPECS, Param, declare

    with pytest.raises(jaco.JacoError, match=match) as e:
        declare(Param(*param))
    assert "\n" not in str(e.value) and "kappa_bad" not in SPECS and "two words" not in SPECS
