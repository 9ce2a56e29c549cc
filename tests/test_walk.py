"""Ant walks: roulette probabilities are the analytic ones, the uniforms are Threefry of (ant,
step), tabu and dead ends behave, and a colony walks the same whatever it is batched with."""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from jax.extend.random import threefry_2x32

import jaco
from jaco.engine.colony import step_cells, step_targets
from jaco.engine.problem import make_problem, to_device
from jaco.engine.walk import choose, key_words, step_uniforms, walk
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


def _walk(p, weights, n_ants, steplimit, seed=0, q0=0.0, exploit=False):
    return walk(p, weights, jax.random.key(seed), q0, n_ants=n_ants, steplimit=steplimit, exploit=exploit)


def test_uniforms_are_word_step_mod_2_of_threefry_on_ant_and_half_step():
    """The uniform of (ant, step) is jax's own Threefry-2x32 hash of the counter (ant, step // 2),
    word step % 2, its top 23 bits as the mantissa: checked on a million random counters."""
    rng = np.random.default_rng(0)
    n = 1_000_000
    words = rng.integers(0, 2**32, 2, dtype=np.uint32)
    ants = rng.integers(0, 2**32, n, dtype=np.uint32)
    steps = rng.integers(0, 2**31, n, dtype=np.uint32)
    got = np.asarray(jax.jit(step_uniforms)(jnp.asarray(words), ants, steps))
    hashed = np.asarray(threefry_2x32((words[0], words[1]), jnp.concatenate([ants, steps >> 1])))
    bits = np.where(steps & 1, hashed[n:], hashed[:n])
    expected = ((bits >> 9) | 0x3F800000).view(np.float32) - np.float32(1)
    np.testing.assert_array_equal(got, expected)
    assert got.min() >= 0.0 and got.max() < 1.0
    counts = np.bincount((got * 20).astype(int), minlength=20)  # 20 equal bins of 50,000 expected
    assert np.abs(counts - n / 20).max() < 5 * math.sqrt(n / 20)


def test_walk_reaches_goal_in_a_corridor_and_records_the_cells():
    grid, p = _problem(["......"], (0, 0), (0, 5))
    tours = _walk(p, jnp.where(p.nbr >= 0, 1.0, 0.0), n_ants=4, steplimit=10)
    assert np.asarray(tours.arrived).all()  # the tabu list forbids going back
    assert (np.asarray(tours.n_steps) == 5).all() and np.allclose(tours.length, 5.0)
    assert np.asarray(tours.cells)[:5, 0].tolist() == [1, 2, 3, 4, 5]
    assert (np.asarray(tours.cells)[5:] == -1).all() and (np.asarray(tours.moves)[5:] == -1).all()


def test_ant_in_a_dead_end_dies_and_step_limit_stops_ants():
    # The ant is forced into a dead-end pocket: weights only allow the move to the right.
    grid, p = _problem([".#.", "..."], (1, 0), (0, 2))
    right = int(np.where((MOVES == (0, 1)).all(axis=1))[0][0])
    weights = jnp.where((p.nbr >= 0) & (jnp.arange(8)[None, :] == right), 1.0, 0.0)
    tours = _walk(p, weights, n_ants=2, steplimit=5)
    assert not np.asarray(tours.arrived).any()
    assert (np.asarray(tours.n_steps) == 2).all()  # (1,0)->(1,1)->(1,2), then nothing allowed
    grid, p = _problem(["." * 12], (0, 0), (0, 11))
    tours = _walk(p, jnp.where(p.nbr >= 0, 1.0, 0.0), n_ants=3, steplimit=4)
    assert (np.asarray(tours.n_steps) == 4).all() and not np.asarray(tours.arrived).any()


def test_diagonal_lengths_are_exact():
    grid, p = _problem(["...", "...", "..."], (0, 0), (2, 2))
    diag = int(np.where((MOVES == (1, 1)).all(axis=1))[0][0])
    weights = jnp.where((p.nbr >= 0), jnp.where(jnp.arange(8)[None, :] == diag, 1e6, 1e-6), 0.0)
    tours = _walk(p, weights, n_ants=1, steplimit=4)
    assert float(tours.length[0]) == pytest.approx(2 * math.sqrt(2), rel=1e-7)


def test_start_on_the_goal_has_arrived_without_a_step():
    grid, p = _problem(["..."], (0, 1), (0, 1))
    tours = _walk(p, jnp.where(p.nbr >= 0, 1.0, 0.0), n_ants=3, steplimit=4)
    assert np.asarray(tours.arrived).all() and (np.asarray(tours.n_steps) == 0).all()


@pytest.mark.parametrize("exploit", [False, True])
def test_a_colony_walks_the_same_alone_and_in_any_batch(exploit):
    """Counter-based uniforms: a colony's walks depend on its key, weights and ants only, not on
    the colonies, configurations or seeds it is batched with (nested vmaps included)."""
    grid = jaco.maps.random_map(12, 0.3, seed=1)
    p = to_device(make_problem(grid, (0, 0), (11, 11)))
    base = jnp.where(p.nbr >= 0, 1.0 / jnp.maximum(p.goal_dist[jnp.maximum(p.nbr, 0)], 0.5), 0.0)
    W = base[None] ** jnp.array([2.0, 6.0, 12.0])[:, None, None]
    keys = jax.random.split(jax.random.key(3), 2)
    q0 = jnp.array([0.2, 0.7])
    one = jax.jit(lambda w, k, q: walk(p, w, k, q, n_ants=5, steplimit=60, exploit=exploit))
    batched = jax.jit(jax.vmap(jax.vmap(one, in_axes=(None, 0, 0)), in_axes=(0, None, None)))(W, keys, q0)
    arrived = False
    for i in range(3):
        for j in range(2):
            alone = one(W[i], keys[j], q0[j])
            for field in ("cells", "moves", "n_steps", "arrived", "visited"):
                np.testing.assert_array_equal(getattr(batched, field)[i, j], getattr(alone, field))
            arrived |= bool(np.asarray(alone.arrived).any())
    assert arrived
    assert not np.array_equal(batched.cells[0, 0], batched.cells[0, 1])  # other key, other walks


@pytest.mark.parametrize("rows", [None, [".", ".", ".", "."], ["..", "..", "..", ".."]])
def test_the_cells_follow_from_the_steps_pheromone_elements(rows):
    """step_cells inverts step_targets for both layouts (a run derives its best path's cells from
    them), from the walk's edges and from the targets made of cells and moves; on maps 1 and 2
    cells wide too, where two moves can have one offset."""
    grid = jaco.maps.random_map(12, 0.3, seed=1) if rows is None else jaco.Grid.from_rows(rows)
    goal = (grid.height - 1, grid.width - 1)
    p = to_device(make_problem(grid, (0, 0), goal))
    n = p.nbr.shape[0]
    tours = walk(p, jnp.where(p.nbr >= 0, 1.0, 0.0), jax.random.key(4), 0.0, n_ants=20, steplimit=40, exploit=False)
    assert (np.asarray(tours.n_steps) > 1).any()
    for layout in ("cells", "moves"):
        for edges in (tours.edges, None):
            targets = step_targets(layout, tours.cells, tours.moves, p.start, n, edges)
            np.testing.assert_array_equal(step_cells(layout, targets, p.offsets, n), tours.cells)


def test_a_walk_over_the_last_walks_steps_takes_the_same_walks():
    """``previous`` (a run's Trail.steps) changes no walk, with whichever walk is active: the native
    walk writes over it and clears the rows it used (here another key's walks, some longer), the
    JAX walk does not read it. A buffer of another shape is refused before any compile."""
    p = to_device(make_problem(jaco.maps.random_map(12, 0.3, seed=1), (0, 0), (11, 11)))
    weights = jnp.where(p.nbr >= 0, 1.0, 0.0)
    fresh = _walk(p, weights, 20, 40, seed=4)
    last = _walk(p, weights, 20, 40, seed=5)
    assert (np.asarray(last.n_steps) > np.asarray(fresh.n_steps)).any()
    again = walk(p, weights, jax.random.key(4), 0.0, n_ants=20, steplimit=40, exploit=False, previous=last.edges)
    for a, b in zip(fresh, again, strict=True):
        np.testing.assert_array_equal(np.asarray(a), np.asarray(b))
    with pytest.raises(jaco.JacoError, match=r"previous must be the \(steplimit, n_ants\) = \(40, 20\)"):
        walk(p, weights, jax.random.key(4), 0.0, n_ants=20, steplimit=40, exploit=False, previous=last.edges[:, :5])


def test_key_words_are_two_words_of_any_key():
    words = key_words(jax.random.key(0))
    assert words.shape == (2,) and words.dtype == jnp.uint32
    assert not np.array_equal(words, key_words(jax.random.key(1)))


def test_key_words_are_jax_random_bits_of_the_key_bit_for_bit():
    """key_words hashes default keys with its own unrolled Threefry (jax's CPU lowering is a loop):
    the words must be jax.random.bits's, for every kind of key and inside jit and vmap."""
    keys = jax.random.split(jax.random.key(7), 4096)
    bits = jax.vmap(lambda k: jax.random.bits(k, (2,), jnp.uint32))
    np.testing.assert_array_equal(jax.jit(jax.vmap(key_words))(keys), bits(keys))
    for key in (jax.random.key(2**32 - 1), jax.random.PRNGKey(5), jax.random.key(3, impl="rbg")):
        np.testing.assert_array_equal(key_words(key), jax.random.bits(key, (2,), jnp.uint32))
