"""A batch of trials evaluated as one compiled call (:class:`Evaluator`): the trials are grouped by
planner and sizes, each group runs trials × seeds × queries through one planner's chunk program
(:class:`jaco.research.chunks.Runner`, the one :func:`jaco.sweep` uses), and each trial's runs
become its objective values, a failed run counted as its penalty (:mod:`jaco.research.search`)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from ..metrics import gap

if TYPE_CHECKING:
    from .search_setup import SearchSetup


@dataclass(eq=False)  # a job is one trial's evaluation: two jobs are the same only if one object
class Job:
    """One evaluation: ``trial`` (an Optuna Trial), ``planner``, ``values`` (every parameter),
    ``own`` (the planner's own, as stored), ``stored`` (its runs by iterations), ``n_ants``,
    ``n_iters``; ``member``: its place in an evosax generation. :meth:`Evaluator.__call__` sets
    ``runs`` and ``objective``."""

    trial: Any
    planner: str
    values: dict
    own: dict
    stored: dict
    n_ants: int
    n_iters: int
    member: int | None = None
    runs: dict | None = None
    objective: list | None = None


def pow2(n: int) -> int:
    """The smallest power of two >= ``n`` (1 for n <= 1)."""
    return 1 << max(0, int(n) - 1).bit_length()


class Evaluator:
    """Runs jobs in batches over the study's queries and seeds (see :mod:`jaco.research.search`)."""

    def __init__(self, setup: SearchSetup):
        from jax.sharding import Mesh

        from .chunks import AXIS, mesh_devices

        self.space, self.queries, self.seeds = setup.space, setup.queries, np.asarray(setup.seeds, np.uint32)
        self.steplimit, self.objectives = setup.steplimits, setup.objectives  # step limits by planner
        self.batch, self.budget = setup.batch, setup.budget
        self.paths = "turns" in self.objectives
        self.mesh = Mesh(np.array(mesh_devices(setup.devices)), (AXIS,))
        self.runners: dict = {}
        self.cell = np.array([g.cell_size for g, _, _ in self.queries.queries])
        self.optimal = setup.optima
        self.penalty = self._penalties(setup.penalties)
        self.compiles = 0

    def _penalties(self, given: dict) -> dict:
        """Each penalised objective's penalty by query: the one given, else the worst value a
        successful run could have (a path of steplimit diagonal steps, for the largest step limit
        of the planners searched: a failure is worse than any success)."""
        longest = max(self.steplimit.values())
        worst = math.sqrt(2.0) * longest * self.cell
        default = {
            "length": worst,
            "turns": np.full(len(self.cell), float(longest)),
            "gap": np.array([gap(w, o) for w, o in zip(worst, self.optimal)], np.float64),
        }
        return {n: (default[n] if v is None else np.full(len(self.cell), v)) for n, v in given.items()}

    def _runner(self, planner, n_ants, n_iters, n_trials):
        from ..engine.shape import RunShape
        from .chunks import Runner

        width = min(pow2(n_trials), pow2(self.batch)) * len(self.seeds)
        key = (planner, n_ants, n_iters, width)
        if key not in self.runners:

            def compiling():
                self.compiles += 1

            shape = RunShape(n_ants, n_iters, self.steplimit[planner])  # the queries' problems hold their moves
            self.runners[key] = Runner(
                self.space.planners[planner],
                self.queries,
                shape=shape,
                mesh=self.mesh,
                rows=width,
                budget=self.budget,
                on_compile=compiling,
                paths=self.paths,
            )
        return self.runners[key]

    def __call__(self, jobs: list[Job]) -> None:
        groups: dict = {}
        for job in jobs:
            groups.setdefault((job.planner, job.n_ants, job.n_iters), []).append(job)
        n_s = len(self.seeds)
        for (planner, n_ants, n_iters), group in groups.items():
            runner = self._runner(planner, n_ants, n_iters, len(group))
            names = list(group[0].values)
            values = {k: np.repeat([j.values[k] for j in group], n_s) for k in names}  # trial-major, seeds inner
            outs = runner(values, np.tile(self.seeds, len(group)))
            for i, job in enumerate(group):
                part = [o[:, i * n_s : (i + 1) * n_s] for o in outs]
                job.runs = self._runs(part)
                job.objective = self.objective(job.runs, n_ants, n_iters)

    def _runs(self, outs) -> dict:
        """Per-run results, arrays ``(queries, seeds)``."""
        cost, length, best_iter = outs[0], outs[1], outs[2]
        ok = np.isfinite(cost)
        L = np.where(ok, length.astype(np.float64) * self.cell[:, None], np.inf)
        gaps = np.array([gap(row, o) for row, o in zip(L, self.optimal)], np.float64)
        runs = {"success": ok, "length": L, "gap": gaps, "best_iteration": best_iter.astype(np.int64)}
        if self.paths:
            runs["turns"] = self._turns(outs[4], ok)
        return runs

    def _turns(self, cells, ok) -> np.ndarray:
        from ..engine.result import path_cells
        from ..metrics import turns

        out = np.full(ok.shape, np.inf)
        for q, (g, s, _) in enumerate(self.queries.queries):
            for j in range(ok.shape[1]):
                if ok[q, j]:
                    out[q, j] = turns(path_cells(g, s, cells[q, j]))
        return out

    def objective(self, runs: Any, n_ants: int, n_iters: int) -> list[float]:
        """The trial's objective values, failures counted as their penalty."""
        out = []
        for name in self.objectives:
            if name == "success":
                out.append(float(np.mean(runs["success"])))
            elif name == "budget":
                out.append(float(n_ants * n_iters))
            else:
                v = np.where(runs["success"], runs[name], self.penalty[name][:, None])
                out.append(float(np.mean(v)))
        return out
