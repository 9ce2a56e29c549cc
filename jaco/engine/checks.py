"""Validation before anything compiles: the sizes, seeds, map, pheromone choice, parameter values
and their relations, and the default step limit, all with numpy, so that a mistake is a one-line
:class:`~jaco.errors.JacoError` rather than a trace. Every check lives here once: :func:`jaco.solve`
(:func:`prepare`), the waypoint legs, :func:`jaco.sweep`, :func:`jaco.tune` and :func:`jaco.search`
call the same functions.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from typing import Any, cast

import numpy as np

from ..errors import JacoError, ProblemError, ResourceError
from ..grid import Grid
from .memory import check_memory, check_run_memory
from .params import Params, check_order, check_values
from .planner import Planner
from .shape import RunShape

KEEP_PHEROMONE = (False, True, "history")


def default_steplimit(grid: Grid, planner: Planner | None = None) -> int:
    """Step limit when none is given: 4·(H + W), at most the number of free cells (a walk with a
    tabu list can never be longer). Ants that step back at dead ends (a construct marked
    ``back_steps``, IACA's) count their back-steps against the limit and explore dead branches,
    whose length grows with how far apart the free cells lie: they get 8·E, at most twice the free
    cells, with E = max(H + W, the free cells' extent :func:`jaco.exact.free_extent`, the longest
    shortest path between two free cells). Twice 4·(H + W) gives them the forward reach of the
    ants that die (a back-step undoes a forward step); the extent stretches it on mazes, where
    paths are much longer than the map is wide; 2·(free cells) is the depth-first search's bound
    (every cell entered once and left once), so where it is the limit every backtracking ant
    reaches a reachable goal (docs/compose.md, "The step limit")."""
    if planner is not None and planner.back_steps:
        from ..exact import free_extent

        extent = max(grid.height + grid.width, math.ceil(free_extent(grid)))
        return int(max(1, min(8 * extent, 2 * grid.n_free)))
    return int(max(1, min(4 * (grid.height + grid.width), grid.n_free)))


def resolve_steplimit(grid: Grid, planner: Planner | None, steplimit: int | None, *, n_ants: int, n_iters: int) -> int:
    """A run's step limit, checked with its other sizes (:func:`check_sizes`): ``steplimit`` when
    given, else :func:`default_steplimit` of the map and planner."""
    steplimit = default_steplimit(grid, planner) if steplimit is None else steplimit
    check_sizes(n_ants, n_iters, steplimit)
    return steplimit


def legacy_steplimit(grid: Grid, planner: Planner | None = None, format_version: int = 2) -> int:
    """The default step limit of the jaco that wrote a record of ``format_version`` (a sweep record
    stores ``steplimit: null`` when none was given): before format 3, 4·(H + W) at most the free
    cells for every planner; in format 3, twice that (at most twice the free cells) for
    backtracking ants; since format 4, :func:`default_steplimit`."""
    if format_version >= 4:
        return default_steplimit(grid, planner)
    free, extent = grid.n_free, 4 * (grid.height + grid.width)
    if format_version == 3 and planner is not None and planner.back_steps:
        free, extent = 2 * free, 2 * extent
    return int(max(1, min(extent, free)))


INT32_MAX = 2**31 - 1
#: Seeds are 32-bit: ``jax.random.key(seed)`` keeps only the low 32 bits, so 2**32 would silently
#: give the run of seed 0. A larger seed is an error, never wrapped.
SEED_LIMIT = 2**32


def check_sizes(n_ants: int, n_iters: int, steplimit: int) -> None:
    """Positive integers whose products still fit the compiled program's 32-bit indices."""
    for name, v in (("n_ants", n_ants), ("n_iters", n_iters), ("steplimit", steplimit)):
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 1:
            raise JacoError(f"{name} must be a positive integer (int), got {type(v).__name__} {v!r}")
        if v > INT32_MAX:
            raise ResourceError(f"{name} = {v} is more than the compiled program's 32-bit indices hold ({INT32_MAX})")
    if int(n_ants) * int(steplimit) > INT32_MAX:
        raise ResourceError(
            f"n_ants x steplimit = {int(n_ants) * int(steplimit)} ant-steps per iteration is more than the "
            f"compiled program's 32-bit indices hold ({INT32_MAX})"
        )


def check_seed(seed: int, what: str = "seed") -> int:
    """An integer seed in [0, 2**32) (:data:`SEED_LIMIT`), as a Python int."""
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)):
        raise JacoError(f"{what} must be an integer in [0, 2**32), got {type(seed).__name__} {seed!r}")
    if not 0 <= seed < SEED_LIMIT:
        raise JacoError(
            f"{what} must be in [0, 2**32) (jax keys take 32 bits; a larger one would alias a smaller seed), got {seed}"
        )
    return int(seed)


def check_seeds(seeds: int | Iterable[int]) -> np.ndarray:
    """A sweep's seeds: a count (``range(seeds)``) or a non-empty list of :func:`check_seed` seeds,
    as uint32."""
    items: Iterable[int]
    if isinstance(seeds, (int, np.integer)) and not isinstance(seeds, bool):
        check_memory(64 * int(seeds), f"{seeds} seeds", "use fewer seeds")
        items = range(seeds)
    elif isinstance(seeds, (str, bytes)) or not hasattr(seeds, "__iter__"):
        raise JacoError(
            f"seeds must be a count or a list of integers in [0, 2**32), got {type(seeds).__name__} {seeds!r}"
        )
    else:
        items = cast("Iterable[int]", seeds)  # not an int: a bool has no __iter__ and was refused above
    out = []
    for s in items:
        try:
            out.append(check_seed(s, "seeds"))
        except JacoError:
            raise JacoError(f"seeds must be integers in [0, 2**32), got {type(s).__name__} {s!r}") from None
    if not out:
        raise JacoError("seeds: need at least one seed")
    return np.array(out, np.uint32)


def check_keep_pheromone(keep_pheromone: bool | str) -> bool | str:
    """``False``, ``True`` or ``"history"``."""
    if keep_pheromone not in KEEP_PHEROMONE:
        raise JacoError(f"keep_pheromone must be False, True or 'history', got {keep_pheromone!r}")
    return keep_pheromone


def check_shape(shape: RunShape) -> RunShape:
    """The sizes (:func:`check_sizes`) and the pheromone choice of a :class:`RunShape`."""
    check_keep_pheromone(shape.keep_pheromone)
    check_sizes(shape.n_ants, shape.n_iters, shape.steplimit)
    return shape


def resolve_params(planner: Planner, values: dict, *, where: str) -> dict:
    """Validated parameter values (numpy float arrays) over the planner's defaults."""
    merged = {k: np.asarray(planner.defaults[k], np.float64) for k in planner.params}
    merged.update(check_values(values, planner.params, where))
    check_order(merged, planner.params)
    return merged


def params_from(values: dict, shape: Any = ()) -> Params:
    return Params(**{k: np.broadcast_to(np.float32(v), shape) for k, v in values.items()})


def check_grid(grid: object) -> Grid:
    """``grid`` itself when it is a :class:`~jaco.grid.Grid` (a map name says how to load it)."""
    if not isinstance(grid, Grid):
        hint = " (a map name: load it with jaco.maps.named or jaco.maps.load first)" if isinstance(grid, str) else ""
        raise ProblemError(f"expected a jaco.Grid, got {type(grid).__name__}{hint}")
    return grid


def prepare(
    grid: Grid,
    planner: Planner,
    *,
    seed: int,
    n_ants: int,
    n_iters: int,
    steplimit: int | None,
    params: dict,
    runs: int = 1,
    keep_pheromone: bool | str = False,
) -> tuple[int, dict]:
    """Validate one call with numpy before anything compiles: the map's type, the sizes and their
    memory estimate (``runs`` runs at once), the seed and every parameter (unknown names list the
    valid ones). Returns the step limit (the default when ``steplimit`` is None) and the parameter
    values over the planner's defaults."""
    check_grid(grid)
    check_keep_pheromone(keep_pheromone)
    steplimit = resolve_steplimit(grid, planner, steplimit, n_ants=n_ants, n_iters=n_iters)
    check_seed(seed)
    check_run_memory(grid.n_cells, n_ants, n_iters, steplimit, runs=runs, keep_pheromone=keep_pheromone)
    values = resolve_params(planner, params, where=f"planner {planner.name!r}")
    for k, v in values.items():
        if v.ndim:
            raise JacoError(f"solve takes one value per parameter; {k!r} has {v.size} (use jaco.sweep)")
    return steplimit, values
