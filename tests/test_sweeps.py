"""Sweeps at scale: designs, chunking under a memory budget, summaries, sharding over devices and
over processes (jax.distributed), each checked against the one-device, one-process table bit for bit."""

import doctest
import json
import math
import os
import socket
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import jaco
from jaco.engine.run import TRACES
from jaco.research import designs
from jaco.research.chunks import fit_chunk
from jaco.research.sweep_setup import config_table
from jaco.research.sweeps import bytes_per_run

ROOT = Path(__file__).resolve().parents[1]
GRID = jaco.maps.random_map(12, 0.2, seed=3)
ENDS = (GRID.meta["start"], GRID.meta["goal"])
TINY = dict(n_ants=8, n_iters=5)
AXES = {"alpha": [0.5, 1.0, 2.0], "beta": [1.0, 3.0]}
SEEDS = [0, 5, 9]


@pytest.fixture(scope="module")
def reference():
    """The one-device, one-chunk table every other way of running the sweep must reproduce."""
    table = jaco.sweep(GRID, *ENDS, "as", params=AXES, seeds=SEEDS, **TINY)
    assert table.attrs["sweep"]["devices"] == 1 and table.attrs["sweep"]["chunks"] == 1
    return table


# -- designs ---------------------------------------------------------------------------------
def test_grid_design_is_the_dict_product_in_the_same_order():
    d = designs.grid(AXES)
    assert len(d) == 6 and d.names == ("alpha", "beta")
    assert d["alpha"].tolist() == [0.5, 0.5, 1.0, 1.0, 2.0, 2.0]
    assert d["beta"].tolist() == [1.0, 3.0] * 3
    assert designs.grid(alpha=[1.0]) == designs.grid({"alpha": 1.0})


def test_random_design_is_seeded_within_ranges_and_log_uniform():
    ranges = {"alpha": (0.5, 4.0), "rho": (0.001, 0.1)}
    a = designs.random(7, 4000, ranges, log=["rho"])
    assert a == designs.random(7, 4000, ranges, log=["rho"])
    assert a != designs.random(8, 4000, ranges, log=["rho"])
    assert a["alpha"].min() >= 0.5 and a["alpha"].max() <= 4.0
    assert a["rho"].min() >= 0.001 and a["rho"].max() <= 0.1
    # log-uniform: each decade [1e-3, 1e-2), [1e-2, 1e-1) holds half the draws (±4 sd of a binomial)
    low = np.mean(a["rho"] < 0.01)
    assert abs(low - 0.5) < 4 * math.sqrt(0.25 / 4000)
    # linear: the lower half of alpha's range holds half
    assert abs(np.mean(a["alpha"] < 2.25) - 0.5) < 4 * math.sqrt(0.25 / 4000)


def test_latin_hypercube_has_one_point_in_every_stratum():
    n = 50
    d = designs.latin_hypercube(3, n, {"beta": (1.0, 9.0), "q": (0.1, 1000.0)}, log=("q",))
    assert len(d) == n and d == designs.latin_hypercube(3, n, {"beta": (1.0, 9.0), "q": (0.1, 1000.0)}, log=("q",))
    beta_strata = np.floor((d["beta"] - 1.0) / 8.0 * n).astype(int)
    q_strata = np.floor((np.log(d["q"]) - np.log(0.1)) / (np.log(1000.0) - np.log(0.1)) * n).astype(int)
    assert sorted(beta_strata) == list(range(n)) and sorted(q_strata) == list(range(n))
    assert not np.array_equal(np.argsort(beta_strata), np.argsort(q_strata))  # paired at random


def test_module_examples_run():
    assert doctest.testmod(designs).failed == 0


def test_product_and_table_designs():
    h = designs.latin_hypercube(0, 3, {"alpha": (1.0, 2.0)})
    p = designs.product(h, designs.grid(rho=[0.1, 0.2]))
    assert len(p) == 6 and p["alpha"].tolist() == np.repeat(h["alpha"], 2).tolist()
    assert p["rho"].tolist() == [0.1, 0.2] * 3
    t = designs.table(p.to_frame())
    assert t == designs.table(p.values)
    with pytest.raises(jaco.ParamError, match="share"):
        designs.product(h, h)


@pytest.mark.parametrize(
    "call,match",
    [
        (lambda: designs.random(0, 5, {"rho": (0.0, 0.5)}), r"'rho' = 0 is out of range \(0, 1\]"),
        (lambda: designs.random(0, 5, {"alpha": (3.0, 1.0)}), "low <= high"),
        (lambda: designs.random(0, 5, {"alpha": (0.0, 1.0)}, log=["alpha"]), "needs low > 0"),
        (lambda: designs.random(0, 5, {"alpha": (1.0, 2.0)}, log=["beta"]), "no range"),
        (lambda: designs.random(0, 5, {"alfa": (1.0, 2.0)}), "unknown parameter 'alfa'"),
        (lambda: designs.random(0, 5, {"alpha": (1.0, math.inf)}), "finite"),
        (lambda: designs.random(0, 0, {"alpha": (1.0, 2.0)}), "n must be a positive integer"),
        (lambda: designs.latin_hypercube(-1, 5, {"alpha": (1.0, 2.0)}), "seed must be a non-negative integer"),
        (lambda: designs.table({"alpha": [1.0, 2.0], "beta": [1.0]}), "one value per configuration"),
        (lambda: designs.grid(beta=[1.0, float("nan")]), "NaN"),
    ],
)
def test_bad_designs_are_param_errors(call, match):
    with pytest.raises(jaco.ParamError, match=match):
        call()


def test_sweep_checks_a_design_against_the_variant_before_compiling():
    before = sum(TRACES.values())
    with pytest.raises(jaco.ParamError, match="unknown parameter 'q0' for planner 'as'"):
        jaco.sweep(GRID, *ENDS, "as", params=designs.grid(q0=[0.5]), seeds=1, **TINY)
    # relations hold row by row: every row of this design has tau_min < tau_max ...
    rows = designs.table({"tau_min": [0.5, 0.01], "tau_max": [1.0, 0.2]})
    values, _ = config_table(jaco.PLANNERS["idaca"], rows)
    assert values["tau_min"].tolist() == [0.5, 0.01]
    # ... and one bad row is named
    bad = designs.table({"tau_min": [0.01, 0.5], "tau_max": [1.0, 0.2]})
    with pytest.raises(jaco.ParamError, match=r"tau_min < tau_max.*configuration 1"):
        jaco.sweep(GRID, *ENDS, "idaca", params=bad, seeds=1, **TINY)
    with pytest.raises(jaco.JacoError, match="seeds must be integers"):
        jaco.sweep(GRID, *ENDS, "as", seeds=[0, -1], **TINY)
    with pytest.raises(jaco.JacoError, match="memory_budget"):
        jaco.sweep(GRID, *ENDS, "as", seeds=1, memory_budget=0, **TINY)
    with pytest.raises(jaco.JacoError, match="devices"):
        jaco.sweep(GRID, *ENDS, "as", seeds=1, devices=5, **TINY)
    assert sum(TRACES.values()) == before


def test_sweep_of_a_design_equals_the_dict_sweep_and_solve(reference):
    table = jaco.sweep(GRID, *ENDS, "as", params=designs.grid(AXES), seeds=SEEDS, **TINY)
    pd.testing.assert_frame_equal(table, reference, check_exact=True)
    assert table.config.tolist() == np.repeat(np.arange(6), 3).tolist()
    # six Latin-hypercube rows × three seeds: the reference's shape, so no new compile
    lhs = designs.latin_hypercube(1, 6, {"alpha": (0.5, 3.0), "rho": (0.05, 0.9)}, log=["rho"])
    got = jaco.sweep(GRID, *ENDS, "as", params=lhs, seeds=SEEDS, **TINY)
    assert got.alpha.tolist() == np.repeat(lhs["alpha"], 3).tolist() and got.rho.tolist() == np.repeat(lhs["rho"], 3).tolist()
    for _, row in got.iloc[::4].iterrows():
        r = jaco.solve(GRID, *ENDS, "as", seed=int(row.seed), alpha=row.alpha, rho=row.rho, **TINY)
        assert row.length == r.length and row.best_iteration == r.best_iteration and row.cost == r.cost


# -- chunking --------------------------------------------------------------------------------
def test_chunks_fit_the_budget_and_match_one_chunk(reference, capsys):
    one = reference.attrs["sweep"]
    budget = int(one["bytes_per_chunk"] // 2)  # half of what the whole batch needs
    table = jaco.sweep(GRID, *ENDS, "as", params=AXES, seeds=SEEDS, memory_budget=budget, progress=True, **TINY)
    pd.testing.assert_frame_equal(table, reference, check_exact=True)
    plan = table.attrs["sweep"]
    assert plan["chunks"] >= 2 and plan["bytes_per_chunk"] <= budget
    assert plan["chunk"] * plan["chunks"] >= len(reference)
    assert "sweep as" in capsys.readouterr().err  # the tqdm bar, one step per chunk
    again = jaco.research.sweeps.plan_sweep(GRID, *ENDS, "as", params=AXES, seeds=SEEDS, memory_budget=budget, **TINY)
    assert again == {**plan, "compiles": 0}  # the same plan, from the cache


def test_a_low_first_guess_is_corrected_by_the_compiled_memory_analysis(reference, monkeypatch):
    budget = int(reference.attrs["sweep"]["bytes_per_chunk"] * 0.6)
    monkeypatch.setattr(jaco.research.chunks, "bytes_per_run", lambda *a, **k: 1)  # "everything fits"
    monkeypatch.setattr(jaco.research.chunks, "_PER_CONFIG", {})
    table = jaco.sweep(GRID, *ENDS, "as", params=AXES, seeds=SEEDS, memory_budget=budget, **TINY)
    pd.testing.assert_frame_equal(table, reference, check_exact=True)
    plan = table.attrs["sweep"]
    assert plan["chunks_tried"][0] == len(reference) and len(plan["chunks_tried"]) >= 2
    assert plan["bytes_per_chunk"] <= budget and plan["chunks"] >= 2


def test_fit_balances_the_chunks():
    assert fit_chunk(budget=1000, fixed=0, per=100.0, rows_per_device=25) == 9  # 3 chunks of 9, not 10+10+5
    assert fit_chunk(budget=10, fixed=0, per=100.0, rows_per_device=25) == 1  # below one configuration: 1
    assert fit_chunk(budget=10**9, fixed=0, per=100.0, rows_per_device=25) == 25


def test_estimate_is_honest_for_single_and_double_colonies(reference):
    """The first guess is within 25 % of XLA's memory analysis for one and two colonies (the old
    one-colony formula was 2× over for one colony and up to 3× under for two)."""
    plans = {"as": reference.attrs["sweep"]}
    plans["daca"] = jaco.research.sweeps.plan_sweep(GRID, *ENDS, "daca", params=AXES, seeds=SEEDS, devices=1, **TINY)
    for name, plan in plans.items():
        ratio = plan["bytes_per_config_estimate"] / plan["bytes_per_config_measured"]
        assert 0.8 <= ratio <= 1.25, (name, plan)
    assert plans["daca"]["bytes_per_config_measured"] > 2.5 * plans["as"]["bytes_per_config_measured"]
    s = jaco.engine.walk.pad_steps(256)
    assert bytes_per_run(1024, 50, 100, 256, path_len=2 * s) > 3 * bytes_per_run(1024, 50, 100, 256)


# -- summary ---------------------------------------------------------------------------------
def test_summarize_by_hand():
    inf = math.inf
    table = pd.DataFrame(
        {
            "config": [0, 0, 0, 1, 1, 2, 2],
            "alpha": [1.0, 1.0, 1.0, 2.0, 2.0, 3.0, 3.0],
            "seed": [0, 1, 2, 0, 1, 0, 1],
            "success": [True, True, False, True, True, False, False],
            "length": [10.0, 12.0, inf, 9.0, 9.0, inf, inf],
            "cost": [10.0, 12.0, inf, 9.0, 9.0, inf, inf],
            "best_iteration": [3, 4, -1, 1, 2, -1, -1],
            "optimal": [9.0] * 7,
            "gap": [1 / 9, 3 / 9, inf, 0.0, 0.0, inf, inf],
            "coverage": [0.5] * 7,
        }
    )
    s = jaco.summarize(table)
    assert s.config.tolist() == [0, 1, 2] and s.alpha.tolist() == [1.0, 2.0, 3.0]
    # over the successful runs; a configuration that failed on every seed has no figures (NaN), never inf
    assert s.length_mean.tolist()[:2] == [11.0, 9.0] and s.length_min.tolist()[:2] == [10.0, 9.0]
    assert s.length_std[0] == pytest.approx(math.sqrt(2.0)) and s.length_std[1] == 0.0
    assert s.success_rate.tolist() == pytest.approx([2 / 3, 1.0, 0.0])
    assert s.gap_mean.tolist()[:2] == pytest.approx([2 / 9, 0.0]) and s.gap_min.tolist()[:2] == pytest.approx([1 / 9, 0.0])
    # quartiles over the successful runs (numpy's linear interpolation): 10, 12 -> 10.5, 11, 11.5
    assert (s.length_q1[0], s.length_median[0], s.length_q3[0]) == (10.5, 11.0, 11.5)
    assert s.gap_median[0] == pytest.approx(np.median([1 / 9, 3 / 9])) and s.gap_q3[1] == 0.0
    failed = s.iloc[2][["length_mean", "length_std", "length_min", "length_median", "length_q1", "length_q3",
                        "gap_mean", "gap_min", "gap_median", "gap_q1", "gap_q3"]]
    assert failed.isna().all()
    assert not np.isinf(s.select_dtypes("number").to_numpy()).any()
    assert s.runs.tolist() == [3, 2, 2]
    with pytest.raises(jaco.JacoError, match="no column 'beta'"):
        jaco.summarize(table, by=["beta"])


def test_summarize_over_several_planners_keeps_each_planners_own_parameters():
    table = jaco.sweep(GRID, *ENDS, ["as", "acs", "mmas"], params={"beta": [1.0, 3.0]}, seeds=2, **TINY)
    assert table[["q0", "p_best"]].isna().any().all()  # the tidy table: NaN where a planner lacks one
    s = jaco.summarize(table)
    assert len(s) == 6 and not s.drop(columns=["length_std"]).isna().any().any()
    shared = {"alpha", "beta", "rho", "q"}  # every planner here has them: they stay columns
    assert shared <= set(s.columns) and not {"q0", "xi", "tau0", "p_best"} & set(s.columns)
    params = dict(zip(s.planner, s.params))
    assert params == {"as": "tau0=0.1", "acs": "tau0=0.01, q0=0.8, xi=0.1", "mmas": "p_best=0.05"}
    one = jaco.summarize(table[table.planner == "acs"])  # one planner: every parameter a column
    assert "params" not in one and {"q0", "xi", "tau0"} <= set(one.columns)


def test_queries_are_integer_columns_that_survive_a_csv_round_trip(tmp_path):
    from jaco.research import tables

    other = jaco.maps.random_map(12, 0.2, seed=4)
    table = jaco.sweep([GRID, other], *ENDS, "as", params={"alpha": [0.7]}, seeds=2, **TINY)
    assert list(table.columns[:7]) == ["planner", "map", "start_row", "start_col", "goal_row", "goal_col", "config"]
    assert table.start_row.dtype == np.int64 and (table.goal_row == ENDS[1][0]).all()
    path = tables.write_csv(table, tmp_path / "t.csv")
    text = path.read_text()
    for x in table["length"]:  # the shortest decimal of the float32 (54.970562), never float64 noise
        assert f",{str(np.float32(x))}," in text
    assert all(len(cell.replace("-", "").replace(".", "").lstrip("0")) <= 9 for line in text.splitlines()[1:]
               for cell in line.split(",")[2:])  # float32 needs at most 9 significant digits
    assert "0.7," in text and "0.699999988079071" not in text  # alpha: a float64 0.7 is written as the float32 it ran as
    back = tables.read_table(path)
    assert list(back.columns) == list(table.columns) and back.start_col.dtype.kind == "i"
    for col in ("length", "cost", "optimal", "gap", "coverage", "alpha"):
        assert back[col].to_numpy(np.float32).tobytes() == table[col].to_numpy(np.float32).tobytes(), col
    assert tables.differences(back, table) == []


def test_a_one_planner_table_names_its_planner_and_compares(tmp_path):
    """Every table names its planner, one planner too: the CSV says what produced it, and
    jaco.compare reads it back by planner and the swept columns."""
    from jaco.research import tables

    table = jaco.sweep(GRID, *ENDS, "acs", params={"beta": [1.0, 3.0]}, seeds=3, **TINY)
    assert table.columns[0] == "planner" and set(table["planner"]) == {"acs"}
    path = tables.write_csv(table, tmp_path / "one.csv")
    assert path.read_text().startswith("planner,config,") and "\nacs,0," in path.read_text()
    back = tables.read_table(path)
    c = jaco.compare(back, by=["planner", "beta"], n_boot=20)
    assert set(c.summary["configuration"]) == {"acs, beta=1", "acs, beta=3"}
    assert c.text.startswith("2 configurations (planner, beta) compared on gap")
    with pytest.raises(jaco.JacoError, match=r"column 'beta' varies .*by=\['planner', 'beta'\]"):
        jaco.compare(back)  # the default, by planner: the hint names the swept column
    # a table of an older jaco names its planner "variant": it is read as "planner"
    old = tmp_path / "old.csv"
    old.write_text(path.read_text().replace("planner,", "variant,", 1))
    assert list(tables.read_table(old).columns) == list(back.columns)


def test_summarize_a_real_sweep_per_query():
    other = jaco.maps.random_map(12, 0.2, seed=4)
    table = jaco.sweep([GRID, other], *ENDS, "as", params={"beta": [1.0, 3.0]}, seeds=3, **TINY)
    s = jaco.summarize(table)
    assert len(s) == 4 and (s.runs == 3).all() and set(s["map"]) == {GRID.name, other.name}
    part = table[(table["map"] == other.name) & (table.beta == 3.0)]
    row = s[(s["map"] == other.name) & (s.beta == 3.0)].iloc[0]
    assert row.success_rate == part.success.mean() and row.gap_min == part.gap.min()


# -- sharding over devices and processes (subprocesses, tiny sizes) ---------------------------
WORKER = textwrap.dedent(
    """
    import sys
    import jax, pandas as pd, jaco
    mode, out = sys.argv[1], sys.argv[2]
    if mode == "process":
        pid, port = int(sys.argv[3]), sys.argv[4]
        jax.distributed.initialize(f"127.0.0.1:{port}", num_processes=2, process_id=pid, initialization_timeout=120)
    g = jaco.maps.random_map(12, 0.2, seed=3)
    kw = dict(params={"alpha": [0.5, 1.0, 2.0], "beta": [1.0, 3.0]}, seeds=[0, 5, 9], n_ants=8, n_iters=5)
    tables = {}
    if mode == "devices":  # 2 devices: all of them, and one configuration per device and chunk
        if jax.device_count() == 2:
            tables[2] = jaco.sweep(g, g.meta["start"], g.meta["goal"], "as", **kw)
            tables["chunked"] = jaco.sweep(g, g.meta["start"], g.meta["goal"], "as", memory_budget=1, **kw)
        else:  # 4 devices: all of them (18 runs padded to 5 per device), and 3
            tables[4] = jaco.sweep(g, g.meta["start"], g.meta["goal"], "as", **kw)
            tables[3] = jaco.sweep(g, g.meta["start"], g.meta["goal"], "as", devices=3, **kw)
    else:
        tables["all"] = jaco.sweep(g, g.meta["start"], g.meta["goal"], "as", memory_budget=1, **kw)
    pd.to_pickle({k: (t, t.attrs["sweep"]) for k, t in tables.items()}, out)
    """
)


def _worker(tmp_path):
    path = tmp_path / "worker.py"
    path.write_text(WORKER)
    return path


def _env(**extra):
    env = {k: v for k, v in os.environ.items() if k not in ("XLA_FLAGS",)}
    env.update(JAX_PLATFORMS="cpu", **extra)  # the installed jaco (the checkout has no kernel after `pip install .`)
    return env


@pytest.mark.parametrize("count", [2, pytest.param(4, marks=pytest.mark.slow)])
def test_sharded_over_devices_equals_one_device(reference, tmp_path, count):
    out = tmp_path / "tables.pkl"
    env = _env(XLA_FLAGS=f"--xla_force_host_platform_device_count={count}")
    r = subprocess.run([sys.executable, str(_worker(tmp_path)), "devices", str(out)], env=env,
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr[-3000:]
    tables = pd.read_pickle(out)
    assert set(tables) == ({4, 3} if count == 4 else {2, "chunked"})
    if count == 4:
        assert tables[4][1]["chunk"] == 20  # 18 runs, padded to a multiple of 4 devices
    for key, (table, plan) in tables.items():
        pd.testing.assert_frame_equal(table, reference, check_exact=True)
        assert plan["devices"] == (count if key == "chunked" else key)
        assert plan["chunk"] % plan["devices"] == 0  # padded to a multiple of the devices
    if count == 2:
        assert tables["chunked"][1]["chunks"] == len(reference) // 2 == 9


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.mark.slow  # two processes joined by jax.distributed
def test_two_processes_with_jax_distributed_equal_one_process(reference, tmp_path):
    worker, port = _worker(tmp_path), _free_port()
    outs = [tmp_path / f"tables{i}.pkl" for i in range(2)]
    procs = [
        subprocess.Popen([sys.executable, str(worker), "process", str(outs[i]), str(i), str(port)], env=_env(),
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        for i in range(2)
    ]
    try:
        results = [p.communicate(timeout=300) for p in procs]
    finally:
        for p in procs:
            if p.poll() is None:
                p.kill()
    for p, (_, err) in zip(procs, results):
        assert p.returncode == 0, err[-3000:]
    for out in outs:  # every process gets the whole table
        table, plan = pd.read_pickle(out)["all"]
        pd.testing.assert_frame_equal(table, reference, check_exact=True)
        assert plan["processes"] == 2 and plan["devices"] == 2 and plan["chunks"] == 9


# -- 10,000 configurations under a budget (the benchmark script at --smoke size) ---------------
@pytest.mark.slow
def test_ten_thousand_configurations_stay_within_the_budget(tmp_path):
    out = tmp_path / "bench.json"
    r = subprocess.run([sys.executable, str(ROOT / "experiments" / "bench_sweep.py"), "--smoke", "--json", str(out)],
                       env=_env(), capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr[-3000:]
    R = json.loads(out.read_text())
    scale = R["scale"][0]
    plan = scale["plan"]
    assert scale["rows"] == plan["configurations"] == 10_000
    assert plan["chunks"] >= 4 and plan["bytes_per_chunk"] <= plan["memory_budget"]
    # One chunk for all 10,000 would need about chunks × the budget; the process grew by far less.
    unchunked = plan["bytes_per_config_measured"] * plan["configurations"]
    assert unchunked > 4 * plan["memory_budget"]
    assert scale["rss_growth_mib"] * 2**20 < unchunked / 2
    assert scale["rss_peak_mib"] < 8 * 1024


def test_sweep_progress_bar_says_compiling_then_counts_and_changes_nothing(capsys):
    kw = dict(params={"beta": [1.0, 2.0]}, seeds=2, n_ants=8, n_iters=6)  # a shape of its own: compiles
    shown = jaco.sweep(GRID, *ENDS, "as", progress=True, **kw)
    err = capsys.readouterr().err
    assert "sweep as: compiling…" in err and "4/4" in err  # compiling, then the 4 runs of its one chunk
    plain = jaco.sweep(GRID, *ENDS, "as", progress=False, **kw)
    assert capsys.readouterr().err == ""
    pd.testing.assert_frame_equal(shown, plain)
    assert plain.attrs["sweep"]["compiles"] == 0  # the bar is no part of the program
    chunked = jaco.sweep(GRID, *ENDS, "as", progress=True, memory_budget=1, **kw)  # one configuration per chunk
    err = capsys.readouterr().err
    assert chunked.attrs["sweep"]["chunks"] == 4 and "4/4" in err
    pd.testing.assert_frame_equal(chunked, plain)


@pytest.mark.parametrize("walk", ["native", "jax"])
def test_the_bar_moves_inside_one_chunk(walk, monkeypatch):
    """A chunk's progress reaches its bar while it runs: a sweep of one chunk counts its runs up.
    The native walk's runs make no callback (the waiting thread reads the kernel's count of
    finished iterations every ``POLL`` seconds, shortened here); the JAX walk's runs report by callback."""
    if walk == "native" and jaco.engine.native.active_walk() != "native":
        pytest.skip("the native walk is not built here")
    monkeypatch.setattr(jaco.progress, "POLL", 0.0005)
    kw = dict(params={"beta": [1.0, 2.0, 3.0, 4.0]}, seeds=10, n_ants=8, n_iters=30)  # 40 runs, one chunk
    if walk == "native":
        kw["n_iters"] = 3000  # long enough for the polls to see it move
    seen = []
    real = jaco.progress.Bar.update
    monkeypatch.setattr(jaco.progress.Bar, "update", lambda self, done: (seen.append(int(done)), real(self, done)))
    jaco.set_walk(walk)
    try:
        table = jaco.sweep(GRID, *ENDS, "as", progress=True, **kw)
    finally:
        jaco.set_walk(None)
    assert table.attrs["sweep"]["chunks"] == 1
    inside = sorted({d for d in seen if 0 < d < 40})
    assert len(inside) >= 10 and seen == sorted(seen) and seen[-1] == 40  # iteration by iteration, never back
