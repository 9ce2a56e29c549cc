"""pg-aco (jaco.planners.pg): the score function against jax.grad, the advantages by hand, the optax step
and its state in the carry, and that the colony learns (the shared contract runs in
tests/test_variants.py)."""

import jax
import jax.numpy as jnp
import numpy as np
import optax
import pytest

import jaco
from jaco.engine.checks import params_from, resolve_params
from jaco.engine.colony import move_weights
from jaco.engine.pheromone import Trail
from jaco.engine.problem import make_problem, to_device
from jaco.moves import MOVES
from jaco.planners.pg import LOGIT_MAX, PG_ACO, advantages, make_pg_aco, score, step_probabilities

GRID_ROWS = ["....", ".#..", "...."]
# A hand path on the 3×4 map above: right, right, down-right, down. At (0, 1) the start is tabu.
HAND = [(0, 0), (0, 1), (0, 2), (1, 3), (2, 3)]


def _record(grid, paths, s_pad=8):
    """Step-major cells/moves (S, A) of hand paths."""
    cells = np.full((s_pad, len(paths)), -1, np.int32)
    moves = np.full((s_pad, len(paths)), -1, np.int32)
    for a, path in enumerate(paths):
        for t, (u, v) in enumerate(zip(path[:-1], path[1:])):
            d = (v[0] - u[0], v[1] - u[1])
            moves[t, a] = int(np.flatnonzero((MOVES == d).all(axis=1))[0])
            cells[t, a] = grid.index(v)
    return jnp.asarray(cells), jnp.asarray(moves)


def _log_prob(theta, grid, problem, eta_beta, path):
    """log p(path) by the definition (1): a softmax of θ + log η^β over the allowed non-tabu moves
    at every step, written step by step with a Python set for the tabu list."""
    n = grid.n_cells
    nbr = np.asarray(problem.nbr)
    logits = theta.reshape(n, 8) + jnp.log(eta_beta)
    total, seen = 0.0, {grid.index(path[0])}
    for u, v in zip(path[:-1], path[1:]):
        i, j = grid.index(u), grid.index(v)
        allowed = np.array([nbr[i, k] >= 0 and nbr[i, k] not in seen for k in range(8)])
        k = int(np.flatnonzero(nbr[i] == j)[0])
        total = total + logits[i, k] - jax.nn.logsumexp(jnp.where(allowed, logits[i], -jnp.inf))
        seen.add(j)
    return total


@pytest.mark.slow  # jax.grad of the whole walk compiles a program of its own
def test_score_function_equals_jax_grad_of_the_log_probability():
    grid = jaco.Grid.from_rows(GRID_ROWS)
    problem = to_device(make_problem(grid, (0, 0), (2, 3)))
    n = grid.n_cells
    theta = jax.random.normal(jax.random.key(0), (8 * n,))
    eta_beta = jax.random.uniform(jax.random.key(1), (n, 8), minval=0.2, maxval=3.0)
    weights = jnp.where(problem.nbr >= 0, jnp.exp(theta.reshape(n, 8)) * eta_beta, 0.0)
    other = [(0, 0), (1, 0), (2, 0), (2, 1), (2, 2), (2, 3)]  # a second ant, the other way round
    cells, moves = _record(grid, [HAND, other])
    grads = [jax.jit(jax.grad(lambda th, path=path: _log_prob(th, grid, problem, eta_beta, path)))(theta) for path in (HAND, other)]
    for adv in ([1.0, 0.0], [0.0, 1.0], [0.7, -1.3]):
        g = score(problem, weights, cells, moves, jnp.asarray(adv))
        np.testing.assert_allclose(np.asarray(g), np.asarray(adv[0] * grads[0] + adv[1] * grads[1]), atol=2e-6)
    # Eq. (2): at the start the used move gets 1 − p, the others −p; cells never left get 0.
    cur, p = step_probabilities(problem, weights, cells, moves)
    np.testing.assert_allclose(np.asarray(p.sum(-1))[np.asarray(moves) >= 0], 1.0, rtol=1e-6)
    g = np.asarray(score(problem, weights, cells, moves, jnp.array([1.0, 0.0]))).reshape(n, 8)
    assert g[grid.index((0, 0)), int(moves[0, 0])] == pytest.approx(1 - float(p[0, 0, int(moves[0, 0])]), rel=1e-5)
    assert (g[grid.index((2, 3))] == 0).all() and (g[grid.index((1, 0))] == 0).all()
    # At (0, 1) the start (0, 0) is tabu: its move has probability 0 and gradient 0.
    back = int(np.flatnonzero(np.asarray(problem.nbr)[grid.index((0, 1))] == grid.index((0, 0)))[0])
    assert float(p[1, 0, back]) == 0.0 and g[grid.index((0, 1)), back] == 0.0


def test_advantages_by_hand():
    cost = jnp.array([10.0, 20.0, jnp.inf, jnp.inf])
    # L̄ = 15, a failed ant costs 1.5·15 = 22.5; baseline over all ants = 18.75.
    np.testing.assert_allclose(advantages(cost, 0.5), [-8.75 / 15, 1.25 / 15, 3.75 / 15, 3.75 / 15], rtol=1e-6)
    np.testing.assert_allclose(advantages(cost, 0.5, "successful"), [-1 / 3, 1 / 3, 0.5, 0.5], rtol=1e-6)
    # Nothing to learn when no ant arrived (and on the trivial query, where every cost is 0).
    np.testing.assert_array_equal(advantages(jnp.full(4, jnp.inf), 0.5), 0.0)
    np.testing.assert_array_equal(advantages(jnp.zeros(3), 0.5), 0.0)


def _one_iteration_setup(variant):
    grid = jaco.Grid.from_rows(GRID_ROWS)
    problem = to_device(make_problem(grid, (0, 0), (2, 3)))
    params = params_from(resolve_params(variant, {"q": 0.5, "rho": 0.1}, where="test"))
    trail = variant.rule.init(Trail(jnp.zeros(8 * grid.n_cells), jnp.float32(0), jnp.float32(jnp.inf)), problem, params)
    return problem, params, trail


def _construct(variant):
    return jax.jit(lambda *a: variant.construct(variant, *a[:3], a[3], 5, a[4], n_ants=6, steplimit=8))


def test_sgd_step_is_eq_4_and_adam_state_is_carried():
    sgd = make_pg_aco(optax.sgd(1.0), name="pg-aco-sgd-test")
    problem, params, trail = _one_iteration_setup(sgd)
    theta0, _ = trail.state["pg"]  # the logits and the optimiser's state: the rule's own state in the trail
    assert (trail.tau == 1.0).all() and (theta0 == 0.0).all()
    new, colony = _construct(sgd)(problem, trail, params, 0, jax.random.key(7))
    # θ1 = (1 − ρ)·0 − Q·g, g = (1/A)Σ_k adv_k ∇ log p_k with the weights of θ0 = 0 (α ≡ 1).
    weights = move_weights(sgd, trail, problem, params.replace(alpha=1.0), 0, 5)
    n = problem.nbr.shape[0]
    moves = jnp.where(colony.targets < 8 * n, colony.targets % 8, -1)
    g = score(problem, weights, colony.cells, moves, advantages(colony.cost, params.penalty)) / 6
    assert np.abs(np.asarray(g)).max() > 0  # the ants took different paths: something to learn
    theta1, _ = new.state["pg"]
    np.testing.assert_allclose(np.asarray(theta1), np.asarray(-0.5 * g), atol=1e-7)
    np.testing.assert_allclose(np.asarray(new.tau), np.exp(np.asarray(theta1)), rtol=1e-6)
    # adam's moments and step count live in the trail and advance with every iteration.
    problem, params, trail = _one_iteration_setup(PG_ACO)
    step = _construct(PG_ACO)
    for it in range(3):
        trail, _ = step(problem, trail, params, it, jax.random.key(it))
    theta, opt = trail.state["pg"]
    assert int(opt[0].count) == 3
    assert np.abs(np.asarray(theta)).max() <= LOGIT_MAX


def test_the_colony_learns_shorter_paths():
    grid = jaco.maps.named("random-20-30")
    start, goal = grid.meta["start"], grid.meta["goal"]
    runs = [jaco.solve(grid, start, goal, PG_ACO, seed=s, n_ants=50, n_iters=60) for s in range(8)]
    gaps = [r.gap for r in runs]
    # Measured, seeds 0-7: mean gap 3.5 %, at most 12.3 % (an unlucky seed).
    assert all(r.success for r in runs) and np.mean(gaps) < 0.06 and max(gaps) < 0.2, gaps
    r = runs[0]
    mean = r.history["mean"]
    # The iteration mean (successful ants) falls and the success rate rises as the policy learns.
    early, late = np.nanmean(np.where(np.isfinite(mean[:20]), mean[:20], np.nan)), mean[-10:].mean()
    assert late < early and r.history["success_rate"][-10:].mean() > 0.9


def test_alpha_is_not_a_parameter_and_bad_choices_are_errors():
    grid = jaco.Grid.from_rows(GRID_ROWS)
    with pytest.raises(jaco.ParamError, match="unknown parameter 'alpha'"):
        jaco.solve(grid, (0, 0), (2, 3), "pg-aco", alpha=2.0, n_ants=4, n_iters=2)
    with pytest.raises(jaco.JacoError, match="optax GradientTransformation"):
        make_pg_aco("adam")
    with pytest.raises(jaco.JacoError, match="baseline must be one of"):
        make_pg_aco(baseline="median")
    assert PG_ACO.doc.startswith("Policy-gradient ACO (Meuleau & Dorigo 2002")
