"""What :func:`jaco.compare` checks before it computes anything: a table of numbers, one run per
configuration and pair, ``by`` and the pairing that tell the runs apart (a column that would
merge two configurations is named, with the fix), each mistake one :class:`~jaco.errors.JacoError`
line; and how a configuration is named (:func:`config_label`)."""

from __future__ import annotations

from typing import Sequence

import numpy as np
import pandas as pd

from ..errors import JacoError
from .tables import FORMER_PLANNER, PLANNER, QUERY_COLUMNS, number, short_name

PAIRING = (*QUERY_COLUMNS, "seed")
#: Columns of a sweep table that are results, not part of a configuration or of the pairing.
RESULTS = ("success", "length", "cost", "best_iteration", "optimal", "gap", "coverage")
#: Names of a column that names the query (a number, a scenario): it belongs in the pairing, not in ``by``.
QUERY_LIKE = (*QUERY_COLUMNS, "query", "query_id", "scenario", "scen", "problem", "instance", "start", "goal")


class ByError(JacoError):
    """A table whose configurations ``by`` does not tell apart; ``by`` is the list that would
    (the command line names it as ``--by`` options)."""

    def __init__(self, message: str, by: list):
        super().__init__(message)
        self.by = by


def config_label(by, key) -> str:
    """A configuration's name in tables and words: a planner by its short name, text as it is,
    a number as ``column=value``."""
    key = key if isinstance(key, tuple) else (key,)
    parts = []
    for name, v in zip(by, key):
        if name in (PLANNER, FORMER_PLANNER):
            parts.append(short_name(v))
        elif isinstance(v, str):
            parts.append(v)
        else:
            parts.append(f"{name}={number(v)}")
    return ", ".join(parts)


def _runs_text(table: pd.DataFrame, mask, columns: Sequence[str]) -> str:
    """``"1 run (planner=A, seed=3)"`` or ``"3 runs (the first: planner=A, seed=3)"``."""
    mask = np.asarray(mask, bool)
    first = table[mask].iloc[0]
    where = ", ".join(f"{c}={number(first[c])}" for c in columns)
    n = int(mask.sum())
    return f"1 run ({where})" if n == 1 else f"{n} runs (the first: {where})"


def _check_dtype(table: pd.DataFrame, column: str, role: str) -> None:
    dtype = table[column].dtype
    if not pd.api.types.is_numeric_dtype(dtype) or pd.api.types.is_bool_dtype(dtype):
        raise JacoError(
            f"compare: {role} {column!r} must be a column of numbers (gap, length, cost ...), it holds {dtype}"
        )


def _check_numbers(table: pd.DataFrame, column: str, role: str, where: list[str]) -> None:
    """``column`` holds numbers, +inf for a failed run: no NaN (a run without its value) and no -inf."""
    _check_dtype(table, column, role)
    x = table[column].to_numpy(np.float64)
    if np.isnan(x).any():
        raise JacoError(
            f"compare: column {column!r} is empty (NaN) on {_runs_text(table, np.isnan(x), where)}; a failed run is +inf"
        )
    if np.isneginf(x).any():
        raise JacoError(
            f"compare: column {column!r} is -inf on {_runs_text(table, np.isneginf(x), where)}; "
            "a run's value is a number, or +inf when it failed"
        )


def check_table(table, by, value, blocks, pairing, ratio_of) -> tuple[pd.DataFrame, list[str], list[str], str]:
    """The table in the current layout, ``by``, the pairing and ``ratio_of``, or one JacoError line."""
    if not isinstance(table, pd.DataFrame):
        raise JacoError(f"compare takes a results table (a DataFrame), got {type(table).__name__}")
    from .tables import normalise, planner_by

    table = normalise(table)  # an older table's "variant" column is "planner"
    if len(table) == 0:  # before the columns: a header-only CSV reads as columns of objects
        raise JacoError("compare: the table has no rows")
    by = planner_by(by, table, "compare", stacklevel=4)  # "variant": the planner column's former name
    if not by:
        raise JacoError("compare: by must name at least one column (the planner or configuration)")
    columns = ", ".join(map(str, table.columns))
    for name in [*by, value]:
        if name not in table.columns:
            raise JacoError(f"compare: no column {name!r} in the table (columns: {columns})")
    _check_dtype(table, value, "value")
    if blocks not in ("run", "query"):
        raise JacoError(f"compare: blocks must be 'run' or 'query', got {blocks!r}")
    if pairing is None:
        pairing = [c for c in PAIRING if c in table.columns and c not in by]
    else:
        pairing = [pairing] if isinstance(pairing, str) else list(pairing)
        for name in pairing:
            if name not in table.columns or name in by:
                raise JacoError(
                    f"compare: pairing column {name!r} is not a column of the table outside by (columns: {columns})"
                )
    if not pairing:
        raise JacoError("compare: the table has no pairing column (a query or 'seed') to pair the runs by")
    if blocks == "query" and not [c for c in pairing if c != "seed"]:
        raise JacoError("compare: blocks='query' needs query columns (map, start_row, ...) in the pairing")
    for name in pairing:
        missing = table[name].isna().to_numpy()
        if missing.any():  # NaN never equals NaN: each such run would be a pair of its own
            raise JacoError(
                f"compare: pairing column {name!r} is empty (NaN) on {_runs_text(table, missing, by)}; "
                "every run needs its pair"
            )
    _check_numbers(table, value, "value", by + pairing)
    ratio_of = ratio_of or ("length" if "length" in table.columns else value)
    if ratio_of not in table.columns:
        raise JacoError(f"compare: no column {ratio_of!r} for the performance ratios")
    _check_numbers(table, ratio_of, "ratio_of", by + pairing)
    _check_pairs(table, by, pairing)
    _check_settings(table, by, pairing)
    if len(table.groupby(by, dropna=False)) < 2:
        raise JacoError(f"compare: the table has one configuration of {by}; need two or more")
    return table, by, pairing, ratio_of


def _other_columns(table: pd.DataFrame, by: list[str], pairing: list[str]) -> list[str]:
    """Columns that are neither results nor ``by`` nor the pairing (``config`` last)."""
    rest = [c for c in table.columns if c not in (*by, *pairing, *RESULTS, "config")]
    return rest + ["config"] * ("config" in table.columns and "config" not in (*by, *pairing))


def _check_pairs(table: pd.DataFrame, by: list[str], pairing: list[str]) -> None:
    """One run per configuration and pair; a column that tells repeated runs apart is named,
    with the fix: a query's name belongs in the pairing, a setting in ``by``."""
    dup = table.duplicated(by + pairing, keep=False).to_numpy()
    if not dup.any():
        return
    varying = [
        c
        for c in _other_columns(table, by, pairing)
        if table[dup].groupby(by + pairing, dropna=False)[c].nunique(dropna=False).max() > 1
    ]
    query = [c for c in varying if str(c).lower() in QUERY_LIKE]
    # the settings that vary, every one at once ("config", the design's row, only when nothing else does)
    settings = [c for c in varying if c not in query and c != "config"] or [c for c in varying if c == "config"]
    no_seed = "seed" not in table.columns
    if query:
        suggest = [c for c in pairing if c != "seed"] + [query[0]] + ["seed"] * ("seed" in pairing)
        hint = (
            f"column {query[0]!r} names the query and varies within a configuration and pair: "
            f"pair the runs by it (pairing={suggest!r})"
        )
    elif settings:
        which = f"column {settings[0]!r} varies" if len(settings) == 1 else f"columns {_names(settings)} vary"
        suggest = by + settings
        raise ByError(
            f"compare: {int(dup.sum())} rows share a configuration and pair ({', '.join(by + pairing)}); "
            f"{which} within a configuration and pair: add {'it' if len(settings) == 1 else 'them'} to by "
            f"(by={suggest!r}) or select their rows first" + (f"; {_NO_SEED}" if no_seed else ""),
            suggest,
        )
    elif no_seed:
        hint = _NO_SEED
    else:
        hint = "the table repeats runs (the same configuration, query and seed twice)"
    raise JacoError(
        f"compare: {int(dup.sum())} rows share a configuration and pair ({', '.join(by + pairing)}); {hint}"
    )


_NO_SEED = (
    "the table has no 'seed' column, so the repeated runs of a configuration cannot be paired: "
    "keep the 'seed' column jaco.sweep writes (or give pairing= the columns that name a run)"
)


def _names(columns) -> str:
    """``'beta', 'rho'``."""
    return ", ".join(repr(c) for c in columns)


def _check_settings(table: pd.DataFrame, by: list[str], pairing: list[str]) -> None:
    """A setting (a column constant within at least half of the configurations) that changes
    within another configuration, and not with the pair, would merge two configurations."""
    ids = table.groupby(by, dropna=False, sort=False).ngroup().to_numpy()
    found = []  # (column, the first configuration it changes in), every such column
    for c in _other_columns(table, by, pairing):
        counts = table[c].groupby(ids).nunique(dropna=False)
        changing = counts.index[counts.to_numpy() > 1]
        if len(changing) == 0 or len(changing) > len(counts) / 2:
            continue  # constant everywhere, or changing in most configurations: a measurement
        if table.groupby(pairing, dropna=False)[c].nunique(dropna=False).max() <= 1:
            continue  # fixed by the pair (a query's cells when the pairing numbers the queries)
        found.append((c, changing[0]))
    if not found:
        return
    c, first = found[0]
    part = table[ids == first]
    shown = part[c].value_counts(dropna=False)
    values = ", ".join(f"{number(v)} on {n} run{'s' * (n != 1)}" for v, n in shown.iloc[:3].items())
    more = [name for name, _ in found[1:]]
    also = f"; so do {_names(more)}" if more else ""
    suggest = by + [c, *more]
    raise ByError(
        f"compare: column {c!r} changes within configuration {config_label(by, tuple(part[by].iloc[0]))} "
        f"({values}{', ...' * (len(shown) > 3)}){also}: add {'them' if more else 'it'} to by (by={suggest!r}) "
        "or select its rows first (or drop the column, if it is a measurement and not a setting)",
        suggest,
    )
