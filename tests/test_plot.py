"""Tests of jaco.plot: every figure renders headless to a valid PNG and shows the right data."""

import matplotlib

matplotlib.use("Agg")

import math  # noqa: E402

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
from matplotlib.colors import LogNorm  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

import jaco  # noqa: E402
from jaco.grid import Grid  # noqa: E402
from jaco.plot import plot_convergence, plot_map, plot_paths, plot_pheromone, save  # noqa: E402

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"

GRID = Grid.from_rows([
    "......",
    ".##...",
    "...#..",
    "......",
])
START, GOAL = (0, 0), (3, 5)
P1 = np.array([(0, 0), (0, 1), (0, 2), (0, 3), (1, 4), (2, 5), (3, 5)])
P2 = np.array([(0, 0), (1, 0), (2, 0), (3, 1), (3, 2), (3, 3), (3, 4), (3, 5)])
P3 = [(0, 0), (1, 0), (2, 1), (2, 2), (3, 3), (3, 4), (3, 5)]


def _assert_png(path):
    assert path.exists() and path.stat().st_size > 0
    assert path.read_bytes()[:8] == PNG_MAGIC


def assert_beside(legend, *axes):
    """The legend covers no data: its box overlaps neither the data area of any of ``axes`` nor
    (for a twin) its tick labels and axis label."""
    fig = legend.figure
    fig.draw_without_rendering()
    box = legend.get_window_extent()
    for ax in axes:
        assert not box.overlaps(ax.get_window_extent())
        assert not box.overlaps(ax.get_tightbbox(bbox_extra_artists=[]))  # ticks and labels


def test_plot_map(tmp_path):
    fig = plot_map(GRID, start=START, goal=GOAL, title="map")
    assert isinstance(fig, Figure)
    ax = fig.axes[0]
    assert len(ax.images) == 1
    np.testing.assert_array_equal(np.asarray(ax.images[0].get_array()), GRID.free.astype(np.uint8))
    assert len(ax.collections) == 2  # start and goal markers
    # Start marker at x = col, y = row; row 0 at the top (y axis inverted).
    np.testing.assert_array_equal(ax.collections[1].get_offsets()[0], [GOAL[1], GOAL[0]])
    assert ax.get_ylim()[0] > ax.get_ylim()[1]
    assert ax.get_title() == "map"
    out = save(fig, tmp_path / "sub" / "map.png")
    _assert_png(out)


def test_plot_paths_three_labelled(tmp_path):
    fig = plot_paths(GRID, [P1, P2, P3], labels=["a", "b", "c"], start=START, goal=GOAL)
    ax = fig.axes[0]
    assert len(ax.lines) == 3
    legend = ax.get_legend()
    assert legend is not None and [t.get_text() for t in legend.get_texts()] == ["a", "b", "c"]
    assert_beside(legend, ax)  # beside the map, not on it
    missing = plot_paths(GRID, {"a": P1, "no path": None, "b": []}).axes[0].get_legend()
    assert [t.get_text() for t in missing.get_texts()] == ["a", "no path", "b (no path)"]  # said once
    # Lines go through cell centres: x = col, y = row.
    np.testing.assert_array_equal(ax.lines[0].get_xdata(), P1[:, 1])
    np.testing.assert_array_equal(ax.lines[0].get_ydata(), P1[:, 0])
    _assert_png(save(fig, tmp_path / "paths.png"))


def test_plot_paths_single_dict_and_missing(tmp_path):
    fig = plot_paths(GRID, P1)
    assert len(fig.axes[0].lines) == 1 and fig.axes[0].get_legend() is None
    fig = plot_paths(GRID, P3)  # a list of tuples is one path, not seven
    assert len(fig.axes[0].lines) == 1
    np.testing.assert_array_equal(fig.axes[0].lines[0].get_xdata(), [c for _, c in P3])
    fig = plot_paths(GRID, {"ACS": P1, "MMAS": P2, "failed": None})
    ax = fig.axes[0]
    assert len(ax.lines) == 3
    assert [t.get_text() for t in ax.get_legend().get_texts()] == ["ACS", "MMAS", "failed (no path)"]
    _assert_png(save(fig, tmp_path / "dict.png"))
    with pytest.raises(ValueError):
        plot_paths(GRID, [P1, P2], labels=["only one"])


def test_draw_into_existing_axes(tmp_path):
    fig = Figure(figsize=(8, 4))
    ax1, ax2 = fig.subplots(1, 2)
    assert plot_paths(GRID, [P1, P2], ax=ax1) is fig
    assert plot_map(GRID, ax=ax2) is fig
    assert len(ax1.lines) == 2 and len(ax2.lines) == 0
    _assert_png(save(fig, tmp_path / "two.png"))


def _per_move_tau():
    rng = np.random.default_rng(0)
    n = GRID.n_cells
    tau = rng.uniform(0.1, 2.0, size=(n, 8))
    tau[3, 2] = np.inf  # some layouts mark impossible moves this way: ignored in the sum
    return tau


def test_plot_pheromone_per_move_sums(tmp_path):
    tau = _per_move_tau()
    fig = plot_pheromone(GRID, tau, path=P1)
    ax = fig.axes[0]
    assert len(fig.axes) == 2  # the map and its colorbar
    assert len(ax.images) == 1
    shown = ax.images[0].get_array()
    expected = np.where(np.isfinite(tau), tau, 0.0).sum(axis=1).reshape(GRID.shape)
    free = GRID.free
    np.testing.assert_allclose(np.asarray(shown)[free], expected[free])
    np.testing.assert_array_equal(np.ma.getmaskarray(shown), ~free)  # obstacles masked
    assert len(ax.lines) == 1
    _assert_png(save(fig, tmp_path / "tau_moves.png"))


def test_plot_pheromone_shapes_agree_and_log(tmp_path):
    per_cell = np.arange(GRID.n_cells, dtype=float)
    a = plot_pheromone(GRID, per_cell).axes[0].images[0].get_array()
    b = plot_pheromone(GRID, per_cell.reshape(GRID.shape)).axes[0].images[0].get_array()
    np.testing.assert_array_equal(np.asarray(a)[GRID.free], np.asarray(b)[GRID.free])
    np.testing.assert_array_equal(np.asarray(a)[GRID.free], per_cell.reshape(GRID.shape)[GRID.free])
    fig = plot_pheromone(GRID, per_cell, log=True)
    im = fig.axes[0].images[0]
    assert isinstance(im.norm, LogNorm)
    assert np.ma.getmaskarray(im.get_array())[0, 0]  # cell 0 holds 0: not shown on a log scale
    _assert_png(save(fig, tmp_path / "tau_log.png"))
    with pytest.raises(ValueError):
        plot_pheromone(GRID, np.ones(GRID.n_cells + 1))


def test_plot_convergence_masks_inf(tmp_path):
    best = np.array([np.inf, np.inf, 30.0, 31.0, 28.0, 28.5, 27.0])
    mean = np.array([np.inf, np.inf, 35.0, np.nan, 33.0, 32.0, 30.0])
    rate = np.array([0.0, 0.0, 0.1, 0.2, 0.4, 0.5, 0.7])
    fig = plot_convergence({"best": best, "mean": mean, "success_rate": rate}, optimal=26.0, label="ACS")
    ax = fig.axes[0]
    assert len(fig.axes) == 2  # twin axis for the success rate
    best_line, mean_line, opt_line = ax.lines
    y = best_line.get_ydata()
    assert np.ma.getmaskarray(y).tolist() == [True, True, False, False, False, False, False]
    np.testing.assert_array_equal(np.ma.compressed(y), [30.0, 30.0, 28.0, 28.0, 27.0])  # best so far
    assert np.ma.getmaskarray(mean_line.get_ydata()).tolist() == [True, True, False, True, False, False, False]
    assert opt_line.get_ydata()[0] == 26.0 and opt_line.get_linestyle() == "--"
    legend = ax.get_legend()  # one legend for both axes, beside the twin's ticks and label
    assert [t.get_text() for t in legend.get_texts()] == [
        "ACS best so far", "ACS iteration mean", "optimum 26", "ACS success rate"]
    assert_beside(legend, ax, fig.axes[1])
    assert ax.get_ylabel() == "path cost" and fig.axes[1].get_ylabel() == "success rate"
    assert plot_convergence({"best": best}, ylabel="path length").axes[0].get_ylabel() == "path length"
    _assert_png(save(fig, tmp_path / "conv.png"))


def test_plot_convergence_several_runs(tmp_path):
    runs = [
        {"best": [10.0, 9.0, 9.0], "mean": [12.0, 11.0, 10.0]},
        {"best": [math.inf, 11.0, 8.0], "mean": [math.inf, 13.0, 9.0]},
    ]
    fig = plot_convergence(runs, label=["AS", "MMAS"])
    ax = fig.axes[0]
    assert len(fig.axes) == 1 and len(ax.lines) == 4
    texts = [t.get_text() for t in ax.get_legend().get_texts()]
    assert texts == ["AS best so far", "AS iteration mean", "MMAS best so far", "MMAS iteration mean"]
    assert_beside(ax.get_legend(), ax)
    _assert_png(save(fig, tmp_path / "runs.png"))
    with pytest.raises(ValueError):
        plot_convergence({"mean": [1.0]})


def test_no_pyplot_figures_are_left_open():
    before = set(plt.get_fignums())
    plot_map(GRID)
    plot_paths(GRID, P1)
    plot_pheromone(GRID, np.ones(GRID.shape))
    plot_convergence({"best": [1.0], "mean": [1.0]})
    assert set(plt.get_fignums()) == before


# -- sweeps and animation -------------------------------------------------------------------------
def _sweep_table():
    import pandas as pd

    rows = []
    for a in (1.0, 2.0):
        for b in (2.0, 4.0, 8.0):
            for seed in range(3):
                failed = a == 2.0 and b == 8.0 and seed == 1
                gap_ = np.inf if failed else 0.01 * (a + b) + 0.001 * seed
                rows.append(dict(alpha=a, beta=b, seed=seed, gap=gap_, optimal=10.0,
                                 length=np.inf if failed else 10.0 * (1 + gap_)))
    return pd.DataFrame(rows)


def test_sweep_heatmap_shows_the_mean_over_seeds_and_marks_failures(tmp_path):
    table = _sweep_table()
    xs, ys, Z = jaco.plot.sweep_grid(table, "alpha", "beta", "gap")
    assert list(xs) == [1.0, 2.0] and list(ys) == [2.0, 4.0, 8.0]
    assert Z[1, 0] == pytest.approx(0.01 * 5 + 0.001)  # beta=4, alpha=1: mean over seeds 0, 1, 2
    assert np.isinf(Z[2, 1]) and np.isfinite(np.delete(Z.ravel(), 5)).all()
    fig = jaco.plot.plot_sweep_heatmap(table, "alpha", "beta")
    ax = fig.axes[0]
    texts = {t.get_text() for t in ax.texts}
    assert "fail" in texts and f"{100 * (0.01 * 5 + 0.001):.1f}%" in texts
    assert [t.get_text() for t in ax.get_xticklabels()] == ["1", "2"]
    jaco.plot.save(fig, tmp_path / "heat.png")
    with pytest.raises(jaco.ParamError, match="not a column"):
        jaco.plot.plot_sweep_heatmap(table, "alpha", "gamma")


def test_sweep_box_one_box_per_configuration_failures_left_out():
    table = _sweep_table()
    fig = jaco.plot.plot_sweep_box(table, by=["alpha", "beta"], value="length")
    ax = fig.axes[0]
    labels = [t.get_text() for t in ax.get_xticklabels()]
    assert len(labels) == 6 and labels[-1] == "alpha=2, beta=8\n(1 failed)"
    # The median line of the first box is the median of its three seeds.
    first = table[(table.alpha == 1.0) & (table.beta == 2.0)]["length"]
    medians = [line for line in ax.lines if line.get_color() in ("C1", "#ff7f0e", "orange")]
    assert medians and medians[0].get_ydata()[0] == pytest.approx(np.median(first))
    assert any(line.get_linestyle() == "--" and line.get_ydata()[0] == 10.0 for line in ax.lines)


def test_pheromone_history_animates_to_a_gif(tmp_path):
    from PIL import Image

    grid = jaco.maps.named("simple-20")
    r = jaco.solve(grid, grid.meta["start"], grid.meta["goal"], "as", seed=0, n_ants=8, n_iters=6,
                   keep_pheromone="history")
    assert r.pheromone.shape == (6, 8 * grid.height * grid.width)
    final = jaco.solve(grid, grid.meta["start"], grid.meta["goal"], "as", seed=0, n_ants=8, n_iters=6,
                       keep_pheromone=True).pheromone
    np.testing.assert_array_equal(r.pheromone[-1], final)  # the last frame is the final pheromone
    anim = jaco.plot.animate_pheromone(grid, r.pheromone, path=r.path, every=2)
    out = jaco.plot.save_gif(anim, tmp_path / "tau.gif", fps=4)
    with Image.open(out) as im:
        assert im.format == "GIF" and im.n_frames == 3  # iterations 1, 3, 5
    with pytest.raises(jaco.JacoError, match="keep_pheromone"):
        jaco.solve(grid, grid.meta["start"], grid.meta["goal"], "as", n_iters=2, keep_pheromone="all")


# -- categorical axes: planners as an axis --------------------------------------------------------
COMPOSED = "compose(construct=backtrack, heuristic=chaos, rule=iaca, transition=q0, schedule=constant, cost=length)"


def _planner_table():
    """Two planners x beta x 2 seeds, the layout of jaco.sweep(..., variant=[...])."""
    import pandas as pd

    rows = []
    for v, base in (("iaca", 0.3), (COMPOSED, 0.2)):
        for b in (8.0, 16.0):
            for seed in range(2):
                failed = v == "iaca" and b == 16.0 and seed == 1
                g = np.inf if failed else base + 0.01 * b + 0.001 * seed
                rows.append(dict(variant=v, beta=b, seed=seed, gap=g, optimal=100.0, best_iteration=3 + seed,
                                 length=np.inf if failed else 100.0 * (1 + g)))
    return pd.DataFrame(rows)


def test_sweep_heatmap_draws_the_planner_axis():
    table = _planner_table()
    xs, ys, Z = jaco.plot.sweep_grid(table, "beta", "variant")
    assert list(xs) == [8.0, 16.0] and list(ys) == ["iaca", COMPOSED]  # text in order of appearance
    assert Z[1, 0] == pytest.approx(0.2 + 0.08 + 0.0005) and np.isinf(Z[0, 1])
    fig = jaco.plot.plot_sweep_heatmap(table, "beta", "variant")
    ax = fig.axes[0]
    assert [t.get_text() for t in ax.get_yticklabels()] == ["iaca", "backtrack/chaos/iaca"]
    assert [t.get_text() for t in ax.get_xticklabels()] == ["8", "16"]
    texts = [t.get_text() for t in ax.texts]
    assert "fail" in texts and f"{100 * (0.2 + 0.08 + 0.0005):.1f}%" in texts
    # integers read as integers: the mean best iteration of two seeds, 3 and 4, is 3.5; of one value, 3
    one = table[table.seed == 0]
    assert {t.get_text() for t in jaco.plot.plot_sweep_heatmap(one, "beta", "variant", "best_iteration").axes[0].texts} == {"3"}


def test_sweep_box_draws_the_planner_axis():
    table = _planner_table()
    fig = jaco.plot.plot_sweep_box(table, by="variant", value="gap")
    ax = fig.axes[0]
    assert [t.get_text() for t in ax.get_xticklabels()] == ["iaca\n(1 failed)", "backtrack/chaos/iaca"]
    assert ax.get_ylabel() == "gap (%)"
    medians = [line for line in ax.lines if line.get_color() in ("C1", "#ff7f0e", "orange")]
    ok = table[(table.variant == COMPOSED)]["gap"]
    assert medians[1].get_ydata()[0] == pytest.approx(100 * np.median(ok))  # the gap in %
    both = jaco.plot.plot_sweep_box(table, by=["variant", "beta"], value="length")
    labels = [t.get_text() for t in both.axes[0].get_xticklabels()]
    assert labels == ["iaca, beta=8", "iaca, beta=16\n(1 failed)", "backtrack/chaos/iaca, beta=8",
                      "backtrack/chaos/iaca, beta=16"]
    assert_beside(both.axes[0].get_legend(), both.axes[0])  # the optimum's legend


@pytest.mark.parametrize("call", [
    lambda t: jaco.plot.plot_sweep_heatmap(t, "beta", "seed", "variant"),
    lambda t: jaco.plot.plot_sweep_box(t, by="beta", value="variant"),
    lambda t: jaco.plot.sweep_grid(t, "beta", "seed", "variant"),
])
def test_a_text_column_where_numbers_are_needed_is_one_line(call):
    with pytest.raises(jaco.ParamError, match=r"^value 'variant' is a column of text \('iaca', .*needs numbers") as e:
        call(_planner_table())
    assert "\n" not in str(e.value)


def test_sweep_box_reads_a_planner_column_as_the_planner():
    """Tables name the planner ``planner`` (``variant`` before): both are shown by short names."""
    table = _planner_table().rename(columns={"variant": "planner"})
    fig = jaco.plot.plot_sweep_box(table, by=["planner", "beta"], value="length")
    labels = [t.get_text() for t in fig.axes[0].get_xticklabels()]
    assert labels == ["iaca, beta=8", "iaca, beta=16\n(1 failed)", "backtrack/chaos/iaca, beta=8",
                      "backtrack/chaos/iaca, beta=16"]


# -- searches -----------------------------------------------------------------------------------
def _search_study(rows, objective="gap", planners=("acs", "mmas", "iaca"), column=None):
    """A jaco search Study made by hand (no runs): one finished trial per row ``(planner, beta,
    rho, value)``. ``column``: the name the trials table gives the planner (``planner`` or the older
    ``variant``), whichever jaco writes now."""
    optuna = pytest.importorskip("optuna")
    from optuna.distributions import CategoricalDistribution, FloatDistribution

    from jaco.research import search as S

    optuna.logging.set_verbosity(optuna.logging.WARNING)
    study = optuna.create_study(direction="maximize" if objective == "success" else "minimize")
    space = {"variant": list(planners), "beta": "1:20:log", "rho": "0.05:0.6"}
    study.set_user_attr(S.ATTR, {"format": S.FORMAT, "format_version": S.FORMAT_VERSION, "space": space,
                                 "objectives": [objective], "sampler": "tpe"})
    dists = {"variant": CategoricalDistribution(list(planners)), "beta": FloatDistribution(1.0, 20.0, log=True),
             "rho": FloatDistribution(0.05, 0.6)}
    for k, (planner, beta, rho, value) in enumerate(rows):
        runs = {"8": {"success": [[True]], "gap": [[value]], "length": [[1.0 + value]]}}
        study.add_trial(optuna.trial.create_trial(
            params={"variant": planner, "beta": beta, "rho": rho}, distributions=dists, value=value,
            user_attrs={"jaco_trial": {"planner": planner, "generation": k, "params": {}, "n_ants": 1},
                        "jaco_runs": runs}))
    out = S.Study(study)
    if column is not None:
        table = out.trials
        renamed = table.rename(columns={c: column for c in ("variant", "planner") if c in table.columns})
        out.__class__ = type("RenamedStudy", (S.Study,), {"trials": property(lambda self: renamed)})
    return out


def _three_planners(n=12, seed=0):
    """acs improves with beta, iaca with rho, mmas fails everywhere (one penalty value)."""
    rng = np.random.default_rng(seed)
    rows = []
    for planner in ("acs", "mmas", "iaca"):
        for beta, rho in zip(rng.uniform(1.0, 20.0, n), rng.uniform(0.05, 0.6, n)):
            value = {"acs": 0.01 * beta, "mmas": 1.0, "iaca": 0.2 * rho}[planner]
            rows.append((planner, float(beta), float(rho), value))
    return rows


def _panels(fig):
    return [a for a in fig.axes if any(c.get_label() == "trials" for c in a.collections)]


@pytest.mark.parametrize("column", ["planner", "variant"])
def test_search_contour_draws_one_panel_per_planner_with_its_own_trials(column):
    rows = _three_planners()
    study = _search_study(rows, column=column)
    fig = jaco.plot.plot_search_contour(study, "beta", "rho")
    panels = _panels(fig)
    assert len(panels) == 3 and len(fig.axes) == 4  # one panel per planner and one colour bar
    norms = set()
    for ax, planner in zip(panels, ("acs", "mmas", "iaca")):  # the space's order
        assert ax.get_title().startswith(f"{planner} (12 trials")
        (points,) = [c for c in ax.collections if c.get_label() == "trials"]
        mine = sorted((b, r) for p, b, r, _ in rows if p == planner)
        np.testing.assert_allclose(sorted(map(tuple, points.get_offsets())), mine)
        np.testing.assert_allclose(sorted(points.get_array()), sorted(100 * v for p, _, _, v in rows if p == planner))
        norms.add((points.norm.vmin, points.norm.vmax))
        stars = [c for c in ax.collections if c.get_label().startswith("best")]
        if planner == "mmas":  # all its trials fail alike: no best trial to star
            assert not stars and "all equal" in ax.get_title()
        else:
            best = min((v, b, r) for p, b, r, v in rows if p == planner)
            np.testing.assert_allclose(stars[0].get_offsets()[0], best[1:])
    assert norms == {(100 * min(r[3] for r in rows), 100 * max(r[3] for r in rows))}  # one colour scale
    assert len(panels[0].get_shared_x_axes().get_siblings(panels[0])) == 3


def test_search_contour_draws_one_planner_when_asked_and_refuses_a_mix_in_one_axes():
    rows = _three_planners()
    study = _search_study(rows)
    fig = jaco.plot.plot_search_contour(study, "beta", "rho", planner="iaca")
    (ax,) = _panels(fig)
    (points,) = [c for c in ax.collections if c.get_label() == "trials"]
    np.testing.assert_allclose(sorted(map(tuple, points.get_offsets())), sorted((b, r) for p, b, r, _ in rows if p == "iaca"))
    assert "of iaca" in ax.get_title()
    fig, ax = plt.subplots()
    try:
        with pytest.raises(jaco.ParamError, match=r"span 3 planners \(acs, mmas, iaca\).*planner="):
            jaco.plot.plot_search_contour(study, "beta", "rho", ax=ax)
        assert jaco.plot.plot_search_contour(study, "beta", "rho", ax=ax, planner="acs") is fig
    finally:
        plt.close(fig)
    with pytest.raises(jaco.ParamError, match=r"no finished trial of planner 'ras' .*acs, mmas, iaca"):
        jaco.plot.plot_search_contour(study, "beta", "rho", planner="ras")
    for c in ("planner", "variant"):
        with pytest.raises(jaco.ParamError, match="is not a searched number"):
            jaco.plot.plot_search_contour(_search_study(rows, column=c), c, "rho")


def test_planner_effect_is_eta_squared():
    # acs 0.1, 0.2, 0.3 (mean 0.2), mmas 1, 1, 1 (mean 1), all: mean 0.6
    # between: 3 * 0.4² + 3 * 0.4² = 0.96; total: 0.4² + 0.4² + 0.3² + 3 * 0.4² ... by hand:
    # (0.5² + 0.4² + 0.3²) + 3 * 0.4² = 0.5 + 0.48 = 0.98; η² = 0.96 / 0.98 = 48/49
    values = [0.1, 0.2, 0.3, 1.0, 1.0, 1.0]
    planners = ["acs"] * 3 + ["mmas"] * 3
    assert jaco.plot.search.planner_effect(values, planners) == pytest.approx(48 / 49)
    assert jaco.plot.search.planner_effect([0.2, 0.2, 0.5, 0.5], ["a", "a", "b", "b"]) == pytest.approx(1.0)
    assert jaco.plot.search.planner_effect([0.1, 0.3, 0.1, 0.3], ["a", "a", "b", "b"]) == pytest.approx(0.0)
    assert np.isnan(jaco.plot.search.planner_effect([0.4, 0.4], ["a", "b"]))  # nothing varies


@pytest.mark.filterwarnings("ignore:Argument ``normalize``", "ignore:Target and region quantiles")
@pytest.mark.parametrize("column", ["planner", "variant"])
def test_param_importance_shows_the_planner_effect_and_importance_within_each_planner(column):
    optuna = pytest.importorskip("optuna")
    from optuna.distributions import FloatDistribution

    rows = _three_planners(n=30)
    study = _search_study(rows, column=column)
    fig = jaco.plot.plot_param_importance(study)
    effect_ax, ax = fig.axes
    # the planner's effect, by hand: between-planner sum of squares over the total
    v = np.array([r[3] for r in rows])
    between = sum(30 * (np.mean([r[3] for r in rows if r[0] == p]) - v.mean()) ** 2 for p in ("acs", "mmas", "iaca"))
    eta = between / ((v - v.mean()) ** 2).sum()
    (bar,) = effect_ax.containers[0]
    assert bar.get_width() == pytest.approx(eta) and eta > 0.5
    assert [t.get_text().strip() for t in effect_ax.texts] == [f"η² = {eta:.2f}"]
    assert "η²" in effect_ax.get_xlabel() and "between planners" in effect_ax.get_xlabel()
    # one bar group per planner: PED-ANOVA over that planner's own trials, shares summing to 1
    labels = [c.get_label() for c in ax.containers]
    assert labels == ["acs (30 trials)", "mmas (30 trials: nothing separates its best trials)", "iaca (30 trials)"]
    names = [t.get_text() for t in ax.get_yticklabels()]
    for container, planner in zip(ax.containers, ("acs", "mmas", "iaca")):
        alone = optuna.create_study()
        for p, b, r, value in rows:
            if p == planner:
                alone.add_trial(optuna.trial.create_trial(
                    params={"beta": b, "rho": r}, value=value,
                    distributions={"beta": FloatDistribution(1.0, 20.0, log=True), "rho": FloatDistribution(0.05, 0.6)}))
        raw = optuna.importance.get_param_importances(
            alone, evaluator=optuna.importance.PedAnovaImportanceEvaluator(), normalize=False)
        total = sum(raw.values())
        widths = {n: bar.get_width() for n, bar in zip(names, container)}
        assert widths == pytest.approx({n: (raw[n] / total if total else 0.0) for n in names})
    shares = {n: bar.get_width() for n, bar in zip(names, ax.containers[0])}
    assert shares["beta"] > 0.5 > shares["rho"]  # acs: beta decides
    shares = {n: bar.get_width() for n, bar in zip(names, ax.containers[2])}
    assert shares["rho"] > 0.5 > shares["beta"]  # iaca: rho decides
    assert all(bar.get_width() == 0.0 for bar in ax.containers[1])  # mmas: nothing (not equal shares)
    fig2, ax2 = plt.subplots()
    try:
        with pytest.raises(jaco.ParamError, match="span 3 planners.*planner="):
            jaco.plot.plot_param_importance(study, ax=ax2)
        jaco.plot.plot_param_importance(study, ax=ax2, planner="acs")
        assert [c.get_label() for c in ax2.containers] == ["acs (30 trials)"] and len(fig2.axes) == 1
        assert ax2.get_title() == "parameter importance within acs (30 trials)"
    finally:
        plt.close(fig2)


@pytest.mark.parametrize("values, scale", [([0.3, 0.2, 0.25, 0.0, 0.1], "symlog"), ([0.3, 0.2, 0.25, 0.05], "log")])
def test_search_history_log_axis_keeps_a_gap_of_zero(values, scale):
    study = _search_study([("acs", 2.0, 0.1, v) for v in values], planners=("acs",))
    fig = jaco.plot.plot_search_history(study, log=True)
    ax = fig.axes[0]
    assert ax.get_yscale() == scale
    (line,) = ax.get_lines()
    np.testing.assert_allclose(line.get_ydata(), 100 * np.minimum.accumulate(values))  # the values as they are
    points = [c for c in ax.collections if c.get_label() == "trials"][0]
    np.testing.assert_allclose(points.get_offsets()[:, 1], 100 * np.asarray(values))
    fig.draw_without_rendering()  # a 0 on a plain log axis would be dropped; here it is drawn
    assert ax.get_ylim()[0] <= 0.0 if scale == "symlog" else ax.get_ylim()[0] > 0.0
    assert ax.get_ylabel().startswith("gap to the optimum (%) (log scale")
    if scale == "symlog":
        assert "linear below 10" in ax.get_ylabel()  # the smallest positive gap is 10%
    assert jaco.plot.plot_search_history(study).axes[0].get_yscale() == "linear"


def _comparison_of(columns):
    import pandas as pd

    from jaco.research import compare as cmp

    rows = [dict(config=name, seed=seed, success=math.isfinite(g), gap=g, optimal=100.0, length=100.0 * (1 + g))
            for name, gaps in columns.items() for seed, g in enumerate(gaps)]
    return cmp.compare(pd.DataFrame(rows), by="config", n_boot=20)


@pytest.mark.parametrize("n", [4, 14, 25])
def test_performance_profile_curves_are_all_told_apart(n):
    import dataclasses

    import pandas as pd

    base = [0.0, 0.1, 0.2, 0.05, 0.3, 0.0]
    columns = {f"c{i:02d}": [g + 0.02 * (i % 3) for g in base] for i in range(n - 2)}  # many exact ties
    columns["twin"] = list(columns["c00"])
    columns["never"] = [math.inf] * len(base)
    c = _comparison_of({k: columns[k] for k in ("c00", "c01", "twin", "never")})
    if n > 4:  # the same comparison with more configurations (compare itself takes seconds for them)
        ratios = pd.DataFrame(columns) + 1.0
        c = dataclasses.replace(c, ratios=ratios / ratios.min(axis=1).to_numpy()[:, None])
    fig = jaco.plot.plot_performance_profile(c)
    ax = fig.axes[0]
    lines = ax.get_lines()
    assert len(lines) == n
    colors = [tuple(np.round(matplotlib.colors.to_rgba(line.get_color()), 6)) for line in lines]
    assert len(set(colors)) == n  # a distinct colour for every configuration
    assert len({(line.get_linestyle(), line.get_marker()) for line in lines}) == n  # and a distinct style too
    assert len({(col, line.get_linestyle(), line.get_marker()) for col, line in zip(colors, lines)}) == n
    profile = c.profile()
    taus = profile.index.to_numpy(float)
    for line, name in zip(lines, profile.columns):
        rho = profile[name].to_numpy(float)
        np.testing.assert_array_equal(line.get_ydata()[:-1], rho)  # drawn exactly: no offset
        np.testing.assert_array_equal(line.get_xdata()[:-1], taus)
        steps = [i for i in range(len(rho)) if rho[i] != (rho[i - 1] if i else 0.0)]
        assert list(line.get_markevery()) == steps  # a marker where the curve steps up
        assert line.get_markerfacecolor() == "none"
    labels = {t.get_text() for t in ax.get_legend().get_texts()}
    assert "twin (same curve as c00)" in labels and "never (no path: on the τ axis)" in labels
    twins = [line for line in lines if line.get_label() in ("c00", "twin (same curve as c00)")]
    assert twins[0].get_linewidth() != twins[1].get_linewidth() or twins[0].get_marker() != twins[1].get_marker()
    by_width = sorted(lines, key=lambda line: line.get_linewidth())
    assert all(a.get_zorder() >= b.get_zorder() for a, b in zip(by_width, by_width[1:]))  # wider lines below
