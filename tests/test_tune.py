"""jaco.tune: transforms, fitness shaping, the ES estimator, validation before compiling, and that
tuned parameters beat a poor starting point on held-out seeds."""

import math

import jax
import jax.numpy as jnp
import numpy as np
import optax
import pandas as pd
import pytest

import jaco
from jaco.engine.params import SPECS
from jaco.engine.run import TRACES
from jaco.research.tuning import TUNABLE, centered_ranks, es_gradient, member_objective, to_params, to_unconstrained

# A 16×16 map on which β = 0.5 is poor for `as` with few ants: about a quarter of the runs fail
# and the rest are about twice the optimum; β ≈ 4–8 finds near-optimal paths every time.
SMALL = dict(n_ants=10, n_iters=10)
ES = dict(steps=30, population=16, n_seeds=2)
HELD_OUT = list(range(1000, 1032))


@pytest.fixture(scope="module")
def poor_start():
    grid = jaco.maps.random_map(16, 0.2, seed=1)
    return grid, grid.meta["start"], grid.meta["goal"]


# -- transforms --------------------------------------------------------------------------------
def test_transforms_round_trip_and_stay_in_range():
    names = TUNABLE
    values = []
    for n in names:
        spec = SPECS[n]
        hi = spec.hi if math.isfinite(spec.hi) else spec.lo + 10.0
        values.append(spec.lo + 0.37 * (hi - spec.lo))
    z = to_unconstrained(names, values)
    back = np.asarray(to_params(names, jnp.asarray(z, jnp.float32)), np.float64)
    np.testing.assert_allclose(back, values, rtol=1e-4)
    # Whatever the optimiser does, a value never leaves its range (open ends included).
    for extreme in (-1e4, -30.0, 30.0, 1e4):
        x = np.asarray(to_params(names, jnp.full((len(names),), extreme, jnp.float32)), np.float64)
        for n, v in zip(names, x):
            assert SPECS[n].contains(np.asarray(v)), (n, extreme, v)


def test_transform_kinds_follow_the_specs():
    # (0, 1) → logit, (0, ∞) → log, [0, 20] → scaled logit.
    z = np.array([0.0, 0.0, 0.0], np.float32)
    rho, q, beta = np.asarray(to_params(("rho", "q", "beta"), z))
    assert rho == pytest.approx(0.5) and q == pytest.approx(1.0) and beta == pytest.approx(10.0)
    assert to_unconstrained(("q",), [math.e])[0] == pytest.approx(1.0)
    assert to_unconstrained(("rho",), [0.2])[0] == pytest.approx(math.log(0.2 / 0.8))
    # A starting value on a closed end moves 0.1 % of the range inside.
    assert float(to_params(("beta",), to_unconstrained(("beta",), [0.0]).astype(np.float32))[0]) == pytest.approx(0.02)
    assert "tau_min" not in TUNABLE and "q1" not in TUNABLE and "alpha" in TUNABLE


# -- fitness shaping and the estimator ---------------------------------------------------------
def test_centered_ranks_by_hand():
    np.testing.assert_allclose(centered_ranks(jnp.array([3.0, 1.0, 2.0, 10.0])), [1 / 6, -0.5, -1 / 6, 0.5], atol=1e-7)
    # Ties share their mean rank: equal objectives contribute nothing.
    np.testing.assert_allclose(centered_ranks(jnp.array([5.0, 5.0, 1.0, 9.0])), [0.0, 0.0, -0.5, 0.5], atol=1e-7)
    np.testing.assert_allclose(centered_ranks(jnp.full(6, 2.0)), 0.0)


def test_es_gradient_by_hand_and_on_a_quadratic():
    eps = jnp.array([[1.0, 0.0], [0.0, 2.0], [-1.0, 0.0], [0.0, -2.0]])
    f = jnp.array([4.0, 1.0, 0.0, 3.0])  # ranks 3, 1, 0, 2 → u = 1/2, −1/6, −1/2, 1/6
    g = es_gradient(eps, f, 0.5)
    np.testing.assert_allclose(g, [(0.5 + 0.5) / 2.0, (-2 / 6 - 2 / 6) / 2.0], rtol=1e-6)
    # Antithetic ES on f(z) = |z − c|² points along the true gradient 2(z − c).
    z, c = jnp.array([1.0, -2.0, 0.5]), jnp.array([0.0, 1.0, 0.0])
    e = jax.random.normal(jax.random.key(0), (2000, 3))
    eps = jnp.concatenate([e, -e])
    f = jnp.sum((z[None, :] + 0.1 * eps - c[None, :]) ** 2, axis=1)
    g = es_gradient(eps, f, 0.1)
    true = 2 * (z - c)
    assert float(g @ true / (jnp.linalg.norm(g) * jnp.linalg.norm(true))) > 0.99


def test_failed_runs_count_as_the_penalty():
    cost = jnp.array([[10.0, jnp.inf], [jnp.inf, jnp.inf], [4.0, 6.0]])
    np.testing.assert_allclose(member_objective(cost, 100.0), [55.0, 100.0, 5.0])


# -- validation before compiling ---------------------------------------------------------------
@pytest.mark.parametrize(
    "kwargs, error, match",
    [
        (dict(tune=("alpha", "gamma_x")), jaco.ParamError, "unknown parameter 'gamma_x'"),
        (dict(planner="iaca", tune=("tau_min",)), jaco.ParamError, "cannot be tuned.*tau_min < tau_max"),
        (dict(tune=("q0",)), jaco.ParamError, "does not use parameter 'q0'"),
        (dict(planner="idaca", tune=("alpha",)), jaco.ParamError, "does not use parameter 'alpha'"),
        (dict(tune=()), jaco.ParamError, "at least one"),
        (dict(tune=("beta", "beta")), jaco.ParamError, "named twice"),
        (dict(population=5), jaco.JacoError, "population must be an even integer"),
        (dict(steps=0), jaco.JacoError, "steps must be a positive integer"),
        (dict(n_seeds=1.5), jaco.JacoError, "n_seeds must be a positive integer"),
        (dict(n_ants=0), jaco.JacoError, "n_ants must be a positive integer"),
        (dict(sigma=-0.1), jaco.JacoError, "sigma must be a positive finite number"),
        (dict(penalty=float("nan")), jaco.JacoError, "penalty must be a positive finite number"),
        (dict(optimizer="adam"), jaco.JacoError, "optax GradientTransformation"),
        (dict(init={"beta": 50.0}), jaco.ParamError, "'beta' = 50 is out of range"),
        (dict(init={"q0": 0.5}), jaco.ParamError, "unknown parameter 'q0'"),
        (dict(init={"beta": [1.0, 2.0]}), jaco.JacoError, "one value per parameter"),
        (dict(seed=1.5), jaco.JacoError, "seed must be an integer"),
    ],
)
def test_bad_input_is_a_clear_error_before_compiling(kwargs, error, match):
    grid = jaco.Grid.from_rows(["....", ".##.", "...."])
    kwargs = {"planner": "as", **kwargs}
    planner = kwargs.pop("planner")
    before = dict(TRACES)
    with pytest.raises(error, match=match):
        jaco.tune(grid, (0, 0), (2, 3), planner, **kwargs)
    assert dict(TRACES) == before


def test_unreachable_goal_is_a_problem_error():
    grid = jaco.Grid.from_rows(["..#..", "..#..", "..#.."])
    with pytest.raises(jaco.ProblemError, match="cannot be reached"):
        jaco.tune(grid, (0, 0), (0, 4), "as")


# -- tuning ------------------------------------------------------------------------------------
def _held_out_mean(grid, start, goal, params, penalty):
    table = jaco.sweep(grid, start, goal, "as", params={k: [v] for k, v in params.items()}, seeds=HELD_OUT, **SMALL)
    return float(np.where(table.success, table.cost, penalty).mean())


def test_tuned_parameters_beat_a_poor_start_on_held_out_seeds(poor_start):
    grid, start, goal = poor_start
    res = jaco.tune(grid, start, goal, "as", init={"beta": 0.5}, seed=0, **ES, **SMALL)
    assert res.init["beta"] == 0.5 and res.tuned == ("alpha", "beta", "rho")
    assert set(res.params) == set(jaco.PLANNERS["as"].params)
    assert list(res.history.columns) == ["step", "objective", "success_rate", "alpha", "beta", "rho"]
    assert len(res.history) == ES["steps"] and np.isfinite(res.history.objective).all()
    assert res.history.beta.iloc[0] == pytest.approx(0.5, rel=1e-5)
    # The penalty is √2 × the path buffer (the step limit 4·(16 + 16) = 128, a whole number of chunks).
    assert res.penalty == pytest.approx(math.sqrt(2) * 128)
    # On seeds the tuning never saw, the tuned parameters give a lower mean cost.
    before = _held_out_mean(grid, start, goal, res.init, res.penalty)
    after = _held_out_mean(grid, start, goal, res.params, res.penalty)
    assert after < 0.8 * before, (before, after, res.params)
    assert res.params["beta"] > 1.0  # the heuristic matters on this map
    for name in res.tuned:
        spec = SPECS[name]
        assert spec.contains(np.asarray(res.params[name]))


def test_same_seed_same_result_other_seed_other_result_and_no_recompile(poor_start):
    grid, start, goal = poor_start
    a = jaco.tune(grid, start, goal, "as", init={"beta": 0.5}, seed=3, **ES, **SMALL)
    before = TRACES["as"]
    b = jaco.tune(grid, start, goal, "as", init={"beta": 0.5}, seed=3, **ES, **SMALL)
    c = jaco.tune(grid, start, goal, "as", init={"beta": 2.0}, seed=4, sigma=0.3, **ES, **SMALL)
    other = jaco.maps.random_map(16, 0.1, seed=2)  # another map of the same shape
    jaco.tune(other, (0, 0), (15, 15), "as", seed=5, **ES, **SMALL)
    assert TRACES["as"] == before
    assert a.params == b.params and a.history.equals(b.history)
    assert a.params != c.params


def test_any_optax_optimiser_is_used_as_given():
    grid = jaco.Grid.from_rows(["....", ".#..", "...."])
    zero = optax.set_to_zero()  # no step at all: the parameters stay where they started
    res = jaco.tune(grid, (0, 0), (2, 3), "mmas", tune=("rho", "q"), init={"rho": 0.2, "q": 3.0},
                    optimizer=zero, steps=3, population=4, n_ants=4, n_iters=3)
    assert res.params["rho"] == pytest.approx(0.2, rel=1e-5) and res.params["q"] == pytest.approx(3.0, rel=1e-5)
    np.testing.assert_allclose(res.history.rho, 0.2, rtol=1e-5)
    assert res.params["alpha"] == jaco.PLANNERS["mmas"].defaults["alpha"]  # untuned: unchanged
    assert callable(jaco.tune) and jaco.research.tuning.TuneResult is jaco.TuneResult


def test_tune_progress_bar_counts_steps_and_changes_nothing(capsys):
    grid = jaco.maps.random_map(10, 0.1, seed=0)
    kw = dict(tune=("beta",), steps=3, population=4, n_seeds=1, n_ants=6, n_iters=4)
    shown = jaco.tune(grid, (0, 0), (9, 9), "as", progress=True, **kw)
    err = capsys.readouterr().err
    assert "tune as" in err and "3/3" in err
    before = TRACES["as"]
    plain = jaco.tune(grid, (0, 0), (9, 9), "as", progress=False, **kw)
    assert capsys.readouterr().err == "" and TRACES["as"] == before  # one program with or without a bar
    assert shown.params == plain.params
    pd.testing.assert_frame_equal(shown.history, plain.history)
