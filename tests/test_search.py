"""jaco.search: spaces, samplers, multi-fidelity, durable studies that resume after SIGKILL."""

import math
import sqlite3
import subprocess
import sys
import textwrap
import time

import numpy as np
import pytest

import jaco
from jaco.research import search as S
from jaco.research.space import Categorical, Float, Int, SpaceError, parse_space

optuna = pytest.importorskip("optuna")

GRID = jaco.Grid.from_rows(
    [
        "..........",
        "..####....",
        "......#...",
        ".##...#.#.",
        "......#...",
        "...####...",
        "..........",
    ]
)
ENDS = ((6, 0), (0, 9))
SMALL = dict(seeds=2, n_ants=6, n_iters=8, progress=False)
SPACE = {"beta": (0.5, 12.0, "log"), "rho": (0.05, 0.6)}


def _no_compile(monkeypatch):
    """Any attempt to compile a sweep program fails the test (bad input must stop before)."""

    def boom(*a, **k):
        raise AssertionError("compiled before the error")

    monkeypatch.setattr(jaco.research.chunks, "_plan", boom)


# -- the space ---------------------------------------------------------------------------------
def test_space_forms_and_conditional_parameters():
    sp = parse_space(
        {
            "variant": ["iaca", "acs"],
            "beta": (1.0, 20.0, "log"),
            "q0": [0.5, 0.9],
            "n_ants": [10, 20],
            "xi": (0.0, 0.5),
            "alpha": 1.5,
        }
    )
    assert list(sp.planners) == ["iaca", "acs"]
    assert sp.dims["beta"] == Float(1.0, 20.0, True) and sp.dims["q0"] == Categorical((0.5, 0.9))
    assert sp.dims["n_ants"] == Categorical((10, 20)) and sp.fixed == {"alpha": 1.5}
    assert sp.uses("acs", "xi") and not sp.uses("iaca", "xi")  # ACS's local update only
    assert sp.conditional()
    assert parse_space({"w": (2, 12, "int")}, "ras").dims["w"] == Int(2, 12)


@pytest.mark.parametrize(
    "space, variant, match",
    [
        ({"beta": (5.0, 5.0)}, None, "empty range"),
        ({"beta": (3.0, 1.0)}, None, "empty range"),
        ({"rho": (0.0, 0.5, "log")}, None, "log range needs low > 0"),
        ({"bta": (1.0, 2.0)}, None, "unknown parameter 'bta'"),
        ({"q0": (0.5, 0.9)}, "mmas", "not used by planner 'mmas'"),
        ({"variant": ["acs", "nope"], "beta": (1.0, 2.0)}, None, "unknown planner 'nope'"),
        ({"beta": (1.0, 40.0)}, None, "out of range"),
        ({"n_ants": (1.0, 5.0)}, None, "a size is an integer"),
        ({"variant": [], "beta": (1.0, 2.0)}, None, "empty list of planners"),
        ({"alpha": 1.0}, None, "nothing to search"),
        ({"tau_min": (0.1, 30.0)}, "iaca", "tau_min < tau_max"),
        ({"beta": (1.0, 2.0, "cubic")}, None, "optional 'log'"),
    ],
)
def test_a_bad_space_is_one_line_before_anything_compiles(monkeypatch, space, variant, match):
    _no_compile(monkeypatch)
    with pytest.raises(jaco.JacoError, match=match) as e:
        jaco.search(GRID, *ENDS, space, planner=variant, trials=4, batch=2, **SMALL)
    assert "\n" not in str(e.value)


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(sampler="annealing"), "unknown sampler"),
        (dict(sampler="evosax:NoSuchES"), "unknown evosax strategy"),
        (dict(sampler="cmaes", objective=["gap", "turns"]), "one objective"),
        (dict(objective="speed"), "unknown objective"),
        (dict(trials=0), "trials must be a positive integer"),
        (dict(fidelity="halving", objective=["gap", "turns"]), "one objective"),
        (dict(penalty={"success": 1.0}), "only gap"),
        (dict(storage=12), "storage must be"),
        (dict(timeout=0), "timeout must be a positive finite number of seconds, got 0"),
        (dict(timeout=-5.0), "timeout must be a positive finite number"),
        (dict(timeout=float("nan")), "timeout must be a positive finite number"),
        (dict(timeout=math.inf), "timeout must be a positive finite number"),
        (dict(timeout=True), "timeout must be a positive finite number"),
        (dict(timeout="60"), "timeout must be a positive finite number"),
        (dict(trials=None), "give trials, timeout or both"),
        (dict(trials=None, timeout=5.0, sampler="grid"), "sampler 'grid' sizes its grid from trials"),
        (dict(worker=-1), "worker must be an integer >= 0"),
        (dict(heartbeat_interval=0), "heartbeat_interval must be a positive finite number"),
        (dict(heartbeat_interval=5, grace_period=5), r"grace_period \(5 s\) must be longer than heartbeat_interval"),
    ],
)
def test_bad_search_arguments_are_one_line_before_anything_compiles(monkeypatch, kwargs, match):
    _no_compile(monkeypatch)
    with pytest.raises(jaco.JacoError, match=match):
        jaco.search(GRID, *ENDS, SPACE, planner="acs", **{**dict(trials=4, batch=2, **SMALL), **kwargs})


def test_evosax_needs_real_ranges_of_one_planner(monkeypatch):
    _no_compile(monkeypatch)
    with pytest.raises(SpaceError, match="'variant' is the planner"):
        jaco.search(GRID, *ENDS, {"variant": ["acs", "mmas"], "beta": (1.0, 8.0)}, sampler="evosax:SNES", **SMALL)
    with pytest.raises(SpaceError, match="'n_ants' is not a"):
        jaco.search(GRID, *ENDS, {"beta": (1.0, 8.0), "n_ants": [4, 8]}, planner="acs", sampler="evosax:SNES", **SMALL)


# -- the search ------------------------------------------------------------------------------
def test_every_trial_equals_solve_with_its_parameters_and_seeds():
    study = jaco.search(
        GRID, *ENDS, {"variant": ["acs", "mmas"], **SPACE}, trials=6, batch=3, sampler="random", **SMALL
    )
    table = study.trials
    assert len(table) == 6 and set(table["state"]) == {"COMPLETE"} and set(table["generation"]) == {0, 1}
    for number in (0, 4):
        frozen = study.study.trials[number]
        runs = study.runs(number)
        for seed in (0, 1):
            r = jaco.solve(GRID, *ENDS, seed=seed, n_ants=6, n_iters=8, progress=False, **study._params(frozen))
            row = runs[runs["seed"] == seed].iloc[0]
            assert bool(row["success"]) == r.success and row["length"] == r.length and row["gap"] == r.gap
        assert table.loc[number, "gap_penalised_mean"] == pytest.approx(np.mean(runs["gap"]))  # every run succeeded here
    assert table.columns[3] == "planner" and set(table["planner"]) <= {"acs", "mmas"}


def test_best_so_far_never_worsens_and_best_params_solve():
    study = jaco.search(GRID, *ENDS, SPACE, planner="acs", trials=12, batch=4, sampler="tpe", seed=3, **SMALL)
    h = study.history()
    assert len(h) == 12 and (np.diff(h["best"]) <= 0).all()
    assert h["best"].iloc[-1] == study.best_value == h["value"].min()
    best = study.best_params
    assert set(best) == {"planner", "beta", "rho"} and best["planner"] == "acs"
    r = jaco.solve(GRID, *ENDS, seed=0, n_ants=6, n_iters=8, progress=False, **best)
    with pytest.warns(DeprecationWarning, match="best_params\\['variant'\\]"):
        assert best["variant"] == "acs"  # the former key still reads the planner
    old = {("variant" if k == "planner" else k): v for k, v in best.items()}  # params of an older jaco
    with pytest.warns(DeprecationWarning, match="variant= is the former name of planner="):
        again = jaco.solve(GRID, *ENDS, seed=0, n_ants=6, n_iters=8, progress=False, **old)
    assert again.length == r.length and again.variant == r.planner == "acs"


def test_a_seeded_sampler_proposes_the_same_trials_and_another_seed_others():
    def params(seed):
        st = jaco.search(GRID, *ENDS, SPACE, planner="acs", trials=8, batch=4, sampler="tpe", seed=seed, **SMALL)
        return st.trials[["beta", "rho"]].to_numpy()

    a, b, c = params(7), params(7), params(8)
    assert np.array_equal(a, b) and not np.array_equal(a, c)


def test_tpe_batches_are_not_one_point_repeated():
    study = jaco.search(GRID, *ENDS, SPACE, planner="acs", trials=24, batch=12, sampler="tpe", **SMALL)
    second = study.trials[study.trials["generation"] == 1]
    assert second["beta"].nunique() == 12  # the constant liar spreads a batch


def test_a_failed_run_counts_as_the_documented_penalty_never_nan():
    # steplimit 3 cannot reach a goal 9 columns away: every run fails
    study = jaco.search(
        GRID,
        *ENDS,
        SPACE,
        planner="acs",
        trials=2,
        batch=2,
        steplimit=3,
        sampler="random",
        objective=["gap", "length", "turns", "success"],
        **SMALL,
    )
    t = study.trials
    optimal = jaco.exact.shortest_path(GRID, *ENDS)[0]
    worst = math.sqrt(2) * 3
    assert (t["success"] == 0).all() and (t["success_rate"] == 0).all()
    assert np.allclose(t["length_penalised_mean"], worst) and np.allclose(t["gap_penalised_mean"], worst / optimal - 1)
    assert np.allclose(t["turns_penalised_mean"], 3) and t["gap_median"].isna().all()  # over successful runs: none
    given = jaco.search(
        GRID, *ENDS, SPACE, planner="acs", trials=2, batch=2, steplimit=3, sampler="random", penalty=2.5, **SMALL
    )
    assert (given.trials["gap_penalised_mean"] == 2.5).all()


@pytest.mark.slow  # several objectives: each trial at its own ants and iterations
def test_sizes_in_the_space_and_a_pareto_front_over_gap_and_budget():
    study = jaco.search(
        GRID,
        *ENDS,
        {"beta": (1.0, 8.0), "n_ants": [3, 6]},
        planner="acs",
        trials=8,
        batch=4,
        sampler="nsga2",
        objective=["gap", "budget"],
        seeds=2,
        n_iters=8,
        progress=False,
    )
    t = study.trials
    assert set(t["n_ants"]) <= {3, 6} and (t["budget"] == t["n_ants"] * 8).all()
    front = study.best_trials
    gap = "gap_penalised_mean"
    for _, row in front.iterrows():  # no trial is better on both objectives
        better = (
            (t[gap] <= row[gap])
            & (t["budget"] <= row["budget"])
            & ((t[gap] < row[gap]) | (t["budget"] < row["budget"]))
        )
        assert not better.any()


def test_turns_objective_counts_heading_changes_of_the_best_path():
    study = jaco.search(
        GRID, *ENDS, SPACE, planner="acs", trials=2, batch=2, sampler="random", objective="turns", **SMALL
    )
    frozen = study.study.trials[0]
    turns = [
        jaco.solve(GRID, *ENDS, seed=s, n_ants=6, n_iters=8, progress=False, **study._params(frozen)).metrics()["turns"]
        for s in (0, 1)
    ]
    assert study.trials.loc[0, "turns_penalised_mean"] == np.mean(turns)


def test_repeated_generations_and_searches_never_recompile():
    jaco.engine.cache.clear_compiled()
    kw = dict(planner="acs", batch=4, sampler="random", **SMALL)
    first = jaco.search(GRID, *ENDS, SPACE, trials=12, **kw)  # 3 generations of 4: one program
    assert first.timings["compiles"] == 1 and first.timings["generations"] == 3
    again = jaco.search(GRID, *ENDS, SPACE, trials=6, **kw)  # 4 + 2 trials: chunks of 4 and 2 (powers of two)
    assert again.timings["compiles"] == 1
    third = jaco.search(GRID, *ENDS, SPACE, trials=6, seed=5, **kw)
    assert third.timings["compiles"] == 0


# -- the timeout -------------------------------------------------------------------------------------
def _fake_clock(monkeypatch, seconds_per_batch):
    """The timeout's clock advances only while a batch is evaluated, by ``seconds_per_batch``."""
    now = [0.0]
    real = S.Evaluator.__call__

    def timed(self, jobs):
        now[0] += seconds_per_batch
        return real(self, jobs)

    monkeypatch.setattr(S, "_clock", lambda: now[0])
    monkeypatch.setattr(S.Evaluator, "__call__", timed)


def test_the_running_batch_finishes_no_new_one_starts_and_trials_may_come_first(monkeypatch):
    _fake_clock(monkeypatch, 10.0)
    kw = dict(planner="acs", batch=2, sampler="random", **SMALL)
    study = jaco.search(GRID, *ENDS, SPACE, trials=None, timeout=25, **kw)
    # batches end at 10, 20 and 30 s: the third started before the 25 s budget passed and finished
    assert study.timings["generations"] == 3 and len(study.trials) == 6 and set(study.trials["state"]) == {"COMPLETE"}
    assert study.stopped == "timeout after 25 s: 6 trials finished"
    first = jaco.search(GRID, *ENDS, SPACE, trials=4, timeout=25, **kw)  # whichever comes first
    assert len(first.trials) == 4 and first.stopped == "trials reached: 4 trials finished"


def test_a_timeout_lets_the_running_bracket_finish(monkeypatch):
    _fake_clock(monkeypatch, 10.0)
    study = jaco.search(
        GRID,
        *ENDS,
        SPACE,
        planner="acs",
        trials=None,
        timeout=5,
        batch=3,
        sampler="random",
        fidelity="halving",
        seeds=2,
        n_ants=6,
        n_iters=9,
        progress=False,
    )
    # rungs at 1, 3 and 9 iterations: three batches of one bracket, nothing left RUNNING
    assert sorted(study.trials["state"]) == ["COMPLETE", "PRUNED", "PRUNED"]
    assert study.stopped == "timeout after 5 s: 3 trials finished"


def test_a_search_with_only_a_timeout_stops_and_stores_every_batch(tmp_path):
    db = str(tmp_path / "t.db")
    t0 = time.monotonic()
    study = jaco.search(
        GRID, *ENDS, SPACE, planner="acs", trials=None, timeout=2.0, batch=4, sampler="random", storage=db, **SMALL
    )
    assert time.monotonic() - t0 >= 2.0  # with trials=None only the timeout stops it
    stored = jaco.load_study(db)
    states = stored.trials["state"]
    assert len(states) >= 4 and len(states) % 4 == 0 and set(states) == {"COMPLETE"}  # whole batches, none RUNNING
    assert stored.stopped == study.stopped == f"timeout after 2 s: {len(states)} trials finished"


def test_a_tiny_timeout_runs_one_batch_and_a_resumed_study_gets_it_afresh(tmp_path):
    db = str(tmp_path / "t.db")
    kw = dict(planner="acs", trials=None, timeout=1e-3, batch=4, sampler="random", storage=db, **SMALL)
    first = jaco.search(GRID, *ENDS, SPACE, **kw)  # the first batch always runs
    assert first.timings["generations"] == 1 and len(first.trials) == 4
    assert first.stopped == "timeout after 0.001 s: 4 trials finished"
    before = {t.number: t.values for t in first.study.trials}
    again = jaco.search(GRID, *ENDS, SPACE, **kw)  # the budget counts from this call: one more batch
    t = again.trials
    assert len(t) == 8 and set(t["state"]) == {"COMPLETE"} and list(t["generation"]) == [0] * 4 + [1] * 4
    assert {n: again.study.trials[n].values for n in before} == before  # the stored trials stay as they were
    assert jaco.load_study(db).stopped == "timeout after 0.001 s: 8 trials finished"


# -- multi-fidelity ------------------------------------------------------------------------------
def test_halving_rungs_promote_the_best_third_and_rerun_at_the_larger_budget():
    assert S.Halving(eta=3).rungs(27) == [3, 9, 27]
    assert S.Halving(min_iters=2, eta=2).rungs(8) == [2, 4, 8]
    assert S.Halving(eta=3, hyperband=True).brackets(9) == [[1, 3, 9], [3, 9], [9]]
    study = jaco.search(
        GRID,
        *ENDS,
        SPACE,
        planner="acs",
        trials=9,
        batch=9,
        sampler="random",
        fidelity="halving",
        seeds=2,
        n_ants=6,
        n_iters=9,
        progress=False,
    )
    t = study.trials
    assert list(t["state"].value_counts().sort_index()) == [1, 8]  # COMPLETE 1, PRUNED 8
    at1 = {tr.number: tr.intermediate_values[1] for tr in study.study.trials}
    best3 = sorted(at1, key=lambda n: (at1[n], n))[:3]
    assert set(t[t["n_iters"] >= 3]["number"]) == set(best3)
    winner = t[t["state"] == "COMPLETE"].iloc[0]
    assert winner["n_iters"] == 9 and winner["iterations"] == 6 * 2 * (1 + 3 + 9)
    # a promoted trial was re-run: its value at 3 iterations is a plain 3-iteration solve
    frozen = study.study.trials[int(winner["number"])]
    r = [jaco.solve(GRID, *ENDS, seed=s, n_ants=6, n_iters=3, progress=False, **study._params(frozen)) for s in (0, 1)]
    assert frozen.intermediate_values[3] == pytest.approx(np.mean([x.gap for x in r]), abs=0)
    assert study.rerun(int(winner["number"])).matched


# -- evosax ---------------------------------------------------------------------------------------
@pytest.mark.slow  # evosax strategies compile their own programs
def test_evosax_strategy_searches_and_replays_after_an_interruption(tmp_path, monkeypatch):
    pytest.importorskip("evosax")
    kw = dict(planner="acs", trials=12, batch=4, sampler="evosax:SNES", **SMALL)
    whole = jaco.search(GRID, *ENDS, SPACE, **kw).trials[["beta", "rho", "gap_penalised_mean"]]
    assert whole["beta"].between(0.5, 12.0).all() and whole["rho"].between(0.05, 0.6).all()
    db = f"sqlite:///{tmp_path / 'es.db'}"
    calls = []
    real = S.Evaluator.__call__

    def dies_in_generation_2(self, jobs):
        calls.append(len(jobs))
        if len(calls) == 2:
            real(self, jobs[:2])
            raise KeyboardInterrupt
        return real(self, jobs)

    monkeypatch.setattr(S.Evaluator, "__call__", dies_in_generation_2)
    with pytest.raises(KeyboardInterrupt):
        jaco.search(GRID, *ENDS, SPACE, storage=db, **kw)
    monkeypatch.setattr(S.Evaluator, "__call__", real)
    resumed = jaco.search(GRID, *ENDS, SPACE, storage=db, **kw)
    t = resumed.trials
    # the interrupted generation's members were failed and asked again (the same proposals)
    assert list(t["state"]) == ["COMPLETE"] * 4 + ["FAIL"] * 4 + ["COMPLETE"] * 8
    t = t[t["state"] == "COMPLETE"]
    assert np.array_equal(t[["beta", "rho", "gap_penalised_mean"]].to_numpy(), whole.to_numpy())  # the same search, bit for bit


def test_tune_estimator_is_evosax_open_es_gradient():
    """jaco.tune hand-writes OpenES's estimator (antithetic pairs, centered ranks): same gradient."""
    pytest.importorskip("evosax")
    import jax
    import jax.numpy as jnp
    from evosax.core.fitness_shaping import centered_rank_fitness_shaping_fn

    from jaco.research.tuning import es_gradient

    e = jax.random.normal(jax.random.key(0), (4, 3))
    eps = jnp.concatenate([e, -e])
    f = jnp.array([3.0, 1.0, 4.0, 1.5, 5.0, 9.0, 2.0, 6.0])
    sigma = 0.5
    ours = es_gradient(eps, f, sigma)
    shaped = centered_rank_fitness_shaping_fn(eps, f, None, None)
    theirs = jnp.dot(shaped, eps) / (8 * sigma)  # evosax Open_ES._tell: (population - mean) / std is eps
    np.testing.assert_allclose(np.asarray(ours), np.asarray(theirs), rtol=1e-6)


# -- durable studies -------------------------------------------------------------------------------
def test_interrupted_batch_resumes_without_loss_or_double_evaluation(tmp_path, monkeypatch):
    db = f"sqlite:///{tmp_path / 's.db'}"
    kw = dict(planner="acs", trials=8, batch=4, sampler="tpe", storage=db, study_name="t", **SMALL)
    real = S.Evaluator.__call__
    state = {"n": 0}

    def interrupted(self, jobs):
        state["n"] += 1
        if state["n"] == 2:
            raise KeyboardInterrupt  # Ctrl-C while the second batch runs
        return real(self, jobs)

    monkeypatch.setattr(S.Evaluator, "__call__", interrupted)
    with pytest.raises(KeyboardInterrupt):
        jaco.search(GRID, *ENDS, SPACE, **kw)
    before = {t.number: (t.state.name, t.values, t.datetime_complete) for t in jaco.load_study(db).study.trials}
    assert sorted(s for s, _, _ in before.values()) == ["COMPLETE"] * 4 + ["RUNNING"] * 4
    monkeypatch.setattr(S.Evaluator, "__call__", real)
    seen = []
    monkeypatch.setattr(
        S.Evaluator, "__call__", lambda self, jobs: (seen.extend(j.trial.number for j in jobs), real(self, jobs))[1]
    )
    study = jaco.search(GRID, *ENDS, SPACE, **kw)
    # each stale trial is failed and evaluated again once, as a new trial that names it (retry_of)
    assert sorted(seen) == [8, 9, 10, 11]
    after = {t.number: (t.state.name, t.values, t.datetime_complete) for t in study.study.trials}
    retried = {t.number: t.user_attrs["jaco_trial"].get("retry_of") for t in study.study.trials}
    assert [retried[n] for n in seen] == [4, 5, 6, 7]
    assert [after[n][0] for n in range(12)] == ["COMPLETE"] * 4 + ["FAIL"] * 4 + ["COMPLETE"] * 4
    for n, old in before.items():
        if old[0] == "COMPLETE":
            assert after[n] == old  # a finished trial is never evaluated again
        else:  # the retry has the stale trial's parameters
            assert study.study.trials[n + 4].params == study.study.trials[n].params


def test_a_resumed_study_must_be_the_same_search(tmp_path):
    db = str(tmp_path / "s.db")
    jaco.search(GRID, *ENDS, SPACE, planner="acs", trials=2, batch=2, sampler="random", storage=db, **SMALL)
    with pytest.raises(S.SearchError, match="differs in: space"):
        jaco.search(
            GRID, *ENDS, {"beta": (1.0, 3.0)}, planner="acs", trials=2, batch=2, sampler="random", storage=db, **SMALL
        )
    more = jaco.search(GRID, *ENDS, SPACE, planner="acs", trials=4, batch=2, sampler="random", storage=db, **SMALL)
    assert len(more.trials) == 4  # more trials extend the study


@pytest.mark.slow  # the CLI test reruns a stored trial in the normal run
def test_a_stored_trial_reruns_to_its_stored_value(tmp_path):
    db = str(tmp_path / "s.journal")
    jaco.search(
        GRID, *ENDS, {"variant": ["acs", "iaca"], **SPACE}, trials=4, batch=4, sampler="random", storage=db, **SMALL
    )
    study = jaco.load_study(db)
    for number in range(4):
        rec = study.rerun(number)
        assert rec.matched, rec.differences
    for number in range(4):  # the stored value is the mean of the stored runs
        runs = study.runs(number)
        if runs["success"].all():
            assert study.trials.loc[number, "gap_penalised_mean"] == np.mean(runs["gap"])
    # a stored run that differs from its rerun is reported
    trial = study.study.trials[1]  # a copy: changing it changes nothing stored
    key = next(iter(trial.user_attrs["jaco_runs"]))
    trial.user_attrs["jaco_runs"][key]["length"][0][0] = 1.0
    rerun = S.TrialRecord(study.info, trial).rerun()
    assert not rerun.matched and "length: 1 of 2 runs differ" in rerun.differences[0]


KILLED = textwrap.dedent("""
    import sys, jaco
    grid = jaco.Grid.from_rows({rows!r})
    jaco.search(grid, {start}, {goal}, {space!r}, planner="acs", trials=60, batch=4, seeds=2, n_ants=6, n_iters=40,
                sampler="tpe", storage=sys.argv[1], progress=False)
""")


@pytest.mark.slow
def test_resume_after_sigkill_loses_nothing_and_duplicates_nothing(tmp_path, kill_after):
    db = tmp_path / "k.db"
    script = KILLED.format(rows=GRID.to_rows(), start=ENDS[0], goal=ENDS[1], space=SPACE)
    proc = subprocess.Popen([sys.executable, "-c", script, str(db)], cwd=tmp_path)

    def complete():
        with sqlite3.connect(db, timeout=0.1) as con:
            return con.execute("SELECT COUNT(*) FROM trials WHERE state = 'COMPLETE'").fetchone()[0]

    kill_after(proc, complete, 8, "search")
    killed = {t.number: (t.state.name, t.values) for t in jaco.load_study(str(db)).study.trials}
    assert 8 <= sum(s == "COMPLETE" for s, _ in killed.values()) < 60
    study = jaco.search(
        GRID,
        *ENDS,
        SPACE,
        planner="acs",
        trials=60,
        batch=4,
        seeds=2,
        n_ants=6,
        n_iters=40,
        sampler="tpe",
        storage=str(db),
        progress=False,
        heartbeat_interval=0.5,
        grace_period=2.0,
    )
    trials = study.study.trials
    assert [t.number for t in trials] == list(range(len(trials)))
    assert sum(t.state.name == "COMPLETE" for t in trials) == 60
    # nothing stays RUNNING; a killed trial is FAIL: never evaluated (killed before its parameters
    # were stored) or evaluated again exactly once, as a later trial with its parameters
    retries = [t.user_attrs["jaco_trial"].get("retry_of") for t in trials if "jaco_trial" in t.user_attrs]
    for t in trials:
        assert t.state.name in ("COMPLETE", "FAIL")
        if t.state.name == "FAIL" and "jaco_trial" in t.user_attrs:
            assert killed[t.number][0] == "RUNNING" and retries.count(t.number) == 1
            (again,) = [r for r in trials if r.user_attrs.get("jaco_trial", {}).get("retry_of") == t.number]
            assert again.state.name == "COMPLETE" and again.params == t.params
    for n, (s, v) in killed.items():
        if s == "COMPLETE":
            assert trials[n].values == v  # kept, not evaluated again
    assert all(study.rerun(n).matched for n in (0, len(trials) - 1))


# -- the command line ---------------------------------------------------------------------------------
def test_cli_search_resumes_prints_the_best_and_reruns_a_trial(tmp_path, capsys):
    from jaco.cli import main

    db = str(tmp_path / "cli.db")
    args = [
        "search",
        "demo",
        "--variant",
        "acs",
        "--param",
        "beta=1:10:log",
        "--param",
        "rho=0.05:0.5",
        "--trials",
        "4",
        "--batch",
        "2",
        "--seeds",
        "2",
        "--ants",
        "6",
        "--iters",
        "8",
        "--sampler",
        "random",
        "--storage",
        db,
        "--csv",
        str(tmp_path / "t.csv"),
        "--plot",
        str(tmp_path / "h.png"),
    ]
    assert main(args) == 0
    out = capsys.readouterr().out
    assert "best: trial" in out and "optuna-dashboard sqlite:///" in out and (tmp_path / "h.png").stat().st_size > 0
    assert "gap_penalised_mean" in out and "gap_median" in out and "variant" not in out
    text = (tmp_path / "t.csv").read_text()
    table = __import__("pandas").read_csv(tmp_path / "t.csv")
    assert len(table) == 4 and table["gap_penalised_mean"].notna().all() and set(table["planner"]) == {"acs"}
    # floats at float32 precision, as every CSV jaco writes: each the shortest decimal of its float32
    trials = jaco.load_study(db).trials
    for col in ("beta", "rho", "gap_penalised_mean", "gap_median", "length_mean", "end_s"):
        back, exact = table[col].to_numpy(np.float64), trials[col].to_numpy(np.float64)
        assert back.astype(np.float32).tobytes() == exact.astype(np.float32).tobytes(), col
        assert all(str(np.float32(x)) in text for x in exact if np.isfinite(x)), col
    assert not [cell for line in text.splitlines()[1:] for cell in line.split(",") if len(cell) > 16]  # no float64 noise
    assert main(args[: args.index("--trials") + 1] + ["6"] + args[args.index("--trials") + 2 :]) == 0
    assert "6 trials in the study" in capsys.readouterr().out
    assert main(["rerun", db, "--trial", "5"]) == 0
    assert "matched the stored trial bit for bit" in capsys.readouterr().out


def test_cli_search_timeout_stops_says_why_and_resumes(tmp_path, capsys):
    from jaco.cli import main

    db = str(tmp_path / "cli.db")
    args = [
        "search",
        "demo",
        "--variant",
        "acs",
        "--param",
        "beta=1:10:log",
        "--param",
        "rho=0.05:0.5",
        "--timeout",
        "0.001",
        "--batch",
        "2",
        "--seeds",
        "2",
        "--ants",
        "6",
        "--iters",
        "8",
        "--sampler",
        "random",
        "--storage",
        db,
    ]
    assert main(args) == 0  # --timeout alone: until it, and the first batch always runs
    out = capsys.readouterr().out
    assert ": 0.001 s in batches of 2" in out and "stopped: timeout after 0.001 s: 2 trials finished" in out
    assert main(args + ["--trials", "3"]) == 0  # resumed: 3 trials is reached first
    out = capsys.readouterr().out
    assert "3 trials or 0.001 s, whichever comes first" in out and "stopped: trials reached: 3 trials finished" in out
    assert jaco.load_study(db).stopped == "trials reached: 3 trials finished"


@pytest.mark.parametrize("value", ["0", "-5", "nan", "inf", "soon"])
def test_cli_bad_timeout_is_one_line_and_exit_2(value, capsys, monkeypatch):
    from jaco.cli import main

    _no_compile(monkeypatch)
    assert main(["search", "demo", "--param", "beta=1:10", "--timeout", value]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("jaco: error:") and "--timeout" in err and "positive finite number of seconds" in err
    assert "\n" not in err


@pytest.mark.parametrize(
    "param, match",
    [
        ("beta=1:20:5", "sweep's form"),
        ("beta=3:3", "empty range"),
        ("rho=0:0.5:log", "log range needs low > 0"),
        ("q0=0.5:0.9", "not used by planner 'mmas'"),
        ("bogus=1:2", "unknown parameter 'bogus'"),
    ],
)
def test_cli_bad_space_is_one_line_and_exit_2(param, match, capsys, monkeypatch):
    from jaco.cli import main

    _no_compile(monkeypatch)
    assert main(["search", "demo", "--param", param, "--trials", "2"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("jaco: error:") and match in err and "\n" not in err


def test_a_study_opened_by_two_workers_at_once_is_jacos_and_a_foreign_one_is_refused(tmp_path):
    """attach_info reads the study's info, then its trials. Another worker that opened the study at
    the same moment may attach its info and ask a trial between the two reads: the info is read
    again then, not taken for a study someone else made. A study with trials and no info is
    refused with one line."""
    import optuna

    from jaco.research.search_checks import SearchError
    from jaco.research.search_setup import ATTR, attach_info

    optuna.logging.set_verbosity(optuna.logging.WARNING)
    storage = f"sqlite:///{tmp_path / 's.db'}"
    info = {"space": {"beta": [1.0, 8.0]}}
    mine = optuna.create_study(storage=storage, study_name="s")
    other = optuna.load_study(storage=storage, study_name="s")
    first = type(mine).user_attrs.fget(mine)  # what this worker read first: no info yet
    assert first == {}
    other.set_user_attr(ATTR, info)  # the other worker attaches its info, then asks a trial
    other.ask()

    class FirstReadEarly:  # this worker's first read happened before the other worker's writes
        study_name, trials = mine.study_name, mine.trials
        reads = iter([first])

        @property
        def user_attrs(self):
            early = next(self.reads, None)
            return mine.user_attrs if early is None else early

    attach_info(FirstReadEarly(), info, storage)  # the same search: no error
    foreign = optuna.create_study(storage=storage, study_name="plain")
    foreign.ask()
    with pytest.raises(SearchError, match="was not made by jaco.search"):
        attach_info(foreign, info, storage)
