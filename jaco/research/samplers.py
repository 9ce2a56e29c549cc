"""The samplers of :func:`jaco.search`: Optuna's through ask-and-tell, and evosax's strategies.

Optuna (Akiba et al. 2019) proposes trials one ``study.ask()`` at a time; jaco asks a whole batch,
evaluates it as one compiled call, then tells every trial. Each sampler is set up for batches:

* ``"tpe"`` — TPE (Bergstra et al. 2011; Watanabe 2023), multivariate, with the *constant liar*:
  a trial asked but not yet told counts as a bad result, so the 128 asks of one batch do not all
  land on the same point; ``group=True`` when a parameter belongs to some planners only;
* ``"cmaes"`` — CMA-ES (Hansen 2016) with its population equal to the batch (one generation per
  batch); categorical dimensions (the planner) are sampled by TPE beside it;
* ``"random"``, ``"qmc"`` (scrambled Sobol), ``"grid"`` (every combination; a range is cut into
  about ``trials^(1/d)`` points, linearly or in log space);
* ``"gp"`` — Gaussian-process Bayesian optimisation (needs PyTorch, not installed by jaco);
* ``"nsga2"`` — NSGA-II (Deb et al. 2002), for several objectives, population = batch;
* ``"evosax:NAME"`` — an evosax strategy (Lange 2023), e.g. ``evosax:CMA_ES``, ``evosax:SNES``,
  ``evosax:Open_ES``, for continuous parameters of one planner: ask and tell are JAX functions of
  an explicit key, so a study's proposals follow from its seed and its told values alone, and a
  resumed study replays them exactly (:class:`EvosaxProposer`).

A sampler object (any ``optuna.samplers.BaseSampler``) is used as given.
"""

from __future__ import annotations

import math
from importlib.util import find_spec
from typing import Any

import numpy as np

from ..engine.params import owners
from ..errors import JacoError
from .space import VARIANT, Categorical, Float, Int, Space, SpaceError

OPTUNA_SAMPLERS = ("tpe", "cmaes", "random", "qmc", "grid", "gp", "nsga2")
EVOSAX_PREFIX = "evosax:"
EXTRA = "pip install 'jaco[search]'"


def require(module: str, what: str) -> Any:
    """Import ``module`` or raise a one-line JacoError naming the extra that installs it."""
    if find_spec(module) is None:
        raise JacoError(f"{what} needs the package {module!r}: {EXTRA}")
    import warnings
    from importlib import import_module

    with warnings.catch_warnings():  # e.g. tqdm's "IProgress not found" when Optuna loads in a notebook
        warnings.simplefilter("ignore")
        return import_module(module)


def check_sampler(sampler: Any, space: Space, n_objectives: int) -> str:
    """The sampler's name (for records and messages), checked against the space before anything
    compiles; a sampler object is named by its class."""
    if not isinstance(sampler, str):
        optuna = require("optuna", "jaco.search")
        if not isinstance(sampler, optuna.samplers.BaseSampler):
            raise JacoError(
                f"sampler must be a name ({', '.join(OPTUNA_SAMPLERS)}, evosax:NAME) or an Optuna sampler, "
                f"got {type(sampler).__name__}"
            )
        return type(sampler).__name__
    if sampler.startswith(EVOSAX_PREFIX):
        require("evosax", f"sampler {sampler!r}")
        from evosax import algorithms

        name = sampler[len(EVOSAX_PREFIX) :]
        if name not in algorithms.distribution_based_algorithms:
            raise JacoError(
                f"unknown evosax strategy {name!r}; distribution-based ones: "
                f"{', '.join(sorted(algorithms.distribution_based_algorithms))}"
            )
        bad = [n for n, d in space.dims.items() if not isinstance(d, Float)]
        if bad:
            raise SpaceError(
                f"evosax strategies search real parameters of one planner; {bad[0]!r} is "
                f"{'the planner' if bad[0] == VARIANT else 'not a (low, high) range'}: use an Optuna sampler"
            )
        if n_objectives > 1:
            raise JacoError("evosax strategies minimise one objective: use sampler='nsga2' (or 'tpe') for several")
        return sampler
    if sampler not in OPTUNA_SAMPLERS:
        raise JacoError(f"unknown sampler {sampler!r}; valid: {', '.join(OPTUNA_SAMPLERS)}, or evosax:NAME")
    require("optuna", "jaco.search")
    if sampler == "cmaes":
        require("cmaes", "sampler 'cmaes'")
        if n_objectives > 1:
            raise JacoError("sampler 'cmaes' minimises one objective: use 'nsga2' or 'tpe' for several")
    if sampler == "gp" and find_spec("torch") is None:
        raise JacoError("sampler 'gp' needs PyTorch (pip install torch), which jaco[search] does not install")
    if sampler == "grid" and space.conditional():
        name = next(n for n in space.dims if not all(space.uses(p, n) for p in space.planners))
        raise SpaceError(
            f"sampler 'grid' needs every parameter to belong to every planner (no conditional parameter): "
            f"{owners(name, space.planners.values())}"
        )
    return sampler


def grid_values(dim: Any, points: int) -> list:
    """The values of one dimension on a grid of ``points`` per range (integers: unique, rounded)."""
    if isinstance(dim, Categorical):
        return list(dim.choices)
    lo, hi = float(dim.low), float(dim.high)
    x = np.geomspace(lo, hi, points) if dim.log else np.linspace(lo, hi, points)
    if isinstance(dim, Int):
        return sorted({int(round(v)) for v in x})
    return [float(v) for v in x]


def grid_points(space: Space, trials: int) -> int:
    """Points per range so that the grid has about ``trials`` combinations (at least 2)."""
    ranges = [d for d in space.dims.values() if not isinstance(d, Categorical)]
    combos = math.prod(len(d.choices) for d in space.dims.values() if isinstance(d, Categorical))
    if not ranges:
        return 2
    return max(2, int(math.floor((trials / combos) ** (1.0 / len(ranges)) + 1e-9)))


def grid_of(space: Space, trials: int) -> dict:
    """The grid of sampler ``"grid"``: name -> values (:func:`grid_points` per range)."""
    points = grid_points(space, trials)
    return {n: grid_values(d, points) for n, d in space.dims.items()}


def optuna_sampler(name: str, space: Space, *, seed: int, batch: int, trials: int) -> Any:
    """An Optuna sampler set up for batches of ``batch`` trials (see the module)."""
    import warnings

    import optuna

    s = optuna.samplers
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", optuna.exceptions.ExperimentalWarning)
        if name == "tpe":
            # TPE models once n_startup_trials are told: with small batches, from the second batch on
            return s.TPESampler(
                seed=seed,
                multivariate=True,
                group=space.conditional(),
                constant_liar=True,
                n_startup_trials=min(10, batch),
            )
        if name == "cmaes":
            beside = s.TPESampler(seed=seed, multivariate=True, constant_liar=True)
            return s.CmaEsSampler(
                seed=seed,
                popsize=batch,
                n_startup_trials=0,
                independent_sampler=beside,
                warn_independent_sampling=False,
            )
        if name == "random":
            return s.RandomSampler(seed=seed)
        if name == "qmc":
            return s.QMCSampler(
                qmc_type="sobol",
                scramble=True,
                seed=seed,
                warn_asynchronous_seeding=False,
                warn_independent_sampling=False,
            )
        if name == "grid":

            class Grid(s.GridSampler):
                def after_trial(self, study, trial, state, values):
                    pass  # Optuna's stops the study when the grid is done; jaco.search asks no more than its size

            return Grid(grid_of(space, trials), seed=seed)
        if name == "gp":
            return s.GPSampler(seed=seed, warn_independent_sampling=False)
        if name == "nsga2":
            return s.NSGAIISampler(population_size=max(batch, 2), seed=seed)
    raise AssertionError(name)  # check_sampler let an unknown name through


def suggest(trial: Any, space: Space) -> tuple[str, dict]:
    """Ask ``trial`` for a planner and its parameters (define-by-run: a parameter is suggested
    only for the planners that use it); returns the planner's name and the suggested values."""
    planner = (
        trial.suggest_categorical(VARIANT, list(space.dims[VARIANT].choices))
        if space.searches_planner
        else next(iter(space.planners))
    )
    values = {}
    for name, dim in space.dims.items():
        if name == VARIANT or not space.uses(planner, name):
            continue
        if isinstance(dim, Float):
            values[name] = trial.suggest_float(name, dim.low, dim.high, log=dim.log)
        elif isinstance(dim, Int):
            values[name] = trial.suggest_int(name, dim.low, dim.high, log=dim.log)
        else:
            values[name] = trial.suggest_categorical(name, list(dim.choices))
    return planner, values


def _queue_sampler():
    """An Optuna sampler that hands out values set in advance (:class:`EvosaxProposer`'s
    proposals), so that its trials live in the study like any other."""
    import optuna

    class Queue(optuna.samplers.BaseSampler):
        def __init__(self):
            self.pending: list = []
            self.by_trial: dict = {}

        def infer_relative_search_space(self, study, trial):
            return {}

        def sample_relative(self, study, trial, search_space):
            return {}

        # ``trial`` is a FrozenTrial of the one study this sampler serves: its number names it
        def before_trial(self, study, trial):
            if self.pending:
                self.by_trial[trial.number] = self.pending.pop(0)

        def sample_independent(self, study, trial, name, distribution):
            return self.by_trial[trial.number][name]

        def after_trial(self, study, trial, state, values):
            self.by_trial.pop(trial.number, None)

    return Queue()


def _evosax_rules():
    """evosax broadcasts ranks implicitly: allow it there, whatever the caller's setting."""
    import jax

    return jax.numpy_rank_promotion("allow")


class EvosaxProposer:
    """An evosax strategy over the space's real parameters, in an unconstrained coordinate z:
    ``x = lo + (hi − lo)·sigmoid(z)`` (log ranges: the same in log x), so any z is a valid value.
    The search starts at z = 0, the middle of every range (in log space for log ranges).

    Generation g asks and tells with keys split from ``fold_in(key(seed), g)``, so the proposals
    of a study follow from its seed and told fitnesses alone: a resumed study replays its finished
    generations (same asks, same stored fitnesses) and continues exactly where it stopped.
    """

    def __init__(self, name: str, space: Space, *, seed: int, batch: int, options: dict | None = None):
        import jax
        import jax.numpy as jnp
        import optax
        from evosax import algorithms

        self.names = [n for n in space.dims]
        dims = [space.dims[n] for n in self.names]
        self.log = np.array([d.log for d in dims])
        lo = np.array([d.low for d in dims], np.float64)
        hi = np.array([d.high for d in dims], np.float64)
        self.lo = np.where(self.log, np.log(lo), lo)
        self.hi = np.where(self.log, np.log(hi), hi)
        self.bounds = (lo, hi)
        cls = algorithms.distribution_based_algorithms[name[len(EVOSAX_PREFIX) :]]
        options = dict(options or {})
        if cls.__name__ == "Open_ES":  # evosax's defaults (sgd 1e-3, std 1) suit raw weights, not z: jaco.tune's
            options.setdefault("optimizer", optax.adam(0.1))
            options.setdefault("std_schedule", optax.constant_schedule(0.5))
        try:
            self.strategy = cls(population_size=batch, solution=jnp.zeros(len(self.names)), **options)
        except (TypeError, AssertionError) as e:
            raise JacoError(f"evosax strategy {name[len(EVOSAX_PREFIX) :]}: {e or 'invalid population size'}") from None
        self.params = self.strategy.default_params
        self.key = jax.random.key(seed)
        k_init = jax.random.fold_in(self.key, 2**31 - 1)
        with _evosax_rules():
            self.state = self.strategy.init(k_init, jnp.zeros(len(self.names)), self.params)

    def _keys(self, generation: int):
        import jax

        return jax.random.split(jax.random.fold_in(self.key, generation))

    def ask(self, generation: int) -> np.ndarray:
        """The population ``z (batch, d)`` of ``generation`` (float32)."""
        k_ask, _ = self._keys(generation)
        with _evosax_rules():
            z, self.state = self.strategy.ask(k_ask, self.state, self.params)
        return np.asarray(z, np.float32)

    def tell(self, generation: int, z: np.ndarray, fitness: np.ndarray) -> None:
        import jax.numpy as jnp

        _, k_tell = self._keys(generation)
        with _evosax_rules():
            self.state, _ = self.strategy.tell(
                k_tell, jnp.asarray(z, jnp.float32), jnp.asarray(fitness, jnp.float32), self.state, self.params
            )

    def values(self, z: np.ndarray) -> list[dict]:
        """Parameter values of each member (inside the ranges, whatever z)."""
        frac = 1.0 / (1.0 + np.exp(-np.asarray(z, np.float64)))
        x = self.lo + (self.hi - self.lo) * frac
        x = np.clip(np.where(self.log, np.exp(x), x), *self.bounds)
        return [{n: float(row[i]) for i, n in enumerate(self.names)} for row in x]

    queue = staticmethod(_queue_sampler)
