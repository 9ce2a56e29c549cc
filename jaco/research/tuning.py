"""Hyperparameter tuning with optax: evolution-strategy gradients over continuous parameters
(docs/algorithms.md §9; docs/tuning.md).

``jaco.tune(grid, start, goal, planner, tune=("alpha", "beta", "rho"), ...) -> TuneResult``

**Transforms.** Each tuned parameter lives in an unconstrained coordinate z, mapped into its range
from :data:`jaco.engine.params.SPECS` by

* ``[lo, hi]`` finite (``(0, 1)`` included): scaled logit, ``x = lo + (hi − lo)·sigmoid(z)``;
* ``[lo, ∞)``: shifted log, ``x = lo + exp(z)``.

The sigmoid is kept in ``[1e-6, 1 − 1e-6]`` and ``z`` of the log in ``[−20, 20]``, so a value
never reaches an open end of its range, whatever the optimiser does. A starting value on a closed
end (β = 0, say) is moved inside, to 0.1 % of the range from it (log: 1e-6 above ``lo``).

**Estimator.** With ``P`` members per step (``population``, even), ``ε_i ~ N(0, I)`` for
``i < P/2`` and ``ε_{i+P/2} = −ε_i`` (antithetic pairs), member i runs the planner at
``x(z + σ ε_i)``. Its objective ``f_i`` is the mean over ``n_seeds`` runs of the final best cost,
a failed run (cost ∞) counting as ``penalty``. Fitness shaping replaces f by centered ranks
``u_i = rank_i/(P − 1) − 1/2`` (ties share their mean rank), and the gradient of the smoothed
objective ``E_ε[f(z + σε)]`` is estimated by

    g = 1/(P σ) · Σ_i u_i ε_i

which one optax step turns into ``z ← z + optimizer.update(g)`` (adam with learning rate 0.1 by
default). All P × n_seeds runs of a step are one vmapped batch, every member of a step uses the
same n_seeds keys (common random numbers: the comparison between members is not blurred by
seed noise), and the whole loop of ``steps`` steps is one jitted ``lax.scan``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import jax
import jax.numpy as jnp
import numpy as np
import optax
import pandas as pd

from .. import progress as _progress
from ..engine.cache import cached
from ..engine.checks import check_grid, check_seed, params_from, resolve_params, resolve_steplimit
from ..engine.memory import check_run_memory
from ..engine.params import ORDERED, SPECS, Params, param_names
from ..engine.planner import Planner
from ..engine.problem import make_problem
from ..engine.run import fetched, make_run
from ..engine.shape import RunShape
from ..errors import JacoError, ParamError, check_keywords, did_you_mean
from ..grid import Grid

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

    from ..grid import Cell
from ..planners.registry import get_planner
from .chunks import path_buffer
from .search_checks import positive_int


#: Parameters that can be tuned: every parameter with a range, except those in an order relation
#: (τmin < τmax, Q1 < Q2 < Q3, ρ2 < ρ1), which one-parameter-at-a-time transforms cannot keep.
def tunable(name: str) -> bool:
    """Whether ``name`` is a declared parameter outside every order relation."""
    return name in SPECS and not any(name in pair for pair in ORDERED)


TUNABLE = tuple(name for name in SPECS if tunable(name))  # the parameters declared by jaco's own components

FRAC_EPS = 1e-6  # the sigmoid stays in [FRAC_EPS, 1 − FRAC_EPS]
LOG_Z = 20.0  # the log transform's z stays in [−LOG_Z, LOG_Z]
INIT_EDGE = 1e-3  # a starting value on a closed end moves this fraction of the range inside

DEFAULT_OPTIMIZER = optax.adam(0.1)


# -- transforms ------------------------------------------------------------------------------
def bounds(name: str) -> tuple[float, float, bool]:
    """``(lo, hi, is_logit)`` of a parameter's transform (logit when ``hi`` is finite)."""
    spec = SPECS[name]
    return float(spec.lo), float(spec.hi), math.isfinite(spec.hi)


def _tables(names):
    lo, hi, logit = zip(*(bounds(n) for n in names))
    span = np.where(logit, np.asarray(hi) - np.asarray(lo), 1.0)
    return np.asarray(lo, np.float32), span.astype(np.float32), np.asarray(logit)


def to_params(names: Sequence[str], z: ArrayLike) -> jax.Array:
    """Parameter values ``(..., d)`` from unconstrained ``z (..., d)`` (the order of ``names``)."""
    z = jnp.asarray(z)
    lo, span, logit = (jnp.broadcast_to(t, z.shape) for t in _tables(names))  # explicit: rank promotion is an error
    frac = jnp.clip(jax.nn.sigmoid(z), FRAC_EPS, 1.0 - FRAC_EPS)
    return jnp.where(logit, lo + span * frac, lo + jnp.exp(jnp.clip(z, -LOG_Z, LOG_Z)))


def to_unconstrained(names: Sequence[str], values: ArrayLike) -> np.ndarray:
    """Inverse of :func:`to_params` (numpy, float64); values on a closed end move inside first."""
    z = []
    for name, v in zip(names, np.asarray(values, np.float64)):
        lo, hi, logit = bounds(name)
        if logit:
            frac = np.clip((v - lo) / (hi - lo), INIT_EDGE, 1.0 - INIT_EDGE)
            z.append(math.log(frac) - math.log1p(-frac))
        else:
            z.append(float(np.clip(math.log(max(v - lo, 1e-6)), -LOG_Z, LOG_Z)))
    return np.asarray(z, np.float64)


def centered_ranks(f: ArrayLike) -> jax.Array:
    """Fitness shaping: ``rank/(P − 1) − 1/2`` in [−1/2, 1/2], the lowest f ranked 0; tied values
    share their mean rank, so equal objectives contribute nothing to the gradient."""
    f = jnp.asarray(f)
    below = jnp.sum(f[None, :] < f[:, None], axis=1)
    tied = jnp.sum(f[None, :] == f[:, None], axis=1)
    rank = below + 0.5 * (tied - 1)
    return rank / max(f.shape[0] - 1, 1) - 0.5


def es_gradient(eps: jax.Array, f: jax.Array, sigma: float | jax.Array) -> jax.Array:
    """``1/(P σ) Σ_i u_i ε_i`` with u the centered ranks of ``f (P,)`` and ``eps (P, d)``."""
    u = centered_ranks(f)
    return jnp.sum(u[:, None] * eps, axis=0) / (eps.shape[0] * sigma)


def member_objective(cost: jax.Array, penalty: float | jax.Array) -> jax.Array:
    """Mean over seeds (last axis) of the final best cost, a failed run (∞) counting as ``penalty``."""
    return jnp.mean(jnp.where(jnp.isfinite(cost), cost, penalty), axis=-1)


# -- the compiled loop -----------------------------------------------------------------------
def _compiled(planner: Planner, names, optimizer, *, n_ants, n_iters, steplimit, steps, population, n_seeds):
    """The jitted tuning loop for these static choices, cached by the planner and the optimiser
    themselves (both hashable: an optax transformation is a tuple of its functions)."""
    key = ("tune", planner, optimizer, names, n_ants, n_iters, steplimit, steps, population, n_seeds)
    return cached(
        key, lambda: _build(planner, names, optimizer, n_ants, n_iters, steplimit, steps, population, n_seeds)
    )


def _build(planner, names, optimizer, n_ants, n_iters, steplimit, steps, population, n_seeds):
    run = make_run(planner, n_ants=n_ants, n_iters=n_iters, steplimit=steplimit)
    # members × seeds on one problem, every member on the same seeds' keys (common random numbers):
    # not a sweep's layout (jaco.engine.run.batch_runs: one key and one configuration per run)
    batch = jax.vmap(jax.vmap(run, in_axes=(0, None, None)), in_axes=(None, None, 0))
    half = population // 2

    def loop(key, problem, base: Params, z0, sigma, penalty):
        def step(carry, t):
            z, state = carry
            k_eps, k_runs = jax.random.split(jax.random.fold_in(key, t))
            e = jax.random.normal(k_eps, (half, z.shape[0]), jnp.float32)
            eps = jnp.concatenate([e, -e], axis=0)  # antithetic pairs
            x = to_params(names, z[None, :] + sigma * eps)
            members = jax.tree.map(lambda v: jnp.broadcast_to(v, (population,)), base)
            members = members.replace(**{name: x[:, i] for i, name in enumerate(names)})
            cost = batch(jax.random.split(k_runs, n_seeds), problem, members).best_cost  # (P, n_seeds)
            f = member_objective(cost, penalty)
            updates, state = optimizer.update(es_gradient(eps, f, sigma), state, z)
            record = (to_params(names, z), jnp.mean(f), jnp.mean(jnp.isfinite(cost)))
            jax.debug.callback(_progress.report, t + 1)  # a progress bar's step (reads nothing back)
            return (optax.apply_updates(z, updates), state), record

        (z, _), (x, objective, success) = jax.lax.scan(step, (z0, optimizer.init(z0)), jnp.arange(steps))
        return to_params(names, z), x, objective, success

    return jax.jit(loop)


# -- the user-facing function ----------------------------------------------------------------
@dataclass
class TuneResult:
    """What :func:`tune` found.

    ``params``: every parameter of the planner, the tuned ones at their final values (ready for
    ``jaco.solve(..., **result.params)``); ``init``: the starting values; ``history``: one row per
    step with the step, the population's mean objective, the share of successful runs and the
    tuned parameters at the centre of that step's population; ``penalty``: the cost a failed run
    counted as.
    """

    params: dict
    history: pd.DataFrame
    init: dict
    tuned: tuple
    planner: str
    penalty: float


def _names(planner: Planner, tune) -> tuple[str, ...]:
    try:
        names = (tune,) if isinstance(tune, str) else tuple(tune)
    except TypeError:
        raise ParamError(f"tune: expected parameter names, got {tune!r}") from None
    if not names:
        raise ParamError("tune: name at least one parameter to tune")
    usable = [n for n in planner.params if tunable(n)]
    for name in names:
        if not isinstance(name, str):
            raise ParamError(f"tune: parameter names must be strings, got {name!r}")
        if name not in param_names():
            raise ParamError(
                f"unknown parameter {name!r}{did_you_mean(name, usable)}; tunable for {planner.name!r}: "
                f"{', '.join(usable)}"
            )
        if not tunable(name):
            pairs = " and ".join(f"{a} < {b}" for a, b in ORDERED if name in (a, b))
            raise ParamError(
                f"parameter {name!r} cannot be tuned: it is ordered ({pairs}), which independent "
                f"transforms cannot keep; sweep it with jaco.sweep instead"
            )
        if name not in planner.params:
            raise ParamError(f"planner {planner.name!r} does not use parameter {name!r}; tunable: {', '.join(usable)}")
    if len(set(names)) != len(names):
        raise ParamError(f"tune: a parameter is named twice in {names!r}")
    return names


def _positive_float(name, v):
    try:
        x = float(v)
    except (TypeError, ValueError):
        raise JacoError(f"{name} must be a positive number, got {v!r}") from None
    if not (math.isfinite(x) and x > 0):
        raise JacoError(f"{name} must be a positive finite number, got {v!r}")
    return x


@check_keywords
def tune(
    grid: Grid,
    start: Cell,
    goal: Cell,
    planner: str | Planner = "mmas",
    *,
    tune: Sequence[str] = ("alpha", "beta", "rho"),
    init: dict | None = None,
    steps: int = 30,
    population: int = 16,
    n_seeds: int = 2,
    sigma: float = 0.5,
    optimizer: optax.GradientTransformation | None = None,
    penalty: float | None = None,
    seed: int = 0,
    n_ants: int = 20,
    n_iters: int = 30,
    steplimit: int | None = None,
    connectivity: int = 8,
    progress: bool | None = None,
) -> TuneResult:
    """Tune continuous hyperparameters of ``planner`` on one query by evolution strategies.

    ``tune``: the parameters to tune (each must be used by the planner and have a range in
    :data:`jaco.engine.params.SPECS`); ``init``: starting values of the tuned parameters and fixed
    values of any other parameter of the planner (default: the planner's defaults); ``steps``
    optimiser steps of ``population`` members (even: antithetic pairs), each run on ``n_seeds``
    seeds; ``sigma``: the perturbation in the unconstrained coordinates (about ±50 % of a value
    for log-transformed parameters); ``optimizer``: any optax ``GradientTransformation``
    (default ``optax.adam(0.1)``; build it once and reuse it, the compiled loop is cached by its
    identity); ``penalty``: the cost of a failed run (default √2 × the run's path buffer, an upper
    bound of any path length the run can return, so a failure is never better than a success;
    give one for a planner whose cost is not the path length); ``seed``: the key of the
    perturbations and of the runs; ``n_ants``, ``n_iters``, ``steplimit``: the planner's sizes;
    ``progress``: a bar of the steps on stderr; None (default) shows it on a terminal or in a
    notebook, True always, False never (:mod:`jaco.progress`; the results are the same either way).

    Everything is validated before anything compiles. Repeated calls with the same planner,
    optimiser, names and sizes reuse one compiled loop (any map of the same shape, any start,
    goal, seed, init, sigma and penalty).

    >>> import jaco
    >>> grid = jaco.maps.random_map(10, 0.1, seed=0)
    >>> res = jaco.tune(grid, (0, 0), (9, 9), "as", tune=("beta",), steps=2, population=4, n_ants=8, n_iters=5)
    >>> sorted(res.params), list(res.history.columns)
    (['alpha', 'beta', 'q', 'rho', 'tau0'], ['step', 'objective', 'success_rate', 'beta'])
    """
    planner = get_planner(planner)
    names = _names(planner, tune)
    check_grid(grid)
    steplimit = resolve_steplimit(grid, planner, steplimit, n_ants=n_ants, n_iters=n_iters)
    steps = positive_int("steps", steps, None, error=JacoError)
    population = positive_int("population", population, None, even="antithetic pairs", error=JacoError)
    n_seeds = positive_int("n_seeds", n_seeds, None, error=JacoError)
    check_run_memory(grid.n_cells, n_ants, n_iters + steps, steplimit, runs=population * n_seeds, what="a tuning step")
    problem = make_problem(grid, start, goal, connectivity=connectivity)
    sigma = _positive_float("sigma", sigma)
    check_seed(seed)
    optimizer = _check_optimizer(DEFAULT_OPTIMIZER if optimizer is None else optimizer)
    values = _start_values(planner, init)
    if penalty is not None:
        penalty = _positive_float("penalty", penalty)

    sizes = dict(
        n_ants=n_ants, n_iters=n_iters, steplimit=steplimit, steps=steps, population=population, n_seeds=n_seeds
    )
    penalty, (final, x, objective, success) = _run_loop(
        planner, names, optimizer, sizes, problem, values, seed=seed, sigma=sigma, penalty=penalty, progress=progress
    )
    start_values = {k: float(values[k]) for k in planner.params}
    tuned = dict(start_values)
    tuned.update({n: float(final[i]) for i, n in enumerate(names)})
    history = pd.DataFrame({"step": np.arange(steps), "objective": objective, "success_rate": success})
    for i, n in enumerate(names):
        history[n] = x[:, i]
    return TuneResult(tuned, history, start_values, names, planner.name, penalty)


def _check_optimizer(optimizer: Any) -> Any:
    """An optax ``GradientTransformation`` (anything with callable ``init`` and ``update``)."""
    if not (callable(getattr(optimizer, "init", None)) and callable(getattr(optimizer, "update", None))):
        raise JacoError(f"optimizer must be an optax GradientTransformation, got {type(optimizer).__name__}")
    return optimizer


def _start_values(planner: Planner, init: Any) -> dict:
    """One validated value per parameter of ``planner``: ``init`` over its defaults."""
    if init is not None and not isinstance(init, Mapping):
        raise ParamError(f"init must be a mapping of parameter names to values, got {type(init).__name__} {init!r}")
    values = resolve_params(planner, dict(init or {}), where=f"planner {planner.name!r}")
    for k, v in values.items():
        if v.ndim:
            raise JacoError(f"init takes one value per parameter; {k!r} has {v.size}")
    return values


def _run_loop(planner, names, optimizer, sizes: dict, problem, values: dict, *, seed, sigma, penalty, progress):
    """Run the compiled tuning loop (:func:`_compiled`) from ``values`` with a bar of its steps;
    returns the penalty of a failed run (the default one when ``penalty`` is None) and the loop's
    ``(final values, values per step, objective, success rate)`` on the host."""
    loop = _compiled(planner, names, optimizer, **sizes)
    base = params_from(values)
    key = jax.random.key(seed)
    if penalty is None:
        shape = RunShape(sizes["n_ants"], sizes["n_iters"], sizes["steplimit"])
        penalty = math.sqrt(2.0) * path_buffer(planner, shape, problem)

    z0 = jnp.asarray(to_unconstrained(names, [values[n] for n in names]), jnp.float32)
    bar = _progress.Bar(_progress.enabled(progress), f"tune {planner.name}", "step")
    bar.start(sizes["steps"])
    with _progress.listening(bar):
        out = _progress.run_interruptibly(
            lambda: fetched(loop(key, problem, base, z0, jnp.float32(sigma), jnp.float32(penalty)))
        )
    return penalty, out
