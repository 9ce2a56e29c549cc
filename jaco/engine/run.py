"""The colony loop (the fifth of the five concepts): ``make_run(planner, ...) -> run(key, problem,
params)``.

Iterations are a loop (``lax.while_loop``, which also ends when the call is interrupted); the ants of an iteration walk together (vectorised over the ant
axis, see :mod:`jaco.engine.walk`); a sweep is ``jit(vmap(run))``. The key is always the first
argument and is never stored in state, so the same key gives the same result bit for bit.

Everything here takes a :class:`~jaco.engine.planner.Planner` itself: names are resolved one layer
up, by :func:`jaco.solve` (:mod:`jaco.api`) through the registry, so the engine never imports the
planners. :func:`solve` is the plain single run; several targets (:mod:`jaco.waypoints`) are
built on top of it.

Around the loop, each in its own module: the static shape of a run (:mod:`jaco.engine.shape`),
validation before anything compiles (:mod:`jaco.engine.checks`), the memory estimate
(:mod:`jaco.engine.memory`) and the compile cache (:mod:`jaco.engine.cache`).
"""

from __future__ import annotations

import functools
import math
from collections import Counter
from collections.abc import Callable
from typing import Any, NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from .. import progress as _progress
from ..errors import JacoError
from ..grid import Grid
from . import native
from .cache import cached, kept
from .checks import check_keep_pheromone, check_seed, check_sizes, params_from, prepare
from .colony import step_cells
from .memory import memory_budget
from .params import Params
from .pheromone import Trail, Walks
from .planner import Planner
from .problem import Problem, device_problem
from .result import Result, to_result
from .shape import RunShape

TRACES: Counter = Counter()  # how often each planner's run was traced (tests check "once")


class History(NamedTuple):
    """Per iteration: best-so-far cost, the iteration's best and mean cost over successful ants
    (inf when none succeeded) and its success rate."""

    best: jax.Array
    iteration_best: jax.Array
    mean: jax.Array
    success_rate: jax.Array


class RunOutput(NamedTuple):
    """Raw arrays of one run (or, under vmap, of a batch of runs)."""

    best_cells: jax.Array  # (S,) cells entered by the best ant, -1 padded
    best_cost: jax.Array
    best_length: jax.Array
    best_iteration: jax.Array  # -1 while no ant succeeded
    history: History
    covered: jax.Array  # number of free cells visited by any ant (coverage = covered / free)
    steps: jax.Array  # real ant-steps taken in the whole run (for throughput figures)
    tau: jax.Array | None


class _Best(NamedTuple):
    targets: jax.Array  # its cells follow from them when the run ends (colony.step_cells)
    step_len: jax.Array
    cost: jax.Array
    length: jax.Array
    iteration: jax.Array


def _no_best(path_len: int, size: int, problem: Problem) -> _Best:
    """The best before the first iteration: none yet, unless start is the goal (an ant on the goal
    has arrived, its path empty)."""
    trivial = problem.start == problem.goal
    return _Best(
        targets=jnp.full((path_len,), size, jnp.int32),
        step_len=jnp.zeros((path_len,), jnp.float32),
        cost=jnp.where(trivial, 0.0, jnp.inf).astype(jnp.float32),
        length=jnp.where(trivial, 0.0, jnp.inf).astype(jnp.float32),
        iteration=jnp.where(trivial, 0, -1).astype(jnp.int32),
    )


def _better_best(best: _Best, col: Any, b: jax.Array, t: jax.Array) -> _Best:
    """The colony's ant ``b`` (its cheapest) where it beats ``best``, else ``best``. Not its cells:
    in the loop their column fused with every step slot's cells into one XLA fusion that XLA splits
    between threads (a wake-up each iteration); the run derives them once, at its end."""
    better = col.cost[b] < best.cost
    candidate = _Best(col.targets[:, b], col.step_len[:, b], col.cost[b], col.length[b], t)
    return jax.tree.map(lambda new, old: jnp.where(better, new, old), candidate, best)


def _history_row(best: _Best, col: Any, b: jax.Array) -> History:
    """One iteration's :class:`History` (mean and success rate over the ants that arrived)."""
    ok = jnp.isfinite(col.cost)
    count = jnp.sum(ok)
    mean = jnp.where(count > 0, jnp.sum(jnp.where(ok, col.cost, 0.0)) / jnp.maximum(count, 1), jnp.inf)
    return History(best.cost, col.cost[b], mean, count / col.cost.shape[0])


def _report_iteration(t: jax.Array, report: bool, n_iters: int) -> None:
    """Hand iteration ``t + 1`` to :func:`jaco.progress.report` when ``report`` (see :func:`make_run`).
    With the native walk on CPU, nothing: the host reads the kernel's count of finished iterations
    (:func:`jaco.engine.native.iterations_done`), where a callback costs about 100 µs."""
    # Decided when tracing, not by native.dispatch: a callback traced into a branch that the CPU
    # lowering drops still gives the program a debug effect, and jax then runs it with effect tokens
    # (about 1 ms more on the benchmark's solve of 6 ms).
    if not report or (native.active_walk() == "native" and jax.default_backend() == "cpu"):
        return
    k = _progress.every(n_iters)  # every few iterations: a callback each iteration took about 15 % of a sweep
    jax.lax.cond((t + 1) % k == 0, lambda: jax.debug.callback(_progress.report, t + 1), lambda: None)


def _iterate(iteration: Callable, key: jax.Array, carry: tuple, n_iters: int, snapshot_size: int | None):
    """Run ``iteration(carry, (key_t, t)) -> (carry, (History row, snapshot))`` for ``n_iters``
    iterations, stacking its rows; returns ``(carry, history, snapshots)`` (snapshots ``(n_iters,
    snapshot_size)``, or None without a size)."""
    keys = jax.random.split(key, n_iters)
    # A while loop, as lax.scan is inside XLA, that also ends when the call is interrupted.
    history = History(*(jnp.zeros((n_iters,), jnp.float32) for _ in History._fields))
    outs = (history, None if snapshot_size is None else jnp.zeros((n_iters, snapshot_size), jnp.float32))

    def body(state):
        t, carry, outs = state
        carry, out = iteration(carry, (jax.lax.dynamic_index_in_dim(keys, t, keepdims=False), t))
        # Row t of each buffer, as lax.scan stacks its outputs (a dynamic-update-slice, also under vmap).
        return (
            t + 1,
            carry,
            jax.tree.map(lambda buf, o: jax.lax.dynamic_update_index_in_dim(buf, o, t, 0), outs, out),
        )

    def more(state):
        return (state[0] < n_iters) & ~native.stop_requested(state[0])

    _, carry, (history, snapshots) = jax.lax.while_loop(more, body, (jnp.int32(0), carry, outs))
    return carry, history, snapshots


def make_run(
    planner: Planner,
    *,
    n_ants: int,
    n_iters: int,
    steplimit: int,
    keep_pheromone: bool | str = False,
    report: bool = False,
) -> Callable[[jax.Array, Problem, Params], RunOutput]:
    """Build ``run(key, problem, params) -> RunOutput`` for fixed shapes (not jitted here).

    ``keep_pheromone``: False (none), True (the final pheromone ``(M,)``) or ``"history"`` (the
    pheromone after every iteration, ``(n_iters, M)``, e.g. for :func:`jaco.plot.animate_pheromone`).
    ``report``: hand the number of finished iterations to :func:`jaco.progress.report` every
    :func:`jaco.progress.every` iterations (a host callback that reads nothing back; under vmap
    the iteration is the same for every run of the batch, so the batch reports once). An
    interrupted call ends at its next iteration whether it reports or not
    (:func:`jaco.engine.native.stop_requested`).
    """
    if not isinstance(planner, Planner):
        raise JacoError(f"make_run takes a Planner, got {planner!r} (by name: jaco.make_run or jaco.PLANNERS[name])")
    check_keep_pheromone(keep_pheromone)
    check_sizes(n_ants, n_iters, steplimit)

    def run(key, problem: Problem, params: Params) -> RunOutput:
        TRACES[planner.name] += 1  # Python side effect: runs once per trace, never when cached
        n = problem.nbr.shape[0]
        size = n if planner.pheromone_on == "cells" else 8 * n
        trail = planner.rule.init(
            Trail(jnp.zeros(size, jnp.float32), jnp.float32(0.0), jnp.float32(jnp.inf)), problem, params
        )

        def construct(trail, t, key):
            p = planner.schedule(params, t, n_iters)
            trail, colony = planner.construct(
                planner, problem, trail, p, t, n_iters, key, n_ants=n_ants, steplimit=steplimit
            )
            return p, trail, colony

        shapes = jax.eval_shape(construct, trail, jnp.int32(0), key)
        # The candidates' path buffer length is the construct step's own (two colonies: longer).
        path_len = shapes[2].cells.shape[0]
        # The walks write over the last iteration's steps (Trail.steps); the first over none.
        empty = lambda s: native.no_steps(s.shape[:-2], s.shape[-2], s.shape[-1], n)  # noqa: E731
        trail = trail._replace(steps=jax.tree.map(empty, shapes[1].steps))

        def iteration(carry, xs):
            trail, best, seen, steps = carry
            key_t, t = xs
            p, trail, col = construct(trail, t, key_t)
            if planner.local_search is not None:  # the improved paths are deposited and become the best
                col = planner.local_search(planner, problem, col, p)
            b = jnp.argmin(col.cost)
            best = _better_best(best, col, b, t)
            walks = Walks(col.targets, col.step_len, col.cost, best.targets, best.step_len, best.cost)
            trail = planner.rule.update(trail, walks, problem, p)
            hist = _history_row(best, col, b)
            snapshot = trail.tau if keep_pheromone == "history" else None
            _report_iteration(t, report, n_iters)
            return (trail, best, seen | col.visited, steps + jnp.sum(col.n_steps)), (hist, snapshot)

        carry = (trail, _no_best(path_len, size, problem), jnp.zeros((n,), bool), jnp.int32(0))
        snapshot_size = size if keep_pheromone == "history" else None
        (trail, best, seen, steps), history, snapshots = _iterate(iteration, key, carry, n_iters, snapshot_size)
        return RunOutput(
            best_cells=step_cells(planner.pheromone_on, best.targets, problem.offsets, n),
            best_cost=best.cost,
            best_length=best.length,
            best_iteration=best.iteration,
            history=history,
            covered=jnp.sum(seen & (problem.clearance > 0)),
            steps=steps,
            tau=snapshots if keep_pheromone == "history" else trail.tau if keep_pheromone else None,
        )

    return run


def batch_runs(run: Callable) -> Callable:
    """``run(key, problem, params)`` batched as a sweep runs it: ``(keys (B,), problems (P, ...),
    params (B,)) -> outputs (P, B, ...)``, vmapped over configurations × seeds (inner, one flat
    axis) and problems (outer). The one batch layout of :func:`compiled_run` and the sweep's and
    search's chunk program (:mod:`jaco.research.chunks`)."""
    return jax.vmap(jax.vmap(run, in_axes=(0, None, 0)), in_axes=(None, 0, None))


def paired_runs(run: Callable) -> Callable:
    """``run(key, problem, params)`` over pairs: ``(keys (L,), problems (L, ...), params) -> outputs
    (L, ...)``, run i with key i on problem i, the parameters shared (a waypoint route's legs,
    :mod:`jaco.waypoints`)."""
    return jax.vmap(run, in_axes=(0, 0, None))


# -- the compiled run, cached so repeated calls of one shape never recompile -----------------
def compiled_run(planner: Planner, shape: RunShape, batched: bool, report: bool = False) -> Callable:
    """The jitted run for these static choices (cached by the planner and
    :attr:`RunShape.program <jaco.engine.shape.RunShape.program>`).

    ``report``: the unbatched run that reports its iterations to a progress bar (a program of its
    own, compiled once, so that a run without a bar pays nothing for the callbacks; the two give
    the same results bit for bit).

    ``batched``: ``run(keys (B,), problems (P, ...), params (B,))`` vmapped over configurations
    × seeds (inner) and problems (outer) -> outputs ``(P, B, ...)`` (:func:`batch_runs`).
    """

    def build():
        run = make_run(planner, **shape.sizes, keep_pheromone=shape.keep_pheromone, report=report and not batched)
        return jax.jit(batch_runs(run) if batched else run)

    key = ("run", planner, *shape.program, batched)
    return cached(key + (("report",) if report and not batched else ()), build)


def seed_key(seed: int) -> jax.Array:
    """``jax.random.key(seed)`` for a :func:`~jaco.engine.checks.check_seed` seed, without the
    compiled call that makes it (0.1–0.2 ms of a 7 ms solve): with jax's default Threefry keys,
    the key of a seed below 2**32 is the words ``(0, seed)``. The keys of the last 1024 seeds are
    kept (a key is an immutable array; making one took 0.2–0.3 ms of a solve)."""
    return _seed_key(seed, jax.config.jax_default_prng_impl)  # type: ignore[attr-defined]  # not in jax's stubs


@functools.lru_cache(maxsize=1024)
def _seed_key(seed: int, impl: str) -> jax.Array:
    if impl != "threefry2x32":
        return jax.random.key(seed)
    return jax.random.wrap_key_data(jnp.asarray(np.array([0, seed], np.uint32)))


_PARAMS_KEPT = 256
_DEVICE_PARAMS: dict = {}


def device_params(values: dict) -> Params:
    """:func:`~jaco.engine.checks.params_from` of ``values`` (one value each) on the default
    device; the last 256 sets are kept, keyed by their float32 bits (so -0.0 is not 0.0): a run's
    numpy scalars were copied at every call, about 35 µs each."""
    key = tuple((k, np.float32(v).tobytes()) for k, v in values.items())
    return kept(_DEVICE_PARAMS, key, lambda: jax.tree.map(jnp.asarray, params_from(values)), _PARAMS_KEPT)


def fetched(outputs: Any) -> Any:
    """The numpy values of a run's outputs, as ``jax.device_get``. On the CPU each array's value
    is read as it is: ``jax.device_get`` first asks every array for an asynchronous copy to the
    host, which overlaps the copies of an accelerator but on the CPU only costs (a solve's 10
    outputs: about 0.65 ms against 0.2 ms, of a 7–10 ms solve)."""
    if jax.default_backend() != "cpu":
        return jax.device_get(outputs)
    return jax.tree.map(np.asarray, outputs)


_SOLVES_KEPT = 64  # prepared calls kept on each grid


def prepared_solve(
    grid: Grid,
    start: Any,
    goal: Any,
    planner: Planner,
    *,
    seed: int,
    n_ants: int,
    n_iters: int,
    steplimit: int | None,
    connectivity: int,
    keep_pheromone: bool | str,
    params: dict,
) -> tuple[int, dict, Problem, Problem, Params]:
    """A solve's call checked (:func:`~jaco.engine.checks.prepare`,
    :func:`~jaco.engine.problem.device_problem`) and made ready: the step limit, the parameter
    values, the problem, its device copy and the values' device copy. The last 64 calls that
    passed are kept on the grid (which cannot change), keyed by every argument but the seed, each
    with its type (so that ``1``, ``1.0`` and ``True`` stay apart), and by the memory budget: a
    repeated call, or the same with another seed, checks only the seed again. Right after a run,
    when the interpreter's caches are cold, the checks took about 0.2 ms of a 4 ms solve. A call
    with an argument that cannot be a key (an array) is checked in full every time."""

    def build():
        limit, values = prepare(
            grid,
            planner,
            seed=seed,
            n_ants=n_ants,
            n_iters=n_iters,
            steplimit=steplimit,
            params=params,
            keep_pheromone=keep_pheromone,
        )
        problem, on_device = device_problem(grid, start, goal, connectivity=connectivity)
        return limit, values, problem, on_device, device_params(values)

    if not isinstance(grid, Grid):
        return build()  # prepare names the mistake
    sizes = (n_ants, n_iters, steplimit, connectivity, keep_pheromone, start, goal)
    try:
        key = (planner, _typed(sizes), _typed(tuple(sorted(params.items()))), memory_budget())
        hash(key)
    except (TypeError, JacoError):  # an array among the arguments; a malformed budget, named by prepare
        return build()
    ready = kept(grid.meta.setdefault("_solves", {}), key, build, _SOLVES_KEPT)
    check_seed(seed)  # a kept call was checked with another seed
    return ready


def _typed(value: Any) -> Any:
    """``value`` (scalars in nested tuples) with the type of every scalar beside it, and a float's
    sign (``0.0 == -0.0``, but a run tells them apart)."""
    if isinstance(value, tuple):
        return tuple(_typed(v) for v in value)
    if isinstance(value, float | np.floating):
        return type(value), value, math.copysign(1.0, value)
    return type(value), value


def solve(
    grid: Grid,
    start: Any,
    goal: Any,
    planner: Planner,
    *,
    seed: int,
    n_ants: int,
    n_iters: int,
    steplimit: int | None,
    connectivity: int,
    keep_pheromone: bool | str,
    progress: bool | None = None,
    **params: Any,
) -> Result:
    """One run of ``planner`` from ``start`` to ``goal``: the body of :func:`jaco.solve` without
    waypoints (whose signature has the defaults). The call is validated by :func:`prepare` and
    :func:`~jaco.engine.problem.make_problem` (map, start, goal, reachability) before anything
    compiles. ``progress`` (:mod:`jaco.progress`): a bar of iterations once the call has taken
    :data:`jaco.progress.SOLVE_DELAY` seconds."""
    steplimit, values, problem, on_device, on_device_values = prepared_solve(
        grid,
        start,
        goal,
        planner,
        seed=seed,
        n_ants=n_ants,
        n_iters=n_iters,
        steplimit=steplimit,
        connectivity=connectivity,
        keep_pheromone=keep_pheromone,
        params=params,
    )
    shape = RunShape(n_ants, n_iters, steplimit, connectivity, keep_pheromone)
    show = _progress.enabled(progress)
    bar = _progress.Bar(show, f"solve {planner.name}", "it", delay=_progress.SOLVE_DELAY)
    bar.start(n_iters)
    with _progress.listening(bar, runs=True):
        run = compiled_run(planner, shape, batched=False, report=show)
        out = _progress.run_interruptibly(
            lambda: fetched(run(seed_key(seed), on_device, on_device_values)), program=(run, grid.shape)
        )
    return to_result(
        out,
        grid=grid,
        planner=planner,
        start=start,
        goal=goal,
        optimal=problem.optimal,
        seed=seed,
        params=values,
        shape=shape,
    )
