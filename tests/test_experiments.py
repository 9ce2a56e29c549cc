"""The experiment scripts run at --smoke size and write what they promise."""

import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.slow  # about 15 s; paper_tables' smoke run proves the shared machinery in the normal run
def test_thesis_tables_smoke(tmp_path):
    out = subprocess.run(
        [sys.executable, str(ROOT / "experiments" / "thesis_tables.py"), "--smoke", "--out", str(tmp_path)],
        capture_output=True, text=True, timeout=600,
    )
    assert out.returncode == 0, out.stderr[-2000:]
    text = (tmp_path / "results_thesis_smoke.md").read_text()
    for name in ("random-20-10", "utrap-20"):
        row = next(line for line in text.splitlines() if line.startswith(f"| {name} | "))
        optimum = float(row.split("|")[2])
        assert optimum > 0
        # every reported best length is either missing (no success) or >= the exact optimum
        cells = [c.strip() for c in row.split("|")[3:-1]]
        for best in cells[::4]:
            assert best == "–" or float(best) >= optimum - 1e-6
    assert re.search(r"\| ACA best \| ACA gap %", text)
    pngs = sorted(p.name for p in (tmp_path / "figures").glob("*.png"))
    assert "thesis_paths_utrap-20.png" in pngs and "thesis_convergence_random-20-10.png" in pngs
    assert all((tmp_path / "figures" / p).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" for p in pngs)


@pytest.mark.slow  # a subprocess running every planner of the papers
def test_paper_tables_smoke(tmp_path):
    out = subprocess.run(
        [sys.executable, str(ROOT / "experiments" / "paper_tables.py"), "--smoke", "--out", str(tmp_path)],
        capture_output=True, text=True, timeout=600,
    )
    assert out.returncode == 0, out.stderr[-2000:]
    text = (tmp_path / "results_paper_smoke.md").read_text()
    assert text.count("<!-- paper_tables:start -->") == 1 and "<!-- paper_tables:end -->" in text
    rows = {}
    for line in text.splitlines():
        cells = [c.strip() for c in line.split("|")[1:-1]]
        if len(cells) == 12 and cells[0] == "simple-20" and cells[2].isdigit():  # Dong & Zhao 2021's table 1 layout
            rows[cells[1]] = cells
    assert {"ACO", "PF-ACO", "APF-ACO", "APF alone"} <= set(rows)
    import jaco

    grid = jaco.maps.named("simple-20")
    exact, _ = jaco.exact.shortest_path(grid, grid.meta["start"], grid.meta["goal"])
    (r0, c0), (r1, c1) = grid.meta["start"], grid.meta["goal"]
    sg = ((r1 - r0) ** 2 + (c1 - c0) ** 2) ** 0.5  # straight start-goal distance (cell centres)
    for c in rows.values():
        optimum = float(c[5])
        assert abs(optimum - exact) < 0.01
        if c[3] != "–":  # best >= optimum, mean >= best, best / L_SG as printed
            best, mean = float(c[3]), float(c[4])
            assert optimum - 1e-6 <= best <= mean + 1e-6
            assert abs(float(c[11]) - best / sg) < 2e-3
        assert 0 < float(c[10]) <= 100  # coverage %
    assert rows["ACO"][2] == "2" and rows["APF alone"][2] == "1"
    # the published numbers sit beside ours, with the paper's own straight distance 20·√2
    pub = next(line for line in text.splitlines() if line.startswith("| simple-20 | APF-ACO | 28.627 |"))
    assert pub.split("|")[4].strip() == f"{28.627 / (20 * 2**0.5):.3f}"
    comp = [line for line in text.splitlines() if line.startswith("| simple-20 | ") and line.count("|") == 14]
    assert {line.split("|")[2].strip() for line in comp} >= {"AS", "IAACO", "chaos ACO"}
    for line in comp:  # turns, heading change and safety are non-negative numbers
        turns, heading, safety = (float(line.split("|")[k]) for k in (7, 8, 9))
        assert turns >= 0 and heading >= 0 and safety >= 0
    pngs = sorted(p.name for p in (tmp_path / "figures").glob("*.png"))
    assert {"paper003_paths_simple-20.png", "paper003_convergence_simple-20.png",
            "paper_compare_paths_simple-20.png", "paper_compare_convergence_simple-20.png"} <= set(pngs)
    assert all((tmp_path / "figures" / p).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" for p in pngs)


def test_report_never_prints_negative_zero_and_smoke_runs_stay_out_of_docs():
    sys.path.insert(0, str(ROOT / "experiments"))
    try:
        import report
    finally:
        sys.path.remove(str(ROOT / "experiments"))
    # a float32 length a hair below the float64 optimum: a gap of -1e-7 prints as zero
    assert report.fixed(100 * -1e-9, 1) == "0.0" and report.fixed(-0.0) == "0.00" and report.fmt(-0.0) == "0"
    assert report.fixed(-0.06, 1) == "-0.1" and report.fixed(None) == "–" and report.fixed(float("inf")) == "–"
    assert "-0.0" not in report.table(["gap"], [[-0.0], [-1e-12]])
    given = report.output_dir(Path("somewhere"), smoke=True)
    assert given == Path("somewhere")
    assert report.output_dir(None, smoke=False) == ROOT / "docs"
    tmp = report.output_dir(None, smoke=True)  # --smoke without --out: a fresh temporary folder
    try:
        assert tmp.is_dir() and not list(tmp.iterdir()) and ROOT not in tmp.parents
    finally:
        tmp.rmdir()


@pytest.mark.slow  # about 30 s of compiling many planners
def test_movingai_suite_smoke(tmp_path):
    """The suite at --smoke size: every run's optimum is its scenario's, no successful run is
    shorter than it, the gap is measured against it, and a second part (--update) adds a planner
    to the same table without dropping the first part's rows."""
    import pandas as pd

    sys.path.insert(0, str(ROOT / "experiments"))
    try:
        import movingai_suite
    finally:
        sys.path.remove(str(ROOT / "experiments"))
    assert movingai_suite.main(["--smoke", "--out", str(tmp_path)]) == 0
    assert movingai_suite.main(["--smoke", "--out", str(tmp_path), "--update", "--no-select", "--planners", "acs"]) == 0
    df = pd.read_csv(tmp_path / "movingai_suite.csv")
    assert {"mmas", "iaca", "acs"} <= set(df.planner) and any(p.startswith("selected") for p in df.planner)
    import jaco

    for m, part in df.groupby("map"):
        scen = jaco.maps.load_scenarios(jaco.maps.bundled(next(
            n for n in jaco.maps.BUNDLED if n.startswith(m) and n.endswith(".scen"))))
        assert set(part.optimal.round(4)) <= {round(s.optimal, 4) for s in scen}
    ok = df[df.success]
    assert (ok.length >= ok.optimal - 1e-4).all()
    assert ((ok.length - ok.optimal) / ok.optimal).round(5).tolist() == ok.gap.round(5).tolist()
    assert df[~df.success].gap.map(lambda g: g == float("inf")).all()
    text = (tmp_path / "results.md").read_text()
    assert "<!-- movingai_suite:start -->" in text and "Fixed budget" in text
    assert (tmp_path / "figures" / "movingai_suite_gap.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # the parts add up to one run: on every map the larger budget holds exactly the best three at
    # the fixed budget, ranked over both parts' rows
    # a selection on other maps sits beside the default one, which it does not replace
    assert movingai_suite.main(["--smoke", "--out", str(tmp_path), "--update", "--planners",
                                "--select-maps", "room-32-32-4.map"]) == 0
    df = pd.read_csv(tmp_path / "movingai_suite.csv")
    assert {p.split(":")[0] for p in df.planner if p.startswith("selected")} == {"selected", "selected on room-32-32-4"}
    # --report rewrites the section from the CSV alone, the table by scenario length included
    (tmp_path / "results.md").write_text("# Results\n")
    assert movingai_suite.main(["--report", "--out", str(tmp_path)]) == 0
    text = (tmp_path / "results.md").read_text()
    assert "by scenario length" in text and "| acs |" in text
    assert pd.read_csv(tmp_path / "movingai_suite.csv").equals(df)
    rows = df.to_dict("records")
    for m, part in df.groupby("map"):
        assert set(part[part.budget == "larger"].planner) == movingai_suite.best_three(rows, m)


@pytest.mark.parametrize("argv, message", [
    (["--select-maps", "nosuch.map"], "unknown MovingAI map 'nosuch.map'"),
    (["--maps", "map.yaml"], "unknown MovingAI map 'map.yaml'"),  # a ROS map: no scenario file
    (["--planners", "iaca", "nosuch"], "unknown planner 'nosuch'"),
    (["--skip", "nosuch"], "unknown planner 'nosuch'"),
])
def test_movingai_suite_refuses_unknown_names_before_running(argv, message, tmp_path, capsys):
    sys.path.insert(0, str(ROOT / "experiments"))
    try:
        import movingai_suite
    finally:
        sys.path.remove(str(ROOT / "experiments"))
    with pytest.raises(SystemExit) as e:
        movingai_suite.main(["--smoke", "--out", str(tmp_path), *argv])
    assert e.value.code == 2 and message in capsys.readouterr().err
    assert not list(tmp_path.iterdir())  # nothing written


@pytest.mark.slow  # compiles one planner four ways and iaca twice
def test_local_search_benchmark_smoke_writes_its_section(tmp_path):
    sys.path.insert(0, str(ROOT / "experiments"))
    try:
        import bench_local_search
    finally:
        sys.path.remove(str(ROOT / "experiments"))
    out = tmp_path / "BENCHMARKS.md"
    assert bench_local_search.main(["--smoke", "--longest", "1", "--out", str(out)]) == 0
    text = out.read_text()
    assert "<!-- bench_local_search:start -->" in text and "Command: `python experiments/bench_local_search.py --smoke" in text
    for heading in ("Which paths to search", "A solve with and without local search", "The default step limit",
                    "Every map's longest scenarios"):
        assert f"### {heading}" in text
    searched = [line.split(" | ")[1] for line in text.splitlines() if line.startswith("| room-32-32-4 | ")][:4]
    assert searched == ["none", "best 1", "best 5", "every ant"]
    assert re.search(r"\*\*The 2 queries, each at its median: [\d.]+ s without, [\d.]+ s with local search: [\d.]+×\.\*\*", text)
    limits = [line.split(" | ")[1] for line in text.splitlines() if line.startswith("| iaca | ")]
    assert limits == ["256 — old default, 4·(H + W)", "512 — new default for backtracking ants"]
