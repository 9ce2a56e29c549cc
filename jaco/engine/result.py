"""The outcome of a run as a person reads it: :class:`Result` (path, length, optimum, gap,
history, ...), built from the engine's raw arrays by :func:`to_result`. The gap is
:func:`jaco.metrics.gap`, the one gap of jaco.

:meth:`Result.save` and :meth:`Result.save_path` are conveniences that delegate to
:mod:`jaco.research.record_format`, which writes files and never imports the engine back.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, cast

import numpy as np

from ..errors import JacoError
from ..grid import Grid
from ..metrics import gap
from .shape import RunShape


@dataclass
class Result:
    """The outcome of one run: the best path and how the colony got there.

    ``path`` is a ``(K, 2)`` array of ``(row, col)`` (empty when no ant reached the goal);
    ``length`` and ``optimal`` are in cell units times the grid's ``cell_size``; ``cost`` is the
    planner's objective (the length in cell units unless the planner says otherwise). When no ant
    reached the goal, ``hint`` says so and what usually helps on such a map.
    """

    variant: str
    path: np.ndarray
    length: float
    success: bool
    cost: float
    optimal: float
    gap: float
    best_iteration: int
    history: dict
    coverage: float
    seed: int
    params: dict
    n_ants: int
    n_iters: int
    steplimit: int
    start: tuple
    goal: tuple
    grid: Grid | None = field(default=None, repr=False)
    pheromone: np.ndarray | None = field(default=None, repr=False)
    connectivity: int = 8  # records: a rerun needs the move set (jaco.research.records)
    waypoints: tuple = ()  # the targets visited between start and goal (jaco.waypoints)
    # The planner's ants step back from dead ends (Planner.back_steps): the failure hint reads it.
    back_steps: bool = field(default=False, repr=False, compare=False)

    @property
    def planner(self) -> str:
        """The planner's name (the field keeps its former name, ``variant``, as records do)."""
        return self.variant

    @property
    def hint(self) -> str:
        """Empty when the run succeeded; otherwise a plain explanation of the failure and what
        usually helps (:func:`failure_hint`)."""
        return failure_hint(self)

    def metrics(self) -> dict:
        """:func:`jaco.metrics.path_metrics` of the best path (length, turns, heading change E,
        clearance, safety cost S, any-angle length, valid, gap) plus the run's ``cost``,
        ``coverage`` and ``best_iteration``. S uses the run's ``rs_cost`` when the planner has one
        (the multi-objective cost), else :data:`jaco.metrics.SAFETY_RADIUS`, so S and E are those
        of the cost. A failed run has length inf and no path figures. ``gap`` is the result's own
        :attr:`gap` (:func:`jaco.metrics.gap` of :attr:`length`, which the run summed in float32):
        one gap per result, never a second one from the float64 length of the path."""
        from ..metrics import SAFETY_RADIUS, path_metrics

        run = {"cost": self.cost, "coverage": self.coverage, "best_iteration": self.best_iteration}
        if not self.success:
            return {"length": math.inf, "valid": False, "gap": self.gap, **run}
        rs = self.params.get("rs_cost", SAFETY_RADIUS)  # a successful result carries its grid
        figures = path_metrics(cast(Grid, self.grid), self.path, rs=rs)
        return {**figures, "gap": self.gap, **run}

    def to_dict(self) -> dict:
        """JSON-ready dict (no numpy types; inf written as None where JSON has no inf)."""

        def num(x):
            x = float(x)
            return x if math.isfinite(x) else None

        return {
            "planner": self.variant,
            "path": self.path.tolist(),
            "length": num(self.length),
            "success": bool(self.success),
            "cost": num(self.cost),
            "optimal": num(self.optimal),
            "gap": num(self.gap),
            "best_iteration": int(self.best_iteration),
            "coverage": float(self.coverage),
            "seed": int(self.seed),
            "params": {k: float(v) for k, v in self.params.items()},
            "n_ants": self.n_ants,
            "n_iters": self.n_iters,
            "steplimit": self.steplimit,
            "start": list(self.start),
            "goal": list(self.goal),
            "map": None if self.grid is None else self.grid.name,
            "history": {k: [num(x) for x in v] for k, v in self.history.items()},
        }

    # -- records and world coordinates (jaco.research.records, docs/records.md) ---------------
    def save(self, path: Any) -> Any:
        """Write this run as a JSON record (parameters, seed, planner, the map embedded with its
        sha256, sizes, connectivity, result and history, jaco/jax versions); returns the path.
        ``jaco.load_run(path).rerun()`` or ``jaco rerun PATH`` reruns it and checks it bit for bit."""
        from ..research.record_format import save_run

        return save_run(self, path)

    def to_world(self) -> np.ndarray:
        """The path as ``(K, 2)`` world ``(x, y)`` in metres (cell centres), from the map's ROS
        ``resolution`` and ``origin``; a ProblemError when the map has none."""
        if self.grid is None:
            raise JacoError("this Result has no grid: world coordinates need the map")
        return self.grid.cell_to_world(np.asarray(self.path, np.int64).reshape(-1, 2))

    def save_path(self, path: Any, frame: str | None = None, format: str | None = None) -> Any:
        """Write the path as ``.csv`` (columns ``row,col`` and, in the world frame, ``x,y``
        in metres) or ``.json``; ``frame`` is ``"world"`` or ``"cells"`` (default: world when the
        map has a resolution); ``format`` (``"csv"``/``"json"``) overrides the suffix (``-`` or
        a device has none). Returns the path written."""
        from ..research.record_format import save_path

        return save_path(self, path, frame, format)


def failure_hint(result: Result, *, cli: bool = False) -> str:
    """What to try when no ant of ``result`` reached the goal ("" when one did), most likely
    first: a larger step limit when the shortest path is long for it; a backtracking planner
    (IACA's ants step back from a dead end, where the other planners' ants die: the usual cause on
    maps of rooms, corridors and traps); then more ants or iterations and a larger β (the pull
    toward the goal). ``cli``: name the ``jaco`` options instead of the keyword arguments."""
    if result.success:
        return ""
    opt = (
        {
            "steplimit": "--steplimit ",
            "planner": "--planner iaca",
            "n_ants": "--ants ",
            "n_iters": "--iters ",
            "beta": "--param beta=",
        }
        if cli
        else {
            "steplimit": "steplimit=",
            "planner": "planner='iaca'",
            "n_ants": "n_ants=",
            "n_iters": "n_iters=",
            "beta": "beta=",
        }
    )
    cell = result.grid.cell_size if result.grid is not None else 1.0
    steps = result.optimal / cell if math.isfinite(result.optimal) else 0.0  # the shortest path's length in cells
    tips = []
    if steps > 0.5 * result.steplimit:
        tips.append(
            f"a larger step limit ({opt['steplimit']}{2 * result.steplimit}; it is {result.steplimit} and the "
            f"shortest path is {steps:.0f} cells long, so an ant that strays runs out of steps)"
        )
    if not result.back_steps:
        tips.append(
            f"a backtracking planner ({opt['planner']}): {result.variant}'s ants die in dead ends, and maps "
            "of rooms, corridors and traps are full of them; IACA's ants step back instead"
        )
    beta = result.params.get("beta")
    more_beta = f", currently {beta:g}" if beta is not None else ""
    tips.append(
        f"more ants or iterations ({opt['n_ants']}{result.n_ants * 4}, {opt['n_iters']}{result.n_iters * 4}; "
        f"now {result.n_ants} x {result.n_iters})"
    )
    if beta is not None:
        tips.append(f"a larger beta, the pull toward the goal ({opt['beta']}{2 * beta:g}{more_beta})")
    listed = "; ".join(f"{i}. {t}" for i, t in enumerate(tips, 1))
    return f"no ant reached the goal (exact optimum {result.optimal:.4g}). What usually helps, most likely first: {listed}."


def path_cells(grid: Grid, start: Any, best_cells: Any) -> np.ndarray:
    """``(K, 2)`` path from the start cell and the best ant's entered cells. (Written into one
    array: right after a run, when the interpreter's caches are cold, the concatenation and stack
    of the rows took 85 µs of a 3.5 ms solve.)"""
    cells = np.asarray(best_cells)
    entered = cells[cells >= 0]
    path = np.empty((entered.size + 1, 2), np.int64)
    path[0] = start
    np.divmod(entered, grid.width, out=(path[1:, 0], path[1:, 1]))
    return path


def to_result(
    out: Any, *, grid: Grid, planner: Any, start: Any, goal: Any, optimal: Any, seed: int, params: dict, shape: RunShape
) -> Result:
    """Convert one (unbatched) :class:`jaco.engine.run.RunOutput` of a run of ``shape`` to a
    :class:`Result`."""
    cost = float(out.best_cost)
    success = math.isfinite(cost)
    length = float(out.best_length) * grid.cell_size if success else math.inf
    opt = float(optimal) * grid.cell_size
    return Result(
        variant=planner.name,
        path=path_cells(grid, start, out.best_cells) if success else np.empty((0, 2), np.int64),
        length=length,
        success=success,
        cost=cost,
        optimal=opt,
        gap=gap(length, opt),
        best_iteration=int(out.best_iteration),
        history={k: np.asarray(v) for k, v in out.history._asdict().items()},
        coverage=int(out.covered) / grid.n_free,
        seed=int(seed),
        params={k: float(params[k]) for k in planner.params},
        n_ants=shape.n_ants,
        n_iters=shape.n_iters,
        steplimit=shape.steplimit,
        start=tuple(int(v) for v in start),
        goal=tuple(int(v) for v in goal),
        grid=grid,
        pheromone=None if out.tau is None else np.asarray(out.tau),
        connectivity=int(shape.connectivity),
        back_steps=bool(planner.back_steps),
    )
