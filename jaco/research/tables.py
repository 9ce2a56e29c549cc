"""Result tables as files and on screen: one convention for every table jaco writes.

* **Gaps are fractions** in data (``gap = (length − optimum) / optimum``: 0.05 is 5 %), in every
  DataFrame and CSV; on screen and in plots they are shown in % and the label says so
  (``gap_%``, "median gap (%)"). :func:`percent` formats one.
* **CSV at float32 precision.** jaco computes in float32, so :func:`csv_text` writes every float
  as the shortest decimal that reads back to the same float32 (``54.970562``, not
  ``54.97056198120117``); ``inf`` for a failed run, an empty field for a parameter the row's
  planner does not have. Integers stay integers, start and goal are the integer columns
  ``start_row, start_col, goal_row, goal_col``.
* **Older tables** (written before these columns, with ``start``/``goal`` as ``"(row, col)"``
  text and floats at float64 precision) are read by :func:`read_table` into the same layout, and
  :func:`differences` compares two tables value by value, each recorded column at the precision it
  was written in, so a sweep record of either kind reruns bit for bit.
* **The planner column** is ``planner`` in every table, with one planner too. Tables written
  before planners had one name call it ``variant`` (and a one-planner table had none):
  :func:`normalise` renames it on read, and :func:`planner_by` takes ``by="variant"`` as
  ``"planner"`` (with a DeprecationWarning); run and sweep *record files* keep the field
  ``call.variant`` (docs/records.md, "One word per layer").
* **Short names**: :func:`short_name` turns a composition's full name
  ``compose(construct=backtrack, heuristic=chaos, rule=iaca, transition=q0, ...)`` into
  ``backtrack/chaos/iaca`` for tables and legends.
"""

from __future__ import annotations

import io
import math
import re
from pathlib import Path
from typing import TYPE_CHECKING, Any, Iterable

import numpy as np
import pandas as pd

from ..errors import JacoError

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

    from ..outputs import PathArg

#: The columns that name a query in a table of several queries.
QUERY_COLUMNS = ("map", "start_row", "start_col", "goal_row", "goal_col")
#: The column that names the planner of a row, in every table jaco writes.
PLANNER = "planner"
#: The planner column's former name (tables written before planners had one name): read as :data:`PLANNER`.
FORMER_PLANNER = "variant"
_CELL = re.compile(r"^\s*\(\s*(-?\d+)\s*,\s*(-?\d+)\s*\)\s*$")


# -- numbers ----------------------------------------------------------------------------------
def float32_text(values: ArrayLike) -> np.ndarray:
    """The shortest decimal that reads back to the same float32, for each value (an object array;
    NaN stays NaN so that a CSV holds an empty field)."""
    v = np.asarray(values, np.float64)
    out = np.empty(v.shape, object)
    nan = np.isnan(v)
    out[nan] = np.nan
    if (~nan).any():
        unique, inverse = np.unique(v[~nan], return_inverse=True)
        out[~nan] = np.array([str(np.float32(x)) for x in unique], object)[inverse]
    return out


def percent(fraction: float, digits: int = 1) -> str:
    """A gap (a fraction) as text in %: ``0.1793`` -> ``"17.9%"``; a failure (inf) reads
    ``"failed"``, a missing value ``"-"``; never ``-0.0%``."""
    x = float(fraction)
    if math.isnan(x):
        return "-"
    if math.isinf(x):
        return "failed" if x > 0 else "-inf%"
    text = f"{100 * x:.{digits}f}"
    return (text[1:] if text.startswith("-") and not text.strip("-0.") else text) + "%"


def number(x: Any) -> str:
    """A number for a person: integers (and integral floats) without a decimal point, others with
    up to 4 significant digits (``%g``)."""
    if isinstance(x, (bool, np.bool_)):
        return str(bool(x))
    if isinstance(x, (int, np.integer)):
        return str(int(x))
    try:
        x = float(x)
    except (TypeError, ValueError):
        return str(x)
    if math.isfinite(x) and x == int(x) and abs(x) < 1e15:
        return str(int(x))
    return f"{x:.4g}"


# -- CSV --------------------------------------------------------------------------------------
def csv_text(table: pd.DataFrame) -> str:
    """The CSV text of a result table: every float column at float32 precision (the shortest
    decimal that reads back to the same float32), ``inf`` for failed runs, ``\\n`` line ends."""
    out = table.copy()
    for col in out.columns:
        if pd.api.types.is_float_dtype(out[col].dtype):
            out[col] = float32_text(out[col].to_numpy())
    return out.to_csv(index=False, lineterminator="\n")


def write_csv(table: pd.DataFrame, path: PathArg) -> Path:
    """Write :func:`csv_text` of ``table`` atomically at ``path`` (:func:`jaco.outputs.write_text`)."""
    from ..outputs import write_text

    return write_text(path, csv_text(table))


def read_table(source: PathArg) -> pd.DataFrame:
    """A result table from a CSV file (a path) or CSV text (a ``str`` holding a newline), in the
    current layout: ``start``/``goal`` columns of ``"(row, col)"`` text, as older jaco wrote them,
    become the integer columns ``start_row, start_col, goal_row, goal_col``."""
    if isinstance(source, str) and "\n" in source:
        table = pd.read_csv(io.StringIO(source))
    else:
        from ..outputs import as_path

        path = as_path(source, "table")
        if not path.is_file():
            raise JacoError(f"table {str(path)!r} not found")
        try:
            table = pd.read_csv(path)
        except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as e:
            raise JacoError(f"{path.name}: not a CSV table ({' '.join(str(e).split())})") from None
    return normalise(table)


def normalise(table: pd.DataFrame) -> pd.DataFrame:
    """The current layout of a result table: a ``variant`` column (the planner's former name) is
    ``planner``; ``start``/``goal`` columns holding ``"(row, col)"`` text or pairs become two
    integer columns each, in their place; anything else is unchanged."""
    out = table
    if FORMER_PLANNER in out.columns and PLANNER not in out.columns:
        out = out.rename(columns={FORMER_PLANNER: PLANNER})
    for end in ("start", "goal"):
        if end not in out.columns or f"{end}_row" in out.columns:
            continue
        cells = [_cell(x) for x in out[end]]
        if any(c is None for c in cells):
            continue  # not a column of cells: leave it as it is
        at = list(out.columns).index(end)
        rows, cols = (np.array([c[k] for c in cells], np.int64) for k in (0, 1))
        out = out.drop(columns=end)
        out.insert(at, f"{end}_col", cols)
        out.insert(at, f"{end}_row", rows)
    return out


def planner_by(by: Any, table: pd.DataFrame | None = None, where: str = "by", stacklevel: int = 3) -> list:
    """``by`` (a column name or a list of them) as a list, the planner column's former name
    ``"variant"`` read as ``"planner"`` (a DeprecationWarning) unless ``table`` has a column
    ``variant`` (an older table not read through :func:`normalise`)."""
    import warnings

    names = [by] if isinstance(by, str) else list(by)
    if FORMER_PLANNER not in names or (table is not None and FORMER_PLANNER in table.columns):
        return names
    warnings.warn(
        f"{where}: {FORMER_PLANNER!r} is the former name of the planner column; use {PLANNER!r}",
        DeprecationWarning,
        stacklevel=stacklevel,
    )
    return [PLANNER if n == FORMER_PLANNER else n for n in names]


def _cell(x):
    if isinstance(x, str):
        m = _CELL.match(x)
        return (int(m.group(1)), int(m.group(2))) if m else None
    if isinstance(x, (tuple, list, np.ndarray)) and len(x) == 2:
        return int(x[0]), int(x[1])
    return None


def fold_params(table: pd.DataFrame, results: Iterable[str] = ()) -> pd.DataFrame:
    """A table of several planners (a ``planner`` column) with the parameters only some of them
    have folded into one text column ``params`` after the others, each row holding its own
    planner's values (``"q0=0.8, xi=0.1"``, float32 precision); other tables as they are.
    A parameter column is any numeric column that is not a query column, ``config`` or one of
    ``results``; it is folded when it is empty (NaN) on some rows."""
    name = PLANNER if PLANNER in table.columns else FORMER_PLANNER  # an older table's "variant"
    if name not in table.columns or table[name].nunique() < 2:
        return table
    skip = {*results, *QUERY_COLUMNS, name, "config"}
    params = [c for c in table.columns if c not in skip and pd.api.types.is_numeric_dtype(table[c].dtype)]
    partial = [c for c in params if table[c].isna().any()]
    if not partial:
        return table
    text = {c: float32_text(table[c].to_numpy()) for c in partial}
    folded = [", ".join(f"{c}={text[c][i]}" for c in partial if isinstance(text[c][i], str)) for i in range(len(table))]
    out = table.drop(columns=partial)
    cols = list(out.columns)
    after = max([cols.index(c) for c in params if c in cols] + [cols.index("config") if "config" in cols else 0])
    out.insert(after + 1, "params", folded)
    return out


# -- comparing tables -------------------------------------------------------------------------
def _written_as_float32(values: np.ndarray) -> bool:
    """Whether a column read from CSV was written at float32 precision: each finite value is what
    the shortest float32 decimal of it reads back as (a column written at float64 precision, as
    older jaco did, holds other decimals, e.g. ``54.97056198120117`` for float32 ``54.970562``)."""
    finite = values[np.isfinite(values)]
    return bool(np.array_equal(float32_text(finite).astype(np.float64), finite))


def _same(a: pd.Series, b: pd.Series) -> np.ndarray:
    """Row-wise equality of a recorded column ``a`` (read from CSV) and a rerun's column ``b``:
    numbers bit for bit at the precision ``a`` was written in (float32 when each of its values is
    a float32, else float64; NaN equals NaN, 0.0 and -0.0 differ), anything else as text."""
    numeric = pd.api.types.is_numeric_dtype
    if (
        numeric(a.dtype)
        and numeric(b.dtype)
        and not (pd.api.types.is_bool_dtype(a.dtype) ^ pd.api.types.is_bool_dtype(b.dtype))
    ):
        x, y = a.to_numpy(np.float64), b.to_numpy(np.float64)
        if _written_as_float32(x):
            x, y = x.astype(np.float32), y.astype(np.float32)
        return ((x == y) & (np.signbit(x) == np.signbit(y))) | (np.isnan(x) & np.isnan(y))
    return (a.astype(str).to_numpy() == b.astype(str).to_numpy()) | (a.isna().to_numpy() & b.isna().to_numpy())


def differences(recorded: pd.DataFrame, rerun: pd.DataFrame) -> list[str]:
    """What differs between a recorded table (read back from its CSV, any layout) and a rerun's
    table: the columns, the number of rows, or the rows and columns whose values differ (compared
    as numbers, not as text, each recorded column at the precision it was written in). An empty
    list when they are the same."""
    a, b = normalise(recorded).reset_index(drop=True), normalise(rerun).reset_index(drop=True)
    if set(a.columns) != set(b.columns):
        return [f"columns: recorded {list(a.columns)}, rerun {list(b.columns)}"]
    if len(a) != len(b):
        return [f"rows: recorded {len(a)}, rerun {len(b)}"]
    same = {c: _same(a[c], b[c]) for c in a.columns}
    cols = [c for c, ok in same.items() if not ok.all()]
    if not cols:
        return []
    rows = np.flatnonzero(~np.logical_and.reduce([same[c] for c in cols])).tolist()
    return [f"{len(rows)} of {len(a)} rows differ (first rows {rows[:5]}; columns {cols})"]


# -- names ------------------------------------------------------------------------------------
def short_name(name: str) -> str:
    """A planner's name for tables and legends: a registered name as it is; a composition
    ``compose(construct=C, heuristic=H, rule=R, transition=T, schedule=S, cost=K)`` as ``C/H/R``,
    followed by ``+kind=value`` for each of transition, schedule and cost that is not the
    default (the rule's own transition, ``constant``, ``length``)."""
    text = str(name)
    m = re.match(r"^compose\((.*)\)$", text.strip())
    if m is None:
        return text
    parts = dict(p.strip().partition("=")[::2] for p in m.group(1).split(",") if "=" in p)
    from ..planners.compose import default_transition

    rule = parts.get("rule", "as")
    head = "/".join(parts.get(k, d) for k, d in (("construct", "dying"), ("heuristic", "distance"), ("rule", "as")))
    extra = [
        f"+{k}={parts[k]}"
        for k, d in (("transition", default_transition(rule)), ("schedule", "constant"), ("cost", "length"))
        if parts.get(k, d) != d
    ]
    return head + "".join(extra)


def text_table(frame: pd.DataFrame, left: Iterable[str] = ()) -> str:
    """``frame`` (of strings) as a text table for a terminal: the columns in ``left`` (names such
    as a planner's) left-aligned, the others (numbers) right-aligned, two spaces between."""
    cols = list(frame.columns)
    cells = [[str(x) for x in frame[c]] for c in cols]
    width = [max([len(str(c))] + [len(x) for x in col]) for c, col in zip(cols, cells)]
    align = [(str.ljust if c in left else str.rjust) for c in cols]
    rows = [[str(c) for c in cols]] + [[cells[j][i] for j in range(len(cols))] for i in range(len(frame))]
    return "\n".join("  ".join(a(x, w) for a, x, w in zip(align, row, width)).rstrip() for row in rows)
