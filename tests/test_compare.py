"""jaco.research.compare: the statistics against scipy and hand-computed answers on small tables,
how failed runs and ties are counted, the words, the plots and the `jaco compare` command."""

import math

import matplotlib

matplotlib.use("Agg")

import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
import pytest  # noqa: E402
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
            rows.append(dict(variant=name, seed=seed, success=math.isfinite(g), gap=g, optimal=optimal,
                             length=optimal * (1 + g)))
    return pd.DataFrame(rows)


@pytest.fixture(scope="module")
def three():
    return cmp.compare(table_of({"A": A, "B": B, "C": C}), n_boot=500, seed=3)


def test_quantiles_equal_numpy_and_allow_inf():
    rng = np.random.default_rng(0)
    x = rng.normal(size=(7, 9))
    for q in (0.0, 0.25, 0.5, 0.9, 1.0):
        np.testing.assert_allclose(cmp.quantile(x, q, axis=1), np.quantile(x, q, axis=1), rtol=0, atol=1e-12)
    assert cmp.quantile([1.0, 2.0, INF, INF], 0.5) == INF  # more than half failed
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
    ref = stats.bootstrap((x,), np.median, n_resamples=4000, confidence_level=0.9, method="percentile",
                          rng=np.random.default_rng(1)).confidence_interval
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
    xy = t.pairwise.set_index(["a", "b"]).loc[("X", "Y")] if ("X", "Y") in set(zip(t.pairwise.a, t.pairwise.b)) \
        else t.pairwise.set_index(["a", "b"]).loc[("Y", "X")]
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
    assert f"A beats B on 8 of 8 pairs (B better on 0, 0 ties), p = {3 * 2 / 256:.2g} after Holm" in text
    assert "Friedman test over 8 blocks" in text and "the configurations differ" in text
    same = cmp.compare(table_of({"P": [0.1, 0.3, 0.2, 0.5], "Q": [0.2, 0.1, 0.3, 0.4]}), n_boot=20)
    assert "P and Q cannot be told apart (p = " in same.text


def test_blocks_by_query_take_the_median_over_seeds():
    rows = []
    for q, (ga, gb) in enumerate([(0.1, 0.2), (0.3, 0.2), (0.05, 0.5)]):
        for name, g in (("A", ga), ("B", gb)):
            for seed in range(3):
                rows.append(dict(variant=name, map="m", start_row=q, start_col=0, goal_row=5, goal_col=5, seed=seed,
                                 gap=g + 0.01 * seed, length=100 * (1 + g + 0.01 * seed)))
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
    with pytest.raises(jaco.JacoError, match=r"column 'beta' varies .*by=\['variant', 'beta'\]"):
        cmp.compare(t)
    c = cmp.compare(t, by=["variant", "beta"], n_boot=20)
    assert set(c.summary["configuration"]) == {"iaca, beta=8", "iaca, beta=16", "backtrack/chaos/iaca, beta=8",
                                                "backtrack/chaos/iaca, beta=16"}


@pytest.mark.parametrize("kw, match", [
    (dict(value="variant"), "must be a column of numbers"),
    (dict(by="nope"), "no column 'nope'"),
    (dict(blocks="map"), "blocks must be"),
    (dict(alpha=1.5), "alpha must be"),
    (dict(n_boot=0), "n_boot"),
    (dict(pairing=["query"]), "pairing column 'query'"),
    (dict(pairing="variant"), "pairing column 'variant'"),
])
def test_bad_calls_are_one_line(kw, match):
    with pytest.raises(jaco.JacoError, match=match) as e:
        cmp.compare(table_of({"A": A, "B": B}), **kw)
    assert "\n" not in str(e.value)


def test_pairing_by_a_query_number():
    """A table that numbers its queries (no start/goal columns) pairs by the columns it names:
    two queries × 8 seeds are 16 pairs, as many as the same runs with their query's cells."""
    t = table_of({"A": A + B, "B": B + C}).assign(query=lambda d: d.index % 16 // 8, seed=lambda d: d.index % 8)
    with pytest.raises(jaco.JacoError, match="rows share a configuration and pair"):
        cmp.compare(t)  # paired by seed alone, each seed is two runs
    by_number = cmp.compare(t, pairing=["query", "seed"], n_boot=20)
    by_cells = cmp.compare(t.assign(map="m", start_row=0, start_col=0, goal_row=1, goal_col=t["query"]).drop(columns="query"),
                           n_boot=20)
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
    assert len(bars) == len(jaco.plot._cliques(ranks, three.friedman["cd"]))
    jaco.plot.save(fig, tmp_path / "cd.png")
    prof = jaco.plot.plot_performance_profile(three)
    assert [t.get_text() for t in prof.axes[0].get_legend().get_texts()] == ["A", "B", "C"]
    jaco.plot.save(prof, tmp_path / "profile.png")
    with pytest.raises(jaco.JacoError, match="Comparison"):
        jaco.plot.plot_critical_difference(three.summary)


def test_cliques_by_hand():
    assert jaco.plot._cliques(np.array([1.0, 1.5, 2.2, 4.0]), 1.0) == [(0, 1), (1, 2)]
    assert jaco.plot._cliques(np.array([1.0, 1.5, 2.2, 4.0]), 1.3) == [(0, 2)]
    assert jaco.plot._cliques(np.array([1.0, 3.0]), 1.0) == []


def test_cli_compare_on_a_saved_table_old_and_new_layout(tmp_path, capsys):
    t = table_of({"A": A, "B": B, "C": C}).assign(map="m", start_row=1, start_col=2, goal_row=3, goal_col=4)
    new = tmp_path / "new.csv"
    new.write_text(csv_text(t))
    old = tmp_path / "old.csv"  # the layout of older jaco: start and goal as "(row, col)" text
    t.drop(columns=["start_row", "start_col", "goal_row", "goal_col"]).assign(start="(1, 2)", goal="(3, 4)").to_csv(old, index=False)
    outputs = []
    for path in (new, old):
        code = main(["compare", str(path), "--boot", "300", "--cd", str(tmp_path / "cd.png"),
                     "--profile", str(tmp_path / "p.svg")])
        out, err = capsys.readouterr()
        assert code == 0, err
        outputs.append(out.split("\n", 1)[1])
    assert outputs[0] == outputs[1]
    assert "A beats B on 8 of 8 pairs" in outputs[0] and "Wilcoxon" in outputs[0]
    assert (tmp_path / "cd.png").read_bytes()[:4] == b"\x89PNG" and (tmp_path / "p.svg").read_text().startswith("<?xml")
    code = main(["compare", str(new), "--where", "variant=A", "--boot", "10"])
    assert code == 2 and "one configuration" in capsys.readouterr().err
    code = main(["compare", str(tmp_path / "missing.csv")])
    assert code == 2 and "not found" in capsys.readouterr().err


def test_short_names_and_percent():
    from jaco.research.tables import percent, short_name

    assert short_name(COMPOSED) == "backtrack/chaos/iaca"
    assert short_name("compose(construct=dying, heuristic=iaaco, rule=mmas, transition=roulette, schedule=constant, "
                      "cost=multi)") == "dying/iaaco/mmas+cost=multi"
    assert short_name("compose(construct=dying, heuristic=distance, rule=acs, transition=roulette, schedule=constant, "
                      "cost=length)") == "dying/distance/acs+transition=roulette"  # acs's own is q0
    assert short_name("mmas") == "mmas"
    assert short_name(jaco.compose(construct="backtrack", heuristic="chaos", rule="iaca").name) == "backtrack/chaos/iaca"
    assert (percent(0.1793), percent(INF), percent(float("nan")), percent(-1e-9, 2)) == ("17.9%", "failed", "-", "0.00%")
