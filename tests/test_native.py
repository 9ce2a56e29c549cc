"""The native walks (C++ through jax.ffi) take the JAX walks' moves bit for bit.

Random maps, shapes down to 1x1, start on the goal, unreachable goals, step limit 1, both
transition rules, the backtracking walk with its local update; every registered planner through
solve, sweep and waypoints; the uniforms and the table powers on a million inputs each; and the
choice of walk (option, environment variable, fallback when the kernel is missing).
"""

import functools
import os
import shutil
import subprocess
import sys
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

import jaco
from jaco import potential
from jaco.engine import bitexact, native, weights
from jaco.engine.problem import make_problem, stack
from jaco.engine.walk import jax_walk, step_uniforms
from jaco.moves import MOVES, neighbour_table
from jaco.planners.iaca import detour, jax_backtrack_walk, native_backtrack_walk

ROOT = Path(__file__).resolve().parents[1]

pytestmark = pytest.mark.skipif(not native.available(), reason="the native walk was not built")


#: The instruction sets of the lane kernels that this build has and this CPU runs (widest last).
RUNNABLE = [name for name, state in native.isas().items() if state in ("active", "runs")]


@pytest.fixture
def isa_choice():
    """Restore the default instruction set after a test that chooses one."""
    yield native.set_isa
    native.set_isa(None)


@pytest.fixture
def tabu_choice():
    """Restore the kernel's choice of tabu layout after a test that forces one."""
    yield native.set_tabu
    native.set_tabu(None)


@pytest.fixture
def walk_choice():
    """Restore the walk choice after a test that changes it."""
    yield native.set_walk
    native.set_walk(None)


def test_kernel_uniforms_equal_the_jax_uniforms_on_a_million_counters():
    rng = np.random.default_rng(1)
    n = 1_000_000
    words = rng.integers(0, 2**32, 2, dtype=np.uint32)
    ants = rng.integers(0, 2**32, n, dtype=np.uint32)
    steps = rng.integers(0, 2**32, n, dtype=np.uint32)
    np.testing.assert_array_equal(
        np.asarray(native.uniforms(words, ants, steps)), np.asarray(jax.jit(step_uniforms)(jnp.asarray(words), ants, steps))
    )


def test_table_powers_agree_with_the_kernel_and_with_float64_pow():
    rng = np.random.default_rng(2)
    x = np.exp(rng.uniform(-70, 70, 1_000_000)).astype(np.float32)
    a = rng.uniform(0, 20, 1_000_000).astype(np.float32)
    got = np.asarray(jax.jit(bitexact.power)(x, a))
    np.testing.assert_array_equal(np.asarray(native.power(x, a)), got)
    with np.errstate(over="ignore"):  # beyond float64: inf, as it should be
        exact = np.exp(a.astype(np.float64) * np.log(x.astype(np.float64)))
    normal = (exact > 1e-37) & (exact < 1e37)
    assert np.max(np.abs(got[normal] / exact[normal] - 1)) < 1e-5
    assert (got[exact < 1e-39] == 0).all() and np.isinf(got[exact > 4e38]).all()
    special = np.asarray(bitexact.power(jnp.array([0.0, -1.0, 2.0, 1.0, 3.0]), jnp.array([2.0, 2.0, 1.0, 7.0, 0.0])))
    assert special.tolist() == [0.0, 0.0, 2.0, 1.0, 1.0]


# -- the move weights: XLA's log and exp, reproduced ----------------------------------------------
def test_the_kernels_move_weights_equal_xlas_with_every_instruction_set(isa_choice):
    """The probe the kernel is checked on once per process, with every set this CPU runs, in both
    pheromone layouts, colonies sharing the map's neighbours and each with its own α and factor."""
    assert weights.kernel_mode() == "fused"  # x86-64 with FMA (every CPU with AVX2): XLA fuses each multiply-add
    tau_cells, tau_moves, nbr, alphas, factor = weights.probe()
    factors = np.stack([factor, factor[::-1], np.zeros_like(factor)])[np.arange(len(alphas)) % 3]
    for cells, tau in ((False, tau_moves), (True, tau_cells)):
        taus = np.stack([tau, tau * np.float32(0.37), np.roll(tau, 5)])[np.arange(len(alphas)) % 3]
        xla = jax.jit(jax.vmap(functools.partial(weights.scaled_weights, cells=cells), in_axes=(0, None, 0, 0)))
        want = np.asarray(xla(taus, nbr, alphas, factors))
        assert (want[:, :16] == 0).all() and ((want > 0) == (nbr >= 0)).all() and (want.max(axis=2)[:, 16:] == 1).all()
        for isa in RUNNABLE:
            isa_choice(isa)
            kernel = functools.partial(weights.native_move_weights, cells=cells, fused=True)
            got = np.asarray(jax.jit(jax.vmap(kernel, in_axes=(0, None, 0, 0)))(taus, nbr, alphas, factors))
            np.testing.assert_array_equal(got.view(np.uint32), want.view(np.uint32), err_msg=f"{isa}, cells={cells}")


def test_the_kernels_log_and_exp_equal_xlas_on_every_binade():
    sys.path.insert(0, str(ROOT / "experiments"))
    import check_xla_math

    assert check_xla_math.main(["--smoke"]) == 0


def test_a_kernel_whose_weights_differ_from_xlas_is_not_used(monkeypatch):
    args = (jnp.ones(8 * 6), jnp.asarray(np.arange(48).reshape(6, 8) % 7 - 1, jnp.int32), 1.5, jnp.zeros((6, 8)))

    def program():
        return jax.jit(functools.partial(weights.move_weights, cells=False)).lower(*args).as_text()

    assert "jaco_move_weights" in program()
    exact = weights.native_move_weights
    monkeypatch.setattr(weights, "native_move_weights", lambda *a, **kw: exact(*a, **kw) * np.float32(1 + 2**-22))
    assert weights.find_mode() is None
    monkeypatch.setitem(weights._state, "mode", None)
    assert "jaco_move_weights" not in program()


# -- random walks on random maps ----------------------------------------------------------------
# Maps of up to 9x9 are drawn inside a fixed 9x9 frame (cells outside the map are obstacles), so
# that the compiled walks are reused across examples; maps of the true shapes 1x1, 1x2 and 2x1
# are explicit examples.
FRAME = 9


@st.composite
def walk_cases(draw):
    # Ant count, step limit and q0 rule are compile-time constants: each combination drawn is a
    # compile of both walks, so the drawn maps take 4 ants and 40 steps, and the other counts and
    # limits (1 ant; 1 and 3 steps) are explicit examples.
    return dict(h=draw(st.integers(1, FRAME)), w=draw(st.integers(1, FRAME)), shape=(FRAME, FRAME),
                density=draw(st.sampled_from([0.0, 0.2, 0.4])), seed=draw(st.integers(0, 2**31 - 1)),
                n_ants=4, steplimit=40,
                exploit=draw(st.booleans()), connectivity=draw(st.sampled_from([4, 8])))


def _arrays(case, colonies=3):
    """Weights, key words, starts, goals, q0 and offsets of ``colonies`` random colonies on one
    random map: starts and goals anywhere free (possibly equal, possibly disconnected)."""
    rng = np.random.default_rng(case["seed"])
    H, W = case["shape"]
    free = np.zeros((H, W), bool)
    free[: case["h"], : case["w"]] = rng.random((case["h"], case["w"])) >= case["density"]
    free.flat[rng.integers(H * W) if free.sum() == 0 else np.flatnonzero(free)[0]] = True
    nbr, _ = neighbour_table(free, case["connectivity"])
    cells = np.flatnonzero(free)
    weights = np.exp(rng.normal(0, 4, (colonies,) + nbr.shape)).clip(1e-30, 1e30)
    weights = np.where(nbr[None] >= 0, weights, 0).astype(np.float32)
    return (
        jnp.asarray(weights),
        jnp.asarray(rng.integers(0, 2**32, (colonies, 2), dtype=np.uint32)),
        jnp.asarray(rng.choice(cells, colonies).astype(np.int32)),
        jnp.asarray(rng.choice(cells, colonies).astype(np.int32)),
        jnp.asarray(rng.uniform(0, 1, colonies).astype(np.float32)),
        jnp.asarray(np.broadcast_to(MOVES[:, 0] * W + MOVES[:, 1], (colonies, 8)).astype(np.int32)),
    )


@functools.lru_cache(maxsize=None)
def _dying(kind, n_ants, steplimit, exploit):
    fn = jax_walk if kind == "jax" else native.walk
    return jax.jit(jax.vmap(functools.partial(fn, n_ants=n_ants, steplimit=steplimit, exploit=exploit)))


@functools.lru_cache(maxsize=None)
def _backtracking(kind, n_ants, steplimit, exploit, table):
    fn = jax_backtrack_walk if kind == "jax" else native_backtrack_walk
    return jax.jit(jax.vmap(functools.partial(fn, n_ants=n_ants, steplimit=steplimit, exploit=exploit, table=table)))


def _same(a, b):
    for x, y in zip(a, b, strict=True):
        np.testing.assert_array_equal(np.asarray(x), np.asarray(y))


_EDGES = [dict(h=1, w=1, shape=(1, 1), density=0.0, seed=0, n_ants=4, steplimit=3, exploit=False, connectivity=8),
          dict(h=1, w=2, shape=(1, 2), density=0.0, seed=5, n_ants=4, steplimit=1, exploit=True, connectivity=8),
          dict(h=2, w=1, shape=(2, 1), density=0.0, seed=7, n_ants=1, steplimit=40, exploit=False, connectivity=4)]


@pytest.mark.slow  # the normal run compares whole runs of ACS and IACA with both walks (below)
@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(walk_cases())
@example(_EDGES[0])
@example(_EDGES[1])
@example(_EDGES[2])
def test_native_dying_walk_takes_the_jax_walks_moves(case):
    """Every instruction set this CPU runs (the lane kernels' widths differ: 4, 8, 16 ants at once),
    with each tabu layout (a bit a lane, a bit an ant)."""
    args = _arrays(case)
    key = (case["n_ants"], case["steplimit"], case["exploit"])
    expected = _dying("jax", *key)(*args)
    try:
        for isa in RUNNABLE:
            native.set_isa(isa)
            for layout in native.TABU_LAYOUTS:
                native.set_tabu(layout)
                _same(expected, _dying("native", *key)(*args))
    finally:
        native.set_isa(None)
        native.set_tabu(None)



@pytest.mark.parametrize("exploit", [False, True])
@pytest.mark.parametrize("shape", [(12, 12), (9, 2)])  # width 2: each neighbour looked up on its own
def test_colonies_walked_in_groups_of_one_pool_of_lanes_take_the_jax_walks_moves(shape, exploit, isa_choice,
                                                                                 tabu_choice):
    """A call of 37 colonies (a sweep's chunk): the kernel walks them in groups of consecutive
    colonies that share one pool of lanes (4 colonies a group on two threads: 9 groups of 4 and one
    of 1), a lane taking the next colony's ant when its colony has none left. Each colony has its
    own start, goal (some equal, some cut off), key and q0, and 13 ants (not a multiple of any lane
    count); every instruction set this CPU runs, with each tabu layout, gives each colony the JAX
    walk's results."""
    case = dict(h=shape[0], w=shape[1], shape=shape, density=0.25, seed=4, n_ants=13, steplimit=60,
                exploit=exploit, connectivity=8)
    args = _arrays(case, colonies=37)
    start, goal = np.asarray(args[2]).copy(), np.asarray(args[3]).copy()
    goal[5], goal[17] = start[5], start[17]  # ants that start on the goal take no step
    args = (*args[:2], jnp.asarray(start), jnp.asarray(goal), *args[4:])
    key = (case["n_ants"], case["steplimit"], exploit)
    expected = _dying("jax", *key)(*args)
    steps, arrived = np.asarray(expected[2]), np.asarray(expected[4])
    assert steps.sum() > 37 * 13 * 2 and arrived.any() and not arrived.all()  # ants walk, arrive and fail
    for isa in RUNNABLE:
        isa_choice(isa)
        for layout in native.TABU_LAYOUTS:
            tabu_choice(layout)
            _same(expected, _dying("native", *key)(*args))


@pytest.mark.slow  # the normal run compares IACA's whole runs with both walks (below)
@settings(max_examples=20, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(walk_cases(), st.sampled_from([(1.0, 8.0, 0.1, 0.1), (2.5, 3.0, 0.4, 1.0), (0.0, 0.0, 0.0, 0.5)]),
       st.booleans())
@example(_EDGES[0], (1.0, 8.0, 0.1, 0.1), False)
@example(_EDGES[1], (2.5, 3.0, 0.4, 1.0), True)
def test_native_backtracking_walk_takes_the_jax_walks_moves_and_pheromone(case, exponents, table):
    """IACA's walk: powers of the pheromone that changes while the ants walk (local update),
    backtracking, the infeasible cells; η of eq. (4-5) per step, or a fixed factor table of
    another heuristic (``table``); exponents and rates include 0."""
    weights, words, start, goal, q0, offsets = _arrays(case)
    rng = np.random.default_rng(case["seed"] + 1)
    n = weights.shape[1]
    xy = np.stack(np.divmod(np.arange(n), case["shape"][1]), axis=1).astype(np.float32)
    goal_xy = xy[np.asarray(goal)]
    to_goal = np.sqrt(((xy[None, :, None, :] + MOVES[None, None] - goal_xy[:, None, None, :]) ** 2).sum(-1))
    rows = jnp.asarray(np.where(np.asarray(weights) > 0, np.hypot(*MOVES.T)[None, None] + to_goal, 0).astype(np.float32))
    tau = jnp.asarray(rng.uniform(0.01, 20.0, (3, n)).astype(np.float32))
    alpha, beta, rho_local, q = exponents
    scalars = jnp.asarray(np.array([[q0i, alpha, beta, 0.01, 20.0, rho_local, q] for q0i in np.asarray(q0)], np.float32))
    factors = jnp.asarray(np.where(np.asarray(weights) > 0, rng.uniform(1e-6, 1.0, weights.shape), 0).astype(np.float32))
    args = (tau, rows, factors, words, start, goal, scalars, offsets)
    key = (case["n_ants"], case["steplimit"], case["exploit"], table)
    expected = _backtracking("jax", *key)(*args)
    try:
        for isa in RUNNABLE:  # IACA's lanes are built per instruction set too
            native.set_isa(isa)
            _same(expected, _backtracking("native", *key)(*args))
    finally:
        native.set_isa(None)


@pytest.mark.parametrize("table", [False, True])
def test_one_colony_of_many_ants_walked_by_a_team_of_threads_takes_the_jax_walks_moves(table, isa_choice):
    """One colony in a call (a solve): its 64 ants are split into chunks that XLA's threads take
    at every step, the pheromone updated between steps; on a 24x24 map with obstacles, so ants
    backtrack, die and arrive. Every instruction set this CPU runs gives the JAX walk's results."""
    case = dict(h=24, w=24, shape=(24, 24), density=0.3, seed=11, n_ants=64, steplimit=300, exploit=True,
                connectivity=8)
    weights, words, start, goal, q0, offsets = _arrays(case, colonies=1)
    n = weights.shape[1]
    xy = np.stack(np.divmod(np.arange(n), 24), axis=1).astype(np.float32)
    to_goal = np.sqrt(((xy[:, None, :] + MOVES[None] - xy[int(goal[0])]) ** 2).sum(-1))
    rows = jnp.asarray(np.where(np.asarray(weights[0]) > 0, np.hypot(*MOVES.T)[None] + to_goal, 0).astype(np.float32))
    rng = np.random.default_rng(3)
    tau = jnp.asarray(rng.uniform(0.01, 20.0, n).astype(np.float32))
    factors = jnp.asarray(np.where(np.asarray(weights[0]) > 0, rng.uniform(1e-6, 1.0, (n, 8)), 0).astype(np.float32))
    scalars = jnp.asarray([0.5, 1.0, 4.0, 0.01, 20.0, 0.2, 1.0], jnp.float32)
    args = (tau, rows, factors, words[0], start[0], goal[0], scalars, offsets[0])
    call = {kind: jax.jit(functools.partial(fn, n_ants=64, steplimit=300, exploit=True, table=table))
            for kind, fn in (("jax", jax_backtrack_walk), ("native", native_backtrack_walk))}
    expected = call["jax"](*args)
    assert int(expected[4].sum()) > 64 * 20 and 0 < int(expected[3].sum()) < 64  # long walks; some ants fail
    for isa in RUNNABLE:
        isa_choice(isa)
        _same(expected, call["native"](*args))


# -- the improved APF's next-cell table (apf-aco) -------------------------------------------------
_APF = {kind: jax.jit(jax.vmap(fn)) for kind, fn in (
    ("jax", potential.jax_apf_next),
    ("native", lambda p: potential.native_apf_next(p.clearance > 0, p.nbr, p.goal, p.offsets)),
)}


def _apf_tables(problems):
    batch = stack(problems)
    return [np.asarray(_APF[kind](batch)) for kind in ("jax", "native")]


@pytest.mark.slow  # the normal run compares the tables on two real maps (below)
@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.integers(1, 12), st.integers(1, 12), st.sampled_from([0.0, 0.15, 0.3, 0.45]), st.integers(0, 2**31 - 1),
       st.sampled_from([4, 8]))
def test_native_apf_table_equals_the_jax_table(h, w, density, seed, connectivity):
    """Random maps inside one 12x12 frame (one compiled shape), three goals at once (a batch of
    problems), both connectivities: the kernel's next cell of every cell is the JAX one's."""
    rng = np.random.default_rng(seed)
    free = np.zeros((12, 12), bool)
    free[:h, :w] = rng.random((h, w)) >= density
    free[0, 0] = True
    grid = jaco.Grid(free)
    goals = [tuple(int(v) for v in c) for c in rng.permutation(np.argwhere(free))[:3]]
    problems = [make_problem(grid, g, g, connectivity=connectivity) for g in goals * (3 // len(goals) + 1)][:3]
    ours, theirs = _apf_tables(problems)
    np.testing.assert_array_equal(ours, theirs)


@pytest.mark.slow  # with the random tables above; apf-aco runs with both walks in the slow parity test
def test_native_apf_table_equals_the_jax_table_on_real_maps():
    """Two bundled MovingAI maps (rooms, a maze), two goals each: every cell's next cell agrees,
    and the walkers that reach a target are many (the comparison is not all −1)."""
    rng = np.random.default_rng(0)
    for name in ("room-32-32-4.map", "maze-32-32-2.map"):
        grid = jaco.maps.load(jaco.maps.bundled(name))
        cells = rng.permutation(np.argwhere(grid.free))[:2]
        ours, theirs = _apf_tables([make_problem(grid, tuple(c), tuple(c)) for c in cells])
        np.testing.assert_array_equal(ours, theirs)
        assert (ours >= 0).sum() > 100


def _walk_targets(rng, R, C, M):
    """Targets ``(R, C)`` as walks record them: each column a random number of steps in ``[-M, M)``
    (negative ones count from the end), then targets out of range (``M``, beyond, or below ``-M``)."""
    targets = rng.choice(np.array([M, M + 3, -M - 1], np.int32), size=(R, C))
    for c in range(C):
        n = rng.integers(0, R + 1)
        targets[:n, c] = rng.integers(-M, M, size=n) if rng.random() < 0.3 else rng.integers(0, M, size=n)
    return targets


@pytest.mark.parametrize("shape", [(1, 1), (7, 5), (40, 8), (40, 13), (60, 50)])
@pytest.mark.parametrize("form", ["scalar", "per column", "per target"])
@pytest.mark.parametrize("pheromone", ["plain", "signed zeros and NaN"])
@pytest.mark.parametrize("colonies", [3, 19])
def test_the_deposit_kernel_adds_as_xlas_scatter_add(shape, form, pheromone, colonies, isa_choice):
    """jaco.engine.native.deposit equals XLA's scatter-add bit for bit: few elements (many adds
    to one element, in order), amounts of +0.0 and -0.0 (skipped only where that changes no
    element), several colonies in one vmapped call: 3 (on two threads or more, each colony added
    alone) or 19 (in groups whose adds interleave: 8, 8 and 3 colonies, lists of unequal lengths).
    With every instruction set this CPU runs: the pheromone's copy and check is built per set, and
    a -0.0 or NaN is found in a vector's first lanes and in the tail after the last whole vector."""
    R, C = shape
    M = 37
    rng = np.random.default_rng(R * 100 + C)
    tau = rng.uniform(0.01, 5.0, size=(colonies, M)).astype(np.float32)
    if pheromone != "plain":
        tau[0, 3], tau[1, 5], tau[2, 7] = -0.0, np.nan, 0.0
        tau[-1, M - 2] = -0.0
    targets = np.stack([_walk_targets(rng, R, C, M) for _ in range(colonies)])
    size = {"scalar": (colonies,), "per column": (colonies, C), "per target": (colonies, R, C)}[form]
    amounts = rng.choice(np.array([0.0, -0.0, 1e-7, 0.37, 3.0, 1e30], np.float32), size=size)
    if form == "scalar":
        amounts[1] = 0.0

    def xla(t, g, a):
        return t.at[g.ravel()].add(jnp.broadcast_to(a, g.shape).ravel(), mode="drop")

    want = jax.jit(jax.vmap(xla))(tau, targets, amounts)
    deposit = jax.jit(jax.vmap(native.deposit))
    for isa in RUNNABLE:
        isa_choice(isa)
        got = deposit(tau, targets, amounts)
        np.testing.assert_array_equal(np.asarray(got).view(np.uint32), np.asarray(want).view(np.uint32), err_msg=isa)
    assert not np.array_equal(np.asarray(want), tau) or form == "scalar"  # something was added


def test_detour_rows_of_a_problem_are_what_the_walk_test_builds():
    """The backtracking test builds detour rows by hand; they are jaco.planners.iaca.detour's."""
    grid = jaco.maps.random_map(7, 0.2, seed=3)
    p = jaco.make_problem(grid, (0, 0), (6, 6))
    xy = np.asarray(p.xy)
    to_goal = np.sqrt(((xy[:, None, :] + MOVES[None] - xy[p.goal]) ** 2).sum(-1))
    expected = np.where(np.asarray(p.nbr) >= 0, np.hypot(*MOVES.T)[None] + to_goal, 0)
    np.testing.assert_allclose(np.asarray(detour(jax.tree.map(jnp.asarray, p))), expected, rtol=1e-6)


# -- every planner, both walks ------------------------------------------------------------------
GRID = jaco.maps.random_map(14, 0.15, seed=2)


# One planner of each kind of walk (dying ants with the q0 rule, backtracking ants): a solve whose
# path and history are compared, and a trip through a waypoint (ACS) or a sweep (IACA). Every
# planner and composition: a solve's path, history and pheromone (slow, tests/test_variants.py).
_QUICK = ("acs", "iaca")


def _runs(variant):
    start, goal = (0, 0), (13, 13)
    kw = dict(n_ants=12, n_iters=8)
    solves = [jaco.solve(GRID, start, goal, variant, seed=3, **kw)]
    if variant not in _QUICK:
        return solves, None
    if variant == "acs":
        return solves + [jaco.solve(GRID, start, goal, variant, seed=4, waypoints=[(6, 8)], **kw)], None
    return solves, jaco.sweep(GRID, start, goal, variant, params={"rho": [0.1, 0.3]}, seeds=2, **kw)


def test_one_colony_split_between_threads_takes_the_jax_walks_moves(walk_choice, tabu_choice):
    # One solve is one colony: with more threads than colonies the kernel splits a colony's ants
    # between threads (at least 100 ants a part, walk.cc's kPartAnts: 200 ants on this 196-cell
    # map make two parts), and merges the cells each part visited. Each part numbers its ants'
    # tabu bits from its first ant (4 planes of 32 ants), or gives each lane a bit.
    def solves():
        return [jaco.solve(GRID, (0, 0), (13, 13), planner, seed=5, n_ants=200, n_iters=6) for planner in ("as", "acs")]

    walk_choice("jax")
    runs = {"jax": solves()}
    walk_choice("native")
    for layout in native.TABU_LAYOUTS:
        tabu_choice(layout)
        runs[layout] = solves()
    for a, b, c in zip(runs["lanes"], runs["planes"], runs["jax"], strict=True):
        _same_run(a, b)
        _same_run(a, c)


def _same_run(a, b):
    """Two Results of one solve alike: path, length, coverage and every history row."""
    np.testing.assert_array_equal(a.path, b.path)
    assert a.length == b.length and a.coverage == b.coverage
    for k in a.history:
        np.testing.assert_array_equal(a.history[k], b.history[k])


@pytest.mark.parametrize("variant", _QUICK)
def test_a_planner_of_each_walk_gives_the_same_runs_with_both_walks(variant, walk_choice):
    walk_choice("native")
    native_solves, native_table = _runs(variant)
    walk_choice("jax")
    jax_solves, jax_table = _runs(variant)
    for a, b in zip(native_solves, jax_solves, strict=True):
        _same_run(a, b)
        assert a.cost == b.cost and a.success
    if native_table is not None:
        pd.testing.assert_frame_equal(native_table, jax_table, check_exact=True)
        assert native_table.success.any()


# -- the instruction sets of the lane kernels ----------------------------------------------------
_LANE_CASES = [
    # 30x30 with obstacles: 3x3 neighbourhoods read as rows; 50 ants refill the lanes many times
    dict(h=30, w=30, shape=(30, 30), density=0.25, seed=11, n_ants=50, steplimit=240, exploit=False, connectivity=8),
    dict(h=30, w=30, shape=(30, 30), density=0.25, seed=12, n_ants=50, steplimit=240, exploit=True, connectivity=8),
    dict(h=7, w=9, shape=(7, 9), density=0.3, seed=13, n_ants=21, steplimit=9, exploit=False, connectivity=4),
    *_EDGES,  # widths 1 and 2: each neighbour looked up on its own
]


@pytest.mark.parametrize("case", _LANE_CASES)
def test_each_instruction_set_this_cpu_runs_takes_the_jax_walks_moves(case, isa_choice, tabu_choice):
    """The lane kernels of every set built and supported here (baseline always), forced one by one,
    with each tabu layout, against the JAX walk; the same compiled program serves all (the set and
    the layout are chosen at run time)."""
    args = _arrays(case, colonies=4)
    key = (case["n_ants"], case["steplimit"], case["exploit"])
    expected = _dying("jax", *key)(*args)
    assert RUNNABLE[0] == "baseline" and (np.asarray(expected[2]).sum() > 0 or case["h"] * case["w"] <= 2)
    # A run's walk writes over the last iteration's steps: here another key's walks, longer for
    # some ants and shorter for others, whose old steps past each new walk must be cleared.
    other = (args[0], args[1][:, ::-1]) + args[2:]
    for isa in RUNNABLE:
        isa_choice(isa)
        assert native.isa() == isa
        for layout in native.TABU_LAYOUTS:
            tabu_choice(layout)
            assert native.tabu() == layout
            _same(expected, _dying("native", *key)(*args))
            previous = _dying("native", *key)(*other)
            _same(expected, _dying("native", *key)(*args, previous[0]))
    if case["steplimit"] > 1 and case["h"] * case["w"] > 2:
        assert np.any(np.asarray(previous[2]) > np.asarray(expected[2]))  # the old steps went past the new


def test_a_tabu_layout_is_chosen_by_name_or_refused(tabu_choice):
    assert native.tabu() is None  # the kernel's choice
    tabu_choice("lanes")
    assert native.tabu() == "lanes"
    with pytest.raises(jaco.JacoError, match="unknown tabu layout 'bits'.*lanes, planes"):
        tabu_choice("bits")
    assert native.tabu() == "lanes"
    tabu_choice(None)
    assert native.tabu() is None


#: Each wider set's compiler flags (setup.py) and an intrinsic of that set, for the check below.
_SET_PROBES = {
    "avx2": (["-mavx2", "-mfma", "-mbmi", "-mbmi2", "-mpopcnt"], "_mm256_movemask_ps(_mm256_setzero_ps())"),
    "avx512": (["-mavx512f", "-mavx512bw", "-mavx512vl", "-mavx512dq", "-mavx2"],
               "_mm512_reduce_add_epi32(_mm512_setzero_si512())"),
}


@pytest.mark.skipif(os.environ.get("JACO_NATIVE_ISAS") is not None, reason="a build narrowed on purpose")
@pytest.mark.parametrize("name", sorted(_SET_PROBES))
def test_a_lane_kernel_the_compiler_can_build_was_built(name, tmp_path):
    """setup.py leaves out a set whose lane kernels fail to compile (a compiler without the set),
    with no error; so a compile error in a lane kernel would leave the set out and the kernel
    would run the baseline lanes. Where the compiler takes the set's flags and intrinsics, the
    set must have been built."""
    cxx = os.environ.get("CXX", "c++")
    if not (os.uname().machine in ("x86_64", "amd64") and shutil.which(cxx)):
        pytest.skip("the wider sets are built on x86-64 with a C++ compiler")
    flags, call = _SET_PROBES[name]
    src = tmp_path / "probe.cc"
    src.write_text(f"#include <immintrin.h>\nint probe() {{ return int({call}); }}\n")
    probe = subprocess.run([cxx, "-std=c++17", *flags, "-c", str(src), "-o", str(tmp_path / "probe.o")],
                           capture_output=True, text=True, timeout=120)
    if probe.returncode != 0:
        pytest.skip(f"{cxx} does not build {name} code here")
    assert native.isas()[name] != "not built", f"{name} lane kernels failed to compile: see the install log"


def test_the_widest_instruction_set_is_the_default_and_others_are_chosen_or_refused(isa_choice):
    states = native.isas()
    assert list(states) == ["baseline", "avx2", "avx512"] and states["baseline"] in ("active", "runs")
    assert native.isa() == RUNNABLE[-1]  # the widest this CPU runs
    isa_choice("baseline")
    assert native.isa() == "baseline" and native.isas()[RUNNABLE[-1]] in ("runs", "active")
    isa_choice(None)
    assert native.isa() == RUNNABLE[-1]
    with pytest.raises(jaco.JacoError, match="unknown instruction set 'sse9'.*baseline, avx2, avx512"):
        isa_choice("sse9")
    for name, state in states.items():
        if state not in ("active", "runs"):
            with pytest.raises(jaco.JacoError, match=f"'{name}' (was not built|is not supported by this CPU)"):
                isa_choice(name)
    assert native.isa() == RUNNABLE[-1]  # a refused choice changes nothing


def test_the_environment_chooses_the_instruction_set(tmp_path):  # outside the checkout: the installed jaco
    code = "from jaco.engine import native; print(native.isa())"
    env = dict(os.environ, JACO_NATIVE_ISA="baseline")
    out = subprocess.run([sys.executable, "-c", code], env=env, cwd=tmp_path, capture_output=True, text=True, timeout=120)
    assert out.returncode == 0 and out.stdout.split() == ["baseline"], out.stderr[-2000:]
    env["JACO_NATIVE_ISA"] = "sse9"
    out = subprocess.run([sys.executable, "-c", code], env=env, cwd=tmp_path, capture_output=True, text=True, timeout=120)
    assert "JACO_NATIVE_ISA: unknown instruction set 'sse9'" in out.stderr


# -- choosing the walk --------------------------------------------------------------------------
def test_the_option_and_the_environment_choose_the_walk(walk_choice, monkeypatch):
    assert native.active_walk() == "native"  # built: auto takes it
    walk_choice("jax")
    assert native.active_walk() == "jax"
    walk_choice(None)
    monkeypatch.setenv("JACO_WALK", "jax")
    assert native.active_walk() == "jax"
    monkeypatch.setenv("JACO_WALK", "fast")
    with pytest.raises(jaco.JacoError, match="JACO_WALK.*auto, native, jax"):
        native.active_walk()
    with pytest.raises(jaco.JacoError, match="auto, native, jax"):
        walk_choice("C++")


def test_repeated_calls_with_either_walk_compile_once(walk_choice):
    grid = jaco.maps.named("demo")
    args = (grid, grid.meta["start"], grid.meta["goal"], "as")
    for choice in ("jax", "native"):
        walk_choice(choice)
        jaco.solve(*args, n_ants=7, n_iters=3)
        traced = jaco.engine.run.TRACES["as"]
        jaco.solve(*args, n_ants=7, n_iters=3, seed=5)
        assert jaco.engine.run.TRACES["as"] == traced


def test_without_the_kernel_jaco_walks_in_jax_and_says_so(monkeypatch, walk_choice, capsys):
    """Forced fallback: the library is missing (as after an install without a C++ compiler)."""
    monkeypatch.setattr(native, "_state", {"lib": None, "why": "the native walk was not built at install time"})
    assert not native.available() and native.active_walk() == "jax"
    with pytest.raises(jaco.JacoError, match="not built"):
        walk_choice("native")
    grid = jaco.maps.named("demo")
    r = jaco.solve(grid, grid.meta["start"], grid.meta["goal"], "acs", n_ants=8, n_iters=4)
    assert r.success
    assert jaco.cli.main(["info"]) == 0
    out = capsys.readouterr().out
    assert "walk: jax" in out and "not built at install time" in out


def test_info_names_versions_devices_and_the_active_walk(capsys):
    assert jaco.cli.main(["info"]) == 0
    out = capsys.readouterr().out
    assert f"jaco {jaco.__version__}" in out and f"jax {jax.__version__}" in out
    assert "walk: native" in out and "devices: " in out
    assert f"native instruction sets: baseline ({native.isas()['baseline']})" in out and f"{native.isa()} (active)" in out


@pytest.mark.slow
def test_without_a_compiler_the_package_builds_and_walks_in_jax(tmp_path):
    """``pip wheel`` with a C++ compiler that always fails: the build succeeds without the
    kernel, and the package from that wheel plans with the JAX walk and says so in ``jaco info``.
    The builds here use this environment's build requirements (no build isolation, which would
    install jax and jaxlib into a fresh one for each build); CI's install builds isolated."""
    import zipfile

    # A copy of the sources only: the checkout may hold a build/ folder or an in-place kernel from
    # an earlier install, which setuptools would reuse instead of compiling.
    src = tmp_path / "src"
    src.mkdir()
    for name in ("pyproject.toml", "setup.py", "README.md"):
        shutil.copy2(ROOT / name, src / name)
    shutil.copytree(ROOT / "jaco", src / "jaco", ignore=shutil.ignore_patterns("__pycache__", "*.so"))
    env = dict(os.environ, CC="/bin/false", CXX="/bin/false", JACO_CACHE_DIR=str(tmp_path / "cache"))
    proc = subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q", "-w",
                           str(tmp_path), str(src)], env=env, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    (wheel,) = tmp_path.glob("jaco-*.whl")
    with zipfile.ZipFile(wheel) as z:
        assert not [n for n in z.namelist() if n.endswith(".so")]
        z.extractall(tmp_path / "site")
    code = (
        "import jaco, jaco.cli; assert not jaco.engine.native.available(); g = jaco.maps.named('demo'); "
        "r = jaco.solve(g, g.meta['start'], g.meta['goal'], 'iaca', n_ants=8, n_iters=3); assert r.success; "
        "jaco.cli.main(['info'])"
    )
    run = subprocess.run([sys.executable, "-c", code], env=dict(os.environ, PYTHONPATH=str(tmp_path / "site")),
                         cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr[-3000:]
    assert "walk: jax (the native walk was not built at install time" in run.stdout


def _check_baseline_only(tmp_path, wheel):
    """The package of a ``JACO_NATIVE_ISAS=baseline`` wheel: its kernel has no AVX2 or AVX-512 code
    and says so, and the walk tests of this file (every lane kernel against the JAX walk, planners
    with both walks) pass on it."""
    import zipfile

    site = tmp_path / "narrow-site"
    with zipfile.ZipFile(wheel) as z:
        z.extractall(site)
    env = dict(os.environ, PYTHONPATH=str(site))
    states = subprocess.run([sys.executable, "-c", "from jaco.engine import native; print(native.isas())"],
                            env=env, cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert states.stdout.strip() == "{'baseline': 'active', 'avx2': 'not built', 'avx512': 'not built'}", states.stderr
    tests = subprocess.run([sys.executable, "-m", "pytest", "-q", "-n", "0", "-p", "no:cacheprovider", "-m", "not slow",
                            str(ROOT / "tests" / "test_native.py"), "-k", "instruction_set or planner_of_each or info"],
                           env=env, cwd=tmp_path, capture_output=True, text=True, timeout=900)
    assert tests.returncode == 0, tests.stdout[-3000:]
    assert " passed" in tests.stdout and "failed" not in tests.stdout


@pytest.mark.slow
def test_the_kernel_is_built_once_for_the_same_sources_compiler_and_jaxlib(tmp_path):
    """setup.py keeps the built kernel in JACO_CACHE_DIR: a second build of the same sources copies
    it without running the compiler; a build for other instruction sets is another kernel (and a
    baseline-only one passes the walk tests: :func:`_check_baseline_only`); a changed source runs
    the compiler again."""
    import zipfile

    src = tmp_path / "src"
    src.mkdir()
    for name in ("pyproject.toml", "setup.py", "README.md"):
        shutil.copy2(ROOT / name, src / name)
    shutil.copytree(ROOT / "jaco", src / "jaco", ignore=shutil.ignore_patterns("__pycache__", "*.so"))
    cache = tmp_path / "cache"
    env = dict(os.environ, JACO_CACHE_DIR=str(cache))

    def build(name, **extra):
        """``pip wheel`` of the sources (as ``pip install`` builds): its output, kernel and object files."""
        shutil.rmtree(src / "build", ignore_errors=True)  # setuptools would reuse an earlier build's objects
        proc = subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-v", "-w",
                               str(tmp_path / name), str(src)], env=dict(env, **extra), capture_output=True, text=True,
                              timeout=900)
        assert proc.returncode == 0, proc.stderr[-3000:]
        (wheel,) = (tmp_path / name).glob("jaco-*.whl")
        with zipfile.ZipFile(wheel) as z:
            kernels = [z.read(n) for n in z.namelist() if n.endswith(".so")]
        return proc.stdout + proc.stderr, kernels, list((src / "build").rglob("*.o"))

    first, kernels, objects = build("first")
    (kept,) = cache.rglob("_walk*.so")
    assert "jaco: kept the native walk for later installs" in first and objects
    assert kernels == [kept.read_bytes()]
    second, kernels, objects = build("second")
    assert "jaco: reusing the native walk built before" in second
    assert not objects and kernels == [kept.read_bytes()]  # copied: nothing compiled
    # Built for other instruction sets: another kernel (the key names what the build assumed of the CPU).
    narrow, kernels, objects = build("narrow", JACO_NATIVE_ISAS="baseline")
    assert "reusing" not in narrow and objects and len(kernels) == 1 and kernels != [kept.read_bytes()]
    assert len(list(cache.rglob("_walk*.so"))) == 2
    _check_baseline_only(tmp_path, next((tmp_path / "narrow").glob("jaco-*.whl")))
    for other in list(cache.rglob("_walk*.so")):  # (the rest of the test counts the entries)
        if other != kept:
            shutil.rmtree(other.parent)
    # A changed lane kernel (a file the extension lists as a dependency, compiled first) is compiled again.
    with open(src / "jaco" / "engine" / "walk_lanes.cc", "a") as f:
        f.write("\n#error a changed source is compiled again\n")
    third, kernels, objects = build("third")
    assert "reusing" not in third and "a changed source is compiled again" in third
    assert not kernels and list(cache.rglob("_walk*.so")) == [kept]  # the optional kernel failed: no new entry


#: One planner of each construct (dying ants with roulette and with the q0 rule, backtracking
#: ants, two colonies) and the rules that carry a state of their own (pg-aco's optax state,
#: APF-ACO's potential-field table): the sharded sweep is the same vmapped run whatever the planner.
#: Every planner and composition takes the native walk's moves in a solve: tests/test_variants.py.
SHARDED = ["as", "acs", "iaca", "idaca", "pg-aco", "apf-aco"]


@pytest.mark.slow
def test_planners_sharded_with_the_jax_walk_equal_the_native_walk(tmp_path):
    """A sweep sharded over two devices with the JAX walk equals the one-device sweep with the
    native walk, row for row (one subprocess with two XLA devices)."""
    code = (
        "import sys, jaco, pandas as pd\n"
        "g = jaco.maps.random_map(14, 0.15, seed=2)\n"
        "bad = []\n"
        f"for v in {SHARDED!r}:\n"
        "    tables = []\n"
        "    for walk, devices in (('native', 1), ('jax', 2)):\n"
        "        jaco.set_walk(walk)\n"
        "        tables.append(jaco.sweep(g, (0, 0), (13, 13), v, params={'rho': [0.1, 0.3]}, seeds=2,\n"
        "                                 n_ants=10, n_iters=6, devices=devices))\n"
        "    assert tables[1].attrs['sweep']['devices'] == 2\n"
        "    if not tables[0].equals(tables[1]) or not tables[0].success.any():\n"
        "        bad.append(v)\n"
        "print('differ:', bad)\n"
        "sys.exit(1 if bad else 0)\n"
    )
    env = dict(os.environ, JAX_PLATFORMS="cpu", XLA_FLAGS="--xla_force_host_platform_device_count=2")
    # cwd: not the checkout, whose jaco/ has no kernel after a plain `pip install .`
    proc = subprocess.run([sys.executable, "-c", code], env=env, cwd=tmp_path, capture_output=True, text=True,
                          timeout=1200)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-3000:]
