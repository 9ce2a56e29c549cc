"""The contract every planner passes, as functions a user can call on a planner of their own.

``jaco.testing.check_planner(p)`` runs every check below on ``p`` (a name, a composition or a
:class:`~jaco.engine.planner.Planner`) and raises :class:`AssertionError` naming the first that
fails; each check is also a function of its own. jaco's tests run the same functions on every
registered planner (``tests/test_variants.py``), so a planner that passes here is held to what
the built-in ones are held to: valid paths (free cells, 8-connected, no corner cutting, never
shorter than the exact optimum), finite pheromone, reproducible seeds, a sweep whose rows equal
single runs, one compile per shape, clear errors before compiling, failed runs that are inf and
never NaN, the trivial query, and a documented planner.
"""

from __future__ import annotations

import math
import warnings
from typing import Any, Sequence

import numpy as np

from .api import solve
from .engine.params import SPECS
from .engine.planner import Planner
from .engine.run import TRACES
from .errors import ProblemError
from .grid import Grid
from .maps import named, random_map
from .metrics import validate_path
from .planners.registry import get_planner
from .research.sweeps import sweep

__all__ = [
    "SMALL",
    "default_maps",
    "check_planner",
    "check_paths",
    "check_pheromone",
    "check_reproducible_seeds",
    "check_sweep",
    "check_compiles_once",
    "check_unreachable",
    "check_failed_runs",
    "check_trivial_query",
    "check_documented",
]

#: The size of the contract's runs: small enough for seconds per check, large enough to find paths.
SMALL: dict[str, Any] = dict(n_ants=16, n_iters=12)
#: Every solve of the checks keeps its final pheromone: one compiled program per map serves the
#: path, pheromone, seed, sweep-row, compile-once and trivial-query checks.
_RUN: dict[str, Any] = dict(SMALL, keep_pheromone=True)


def default_maps() -> list[Grid]:
    """Two maps the checks run on: a 12×12 random map (20 % obstacles) and the U-trap of the thesis."""
    return [random_map(12, 0.2, seed=3), named("utrap-15")]


def _ends(grid: Grid) -> tuple[Any, Any]:
    return grid.meta["start"], grid.meta["goal"]


def _other_value(v: Planner) -> tuple[str, float, float]:
    """The planner's first parameter, its default and another value inside its range."""
    name = v.params[0]
    x = float(v.defaults[name])
    spec = SPECS[name]
    for y in (0.5 * x, 2.0 * x, x + 1.0, x - 1.0):
        if y != x and bool(spec.contains(np.asarray(y))):
            return name, x, y
    return name, x, x


def check_paths(planner: str | Planner, maps: Sequence[Grid] | None = None) -> None:
    """On every map: the run succeeds, its path is valid (free cells, 8-connected, no corner cut)
    and never shorter than the exact optimum, the gap is (L − L*)/L*, the history holds no NaN,
    the best-so-far never rises and the best iteration lies in the run."""
    v = get_planner(planner)
    for grid in maps or default_maps():
        start, goal = _ends(grid)
        r = solve(grid, start, goal, v, seed=0, **_RUN)
        assert r.success, f"{v.name}: no path on {grid.name}"
        problems = validate_path(grid, r.path, start, goal)
        assert problems == [], f"{v.name}: invalid path on {grid.name}: {problems}"
        assert r.length >= r.optimal - 1e-4, f"{v.name}: length {r.length} below the optimum {r.optimal}"
        assert math.isclose(r.gap, (r.length - r.optimal) / r.optimal, rel_tol=1e-6, abs_tol=1e-9)
        h = r.history
        assert not np.isnan(h["best"]).any() and not np.isnan(h["mean"]).any(), f"{v.name}: NaN in the history"
        finite = h["best"][np.isfinite(h["best"])]
        assert (np.diff(finite) <= 0).all(), f"{v.name}: the best-so-far rose"
        assert 0 <= r.best_iteration < SMALL["n_iters"], f"{v.name}: best iteration {r.best_iteration}"


def check_pheromone(planner: str | Planner, grid: Grid | None = None) -> None:
    """The final pheromone is finite and non-negative."""
    v = get_planner(planner)
    grid = grid or default_maps()[0]
    r = solve(grid, *_ends(grid), v, seed=1, **_RUN)
    tau = r.pheromone
    assert tau is not None
    assert np.isfinite(tau).all() and (tau >= 0).all(), f"{v.name}: pheromone not finite or negative"


def check_reproducible_seeds(planner: str | Planner, grid: Grid | None = None) -> None:
    """The same seed gives the same run bit for bit; other seeds give other walks (some history or
    the cells the ants covered differ: a planner may find the optimum every time)."""
    v = get_planner(planner)
    grid = grid or default_maps()[0]
    a = solve(grid, *_ends(grid), v, seed=5, **_RUN)
    b = solve(grid, *_ends(grid), v, seed=5, **_RUN)
    assert np.array_equal(a.path, b.path), f"{v.name}: one seed, two paths"
    for k in a.history:
        assert np.array_equal(a.history[k], b.history[k]), f"{v.name}: one seed, two histories ({k})"
    others = [solve(grid, *_ends(grid), v, seed=s, **_RUN) for s in (6, 7, 8)]
    assert any(not np.array_equal(a.history["mean"], o.history["mean"]) or a.coverage != o.coverage for o in others), (
        f"{v.name}: other seeds gave the same walks"
    )


def check_sweep(planner: str | Planner, grid: Grid | None = None) -> None:
    """Each row of a sweep (two values of the planner's first parameter × two seeds) equals the
    single run with that value and seed."""
    v = get_planner(planner)
    grid = grid or default_maps()[1]
    name, x, y = _other_value(v)
    table = sweep(grid, *_ends(grid), v, params={name: [x, y]}, seeds=[0, 3], **SMALL)
    assert len(table) == 4
    for _, row in table.iterrows():
        value: dict[str, Any] = {name: float(row[name])}
        start, goal = _ends(grid)
        r = solve(grid, start, goal, v, seed=int(row.seed), **value, **_RUN)
        assert row.length == r.length and row.best_iteration == r.best_iteration, (
            f"{v.name}: sweep row ({name}={row[name]}, seed {row.seed}) differs from its single run"
        )
        assert row.coverage == r.coverage


def check_compiles_once(planner: str | Planner) -> None:
    """Repeated calls of one shape (other parameter values, maps and queries) compile nothing new."""
    v = get_planner(planner)
    a = random_map(12, 0.2, seed=1)
    b = random_map(12, 0.1, seed=2)
    shape: dict[str, Any] = dict(_RUN, steplimit=96)  # one step limit: a default one may depend on the map
    solve(a, (0, 0), (11, 11), v, seed=0, **shape)
    before = TRACES[v.name]
    name, _, y = _other_value(v)
    other: dict[str, Any] = {name: y}
    solve(a, (0, 0), (11, 11), v, seed=1, **other, **shape)
    solve(b, (0, 0), (11, 11), v, seed=2, **shape)  # other map, same shape
    solve(b, (11, 11), (0, 0), v, seed=3, **shape)  # other query
    assert TRACES[v.name] == before, f"{v.name}: recompiled for a call of the same shape"


def check_unreachable(planner: str | Planner) -> None:
    """An unreachable goal is a :class:`~jaco.errors.ProblemError` before anything compiles."""
    v = get_planner(planner)
    grid = Grid.from_rows(["..#..", "..#..", "..#.."])
    before = TRACES[v.name]
    try:
        solve(grid, (0, 0), (0, 4), v, n_ants=4, n_iters=2)
    except ProblemError as e:
        assert "cannot be reached" in str(e), f"{v.name}: unclear error {e}"
    else:
        raise AssertionError(f"{v.name}: an unreachable goal was not an error")
    assert TRACES[v.name] == before, f"{v.name}: compiled before refusing an unreachable goal"


def check_failed_runs(planner: str | Planner) -> None:
    """Runs that cannot succeed (two steps to the far corner) are inf, never NaN, with best
    iteration −1, inside a batch."""
    v = get_planner(planner)
    grid = random_map(12, 0.1, seed=0)
    name, x, y = _other_value(v)
    table = sweep(grid, (0, 0), (11, 11), v, params={name: [x, y]}, seeds=2, n_ants=4, n_iters=3, steplimit=2)
    assert (~table.success).all()
    assert np.isinf(table.length).all() and np.isinf(table.cost).all() and np.isinf(table.gap).all()
    assert not table.select_dtypes("number").isna().any().any(), f"{v.name}: NaN in a failed batch"
    assert (table.best_iteration == -1).all()


def check_trivial_query(planner: str | Planner, grid: Grid | None = None) -> None:
    """Start = goal: success, length 0, the path is the one cell."""
    v = get_planner(planner)
    grid = grid or default_maps()[0]
    start = _ends(grid)[0]
    r = solve(grid, start, start, v, **_RUN)
    assert r.success and r.length == 0 and r.path.tolist() == [list(start)], f"{v.name}: trivial query"


def check_documented(planner: str | Planner) -> None:
    """A name, a source and a description; every parameter has a finite default."""
    v = get_planner(planner)
    assert isinstance(v, Planner) and v.name and v.source and v.doc, f"{v!r}: name, source and doc are required"
    assert set(v.defaults) >= set(v.params), f"{v.name}: parameters without a default"
    assert all(math.isfinite(float(v.defaults[k])) for k in v.params), f"{v.name}: a default is not finite"


def check_planner(planner: str | Planner, maps: Sequence[Grid] | None = None) -> None:
    """Every check of this module on ``planner`` (a name, a composition or a Planner); raises
    :class:`AssertionError` naming the first that fails. About a minute on two cores: each check
    compiles the planner's programs for its own shapes."""
    maps = list(maps) if maps is not None else default_maps()
    check_documented(planner)
    check_paths(planner, maps)
    check_pheromone(planner, maps[0])
    check_reproducible_seeds(planner, maps[0])
    check_sweep(planner, maps[-1])
    check_compiles_once(planner)
    check_unreachable(planner)
    check_failed_runs(planner)
    check_trivial_query(planner, maps[0])


def __getattr__(name: str) -> Any:
    # check_seeds was this check's name until it met engine.checks.check_seeds (a sweep's seed list)
    if name == "check_seeds":
        warnings.warn(
            "jaco.testing.check_seeds is now jaco.testing.check_reproducible_seeds", DeprecationWarning, stacklevel=2
        )
        return check_reproducible_seeds
    raise AttributeError(f"module 'jaco.testing' has no attribute {name!r}")
