"""The throughput benchmark runs (at --smoke size) and its native reference is a correct AS.

No test here asserts a time: figures only have to be present, finite and positive.
"""

import json
import math
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import jaco

numba = pytest.importorskip("numba")

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "experiments"))

import native_reference as nr  # noqa: E402

NUMBER = re.compile(r"^-?[\d,]*\.?\d+(e[+-]?\d+)?$")


def numbers(cells):
    """The numeric cells of a markdown table row (thousands separators allowed)."""
    return [float(c.replace(",", "")) for c in cells if NUMBER.match(c)]


def table_row(text, label):
    for line in text.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if line.startswith("|") and cells[0].startswith(label):
            return cells
    raise AssertionError(f"no table row starting with {label!r}")


def run_smoke(script, *args, md):
    """Run ``experiments/<script>`` with ``args`` and ``--smoke --out md``; the text it wrote."""
    proc = subprocess.run(
        [sys.executable, str(ROOT / "experiments" / script), *args, "--smoke", "--out", str(md)],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=1200,
    )
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    return md.read_text()


@pytest.fixture(scope="module")
def smoke(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("bench")
    md, js = tmp / "BENCHMARKS.md", tmp / "bench.json"
    proc = subprocess.run(
        [
            sys.executable,
            str(ROOT / "experiments" / "bench_throughput.py"),
            "--smoke",
            "--out",
            str(md),
            "--json",
            str(js),
        ],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=900,
    )
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    return proc.stdout, md.read_text(), json.loads(js.read_text())


@pytest.mark.slow  # the benchmark at --smoke size still takes ~15 s
def test_smoke_writes_the_throughput_table(smoke):
    stdout, md, _ = smoke
    assert "<!-- bench_throughput:start -->" in md and "<!-- bench_throughput:end -->" in md
    assert "Command: `python experiments/bench_throughput.py --smoke" in md
    for label in (
        "native (numba loop, 1 core)",
        "jaco, native walk, 1 device",
        "jaco, native walk, 2 devices",
        "jaco, JAX walk, 1 device",
        "jaco, JAX walk, 2 devices",
    ):
        row = table_row(md, label)
        vals = numbers(row[1:])
        # wall, CPU, configs/s, steps, steps/s, x native, steps per CPU s, x native per core, ns and cycles per step
        assert len(vals) == 10, row
        assert all(math.isfinite(v) and v > 0 for v in vals[:9]), row
        assert label in stdout
    for walk in ("native walk", "JAX walk"):
        assert re.search(rf"\*\*{walk}: [\d.]+× the native loop per core\*\*", md)
    if jaco.engine.native.isa() != "baseline":  # the portable lanes beside the widest, the same table
        assert all(math.isfinite(v) for v in numbers(table_row(md, "jaco, native walk, baseline lanes")[1:]))
    # sharded over 2 devices, and the other walk: the same tables
    assert "native, 2 devices: yes; jax, 2 devices: yes; native walk, JAX walk: yes" in md


@pytest.mark.slow  # the benchmark at --smoke size still takes ~15 s
def test_smoke_reports_solve_scaling_and_targets(smoke):
    _, md, _ = smoke
    for label in ("first `solve` call", "compile time", "`solve` latency after compile", "compiled run alone"):
        vals = numbers(table_row(md, label)[1:])
        assert vals and all(math.isfinite(v) and v > 0 for v in vals), label
    for label in ("8x8", "12x12"):  # the grid-side table at smoke size: both walks and the native loop
        vals = numbers(table_row(md, label)[1:])
        assert len(vals) == 13 and all(math.isfinite(v) and v > 0 for v in vals), label
    assert "### Targets (native walk)" in md and "Peak memory" in md
    assert md.count("**met**") + md.count("**not met**") == 4  # per core, its milestone, solve, compile
    # "median (lower–upper quartile)" of the pairs, "median (lowest–highest)" of the block rounds
    for label in ("`solve` speed-up over the numba loop's run", "the same in blocks"):
        for cell in table_row(md, label)[1:]:
            median, low, high = map(float, re.fullmatch(r"([\d.]+) \(([\d.]+)–([\d.]+)\)", cell).groups())
            assert 0 < low <= median <= high, (label, cell)


@pytest.mark.slow  # the benchmark at --smoke size still takes ~15 s
def test_smoke_json_figures(smoke):
    _, _, R = smoke
    for k, fig in R["throughput"].items():
        for f in (
            "wall_s",
            "configs_per_s",
            "steps",
            "steps_per_s",
            "steps_per_cpu_s",
            "vs_native",
            "vs_native_per_core",
        ):
            assert math.isfinite(fig[f]) and fig[f] > 0, (k, f)
    lanes = {"native walk, baseline lanes": True} if jaco.engine.native.isa() != "baseline" else {}
    assert R["equal"] == {"native, 2 devices": True, "jax, 2 devices": True, "native walk, JAX walk": True, **lanes}
    assert R["machine"]["xla_devices"] == 2 and R["walks"] == ["native", "jax"]
    assert all(R["solve"][w]["median_ms"] > 0 for w in R["walks"]) and R["rss_peak_mib"] > 0
    # the solve's two series ran the same seeds, and the steps behind them are counted on both sides
    assert R["solve_seeds"] == 2 and R["solve_steps"]["jaco"] > 0 and R["solve_steps"]["native"] > 0
    assert all(R["solve"][w]["blocks"] == 2 and R["solve"][w]["speedup_blocks"] > 0 for w in R["walks"])


# -- the native reference -------------------------------------------------------------------------
def check_path(grid, nbr, start, goal, length, cells):
    cells = np.asarray(cells)
    assert cells[0] == start and cells[-1] == goal
    assert len(set(cells.tolist())) == len(cells)  # tabu list: no cell twice
    total = 0.0
    for a, b in zip(cells[:-1], cells[1:]):
        k = np.flatnonzero(nbr[a] == b)
        assert k.size == 1, (a, b)  # an allowed move (8-connected, no corner cutting)
        total += nr.MOVE_LENGTHS[k[0]]
    assert length == pytest.approx(total)


def test_native_finds_a_valid_path_no_shorter_than_the_optimum():
    grid = jaco.maps.random_map(14, 0.25, seed=3)
    start, goal = (0, 0), (13, 13)
    nbr, eta, s, g = nr.problem_arrays(grid, start, goal)
    steplimit = 4 * (14 + 14)
    optimum, _ = jaco.exact.shortest_path(grid, start, goal)
    length, cells, steps = nr.as_colony(nbr, eta, s, g, 1.0, 4.0, 0.3, 1.0, 0.1, 20, 30, steplimit, 0)
    assert math.isfinite(length)
    check_path(grid, nbr, s, g, length, cells)
    assert length >= optimum - 1e-9
    assert length <= 2 * optimum  # AS with beta = 4 does not wander that far
    assert 0 < steps <= 20 * 30 * steplimit
    # reproducible with numba's own seeded generator
    again = nr.as_colony(nbr, eta, s, g, 1.0, 4.0, 0.3, 1.0, 0.1, 20, 30, steplimit, 0)
    assert again[0] == length and np.array_equal(again[1], cells) and again[2] == steps


def test_native_heuristic_matches_jaco():
    grid = jaco.maps.random_map(9, 0.2, seed=1)
    nbr, eta, s, g = nr.problem_arrays(grid, (0, 0), (8, 8))
    problem = jaco.make_problem(grid, (0, 0), (8, 8))
    want = np.asarray(jaco.engine.heuristics.inverse_goal_distance(jaco.engine.problem.to_device(problem), None, 0, 1))
    np.testing.assert_allclose(eta, want, rtol=1e-6)
    np.testing.assert_array_equal(nbr, problem.nbr)
    # the move targets' coordinates, which jaco computes as cell + move: those of the cells nbr holds
    on_device = jaco.engine.problem.to_device(problem)
    xy = np.stack([jaco.engine.heuristics.target_coordinate(on_device, axis) for axis in (0, 1)], axis=-1)
    safe = np.where(nbr >= 0, nbr, np.arange(len(nbr))[:, None])
    np.testing.assert_array_equal(xy, np.stack(np.divmod(safe, grid.width), axis=-1).astype(np.float32))


def test_native_on_an_open_map_most_ants_arrive():
    grid = jaco.Grid(np.ones((10, 10), bool))
    nbr, eta, s, g = nr.problem_arrays(grid, (0, 0), (9, 9))
    n_ants, n_iters = 20, 10
    length, cells, steps, arrivals = nr.as_colony_stats(nbr, eta, s, g, 1.0, 4.0, 0.3, 1.0, 0.1, n_ants, n_iters, 80, 1)
    assert arrivals >= 0.9 * n_ants * n_iters
    assert length == pytest.approx(9 * math.sqrt(2))  # the diagonal is found
    check_path(grid, nbr, s, g, length, cells)
    assert steps >= arrivals * 9  # every arriving ant took at least the 9 diagonal steps


def test_native_corridor_and_trivial_query():
    # a winding corridor: the only path is found
    grid = jaco.Grid.from_rows(["....", ".###", "....", "###."])
    nbr, eta, s, g = nr.problem_arrays(grid, (0, 3), (3, 3))
    length, cells, steps, arrivals = nr.as_colony_stats(nbr, eta, s, g, 1.0, 1.0, 0.3, 1.0, 0.1, 10, 5, 30, 0)
    optimum, _ = jaco.exact.shortest_path(grid, (0, 3), (3, 3))
    assert length == pytest.approx(optimum)
    assert 0 < arrivals <= 50
    # start on the goal: length 0, no steps
    length, cells, steps = nr.as_colony(nbr, eta, g, g, 1.0, 1.0, 0.3, 1.0, 0.1, 5, 3, 30, 0)
    assert length == 0.0 and list(cells) == [g] and steps == 0


def test_sweep_native_runs_every_configuration():
    grid = jaco.maps.random_map(10, 0.2, seed=2)
    nbr, eta, s, g = nr.problem_arrays(grid, (0, 0), (9, 9))
    configs = [(a, b, r) for a in (1.0, 2.0) for b in (2.0, 4.0) for r in (0.3,)]
    lengths, steps = nr.sweep_native(configs, nbr, eta, s, g, n_ants=10, n_iters=5, steplimit=40, seed=7)
    assert lengths.shape == (4,) and steps.shape == (4,)
    assert (steps > 0).all()
    single = nr.as_colony(nbr, eta, s, g, 2.0, 4.0, 0.3, 1.0, 0.1, 10, 5, 40, 7 + 3)
    assert lengths[3] == single[0] and steps[3] == single[2]


@pytest.mark.slow  # a subprocess compiling both walks
def test_profile_smoke_both_walks_take_the_same_moves(tmp_path):
    """The per-part profile runs at smoke size for both walks; they take the same moves (the
    script exits 1 otherwise) and every timed part is reported."""
    text = run_smoke("profile_iteration.py", md=tmp_path / "BENCHMARKS.md")
    assert "<!-- profile_iteration:start -->" in text and "The two walks' moves are identical: yes" in text
    for label in ("weights", "tours", "pheromone update", "whole iteration"):
        vals = numbers(table_row(text, label)[1:])
        # CPU and wall ms of both walks, CPU ns per real step of both, the native walk's cycles per step
        assert len(vals) == 7 and all(math.isfinite(v) and v > 0 for v in vals), label
    cells = [
        [c.strip() for c in line.strip().strip("|").split("|")] for line in text.splitlines() if line.startswith("|")
    ]
    walk_rows = [numbers(row[1:]) for row in cells if row[0] == "walk" or row[0].startswith("walk (")]
    assert sum(len(v) for v in walk_rows) == 7  # the native walk (named by its lanes) and the JAX walk
    assert re.search(r"Where the native iteration's \d+ ns CPU per real step go: the walk \d+", text)


@pytest.mark.slow  # compiles two planners
def test_scale_benchmark_smoke_writes_its_section(tmp_path):
    sys.path.insert(0, str(ROOT / "experiments"))
    try:
        import bench_scale
    finally:
        sys.path.remove(str(ROOT / "experiments"))
    out = tmp_path / "BENCHMARKS.md"
    assert bench_scale.main(["--smoke", "--out", str(out)]) == 0
    text = out.read_text()
    assert "<!-- bench_scale:start -->" in text and "Command: `python experiments/bench_scale.py --smoke" in text
    rows = [line.split(" | ") for line in text.splitlines() if line.startswith("| room-32-32-4")]
    assert [r[1] for r in rows] == ["mmas", "iaca"]
    for r in rows:
        assert r[4] in ("yes", "no") and (r[5].strip(" |") == "–" or float(r[5].strip(" |")) >= 0)


@pytest.mark.slow  # builds a revision's kernel in a worktree and runs both in processes of their own
def test_before_after_smoke_compares_a_revision_with_itself(tmp_path):
    text = run_smoke("bench_before_after.py", "--before", "HEAD", md=tmp_path / "BENCHMARKS.md")
    assert "<!-- bench_before_after:start -->" in text and "the two give the same costs" in text
    for label in ("before (", "after ("):
        vals = numbers(table_row(text, label)[1:])
        assert len(vals) == 6 and all(math.isfinite(v) and v > 0 for v in vals), label
    worktrees = subprocess.run(["git", "worktree", "list"], cwd=ROOT, capture_output=True, text=True).stdout
    assert "jaco-before-" not in worktrees  # removed again


@pytest.mark.slow
@pytest.mark.parametrize("script", ["bench_workers.py", "bench_shared_sweep.py"])
def test_the_worker_benchmarks_run_at_smoke_size_and_write_their_section(tmp_path, script):
    md = tmp_path / "B.md"
    done = subprocess.run(
        [sys.executable, str(ROOT / "experiments" / script), "--smoke", "--out", str(md)],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=900,
    )
    assert done.returncode == 0, done.stderr[-2000:]
    text = md.read_text()
    section = script.removesuffix(".py")
    assert f"<!-- {section}:start -->" in text and f"Command: `python experiments/{script} --smoke`" in text
    if script == "bench_workers.py":  # both worker counts finished their trials
        assert "| 1 worker | 16 |" in text and "| 2 workers | 16 |" in text
    else:  # every worker's table equal to the first
        assert text.count("| True |") == 2 and "| False |" not in text


@pytest.mark.slow  # compiles the lane walk once per revision, and the driver
@pytest.mark.skipif(shutil.which(os.environ.get("CXX", "c++")) is None, reason="needs a C++ compiler")
def test_walk_kernel_bench_smoke_walks_two_builds_alike(tmp_path):
    text = run_smoke("bench_walk_kernel.py", "--revs", "HEAD", ".", md=tmp_path / "BENCHMARKS.md")
    assert "<!-- bench_walk_kernel:start -->" in text and "Every revision took the same steps" in text
    steps = int(re.search(r"solve: ([\d,]+) steps a round", text).group(1).replace(",", ""))
    head = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True, text=True).stdout
    rows = [numbers(table_row(text, label)[1:5]) for label in (head.strip(), "working tree")]
    for ms, best, ns, ns_best in rows:  # the CPU times and their ns a step, of the one step count
        assert 0 < best <= ms and ns == pytest.approx(ms * 1e6 / steps, rel=0.02) and ns_best <= ns
    ratio = table_row(text, "working tree")[5]
    assert re.fullmatch(r"\d+\.\d{3} \(\d+\.\d{3}–\d+\.\d{3}\)", ratio) and table_row(text, head.strip())[5].startswith("1.000")


@pytest.mark.slow  # compiles the IACA kernel once per revision, and the driver
@pytest.mark.skipif(shutil.which(os.environ.get("CXX", "c++")) is None, reason="needs a C++ compiler")
def test_iaca_kernel_bench_smoke_walks_two_builds_alike(tmp_path):
    text = run_smoke("bench_iaca_kernel.py", "--revs", "HEAD", ".", md=tmp_path / "BENCHMARKS.md")
    assert "<!-- bench_iaca_kernel:start -->" in text and "Every revision left the same pheromone" in text
    head = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True, text=True).stdout
    rows = [numbers(table_row(text, label)[1:]) for label in (head.strip(), "working tree")]
    for vals in rows:  # ms median, ms best, steps, ns a step, ratio
        assert len(vals) == 5 and all(math.isfinite(v) and v > 0 for v in vals)
        assert vals[1] <= vals[0] and vals[3] == pytest.approx(vals[0] * 1e6 / vals[2], rel=0.02)
    assert rows[0][2] == rows[1][2] > 0  # the same walks: as many steps


def test_before_after_words_name_the_direction():
    """A sweep that costs more CPU after than before is said to, not "0.80× less"."""
    import bench_before_after

    assert bench_before_after.cpu_words(1.25) == "1.25× less CPU"
    assert bench_before_after.cpu_words(0.8) == "1.25× more CPU"
