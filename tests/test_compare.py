"""jaco.research.compare: the statistics against scipy and hand-computed answers on small tables,
how failed runs and ties are counted, the words, the plots and the `jaco compare` command."""

import math
import re
import warnings

import matplotlib

matplotlib.use("Agg")

import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
import pytest  # noqa: E402
from hypothesis import HealthCheck, example, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402
from scipy import stats  # noqa: E402

import jaco  # noqa: E402
from jaco.cli import main  # noqa: E402
from jaco.research import compare as cmp  # noqa: E402
from jaco.research.tables import csv_text  # noqa: E402

INF = math.inf
# Three planners on one query over 8 seeds; A is better than B on every seed, C fails twice.
A = [0.10, 0.12, 0.08, 0.11, 0.09, 0.13, 0.07, 0.14]
B = [0.15, 0.14, 0.20, 0.12, 0.16, 0.31, 0.18, 0.17]
C = [0.30, INF, 0.12, INF, 0.40, 0.25, 0.22, 0.35]
COMPOSED = "compose(construct=backtrack, heuristic=chaos, rule=iaca, transition=q0, schedule=constant, cost=length)"


def table_of(columns: dict, optimal=100.0) -> pd.DataFrame:
    rows = []
    for name, gaps in columns.items():
        for seed, g in enumerate(gaps):
            rows.append(
                dict(
                    planner=name, seed=seed, success=math.isfinite(g), gap=g, optimal=optimal, length=optimal * (1 + g)
                )
            )
    return pd.DataFrame(rows)


@pytest.fixture(scope="module")
def three():
    return cmp.compare(table_of({"A": A, "B": B, "C": C}), n_boot=500, seed=3)


def test_quantiles_equal_numpy_and_allow_inf():
    rng = np.random.default_rng(0)
    x = rng.normal(size=(7, 9))
    for q in (0.0, 0.25, 0.5, 0.9, 1.0):
        np.testing.assert_allclose(cmp.quantile(x, q, axis=1), np.quantile(x, q, axis=1), rtol=0, atol=1e-12)
    assert cmp.quantile([1.0, 2.0, INF, INF], 0.5) == INF  # half failed: the mean of 2 and inf
    assert cmp.quantile([1.0, 2.0, INF, INF], 0.25) == pytest.approx(1.75)
    assert cmp.quantile([1.0, INF], 0.0) == 1.0 and cmp.quantile([INF, INF], 0.75) == INF  # never NaN


def test_holm_by_hand():
    # sorted 0.005, 0.01, 0.03, 0.04 -> 4*0.005, 3*0.01, 2*0.03, max(1*0.04, 0.06)
    np.testing.assert_allclose(cmp.holm([0.01, 0.04, 0.03, 0.005]), [0.03, 0.06, 0.06, 0.02])
    np.testing.assert_allclose(cmp.holm([0.5, 0.9]), [1.0, 1.0])


def test_critical_difference_matches_demsar_table_and_example():
    # Demšar (2006), table 5(a): q_0.05 for k = 2..10 (Nemenyi)
    table = [1.960, 2.343, 2.569, 2.728, 2.850, 2.949, 3.031, 3.102, 3.164]
    for k, q in zip(range(2, 11), table):
        assert cmp.critical_difference(k, 1) / math.sqrt(k * (k + 1) / 6) == pytest.approx(q, abs=1.5e-3)
    assert cmp.critical_difference(4, 14) == pytest.approx(1.25, abs=0.005)  # Demšar's worked example


def test_per_configuration_statistics(three):
    s = three.summary.set_index("configuration")
    for name, v in (("A", A), ("B", B)):
        assert s.loc[name, "gap_median"] == pytest.approx(np.median(v))
        assert s.loc[name, "gap_q1"] == pytest.approx(np.quantile(v, 0.25))
        assert s.loc[name, "gap_q3"] == pytest.approx(np.quantile(v, 0.75))
        assert s.loc[name, "success_rate"] == 1.0 and s.loc[name, "runs"] == 8
    # C: failures count as +inf: the median of (0.12, 0.22, 0.25, 0.30, 0.35, 0.40, inf, inf) is 0.325
    assert s.loc["C", "gap_median"] == pytest.approx(0.325) and s.loc["C", "gap_q3"] == INF
    assert s.loc["C", "success_rate"] == pytest.approx(6 / 8)
    assert s.loc["A", "gap_median_low"] <= s.loc["A", "gap_median"] <= s.loc["A", "gap_median_high"]
    assert list(three.summary["configuration"]) == ["A", "B", "C"]  # by mean rank


def test_bootstrap_is_seeded_and_agrees_with_scipy():
    x = np.array(A + B)
    rng = lambda s: np.random.default_rng(s)  # noqa: E731
    one = cmp.bootstrap_median(x, n_boot=4000, confidence=0.9, rng=rng(7))
    assert one == cmp.bootstrap_median(x, n_boot=4000, confidence=0.9, rng=rng(7))
    ref = stats.bootstrap(
        (x,), np.median, n_resamples=4000, confidence_level=0.9, method="percentile", rng=np.random.default_rng(1)
    ).confidence_interval
    spacing = np.diff(np.sort(x)).max()  # medians take few values: agree to one step of the data
    assert one[0] == pytest.approx(ref.low, abs=spacing) and one[1] == pytest.approx(ref.high, abs=spacing)
    assert cmp.bootstrap_median([0.2] * 5, n_boot=50, confidence=0.95, rng=rng(0)) == (0.2, 0.2)
    assert cmp.bootstrap_median([INF] * 4, n_boot=50, confidence=0.95, rng=rng(0)) == (INF, INF)


def test_paired_wilcoxon_equals_scipy_with_holm(three):
    pw = three.pairwise.set_index(["a", "b"])
    ab = pw.loc[("A", "B")]
    ref = stats.wilcoxon(np.subtract(A, B), zero_method="zsplit")
    assert ab["p"] == pytest.approx(ref.pvalue) and ab["statistic"] == pytest.approx(ref.statistic)
    assert ab["p"] == pytest.approx(2 / 256)  # exact: all 8 differences negative, distinct
    assert (ab["a_better"], ab["b_better"], ab["ties"], ab["pairs"]) == (8, 0, 0, 8)
    np.testing.assert_allclose(three.pairwise["p_holm"], cmp.holm(three.pairwise["p"]))
    # one failure against a path: one magnitude above every finite difference, failures tied
    bc = pw.loc[("B", "C")]
    d = np.subtract(B, C)
    d[np.isinf(d)] = -(np.abs(d[np.isfinite(d)]).max() + 1.0)
    assert bc["p"] == pytest.approx(stats.wilcoxon(d, zero_method="zsplit").pvalue)
    assert (bc["a_better"], bc["b_better"]) == (6, 2)


def test_failed_runs_tie_with_each_other():
    d = cmp.signed_differences([INF, INF, 1.0, 2.0], [INF, 1.0, INF, 1.5])
    np.testing.assert_array_equal(d, [0.0, 1.5, -1.5, 0.5])  # both failed: a tie; one: above 0.5
    t = cmp.compare(table_of({"X": [INF] * 4, "Y": [INF] * 4, "Z": [0.1, 0.2, 0.3, 0.4]}), n_boot=20)
    xy = (
        t.pairwise.set_index(["a", "b"]).loc[("X", "Y")]
        if ("X", "Y") in set(zip(t.pairwise.a, t.pairwise.b))
        else t.pairwise.set_index(["a", "b"]).loc[("Y", "X")]
    )
    assert xy["ties"] == 4 and xy["p"] == 1.0 and not xy["significant"]
    assert "cannot be told apart: they tie on all 4 pairs" in t.text
    assert "No path in any run: X; Y." in t.text or "No path in any run: Y; X." in t.text


def test_friedman_and_mean_ranks_equal_scipy(three):
    data = np.array([A, B, C]).T
    stand_in = np.where(np.isinf(data), 99.0, data)  # any number above every path ranks the same
    ref = stats.friedmanchisquare(*stand_in.T)
    f = three.friedman
    assert f["statistic"] == pytest.approx(ref.statistic) and f["pvalue"] == pytest.approx(ref.pvalue)
    ranks = stats.rankdata(stand_in, axis=1).mean(axis=0)
    np.testing.assert_allclose(three.ranks[["A", "B", "C"]], ranks)
    assert (f["k"], f["n"]) == (3, 8) and f["cd"] == pytest.approx(cmp.critical_difference(3, 8))
    two = cmp.compare(table_of({"A": A, "B": B}), n_boot=20)
    assert two.friedman["pvalue"] is None  # Friedman needs three configurations


def test_words_say_what_the_data_support(three):
    text = three.text
    assert "Best mean rank: A (median gap 10.5%" in text
    # all 8 differences favour A: A's signed ranks are 1 + ... + 8 = 36, B's none
    assert (
        f"A is better than B: signed ranks favour A 36 to 0; A better on 8 of 8 pairs, B on 0, 0 ties; "
        f"p = {3 * 2 / 256:.2g} after Holm"
    ) in text
    assert "Friedman test over 8 blocks" in text and "the configurations differ" in text
    same = cmp.compare(table_of({"P": [0.1, 0.3, 0.2, 0.5], "Q": [0.2, 0.1, 0.3, 0.4]}), n_boot=20)
    assert "P and Q cannot be told apart (p = " in same.text


def test_blocks_by_query_take_the_median_over_seeds():
    rows = []
    for q, (ga, gb) in enumerate([(0.1, 0.2), (0.3, 0.2), (0.05, 0.5)]):
        for name, g in (("A", ga), ("B", gb)):
            for seed in range(3):
                rows.append(
                    dict(
                        planner=name,
                        map="m",
                        start_row=q,
                        start_col=0,
                        goal_row=5,
                        goal_col=5,
                        seed=seed,
                        gap=g + 0.01 * seed,
                        length=100 * (1 + g + 0.01 * seed),
                    )
                )
    t = cmp.compare(pd.DataFrame(rows), blocks="query", n_boot=20)
    assert t.friedman["n"] == 3 and list(t.ranks.index) == ["A", "B"]
    assert t.ranks["A"] == pytest.approx((1 + 2 + 1) / 3)
    assert t.pairwise.iloc[0]["pairs"] == 9  # the paired tests stay per (query, seed)


def test_performance_profile_by_hand():
    t = cmp.compare(table_of({"A": [0.0, 0.2], "B": [0.1, 0.2], "C": [INF, 1.4]}, optimal=10.0), n_boot=20)
    np.testing.assert_allclose(t.ratios["A"], [1.0, 1.0])
    np.testing.assert_allclose(t.ratios["B"], [1.1, 1.0])
    assert np.isinf(t.ratios["C"].iloc[0]) and t.ratios["C"].iloc[1] == pytest.approx(2.0)
    prof = t.profile([1.0, 1.1, 2.0])
    np.testing.assert_allclose(prof.loc[1.0], [1.0, 0.5, 0.0])
    np.testing.assert_allclose(prof.loc[1.1], [1.0, 1.0, 0.0])
    np.testing.assert_allclose(prof.loc[2.0], [1.0, 1.0, 0.5])


def test_configurations_of_several_columns_and_short_names():
    t = table_of({"iaca": A, COMPOSED: B})
    t = pd.concat([t.assign(beta=8.0), t.assign(beta=16.0, gap=t.gap + 0.01)], ignore_index=True)
    with pytest.raises(jaco.JacoError, match=r"column 'beta' varies .*by=\['planner', 'beta'\]"):
        cmp.compare(t)
    c = cmp.compare(t, by=["planner", "beta"], n_boot=20)
    assert set(c.summary["configuration"]) == {
        "iaca, beta=8",
        "iaca, beta=16",
        "backtrack/chaos/iaca, beta=8",
        "backtrack/chaos/iaca, beta=16",
    }


@pytest.mark.parametrize(
    "kw, match",
    [
        (dict(value="planner"), "must be a column of numbers"),
        (dict(by="nope"), "no column 'nope'"),
        (dict(blocks="map"), "blocks must be"),
        (dict(alpha=1.5), "alpha must be"),
        (dict(n_boot=0), "n_boot"),
        (dict(pairing=["query"]), "pairing column 'query'"),
        (dict(pairing="planner"), "pairing column 'planner'"),
    ],
)
def test_bad_calls_are_one_line(kw, match):
    with pytest.raises(jaco.JacoError, match=match) as e:
        cmp.compare(table_of({"A": A, "B": B}), **kw)
    assert "\n" not in str(e.value)


def test_pairing_by_a_query_number():
    """A table that numbers its queries (no start/goal columns) pairs by the columns it names:
    two queries × 8 seeds are 16 pairs, as many as the same runs with their query's cells."""
    t = table_of({"A": A + B, "B": B + C}).assign(query=lambda d: d.index % 16 // 8, seed=lambda d: d.index % 8)
    with pytest.raises(jaco.JacoError, match="rows share a configuration and pair") as e:
        cmp.compare(t)  # paired by seed alone, each seed is two runs
    # the fix is the pairing, not by
    assert "column 'query' names the query" in str(e.value) and "pairing=['query', 'seed']" in str(e.value)
    assert "add it to by" not in str(e.value)
    by_number = cmp.compare(t, pairing=["query", "seed"], n_boot=20)
    by_cells = cmp.compare(
        t.assign(map="m", start_row=0, start_col=0, goal_row=1, goal_col=t["query"]).drop(columns="query"), n_boot=20
    )
    row = by_number.pairwise.iloc[0]
    assert row.pairs == 16 and (row.a, row.a_better, row.b_better) == ("A", 14, 2)  # C beats B on seeds 2 and 5
    pd.testing.assert_frame_equal(by_number.pairwise, by_cells.pairwise)
    d = np.subtract(A + B, B + C)
    d[np.isinf(d)] = -(np.abs(d[np.isfinite(d)]).max() + 1)  # a failure: one magnitude above every finite difference
    assert row.p == pytest.approx(stats.wilcoxon(d, zero_method="zsplit").pvalue)


def test_plots_of_a_comparison(three, tmp_path):
    fig = jaco.plot.plot_critical_difference(three)
    ax = fig.axes[0]
    texts = [t.get_text() for t in ax.texts]
    for name in ("A", "B", "C"):
        assert f"{name} ({three.ranks[name]:.2f})" in texts
    assert f"CD = {three.friedman['cd']:.2f}" in texts
    ranks = three.ranks.to_numpy()
    bars = [line for line in ax.lines if line.get_linewidth() > 3]
    assert len(bars) == len(jaco.plot.compare.cliques(ranks, three.friedman["cd"]))
    jaco.plot.save(fig, tmp_path / "cd.png")
    prof = jaco.plot.plot_performance_profile(three)
    assert [t.get_text() for t in prof.axes[0].get_legend().get_texts()] == ["A", "B", "C"]
    jaco.plot.save(prof, tmp_path / "profile.png")
    with pytest.raises(jaco.JacoError, match="Comparison"):
        jaco.plot.plot_critical_difference(three.summary)


def test_cliques_by_hand():
    assert jaco.plot.compare.cliques(np.array([1.0, 1.5, 2.2, 4.0]), 1.0) == [(0, 1), (1, 2)]
    assert jaco.plot.compare.cliques(np.array([1.0, 1.5, 2.2, 4.0]), 1.3) == [(0, 2)]
    assert jaco.plot.compare.cliques(np.array([1.0, 3.0]), 1.0) == []


def test_cli_compare_on_a_saved_table_old_and_new_layout(tmp_path, capsys):
    t = table_of({"A": A, "B": B, "C": C}).assign(map="m", start_row=1, start_col=2, goal_row=3, goal_col=4)
    new = tmp_path / "new.csv"
    new.write_text(csv_text(t))
    old = tmp_path / "old.csv"  # the layout of older jaco: "variant", start and goal as "(row, col)" text
    t.drop(columns=["start_row", "start_col", "goal_row", "goal_col"]).assign(start="(1, 2)", goal="(3, 4)").rename(
        columns={"planner": "variant"}
    ).to_csv(old, index=False)
    assert old.read_text().startswith("variant,")
    outputs = []
    for path in (new, old):
        code = main(
            [
                "compare",
                str(path),
                "--boot",
                "300",
                "--cd",
                str(tmp_path / "cd.png"),
                "--profile",
                str(tmp_path / "p.svg"),
            ]
        )
        out, err = capsys.readouterr()
        assert code == 0, err
        outputs.append(out.split("\n", 1)[1])
    assert outputs[0] == outputs[1]
    assert "A is better than B: signed ranks favour A 36 to 0; A better on 8 of 8 pairs" in outputs[0]
    assert "Wilcoxon" in outputs[0]
    assert (tmp_path / "cd.png").read_bytes()[:4] == b"\x89PNG" and (tmp_path / "p.svg").read_text().startswith("<?xml")
    code = main(["compare", str(new), "--where", "planner=A", "--boot", "10"])
    assert code == 2 and "one configuration" in capsys.readouterr().err
    # the former word still works on either table: --by variant and --where variant=... are the planner
    for path in (new, old):
        assert main(["compare", str(path), "--by", "variant", "--where", "variant=A", "--boot", "10"]) == 2
        assert "one configuration of ['planner']" in capsys.readouterr().err
        assert main(["compare", str(path), "--by", "variant", "--boot", "300"]) == 0
        assert outputs[0].startswith(capsys.readouterr().out.split("\n", 1)[1])  # the same, less the figures
    code = main(["compare", str(tmp_path / "missing.csv")])
    assert code == 2 and "not found" in capsys.readouterr().err


def test_an_old_table_with_a_variant_column_still_compares():
    """Tables written before planners had one name call the planner column ``variant``: it is read as
    ``planner``; ``by="variant"`` is ``by="planner"`` (a DeprecationWarning), on either table."""
    new = table_of({"A": A, "B": B, "C": C})
    old = new.rename(columns={"planner": "variant"})
    expected = cmp.compare(new, n_boot=50)
    for table in (old, new):
        with warnings.catch_warnings():
            warnings.simplefilter("error", DeprecationWarning)
            if table is old:
                c = cmp.compare(table, n_boot=50)  # the default: the planner column, by its new name
                assert c.by == ["planner"] and c.text == expected.text
        with pytest.warns(DeprecationWarning, match="'variant' is the former name of the planner column"):
            c = cmp.compare(table, by="variant", n_boot=50)
        assert c.by == ["planner"] and c.text == expected.text
    assert expected.text.startswith("3 configurations (planner) compared on gap")
    with pytest.warns(DeprecationWarning):
        s = jaco.summarize(new.assign(length=new.length, cost=new.length, best_iteration=1, coverage=0.5), by="variant")
    assert list(s["planner"]) == ["A", "B", "C"]


def test_every_varying_column_is_named_at_once():
    """A table over β and ρ compared by planner names both columns in one hint, and the hint's
    by runs as given."""
    base = table_of({"A": A, "B": B})
    t = pd.concat(
        [base.assign(beta=b, rho=r, config=i, gap=base.gap + 0.01 * i) for i, (b, r) in
         enumerate([(2.0, 0.1), (2.0, 0.3), (6.0, 0.1), (6.0, 0.3)])],
        ignore_index=True,
    )
    with pytest.raises(cmp.ByError, match=r"columns 'beta', 'rho' vary .*by=\['planner', 'beta', 'rho'\]") as e:
        cmp.compare(t)
    assert e.value.by == ["planner", "beta", "rho"] and "\n" not in str(e.value)
    c = cmp.compare(t, by=e.value.by, n_boot=20)
    assert len(c.summary) == 8 and "A, beta=2, rho=0.1" in set(c.summary["configuration"])
    # a setting changing inside a configuration (not a pair): every such column in one hint too
    t = table_of({"A": A, "B": B}).assign(beta=8.0, rho=0.1)
    t.loc[(t.planner == "A") & (t.seed == 0), ["beta", "rho"]] = [16.0, 0.5]
    with pytest.raises(cmp.ByError, match=r"column 'beta' changes .*; so do 'rho': add them to by") as e:
        cmp.compare(t)
    assert e.value.by == ["planner", "beta", "rho"]


def test_a_table_without_seed_says_that_seed_is_missing():
    t = table_of({"A": A, "B": B}).drop(columns="seed").assign(map="m", start_row=0, start_col=0, goal_row=1, goal_col=1)
    with pytest.raises(jaco.JacoError, match=r"the table has no 'seed' column, so the repeated runs") as e:
        cmp.compare(t)
    assert "repeats runs" not in str(e.value) and "\n" not in str(e.value)
    with pytest.raises(jaco.JacoError, match=r"the table repeats runs"):  # a seed column, the same run twice
        cmp.compare(pd.concat([table_of({"A": A, "B": B})] * 2, ignore_index=True))


def test_short_names_and_percent():
    from jaco.research.tables import percent, short_name

    assert short_name(COMPOSED) == "backtrack/chaos/iaca"
    assert (
        short_name(
            "compose(construct=dying, heuristic=iaaco, rule=mmas, transition=roulette, schedule=constant, cost=multi)"
        )
        == "dying/iaaco/mmas+cost=multi"
    )
    assert (
        short_name(
            "compose(construct=dying, heuristic=distance, rule=acs, transition=roulette, schedule=constant, "
            "cost=length)"
        )
        == "dying/distance/acs+transition=roulette"
    )  # acs's own is q0
    assert short_name("mmas") == "mmas"
    assert (
        short_name(jaco.compose(construct="backtrack", heuristic="chaos", rule="iaca").name) == "backtrack/chaos/iaca"
    )
    assert (percent(0.1793), percent(INF), percent(float("nan")), percent(-1e-9, 2)) == (
        "17.9%",
        "failed",
        "-",
        "0.00%",
    )


# -- the side named better is the side the signed ranks favour ----------------------------------
# A wins 21 pairs by a hair, B wins 19 by far: the signed-rank test favours B
HAIR_A = np.full(40, 0.10)
FAR_B = np.r_[0.101 + 0.0001 * np.arange(21), 0.05 - 0.001 * np.arange(19)]
HAIR_AND_FAR = pd.DataFrame(
    {"planner": ["A"] * 40 + ["B"] * 40, "seed": list(range(40)) * 2, "gap": np.r_[HAIR_A, FAR_B]}
)


def test_winner_is_the_side_the_signed_ranks_favour_not_the_pair_count():
    a, b = HAIR_A, FAR_B
    c = jaco.compare(HAIR_AND_FAR, by="planner", n_boot=100)
    row = c.pairwise.iloc[0]
    # by hand: A's 21 differences (0.001 ... 0.003) are the 21 smallest magnitudes, ranks 1..21
    assert (row.a_rank_sum, row.b_rank_sum) == (sum(range(1, 22)), sum(range(22, 41))) == (231, 589)
    ref = stats.wilcoxon(a - b, zero_method="zsplit")
    assert row.statistic == pytest.approx(ref.statistic) and row.p == pytest.approx(ref.pvalue)
    assert stats.wilcoxon(a - b, alternative="less").pvalue > 0.95  # "A lower" is what the data do not say
    assert (row.a_better, row.b_better, row.better) == (21, 19, "B")
    assert c.text.splitlines()[-1] == (
        f"B is better than A: signed ranks favour B 589 to 231; B better on 19 of 40 pairs, A on 21, 0 ties; "
        f"p = {row.p_holm:.2g} after Holm."
    )
    assert "beats" not in c.text
    assert re.search(r"^A\s+B\s+40\s+21\s+19\s+0\s+231\s+589\s.*\sB$", c.table(), re.M)  # the table too


def hand_rank_sums(d):
    """The sums of the ranks of |d| favouring a (d < 0) and b (d > 0), ties at their mean rank,
    zeros split in halves: counted pair by pair."""
    m = np.abs(d)
    rank = np.array([1 + (m < x).sum() + ((m == x).sum() - 1) / 2 for x in m])
    return rank[d < 0].sum() + rank[d == 0].sum() / 2, rank[d > 0].sum() + rank[d == 0].sum() / 2


@st.composite
def paired_tables(draw):
    """Two or three configurations on 6 to 30 pairs. Each of B and C is A's run plus, pair by pair,
    one of a few offsets: a hair (±0.001), a far one (±0.05 or +0.3), zero or a failure; drawn
    with its own odds, so that the pair count and the signed ranks often disagree."""
    k, n = draw(st.integers(2, 3)), draw(st.integers(6, 30))
    base = draw(st.lists(st.sampled_from([0.0, 0.02, 0.1, 0.5]), min_size=n, max_size=n))
    columns = {"A": base}
    for name in "BC"[: k - 1]:
        offsets = draw(st.lists(st.sampled_from([0.001, -0.001, 0.05, -0.05, 0.3, 0.0, INF]), min_size=1, max_size=4))
        picks = draw(st.lists(st.integers(0, len(offsets) - 1), min_size=n, max_size=n))
        columns[name] = [g + offsets[i] for g, i in zip(base, picks)]
    return table_of(columns)


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(paired_tables(), st.sampled_from([0.05, 0.2]))
@example(HAIR_AND_FAR, 0.05)  # the winner wins fewer pairs
def test_every_claimed_winner_has_the_larger_rank_sum_and_a_significant_p(table, alpha):
    c = cmp.compare(table, n_boot=10, alpha=alpha)
    pw = c.pairwise.set_index(["a", "b"])
    for (a, b), row in pw.iterrows():
        x, y = c.values[a].to_numpy(), c.values[b].to_numpy()
        ra, rb = hand_rank_sums(cmp.signed_differences(x, y))
        assert (row.a_rank_sum, row.b_rank_sum) == (pytest.approx(ra), pytest.approx(rb))
        if row.ties < row.pairs:
            assert min(ra, rb) == pytest.approx(row.statistic)  # the statistic scipy tested
        if isinstance(row.better, str):
            assert row.p_holm < alpha and (ra > rb if row.better == a else rb > ra)
        else:
            assert row.p_holm >= alpha or ra == rb
    claims = re.findall(
        r"^(\S+) is better than (\S+): signed ranks favour \1 ([\d.]+) to ([\d.]+);.* p = .* after Holm\.$",
        c.text,
        re.M,
    )
    for win, lose, r_win, r_lose in claims:
        row = pw.loc[(win, lose)] if (win, lose) in pw.index else pw.loc[(lose, win)]
        sums = {row.name[0]: row.a_rank_sum, row.name[1]: row.b_rank_sum}
        assert (float(r_win), float(r_lose)) == (sums[win], sums[lose]) and sums[win] > sums[lose]
        assert row.p_holm < alpha and row.better == win
    told_apart = re.findall(r"^(\S+) and (\S+) cannot be told apart", c.text, re.M)
    assert len(claims) + len(told_apart) == len(re.findall(r"after Holm|tie on all", c.text))


# -- unequal pairs, NaN pairs, settings that change ------------------------------------------
def test_a_configuration_missing_pairs_warns_and_says_over_how_many_runs(tmp_path, capsys):
    t = table_of({"A": A, "B": B, "C": C})
    t = t[~((t.planner == "C") & t.seed.isin([6, 7]))]  # C lacks seeds 6 and 7
    with pytest.warns(cmp.UnequalPairsWarning, match=r"of 8 pairs: A on 8; B on 8; C on 6\)") as w:
        c = cmp.compare(t, n_boot=50)
    assert len(w) == 1 and "\n" not in str(w[0].message)
    lines = c.text.splitlines()
    assert lines[0].endswith(
        "over 8 pairs (seed), 6 of them with a run of every configuration; lower is better, "
        "a failed run counts as +inf."
    )
    assert "Note: the configurations have runs on different pairs (of 8 pairs: A on 8; B on 8; C on 6)" in c.text
    assert "the ranks over the 6 complete blocks" in c.text
    s = c.summary.set_index("configuration")
    assert (s.loc["A", "runs"], s.loc["C", "runs"]) == (8, 6)
    assert s.loc["C", "gap_median"] == pytest.approx(np.median(C[:6]))  # over C's own 6 runs
    pw = c.pairwise.set_index(["a", "b"])
    assert pw.loc[("A", "B"), "pairs"] == 8 and pw.loc[("A", "C"), "pairs"] == 6 and c.friedman["n"] == 6
    assert "Best mean rank: A (median gap 10.5% over its 8 runs" in c.text
    path = tmp_path / "unequal.csv"
    t.to_csv(path, index=False)
    assert main(["compare", str(path), "--boot", "20"]) == 0
    err = capsys.readouterr().err  # a jaco warning line, not Python's
    assert err.startswith("jaco: warning: compare: the configurations have runs on different pairs (of 8 pairs")
    assert "UnequalPairsWarning" not in err and len(err.splitlines()) == 1
    with warnings.catch_warnings():
        warnings.simplefilter("error", cmp.UnequalPairsWarning)
        full = cmp.compare(table_of({"A": A, "B": B}), n_boot=20)  # every pair: no warning, no note
    assert "over 8 pairs (seed), each with a run of every configuration" in full.text and "Note" not in full.text


def test_a_nan_seed_is_one_line():
    t = table_of({"A": A, "B": B})
    t["seed"] = t["seed"].astype(float)
    t.loc[3, "seed"] = np.nan
    with pytest.raises(jaco.JacoError, match=r"pairing column 'seed' is empty \(NaN\) on 1 run \(planner=A\)") as e:
        cmp.compare(t)
    assert "\n" not in str(e.value)


def test_a_setting_that_changes_within_a_configuration_is_named():
    t = table_of({"A": A, "B": B}).assign(beta=8.0)
    t.loc[(t.planner == "A") & (t.seed == 0), "beta"] = 16.0
    with pytest.raises(
        jaco.JacoError,
        match=r"column 'beta' changes within configuration A \(8 on 7 runs, 16 on "
        r"1 run\): add it to by \(by=\['planner', 'beta'\]\)",
    ) as e:
        cmp.compare(t)
    assert "\n" not in str(e.value)
    # what may change within a configuration: a measurement that changes in most of them, and a
    # column the pair fixes (the same on a pair for every configuration)
    ok = table_of({"A": A, "B": B, "C": C}).assign(
        seconds=lambda d: 1.0 + 0.1 * np.arange(len(d)), budget=lambda d: 100 + d.seed
    )
    c = cmp.compare(ok, n_boot=20)
    pd.testing.assert_frame_equal(c.pairwise, cmp.compare(table_of({"A": A, "B": B, "C": C}), n_boot=20).pairwise)


def test_empty_tables_have_no_rows(tmp_path, capsys):
    for t in (pd.DataFrame(), table_of({"A": A, "B": B}).iloc[:0]):
        with pytest.raises(jaco.JacoError, match=r"^compare: the table has no rows$"):
            cmp.compare(t)
    path = tmp_path / "header.csv"
    path.write_text("planner,seed,success,gap,optimal,length\n")
    with pytest.raises(jaco.JacoError, match=r"^compare: the table has no rows$"):
        cmp.compare(jaco.research.tables.read_table(path))
    assert main(["compare", str(path)]) == 2
    assert "the table has no rows" in capsys.readouterr().err


def test_nan_length_and_negative_infinite_gap_are_refused():
    t = table_of({"A": A, "B": B})
    t.loc[3, "length"] = np.nan  # its gap is finite: the profile would count the run unsolved
    with pytest.raises(
        jaco.JacoError,
        match=r"column 'length' is empty \(NaN\) on 1 run \(planner=A, seed=3\); "
        r"a failed run is \+inf",
    ):
        cmp.compare(t)
    t = table_of({"A": A, "B": B})
    t.loc[10, "gap"] = -INF
    with pytest.raises(jaco.JacoError, match=r"column 'gap' is -inf on 1 run \(planner=B, seed=2\)"):
        cmp.compare(t)
    t.loc[10, "gap"], t.loc[11, "length"] = 0.2, -INF
    with pytest.raises(jaco.JacoError, match=r"column 'length' is -inf on 1 run \(planner=B, seed=3\)"):
        cmp.compare(t)


def test_a_median_is_failed_exactly_when_at_least_half_the_runs_failed():
    """The median of an even number of runs is the mean of the middle two: half failed makes it
    the mean of a path and a failure, +inf, as numpy's median says."""
    t = table_of({"H": [0.1, 0.2, INF, INF], "L": [0.1, 0.2, 0.3, INF], "M": [0.1, INF, INF, INF]})
    s = cmp.compare(t, n_boot=20).summary.set_index("configuration")["gap_median"]
    assert (s["H"], s["M"]) == (INF, INF) and s["L"] == pytest.approx(0.25)
    for runs in ([0.1, 0.2, INF, INF], [0.1, 0.2, 0.3, INF, INF], [0.1, INF, INF]):
        assert cmp.quantile(runs, 0.5) == np.median(runs)
    text = cmp.compare(t, n_boot=20).table()
    assert re.search(r"^H\s+4\s+50%\s+failed", text, re.M)


def test_a_bootstrap_interval_depends_only_on_its_configuration_and_the_seed():
    t = table_of({"A": A + B, "B": B + A[::-1], "C": C + C})
    one = cmp.compare(t, n_boot=300, seed=5).summary.set_index("configuration")
    cols = ["gap_median_low", "gap_median_high"]
    assert (one.loc[["A", "B"], "gap_median_low"] < one.loc[["A", "B"], "gap_median_high"]).all()  # not degenerate
    shuffled = cmp.compare(t.sample(frac=1.0, random_state=2), n_boot=300, seed=5).summary.set_index("configuration")
    pd.testing.assert_frame_equal(shuffled.loc[["A", "B", "C"], cols], one.loc[["A", "B", "C"], cols])
    without_c = cmp.compare(t[t.planner != "C"], n_boot=300, seed=5).summary.set_index("configuration")
    pd.testing.assert_frame_equal(without_c.loc[["A", "B"], cols], one.loc[["A", "B"], cols])
    renamed = cmp.compare(t.replace({"planner": {"C": "Z"}}), n_boot=300, seed=5).summary.set_index("configuration")
    pd.testing.assert_frame_equal(renamed.loc[["A", "B"], cols], one.loc[["A", "B"], cols])


def test_blocks_by_query_with_missing_seeds_use_each_configurations_own_runs():
    """A and B ran different seeds of the same two queries: every query is a complete block (each
    configuration's median over the seeds it ran), but A and B share no pair to test."""
    rows = []
    for q in range(2):
        for name, seeds, g in (("A", (0, 1), 0.1), ("B", (2, 3), 0.2), ("C", (0, 1, 2, 3), 0.3)):
            for seed in seeds:
                rows.append(
                    dict(
                        planner=name,
                        map="m",
                        start_row=q,
                        start_col=0,
                        goal_row=5,
                        goal_col=5,
                        seed=seed,
                        gap=g + 0.01 * seed + 0.1 * q,
                        length=10.0,
                    )
                )
    with pytest.warns(cmp.UnequalPairsWarning, match=r"of 8 pairs: A on 4; B on 4; C on 8"):
        c = cmp.compare(pd.DataFrame(rows), blocks="query", n_boot=20)
    assert c.friedman["n"] == 2 and list(c.ranks) == [1.0, 2.0, 3.0]
    pw = c.pairwise.set_index(["a", "b"])
    assert pw.loc[("A", "B"), "pairs"] == 0 and pw.loc[("A", "C"), "pairs"] == 4
    assert "A and B cannot be compared: no pair has a run of both." in c.text
    assert "Note: the configurations have runs on different pairs" in c.text and "blocks lack" not in c.text
