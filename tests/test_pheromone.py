"""Pheromone pieces against hand-computed values."""

import jax.numpy as jnp
import numpy as np
import pytest

import jaco
from jaco.engine import pheromone as ph
from jaco.engine.params import Params
from jaco.engine.problem import make_problem

M = 6  # six pheromone elements; index 6 is padding and must be dropped


def _walks(costs=(2.0, 4.0, np.inf)):
    # Three ants, two steps each: ant 0 uses elements 0,1; ant 1 uses 1,2; ant 2 (failed) 3,4.
    targets = jnp.array([[0, 1, 3], [1, 2, 4]], jnp.int32)
    step_len = jnp.ones((2, 3), jnp.float32).at[1, 0].set(np.sqrt(2))
    cost = jnp.array(costs, jnp.float32)
    return ph.Walks(targets, step_len, cost, jnp.array([0, 1, M]), jnp.array([1.0, np.sqrt(2), 0.0]), cost[0])


def _trail(v=1.0):
    return ph.Trail(jnp.full(M, v, jnp.float32), jnp.float32(0), jnp.float32(np.inf))


P = Params(rho=0.25, q=2.0, tau0=0.5, xi=0.1, sigma=3.0, w=3.0, p_best=0.05)


def test_evaporate_then_ant_cycle_deposit():
    rule = ph.chain(ph.evaporate(), ph.deposit_all(ph.ant_cycle))
    tau = np.asarray(rule.update(_trail(), _walks(), None, P).tau)
    # 0.75 + Q/L: element 1 is used by both successful ants.
    assert tau == pytest.approx([0.75 + 1.0, 0.75 + 1.0 + 0.5, 0.75 + 0.5, 0.75, 0.75, 0.75])


def test_density_and_quantity_deposits():
    tau = np.asarray(ph.deposit_all(ph.ant_density).update(_trail(0), _walks(), None, P).tau)
    assert tau == pytest.approx([2, 4, 2, 0, 0, 0])
    tau = np.asarray(ph.deposit_all(ph.ant_quantity).update(_trail(0), _walks(), None, P).tau)
    assert tau == pytest.approx([2, 2 / np.sqrt(2) + 2, 2, 0, 0, 0])


def test_elitist_and_rank_deposits():
    tau = np.asarray(ph.deposit_best_so_far(lambda p: p.sigma).update(_trail(0), _walks(), None, P).tau)
    assert tau == pytest.approx([3, 3, 0, 0, 0, 0])  # σ·Q/L* = 3·2/2 on the best path
    tau = np.asarray(ph.deposit_ranked().update(_trail(0), _walks(), None, P).tau)
    # w=3: rank 1 (cost 2) deposits 2·Q/2 = 2, rank 2 (cost 4) 1·Q/4 = 0.5; best-so-far w·Q/L* = 3.
    assert tau == pytest.approx([2 + 3, 2 + 0.5 + 3, 0.5, 0, 0, 0])


def test_acs_local_update_equals_sequential_updates():
    walks = _walks()
    tau = np.asarray(ph.acs_local().update(_trail(2.0), walks, None, P).tau)
    seq = np.full(M, 2.0)
    for t in np.asarray(walks.targets).ravel():
        if t < M:
            seq[t] = (1 - P.xi) * seq[t] + P.xi * P.tau0
    assert tau == pytest.approx(seq)


def test_acs_global_update_only_on_the_best_path():
    tau = np.asarray(ph.acs_global().update(_trail(1.0), _walks(), None, P).tau)
    on = 0.75 * 1.0 + 0.25 * 2.0 / 2.0
    assert tau == pytest.approx([on, on, 1, 1, 1, 1])


def test_mmas_bounds_and_clamp():
    grid = jaco.Grid.from_rows(["....", "....", "...."])
    problem = make_problem(grid, (0, 0), (2, 3))
    trail = ph.init_mmas().init(_trail(0), problem, P)
    octile = 3 + (np.sqrt(2) - 1) * 2
    assert float(trail.hi) == pytest.approx(P.q / (P.rho * octile))
    rule = ph.chain(ph.mmas_bounds(), ph.clamp())
    # a best path of 40 steps (the rule counts its pheromone elements in range)
    walks = _walks()._replace(best_targets=jnp.zeros(40, jnp.int32), best_step_len=jnp.ones(40))
    out = rule.update(ph.Trail(jnp.array([100.0, 0.0, 1.0, 1.0, 1.0, 1.0]), trail.lo, trail.hi), walks, problem, P)
    hi = P.q / (P.rho * 2.0)
    n, avg = 40, (np.sum(problem.nbr >= 0) / grid.n_free) / 2
    root = P.p_best ** (1 / n)
    lo = hi * (1 - root) / ((avg - 1) * root)
    assert float(out.hi) == pytest.approx(hi) and float(out.lo) == pytest.approx(lo, rel=1e-5)
    assert np.asarray(out.tau) == pytest.approx([hi, lo, 1, 1, 1, 1], rel=1e-5)


def test_failed_ants_and_padding_deposit_nothing():
    walks = _walks(costs=(np.inf, np.inf, np.inf))
    tau = np.asarray(ph.deposit_all(ph.ant_cycle).update(_trail(0), walks._replace(best_cost=jnp.float32(np.inf)), None, P).tau)
    assert (tau == 0).all()
