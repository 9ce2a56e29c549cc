"""A search's study read back (:class:`Study`, made by :func:`jaco.search` or :func:`load_study`):
its trials as a table, the best parameters, the anytime history, every stored run, and the rerun
of a stored trial (:class:`TrialRecord`)."""

from __future__ import annotations

import math
import warnings
from typing import Any

import numpy as np
import pandas as pd

from .record_json import number_from_json
from .samplers import require
from .search_checks import OBJECTIVES, PENALIZED, SearchError
from .search_setup import ATTR, FORMAT, STOPPED
from .search_storage import journal_storage, quiet, storage_target
from .space import SIZES, VARIANT


def objective_column(name: str) -> str:
    """The column of :attr:`Study.trials` that holds objective ``name``: a penalised objective
    (``gap``, ``length``, ``turns``: the mean over runs, a failed run counted as its penalty) is
    ``gap_penalised_mean`` ..., so that it never reads as the ``gap_median`` and ``length_mean``
    beside it (over the successful runs only); ``success`` and ``budget`` keep their names."""
    return f"{name}_penalised_mean" if name in PENALIZED else name


class BestParams(dict):
    """:attr:`Study.best_params`: a dict with the key ``planner``; ``["variant"]`` (its former
    name) still reads it, with a DeprecationWarning."""

    def __missing__(self, key):
        if key == VARIANT and "planner" in self:
            warnings.warn(
                "best_params['variant'] is the former name of best_params['planner']", DeprecationWarning, stacklevel=2
            )
            return self["planner"]
        raise KeyError(key)


def trial_info(frozen: Any) -> dict:
    """What jaco stored with a trial: ``planner``, ``params`` (every parameter of the planner),
    ``n_ants``, ``generation`` (and ``bracket``; ``member`` and ``z`` for evosax), ``runs`` (per-run
    results by iterations) and ``n_iters`` (of its last evaluation; None before one)."""
    a = dict(frozen.user_attrs.get("jaco_trial", {}))
    a["runs"] = frozen.user_attrs.get("jaco_runs", {})
    a["n_iters"] = max((int(k) for k in a["runs"]), default=None)
    return a


def run_value(x):
    """A stored run's value: a number written by :func:`jaco.research.record_json.json_number`
    (None: inf, a failed run's length or gap; ``"nan"``, ``"-inf"``) as a float; a success flag
    or a best iteration as it is."""
    return number_from_json(x) if x is None or isinstance(x, str) else x


def _numbers(rows) -> np.ndarray:
    """Stored per-run values ``(queries, seeds)`` as float64 (None read as inf)."""
    return np.asarray([[number_from_json(x) for x in r] for r in rows], np.float64)


class Study:
    """A search's trials and what was found; ``study`` is the Optuna study (``optuna.Study``,
    for Optuna's own plots and tools). Made by :func:`jaco.search` or :func:`load_study`."""

    def __init__(self, study, timings: dict | None = None):
        self.study = study
        self.info = study.user_attrs.get(ATTR)
        if self.info is None or self.info.get("format") != FORMAT:
            raise SearchError(f"study {study.study_name!r} was not made by jaco.search")
        self.timings = dict(timings or {})
        #: why the last search call stopped: ``"trials reached: 128 trials finished"`` or ``"timeout after 60 s: 192
        #: trials finished"``; None when it did not end (killed, interrupted or still running).
        self.stopped: str | None = study.user_attrs.get(STOPPED)

    def __repr__(self) -> str:
        return (
            f"Study({self.study.study_name!r}: {len(self.study.trials)} trials, sampler {self.info['sampler']}, "
            f"objectives {', '.join(self.info['objectives'])})"
        )

    @property
    def objectives(self) -> list[str]:
        return list(self.info["objectives"])

    def _params(self, frozen) -> dict:
        """A trial's planner (key ``planner``), its searched values and the fixed values of the
        space that apply (the stored trial keeps the planner under Optuna's parameter ``variant``)."""
        a = trial_info(frozen)
        used = set(a["params"]) | set(SIZES)
        fixed = {k: v for k, v in self.info["space"].items() if isinstance(v, (int, float)) and k in used}
        return BestParams(
            {"planner": a["planner"], **fixed, **{k: v for k, v in frozen.params.items() if k != VARIANT}}
        )

    @property
    def best_trial(self) -> Any:
        """The best finished trial (one objective), an ``optuna.trial.FrozenTrial``."""
        if len(self.objectives) > 1:
            raise SearchError("a study with several objectives has a Pareto front: use best_trials")
        return self.study.best_trial

    @property
    def best_params(self) -> dict:
        """The best trial's planner (key ``planner``), searched and fixed parameters and searched
        sizes: ``jaco.solve(grid, start, goal, **study.best_params)`` runs it (``jaco.solve`` also
        takes the former key, ``variant``, and ``best_params["variant"]`` still reads the planner)."""
        return self._params(self.best_trial)

    @property
    def best_value(self) -> float:
        return float(self.best_trial.value)

    @property
    def best_trials(self) -> pd.DataFrame:
        """The Pareto front (several objectives; one objective: the best trial), as rows of
        :attr:`trials`."""
        numbers = [t.number for t in self.study.best_trials]
        table = self.trials
        return table[table["number"].isin(numbers)].reset_index(drop=True)

    @property
    def trials(self) -> pd.DataFrame:
        """One row per trial: ``number, state, generation, planner``, the searched parameters, the
        objective value(s) (a column per objective, :func:`objective_column`: ``gap_penalised_mean``
        for ``gap``, the mean over runs with the penalty counted for failed runs),
        ``success_rate``, ``gap_median`` and ``length_mean`` over the successful runs only,
        ``n_ants, n_iters`` (of its last evaluation), ``runs``, ``iterations`` (ant-iterations
        spent on it, all rungs), ``start_s`` and ``end_s`` (seconds since the study's first trial
        started)."""
        frozen = self.study.get_trials(deepcopy=False)
        starts = [t.datetime_start for t in frozen if t.datetime_start is not None]
        t0 = min(starts) if starts else None
        return pd.DataFrame([self._row(t, t0) for t in frozen])

    def _row(self, t, t0) -> dict:
        """Trial ``t``'s row of :attr:`trials` (``t0``: when the study's first trial started)."""
        a = trial_info(t)
        row = {
            "number": t.number,
            "state": t.state.name,
            "generation": a.get("generation"),
            "planner": a.get("planner"),
        }
        row.update({k: v for k, v in t.params.items() if k != VARIANT})
        values = (
            t.values
            if t.values is not None
            else ([t.intermediate_values[max(t.intermediate_values)]] if t.intermediate_values else [math.nan])
        )
        for name, v in zip(self.objectives, values):
            row[objective_column(name)] = v
        runs = a["runs"]
        last = runs.get(str(a.get("n_iters"))) if runs else None
        if last is not None:
            ok = np.asarray(last["success"], bool)
            gaps, lengths = _numbers(last["gap"]), _numbers(last["length"])
            row["success_rate"] = float(ok.mean())
            row["gap_median"] = float(np.median(gaps[ok])) if ok.any() else math.nan
            row["length_mean"] = float(np.mean(lengths[ok])) if ok.any() else math.nan
            row["runs"] = int(ok.size)
            row["iterations"] = int(a.get("n_ants", 0)) * ok.size * sum(int(k) for k in runs)
        row["n_ants"], row["n_iters"] = a.get("n_ants"), a.get("n_iters")
        row["start_s"] = (t.datetime_start - t0).total_seconds() if t.datetime_start and t0 else math.nan
        row["end_s"] = (t.datetime_complete - t0).total_seconds() if t.datetime_complete and t0 else math.nan
        return row

    def history(self) -> pd.DataFrame:
        """The anytime curve (one objective): finished trials in the order they finished, with the
        ``value``, the ``best`` so far (never worse than before), ``iterations`` spent so far and
        ``end_s``."""
        if len(self.objectives) > 1:
            raise SearchError("history() follows one objective; this study has several")
        table = self.trials
        table = table[table["state"].isin(["COMPLETE", "PRUNED"])].sort_values(["end_s", "number"], kind="stable")
        name = self.objectives[0]
        sign = 1.0 if OBJECTIVES[name] == "minimize" else -1.0
        complete = table["state"].eq("COMPLETE")
        column = objective_column(name)
        best = (sign * table[column].where(complete)).cummin().ffill() * sign  # a pruned trial keeps the best
        out = pd.DataFrame(
            {
                "number": table["number"].to_numpy(),
                "value": table[column].to_numpy(),
                "best": best.to_numpy(),
                "iterations": table["iterations"].cumsum().to_numpy(),
                "end_s": table["end_s"].to_numpy(),
                "state": table["state"].to_numpy(),
            }
        )
        return out.reset_index(drop=True)

    def runs(self, number: int | None = None) -> pd.DataFrame:
        """Every stored run (of one trial, or of all), one row per (trial, iterations, query,
        seed): ``success, length, gap, best_iteration`` (and ``turns``)."""
        rows = []
        for t in self.study.get_trials(deepcopy=False):
            if number is not None and t.number != number:
                continue
            for n_iters, runs in trial_info(t)["runs"].items():
                for q, query in enumerate(self.info["queries"]):
                    for j, s in enumerate(self.info["seeds"]):
                        row = {
                            "number": t.number,
                            "planner": trial_info(t)["planner"],
                            "n_iters": int(n_iters),
                            "query": q,
                            "start": tuple(query["start"]),
                            "goal": tuple(query["goal"]),
                            "seed": s,
                        }
                        row.update({k: run_value(v[q][j]) for k, v in runs.items()})
                        rows.append(row)
        return pd.DataFrame(rows)

    def record(self, number: int) -> "TrialRecord":
        """What reruns trial ``number`` (:class:`TrialRecord`)."""
        matches = [t for t in self.study.get_trials(deepcopy=False) if t.number == number]
        if not matches:
            raise SearchError(f"study {self.study.study_name!r} has no trial {number}")
        t = matches[0]
        if not trial_info(t)["runs"]:
            raise SearchError(f"trial {number} of study {self.study.study_name!r} has no stored runs ({t.state.name})")
        return TrialRecord(self.info, t)

    def rerun(self, number: int) -> Any:
        """Rerun trial ``number`` at every budget it was evaluated at and compare each run's
        success, length and best iteration bit for bit (a :class:`jaco.research.records.Rerun`)."""
        return self.record(number).rerun()


class TrialRecord:
    """A stored trial as a record: its planner, parameters, sizes, seeds and queries (maps
    embedded in the study), and its per-run results to compare a rerun with."""

    def __init__(self, info: dict, frozen: Any):
        self.info, self.trial = info, frozen

    def rerun(self) -> Any:
        from .designs import table
        from .record_map import grid_from_entry
        from .record_versions import version_warnings
        from .records import Rerun
        from .sweeps import sweep

        info, a = self.info, trial_info(self.trial)
        built = [grid_from_entry(e, f"study {self.trial.number}") for e in info["maps"]]
        notes = version_warnings(info.get("versions", {}), 2) + [n for _, ns in built for n in ns]
        grids = [built[q["map"]][0] for q in info["queries"]]
        starts = [tuple(q["start"]) for q in info["queries"]]
        goals = [tuple(q["goal"]) for q in info["queries"]]
        diffs, n_runs = [], 0
        for n_iters, runs in sorted(a["runs"].items(), key=lambda kv: int(kv[0])):
            new = sweep(
                grids,
                starts,
                goals,
                a["planner"],
                table({k: [v] for k, v in a["params"].items()}),
                info["seeds"],
                n_ants=int(a["n_ants"]),
                n_iters=int(n_iters),
                steplimit=info["steplimit"][a["planner"]],
                connectivity=info["connectivity"],
                progress=False,
            )
            n_q, n_s = len(info["queries"]), len(info["seeds"])
            for k in ("success", "length", "best_iteration"):
                old, got = _numbers(runs[k]), np.asarray(new[k].to_numpy().reshape(n_q, n_s), np.float64)
                if not np.array_equal(old, got):
                    diffs.append(f"{n_iters} iterations, {k}: {int(np.sum(old != got))} of {old.size} runs differ")
            n_runs += n_q * n_s
        what = f"trial {self.trial.number}: {n_runs} runs of {a['planner']}"
        return Rerun(not diffs, diffs, notes, None, what)


def load_study(storage: Any, study_name: str | None = None) -> Study:
    """A stored study (no search runs): ``storage`` as in :func:`jaco.search`; ``study_name`` may be
    left out when the storage holds one study."""
    optuna = require("optuna", "jaco.load_study")
    storage_obj, path, text = storage_target(storage)
    if path is not None and not path.is_file():
        raise SearchError(f"no study storage at {str(path)!r}")
    if storage_obj == "journal":
        storage_obj = journal_storage(path)
    with quiet():
        try:
            names = [s.study_name for s in optuna.get_all_study_summaries(storage_obj, include_best_trial=False)]
        except Exception as e:  # noqa: BLE001 - any storage failure is the user's file
            raise SearchError(f"cannot read the studies of {text}: {' '.join(str(e).split())[:200]}") from None
        if study_name is None:
            if len(names) != 1:
                raise SearchError(f"{text} holds {len(names)} studies ({', '.join(names)}): name one with study_name")
            study_name = names[0]
        if study_name not in names:
            raise SearchError(f"{text} has no study {study_name!r}; it has: {', '.join(names) or 'none'}")
        return Study(optuna.load_study(study_name=study_name, storage=storage_obj))
