"""Ant walks: roulette probabilities are the analytic ones, tabu and dead ends behave."""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaco
from jaco.engine.problem import make_problem, to_device
from jaco.engine.walk import choose, pad_steps, walk
from jaco.moves import MOVES


def _frequencies(w, q0=0.0, exploit=False, n=40_000):
    # Evenly spaced uniforms: frequencies equal the probabilities up to 1/n exactly.
    u = (jnp.arange(n) + 0.5) / n
    k = choose(jnp.broadcast_to(jnp.asarray(w, jnp.float32), (n, 8)), u, q0, exploit)
    return np.bincount(np.asarray(k), minlength=8) / n


def test_roulette_matches_random_proportional_rule():
    w = np.array([0, 1, 2, 0, 3, 0, 0, 4], np.float32)
    assert _frequencies(w) == pytest.approx(w / w.sum(), abs=1e-4)


def test_roulette_never_picks_a_zero_weight_move_even_at_u_close_to_one():
    w = jnp.array([[0, 0, 0, 0.3, 0, 0, 0, 0], [1e-30, 0, 0, 0, 0, 0, 0, 0], [0.1, 0.2, 0, 0, 0, 0, 0, 0]] * 3, jnp.float32)
    u = jnp.array([0.0, 0.5, 1 - 2**-24] * 3, jnp.float32)
    k = np.asarray(choose(w, u, 0.0, False))
    assert (np.asarray(w)[np.arange(len(k)), k] > 0).all()


def test_pseudo_random_rule_takes_the_argmax_with_probability_q0():
    w = np.array([1, 0, 2, 0, 0, 0, 1, 0], np.float32)
    q0 = 0.6
    expected = (1 - q0) * w / w.sum()
    expected[2] += q0
    assert _frequencies(w, q0=q0, exploit=True) == pytest.approx(expected, abs=1e-4)


def _problem(rows, start, goal):
    grid = jaco.Grid.from_rows(rows)
    return grid, jax.tree.map(jnp.asarray, make_problem(grid, start, goal))


def test_walk_reaches_goal_in_a_corridor_and_records_the_cells():
    grid, p = _problem(["......"], (0, 0), (0, 5))
    weights = jnp.where(p.nbr >= 0, 1.0, 0.0)
    u = jax.random.uniform(jax.random.key(0), (pad_steps(10), 4))
    tours = walk(p, weights, u, 0.0, steplimit=10, exploit=False)
    assert np.asarray(tours.arrived).all()  # the tabu list forbids going back
    assert (np.asarray(tours.n_steps) == 5).all() and np.allclose(tours.length, 5.0)
    assert np.asarray(tours.cells)[:5, 0].tolist() == [1, 2, 3, 4, 5]


def test_ant_in_a_dead_end_dies_and_step_limit_stops_ants():
    # The ant is forced into a dead-end pocket: weights only allow the move to the right.
    grid, p = _problem([".#.", "..."], (1, 0), (0, 2))
    right = int(np.where((MOVES == (0, 1)).all(axis=1))[0][0])
    weights = jnp.where((p.nbr >= 0) & (jnp.arange(8)[None, :] == right), 1.0, 0.0)
    u = jnp.full((pad_steps(5), 2), 0.3)
    tours = walk(p, weights, u, 0.0, steplimit=5, exploit=False)
    assert not np.asarray(tours.arrived).any()
    assert (np.asarray(tours.n_steps) == 2).all()  # (1,0)->(1,1)->(1,2), then nothing allowed
    grid, p = _problem(["." * 12], (0, 0), (0, 11))
    tours = walk(p, jnp.where(p.nbr >= 0, 1.0, 0.0), jnp.full((pad_steps(4), 3), 0.5), 0.0, steplimit=4, exploit=False)
    assert (np.asarray(tours.n_steps) == 4).all() and not np.asarray(tours.arrived).any()


def test_diagonal_lengths_are_exact():
    grid, p = _problem(["...", "...", "..."], (0, 0), (2, 2))
    diag = int(np.where((MOVES == (1, 1)).all(axis=1))[0][0])
    weights = jnp.where((p.nbr >= 0), jnp.where(jnp.arange(8)[None, :] == diag, 1e6, 1e-6), 0.0)
    tours = walk(p, weights, jnp.full((pad_steps(4), 1), 0.5), 0.0, steplimit=4, exploit=False)
    assert float(tours.length[0]) == pytest.approx(2 * math.sqrt(2), rel=1e-7)


@pytest.mark.parametrize("exploit", [False, True])
def test_pool_walk_takes_the_lockstep_moves_bit_for_bit(monkeypatch, exploit):
    """Under vmap the ants of every configuration share a pool of lanes (refilled between chunks);
    each ant still uses its own uniforms, so every move equals the lock-step walk's, also across
    nested vmaps, pools smaller than a colony, and an ant that dies at once."""
    import jaco.engine.walk as c

    monkeypatch.setattr(c, "POOL", 7)  # 3 configs x 2 seeds x 5 ants = 30 ants on 7 lanes
    grid = jaco.maps.random_map(12, 0.3, seed=1)
    p = to_device(make_problem(grid, (0, 0), (11, 11)))
    s_pad = pad_steps(40)
    base = jnp.where(p.nbr >= 0, 1.0 / jnp.maximum(p.goal_dist[jnp.maximum(p.nbr, 0)], 0.5), 0.0)
    W = base[None] ** jnp.array([0.5, 2.0, 6.0])[:, None, None]
    U = jax.random.uniform(jax.random.key(3), (3, 2, s_pad, 5))
    q0 = jnp.array([0.2, 0.7])

    pooled = jax.jit(jax.vmap(jax.vmap(
        lambda w, u, q: walk(p, w, u, q, steplimit=37, exploit=exploit), in_axes=(None, 0, 0)), in_axes=(0, 0, None)))
    lockstep = jax.jit(jax.vmap(jax.vmap(
        lambda w, u, q: c._lockstep_walk(w, u, p.start, p.goal, q, offsets=p.offsets, steplimit=37, exploit=exploit),
        in_axes=(None, 0, 0)), in_axes=(0, 0, None)))
    got, (moves, visited) = pooled(W, U, q0), lockstep(W, U, q0)
    np.testing.assert_array_equal(np.asarray(got.moves), np.asarray(moves).astype(np.int32))
    np.testing.assert_array_equal(np.asarray(got.visited), np.asarray(visited))
    assert (np.asarray(got.n_steps) > 0).any() and np.asarray(got.arrived).any()
