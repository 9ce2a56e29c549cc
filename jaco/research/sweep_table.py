"""A sweep's table: the tidy DataFrame of its runs (one row per query × configuration × seed) and
its per-configuration summary over seeds (:func:`summarize`)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pandas as pd

from ..errors import JacoError
from ..metrics import gap

RESULT_COLUMNS = ("seed", "success", "length", "cost", "best_iteration", "optimal", "gap", "coverage")


def tidy_table(planner, queries, problems, values, config, seed_arr, cost, length, best_iter, covered) -> pd.DataFrame:
    """The tidy table: one row per query × configuration × seed (query-major)."""
    n_q, n_rows = cost.shape
    cols: dict = {}
    parts = []
    for q, (g, s, t) in enumerate(queries):
        success = np.isfinite(cost[q])
        L = np.where(success, length[q].astype(np.float64) * g.cell_size, math.inf)
        optimal = float(problems[q].optimal) * g.cell_size
        cols = {"planner": [planner.name] * n_rows}  # every table names its planner, one planner too
        if n_q > 1:  # the query as integer columns, so that a CSV round trip keeps them numbers
            cols |= {
                "map": [g.name] * n_rows,
                "start_row": np.full(n_rows, s[0], np.int64),
                "start_col": np.full(n_rows, s[1], np.int64),
                "goal_row": np.full(n_rows, t[0], np.int64),
                "goal_col": np.full(n_rows, t[1], np.int64),
            }
        cols["config"] = config.astype(np.int64)
        cols.update({k: values[k][config] for k in planner.params})
        cols.update(
            seed=seed_arr.astype(np.int64),
            success=success,
            length=L,
            cost=cost[q].astype(np.float64),
            best_iteration=best_iter[q].astype(np.int64),
            optimal=np.full(n_rows, optimal),
            gap=np.where(success, gap(L, optimal), math.inf),
            coverage=covered[q].astype(np.int64) / g.n_free,
        )
        parts.append(pd.DataFrame(cols))
    return parts[0] if n_q == 1 else pd.concat(parts, ignore_index=True)


def summarize(table: pd.DataFrame, by: Any = None) -> pd.DataFrame:
    """Per-configuration summary over seeds, one row per configuration (and query).

    ``by`` defaults to every column that is not a result (the planner, the query columns,
    ``config`` and the parameters). Columns: ``success_rate``; ``length_mean, length_std,
    length_min``, ``length_q1, length_median, length_q3`` (quartiles) and the same for ``gap``
    (``gap_mean, gap_min, gap_q1, gap_median, gap_q3``) over the successful runs, so they are NaN
    for a configuration that failed on every seed (``success_rate`` 0; the std is also NaN with
    fewer than two successes); and ``runs``. A failure is never averaged in as ``inf``: rank
    configurations by ``success_rate`` first, e.g.
    ``summary.sort_values(["success_rate", "gap_median"], ascending=[False, True])``, or compare
    them with :func:`jaco.research.compare.compare`, which counts a failure as worse than any path.
    Gaps are fractions (0.05 is 5 %), as in the table.

    A table of several planners (``jaco.sweep(..., planner=[...])``) has a column for every
    planner's parameters, empty (NaN) on the rows of planners without that parameter. By default
    the summary keeps as columns the parameters every planner of the table has, and folds the
    others into one text column ``params``, each row holding its own planner's values only
    (``"q0=0.8, xi=0.1"``, at float32 precision; empty for a planner without such parameters):
    no column is NaN because of another planner.
    """
    if not isinstance(table, pd.DataFrame):
        raise JacoError(f"summarize takes the DataFrame of jaco.sweep, got {type(table).__name__}")
    if by is None:
        from .tables import fold_params

        table = fold_params(table, RESULT_COLUMNS)
        by = [c for c in table.columns if c not in RESULT_COLUMNS]
    else:
        from .tables import planner_by

        by = planner_by(by, table, "summarize")  # "variant": the planner column's former name
    missing = [c for c in by if c not in table.columns]
    if missing:
        raise JacoError(f"summarize: no column {missing[0]!r} in the table")
    ok = table["success"].astype(bool) & np.isfinite(table["length"])
    finite = table.assign(length=table["length"].where(ok), gap=table["gap"].where(ok))
    # dropna=False: a planner's row may have no value (NaN) for a parameter a given `by` keeps
    quartile = {name: (lambda v, q=q: v.quantile(q)) for name, q in (("q1", 0.25), ("median", 0.5), ("q3", 0.75))}
    stats: dict[str, tuple[str, Any]] = {"success_rate": ("success", "mean")}
    for col in ("length", "gap"):
        stats.update(
            {
                f"{col}_{k}": (col, f)
                for k, f in (
                    ("median", quartile["median"]),
                    ("q1", quartile["q1"]),
                    ("q3", quartile["q3"]),
                    ("mean", "mean"),
                    ("std", "std"),
                    ("min", "min"),
                )
            }
        )
    del stats["gap_std"]
    stats["runs"] = ("seed", "count")
    return finite.groupby(by, sort=False, dropna=False).agg(**stats).reset_index()
