"""From a results table to a conclusion: which planner (or configuration) is better, and how sure.

``jaco.compare(table, by="planner") -> Comparison`` takes a tidy table (:func:`jaco.sweep`, or one
read back with :func:`jaco.research.tables.read_table`) with a column (or columns, ``by``) naming
the configuration (a table of an older jaco names its planner column ``variant``: it is read as
``planner``, and ``by="variant"`` as ``by="planner"``) and pairs its runs over the *pairing*: the query (``map, start_row, start_col,
goal_row, goal_col``, when present) and the ``seed``. Every configuration should have one run per
pair; when some lack pairs others have, :func:`compare` warns (:class:`UnequalPairsWarning`, and a
note in the words) and each statistic says over how many runs or pairs it is.

What it computes, on ``value`` (default ``gap``, a fraction; lower is better):

* **per configuration** (``Comparison.summary``): runs, success rate, the quartiles of the value
  over the configuration's own runs (a failed run counts as +∞, so the median is ``inf`` exactly
  when at least half the runs failed: more than half, or exactly half of an even number, where
  the median is the mean of a path and a failure) and a **percentile bootstrap** confidence
  interval of the median (``n_boot`` resamples of the runs, drawn with a generator seeded by
  ``seed`` and the configuration's label: the interval depends only on the configuration's own
  runs and the seed, not on the order of the rows or on the other configurations);
* **paired comparisons** (``Comparison.pairwise``): for every two configurations A and B, the
  pairs where A's value is lower (A better), higher, or equal, the signed-rank sums of each side
  and the two-sided **Wilcoxon signed-rank test** of the differences (``scipy.stats.wilcoxon``),
  its p-values adjusted for all pairs by **Holm's** step-down method (Holm 1979); the side named
  better (``better``) is the one whose rank sum is larger, when the adjusted p is below ``alpha``;
* **all at once** (``Comparison.friedman``): the **Friedman test** of the ranks within each block
  (``scipy.stats.friedmanchisquare``, three or more configurations) and the mean ranks with the
  **Nemenyi critical difference** CD = q_α √(k(k+1)/(6N)) of the critical-difference diagram
  (Demšar 2006; q_α from ``scipy.stats.studentized_range`` with infinite degrees of freedom, over
  √2); blocks are the pairs (``blocks="run"``) or the queries (``blocks="query"``: each
  configuration's median over the seeds of a query, Demšar's data sets), complete blocks only;
* **performance profile** (``Comparison.ratios``, Dolan & Moré 2002): for each pair and
  configuration the ratio of its path length to the best length any configuration reached on that
  pair (∞ for a failure); the profile ρ(τ) is the share of pairs with ratio ≤ τ
  (:func:`performance_profile`, :func:`jaco.plot.plot_performance_profile`);
* **words** (``Comparison.text``, ``str(comparison)``): what the data support, e.g. "A is better
  than B: signed ranks favour A 780 to 40; A better on 31 of 40 pairs, B on 5, 4 ties; p = 0.003
  after Holm" or "C and D cannot be told apart".

**Ties and failed runs.** A failed run has ``gap`` (and ``length``) +∞: it loses to every run that
found a path, and two failed runs tie. In the signed-rank test a difference of zero (a tie: equal
values, or both failed) is kept and its rank split between the two signs (``zero_method="zsplit"``,
as Demšar 2006 recommends); a difference with one failure is larger than any finite difference,
so it is given one magnitude above all finite ones (these tie with each other); equal magnitudes
share their mean rank. In the Friedman ranks a failure ranks below every success and failures
share their mean rank.
"""

from __future__ import annotations

import hashlib
import math
import warnings
from dataclasses import dataclass, field
from itertools import combinations
from typing import TYPE_CHECKING, Sequence

import numpy as np
import pandas as pd

from ..errors import JacoError
from .tables import FORMER_PLANNER, PLANNER, QUERY_COLUMNS, number, percent, short_name, text_table

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

__all__ = [
    "ByError",
    "Comparison",
    "UnequalPairsWarning",
    "compare",
    "holm",
    "critical_difference",
    "performance_profile",
    "quantile",
    "signed_rank_sums",
]

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


class UnequalPairsWarning(UserWarning):
    """Not every configuration of a compared table has a run on every pair: the paired tests use
    the pairs both configurations have, the ranks the complete blocks, the summary every run."""


# -- statistics -------------------------------------------------------------------------------
def quantile(x: ArrayLike, q: ArrayLike, axis: int = -1) -> np.ndarray:
    """Linear-interpolation quantiles (numpy's default) that allow +∞: interpolating toward an
    infinite value gives ∞ unless the weight on it is zero (``np.quantile`` would give NaN between
    two infinities)."""
    x = np.sort(np.asarray(x, np.float64), axis=axis)
    x = np.moveaxis(x, axis, -1)
    n = x.shape[-1]
    h = np.asarray(q, np.float64) * (n - 1)
    lo = np.floor(h).astype(int)
    hi = np.minimum(lo + 1, n - 1)
    frac = h - lo
    a, b = x[..., lo], x[..., hi]
    with np.errstate(invalid="ignore"):
        out = np.where(frac == 0, a, a + frac * (b - a))
    return np.where(np.isinf(b) & (frac > 0), b, out)


def bootstrap_median(x: ArrayLike, *, n_boot: int, confidence: float, rng: np.random.Generator) -> tuple[float, float]:
    """Percentile bootstrap interval of the median of ``x`` (values may be +∞). ``x`` is sorted
    first, so the interval depends on its values and ``rng``, never on their order."""
    x = np.sort(np.asarray(x, np.float64))
    medians = np.median(x[rng.integers(0, len(x), size=(n_boot, len(x)))], axis=1)
    lo, hi = quantile(medians, [(1 - confidence) / 2, (1 + confidence) / 2])
    return float(lo), float(hi)


def holm(pvalues: ArrayLike) -> np.ndarray:
    """Holm's (1979) step-down adjustment of ``m`` p-values: the i-th smallest becomes
    ``max_{j ≤ i} min(1, (m − j + 1) p_(j))``, in the original order."""
    p = np.asarray(pvalues, np.float64)
    m = len(p)
    order = np.argsort(p, kind="stable")
    adjusted = np.minimum(1.0, np.maximum.accumulate((m - np.arange(m)) * p[order]))
    out = np.empty(m)
    out[order] = adjusted
    return out


def critical_difference(k: int, n: int, alpha: float = 0.05) -> float:
    """The Nemenyi critical difference of mean ranks for ``k`` configurations over ``n`` blocks
    (Demšar 2006, eq. after table 5): q_α √(k(k+1)/(6n)), with q_α the studentized range
    quantile at infinite degrees of freedom over √2."""
    from scipy.stats import studentized_range

    q = studentized_range.ppf(1 - alpha, k, np.inf) / math.sqrt(2)
    return float(q * math.sqrt(k * (k + 1) / (6 * n)))


def _finite_stand_in(values: np.ndarray) -> np.ndarray:
    """+∞ replaced by one number above every finite value (ranks are unchanged, failures tie)."""
    finite = values[np.isfinite(values)]
    top = (finite.max() + abs(finite.max()) + 1.0) if finite.size else 1.0
    return np.where(np.isposinf(values), top, values)


def signed_differences(a: ArrayLike, b: ArrayLike) -> np.ndarray:
    """``a − b`` with both failed (∞ − ∞) a tie (0) and a difference with one failure given one
    magnitude above every finite difference (signed)."""
    a, b = np.asarray(a, np.float64), np.asarray(b, np.float64)
    with np.errstate(invalid="ignore"):
        d = a - b
    d = np.where(np.isinf(a) & np.isinf(b) & (np.sign(a) == np.sign(b)), 0.0, d)
    finite = np.abs(d[np.isfinite(d)])
    big = (finite.max() + 1.0) if finite.size else 1.0
    return np.where(np.isinf(d), np.sign(d) * big, d)


def wilcoxon(a: ArrayLike, b: ArrayLike) -> tuple[float, float]:
    """``(statistic, p)`` of the two-sided Wilcoxon signed-rank test of paired values ``a`` and
    ``b`` (:func:`signed_differences`, ``zero_method="zsplit"``); p = 1 when every pair ties."""
    from scipy.stats import wilcoxon as scipy_wilcoxon

    d = signed_differences(a, b)
    if not np.any(d != 0):
        return math.nan, 1.0
    res = scipy_wilcoxon(d, zero_method="zsplit")
    return float(res.statistic), float(res.pvalue)


def signed_rank_sums(a: ArrayLike, b: ArrayLike) -> tuple[float, float]:
    """``(R_a, R_b)``: the sums of the signed ranks favouring ``a`` (pairs where ``a`` is lower)
    and ``b``, as :func:`wilcoxon` ranks them: the magnitudes of :func:`signed_differences`
    ranked with ties sharing their mean rank, each zero's rank split half to either side
    (``zsplit``). R_a + R_b = n(n+1)/2, and the two-sided statistic is min(R_a, R_b)."""
    from scipy.stats import rankdata

    d = signed_differences(a, b)
    if d.size == 0:
        return 0.0, 0.0
    r = rankdata(np.abs(d))
    half_zeros = r[d == 0].sum() / 2
    return float(r[d < 0].sum() + half_zeros), float(r[d > 0].sum() + half_zeros)


def performance_profile(ratios: pd.DataFrame, taus: ArrayLike | None = None) -> pd.DataFrame:
    """Dolan & Moré's (2002) profile ρ_s(τ): for each configuration (column of ``ratios``, one row
    per problem) the share of problems whose ratio is ≤ τ, at ``taus`` (default: 1 and every
    finite ratio); one row per τ."""
    r = ratios.to_numpy(np.float64)
    if taus is None:
        taus = np.unique(np.concatenate([[1.0], r[np.isfinite(r)]]))
    taus = np.asarray(taus, np.float64)
    rho = (r[None, :, :] <= taus[:, None, None]).mean(axis=1)
    return pd.DataFrame(rho, index=pd.Index(taus, name="tau"), columns=ratios.columns)


# -- the comparison ---------------------------------------------------------------------------
@dataclass
class Comparison:
    """The outcome of :func:`compare`. ``summary`` (one row per configuration, best mean rank
    first; ``runs``: how many runs its figures are over), ``pairwise`` (one row per two
    configurations: ``pairs`` both have, ``a_better``, ``b_better``, ``ties``, the signed-rank sums
    ``a_rank_sum`` and ``b_rank_sum``, ``statistic``, ``p``, ``p_holm``, ``significant`` and
    ``better``, the side the signed ranks favour when significant, else None), ``friedman`` (dict: ``statistic``,
    ``pvalue``, ``k``, ``n`` blocks, ``cd``, ``alpha``; ``statistic``/``pvalue`` None with fewer
    than three configurations), ``ranks`` (mean rank per configuration), ``ratios`` (performance
    ratios of ``ratio_of``, one row per pair), ``values`` (the value per pair and configuration)
    and ``text`` (what the data support, in words)."""

    by: list
    value: str
    pairing: list
    summary: pd.DataFrame
    pairwise: pd.DataFrame
    friedman: dict
    ranks: pd.Series
    ratios: pd.DataFrame
    values: pd.DataFrame
    alpha: float
    confidence: float
    ratio_of: str = "length"
    text: str = ""
    notes: list = field(default_factory=list)

    def __str__(self) -> str:
        return self.text

    def profile(self, taus: ArrayLike | None = None) -> pd.DataFrame:
        """The performance profile of :attr:`ratios` (:func:`performance_profile`)."""
        return performance_profile(self.ratios, taus)

    def table(self) -> str:
        """The summary and the paired tests as text for a terminal (values in % for gaps)."""
        return _tables_text(self)


def _label(by, key) -> str:
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


def _check_table(table, by, value, blocks, pairing, ratio_of) -> tuple[pd.DataFrame, list[str], list[str], str]:
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
        f"compare: column {c!r} changes within configuration {_label(by, tuple(part[by].iloc[0]))} "
        f"({values}{', ...' * (len(shown) > 3)}){also}: add {'them' if more else 'it'} to by (by={suggest!r}) "
        "or select its rows first (or drop the column, if it is a measurement and not a setting)",
        suggest,
    )


def _config_rng(seed: int, name: str) -> np.random.Generator:
    """The bootstrap generator of one configuration: from the user's seed and the configuration's
    label (its bytes: Python's ``hash`` of a string changes from one process to the next)."""
    label = int.from_bytes(hashlib.sha256(name.encode("utf-8")).digest()[:8], "little")
    return np.random.default_rng([int(seed), label])


def compare(
    table: pd.DataFrame,
    by: str | Sequence[str] = "planner",
    value: str = "gap",
    *,
    blocks: str = "run",
    alpha: float = 0.05,
    confidence: float = 0.95,
    n_boot: int = 2000,
    seed: int = 0,
    ratio_of: str | None = None,
    pairing: str | Sequence[str] | None = None,
) -> Comparison:
    """Compare the configurations of a results table (module docstring: what, and how ties and
    failed runs are handled). ``by``: the column (or list of columns) naming a configuration, e.g.
    ``"planner"`` or ``["planner", "beta"]`` (``"variant"``, the planner column's former name, is
    taken as ``"planner"`` with a DeprecationWarning); ``value``: the column compared, lower is better
    (default ``gap``); ``blocks``: ``"run"`` (each pair is a block of the Friedman test) or
    ``"query"`` (each query, the median over its seeds); ``alpha``: the level of the tests'
    verdicts and of the critical difference; ``confidence`` and ``n_boot``: the bootstrap
    interval of the median; ``seed``: the bootstrap's random generators (with the configuration's
    label: the same seed and runs, the same interval); ``ratio_of``: the positive column of the
    performance ratios (default ``length`` when the table has it, else ``value``); ``pairing``:
    the columns that name a pair (default the query columns and ``seed`` the table has; e.g.
    ``["map", "query", "seed"]`` for a table that numbers its queries). Warns
    (:class:`UnequalPairsWarning`) when not every configuration has a run on every pair."""
    table, by, pairing, ratio_of = _check_table(table, by, value, blocks, pairing, ratio_of)
    for name, x, ok in (("alpha", alpha, 0 < alpha < 1), ("confidence", confidence, 0 < confidence < 1)):
        if isinstance(x, bool) or not isinstance(x, (int, float)) or not ok:
            raise JacoError(f"compare: {name} must be a number in (0, 1), got {x!r}")
    if isinstance(n_boot, bool) or not isinstance(n_boot, (int, np.integer)) or n_boot < 1:
        raise JacoError(f"compare: n_boot must be a positive integer, got {n_boot!r}")
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise JacoError(f"compare: seed must be a non-negative integer, got {seed!r}")

    groups = list(table.groupby(by, sort=False, dropna=False))
    names = [_label(by, key) for key, _ in groups]
    if len(set(names)) != len(names):
        raise JacoError(f"compare: two configurations read the same ({names}); name them by other columns")
    wide = table.assign(_config=table.groupby(by, sort=False, dropna=False).ngroup().map(dict(enumerate(names))))
    values = wide.pivot(index=pairing, columns="_config", values=value)[names]
    ratios_of = wide.pivot(index=pairing, columns="_config", values=ratio_of)[names]

    mean_ranks, friedman, notes = _rank_blocks(values, pairing, blocks, alpha)
    unequal = _unequal_pairs(values, friedman["n"])
    if unequal:
        warnings.warn(f"compare: {unequal}", UnequalPairsWarning, stacklevel=2)
        notes = [unequal] + (notes if blocks == "query" else [])  # with blocks="run" it says what they say

    summary = _summary([part for _, part in groups], names, value, mean_ranks, int(n_boot), confidence, seed)
    order = summary["configuration"].tolist()

    best = ratios_of.min(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        ratios = ratios_of.div(best, axis=0).where(np.isfinite(ratios_of), np.inf)
    ratios = ratios.where(ratios_of.notna())

    out = Comparison(
        by,
        value,
        pairing,
        summary,
        _paired(values, order, alpha),
        friedman,
        mean_ranks[order],
        ratios[order],
        values[order],
        alpha,
        confidence,
        ratio_of,
        notes=notes,
    )
    out.text = _words(out)
    return out


def _summary(parts, names, value, mean_ranks, n_boot, confidence, seed) -> pd.DataFrame:
    """One row per configuration, over its own runs: quartiles, the bootstrap interval of the
    median (its own generator) and the mean rank; best mean rank first."""
    rows = []
    for name, part in zip(names, parts):
        v = part[value].to_numpy(np.float64)
        q1, med, q3 = quantile(v, [0.25, 0.5, 0.75])
        lo, hi = bootstrap_median(v, n_boot=n_boot, confidence=confidence, rng=_config_rng(seed, name))
        rows.append(
            {
                "configuration": name,
                "runs": len(v),
                "success_rate": np.isfinite(v).mean(),
                f"{value}_q1": q1,
                f"{value}_median": med,
                f"{value}_q3": q3,
                f"{value}_median_low": lo,
                f"{value}_median_high": hi,
            }
        )
    summary = pd.DataFrame(rows)
    summary["mean_rank"] = mean_ranks.to_numpy()
    return summary.sort_values(["mean_rank", f"{value}_median"], kind="stable").reset_index(drop=True)


def _rank_blocks(values: pd.DataFrame, pairing: list[str], blocks: str, alpha: float) -> tuple[pd.Series, dict, list]:
    """Mean ranks within the complete blocks, the Friedman test and the critical difference."""
    from scipy.stats import friedmanchisquare, rankdata

    block_values = values
    if blocks == "query":
        query = [c for c in pairing if c != "seed"]
        # each configuration's median over its runs on the query; a query it never ran stays NaN
        block_values = values.groupby(level=query).agg(
            lambda s: float(quantile(s.dropna().to_numpy(), 0.5)) if s.notna().any() else math.nan
        )
    complete = block_values.dropna()
    notes = []
    if len(complete) < len(block_values):
        notes.append(
            f"{len(block_values) - len(complete)} of {len(block_values)} blocks lack a configuration "
            "and are left out of the ranks"
        )
    if len(complete) == 0:
        raise JacoError("compare: no block (pair) has a run of every configuration")
    stand_in = _finite_stand_in(complete.to_numpy(np.float64).ravel()).reshape(complete.shape)
    ranks = rankdata(stand_in, axis=1)
    mean_ranks = pd.Series(ranks.mean(axis=0), index=values.columns, name="mean_rank")
    k, n = values.shape[1], len(complete)
    friedman = {
        "statistic": None,
        "pvalue": None,
        "k": k,
        "n": n,
        "alpha": alpha,
        "blocks": blocks,
        "cd": critical_difference(k, n, alpha),
    }
    if k >= 3 and n >= 2:
        if np.all(ranks == ranks[:, :1]):  # every block ties: nothing to tell apart
            friedman.update(statistic=0.0, pvalue=1.0)
        else:
            res = friedmanchisquare(*stand_in.T)
            friedman.update(statistic=float(res.statistic), pvalue=float(res.pvalue))
    return mean_ranks, friedman, notes


def _unequal_pairs(values: pd.DataFrame, complete_blocks: int) -> str | None:
    """The note (and warning) when some configuration lacks a pair another has, else None."""
    have = values.notna().sum()
    if int(have.min()) == len(values):
        return None
    counts = "; ".join(f"{name} on {int(n)}" for name, n in have.items())
    return (
        f"the configurations have runs on different pairs (of {len(values)} pairs: {counts}); each "
        "configuration's median and interval are over its own runs, each paired test over the pairs "
        f"both configurations have, the ranks over the {complete_blocks} complete blocks"
    )


def _paired(values: pd.DataFrame, order: list[str], alpha: float) -> pd.DataFrame:
    """The paired tests of every two configurations, Holm-adjusted, and the side found better."""
    rows = []
    for a, b in combinations(order, 2):
        both = values[[a, b]].dropna()
        x, y = both[a].to_numpy(np.float64), both[b].to_numpy(np.float64)
        stat, p = wilcoxon(x, y)
        ra, rb = signed_rank_sums(x, y)
        d = signed_differences(x, y)
        rows.append(
            {
                "a": a,
                "b": b,
                "pairs": len(both),
                "a_better": int((d < 0).sum()),
                "b_better": int((d > 0).sum()),
                "ties": int((d == 0).sum()),
                "a_rank_sum": ra,
                "b_rank_sum": rb,
                "statistic": stat,
                "p": p,
            }
        )
    pairwise = pd.DataFrame(rows)
    pairwise["p_holm"] = holm(pairwise["p"].to_numpy())
    pairwise["significant"] = pairwise["p_holm"] < alpha
    # the side the signed ranks favour (the test's direction), never the side that wins more pairs
    pairwise["better"] = [
        (r.a if r.a_rank_sum > r.b_rank_sum else r.b) if r.significant and r.a_rank_sum != r.b_rank_sum else None
        for r in pairwise.itertuples()
    ]
    return pairwise


# -- words --------------------------------------------------------------------------------------
def _fmt_value(value: str, x: float) -> str:
    if value == "gap":
        return percent(x)
    return "failed" if math.isinf(x) and x > 0 else number(x)


def _p(p: float) -> str:
    return f"{p:.2g}" if p >= 0.001 else f"{p:.1e}"


def _rank(x: float) -> str:
    """A rank sum: a multiple of 1/4 (mean ranks of ties, zeros split in halves), without trailing zeros."""
    return f"{x:.2f}".rstrip("0").rstrip(".")


def _pair_sentence(row, alpha) -> str:
    a, b, n, ties = row["a"], row["b"], row["pairs"], row["ties"]
    if n == 0:
        return f"{a} and {b} cannot be compared: no pair has a run of both"
    if ties == n:
        return f"{a} and {b} cannot be told apart: they tie on all {n} pairs"
    if isinstance(row["better"], str):  # the side the signed ranks favour, which may win fewer pairs
        win, lose = (a, b) if row["better"] == a else (b, a)
        rw, rl, w, lost = (
            (row["a_rank_sum"], row["b_rank_sum"], row["a_better"], row["b_better"])
            if win == a
            else (row["b_rank_sum"], row["a_rank_sum"], row["b_better"], row["a_better"])
        )
        return (
            f"{win} is better than {lose}: signed ranks favour {win} {_rank(rw)} to {_rank(rl)}; "
            f"{win} better on {w} of {n} pairs, {lose} on {lost}, {ties} ties; p = {_p(row['p_holm'])} after Holm"
        )
    return (
        f"{a} and {b} cannot be told apart (p = {_p(row['p_holm'])} after Holm; signed ranks {a} "
        f"{_rank(row['a_rank_sum'])}, {b} {_rank(row['b_rank_sum'])}; {a} better on {row['a_better']} of {n} pairs, "
        f"{b} on {row['b_better']}, {ties} ties)"
    )


def _words(c: Comparison) -> str:
    v, s, alpha = c.value, c.summary, c.alpha
    unit = " (a fraction of the optimum, shown in %)" if v == "gap" else ""
    n, full = len(c.values), int(c.values.notna().all(axis=1).sum())
    over = (
        "each with a run of every configuration" if full == n else f"{full} of them with a run of every configuration"
    )
    lines = [
        f"{len(s)} configurations ({', '.join(c.by)}) compared on {v}{unit} over {n} pairs "
        f"({', '.join(c.pairing)}), {over}; lower is better, a failed run counts as +inf."
    ]
    top = s.iloc[0]
    ci = f"{100 * c.confidence:g}% CI {_fmt_value(v, top[f'{v}_median_low'])}–{_fmt_value(v, top[f'{v}_median_high'])}"
    lines.append(
        f"Best mean rank: {top['configuration']} (median {v} {_fmt_value(v, top[f'{v}_median'])} over its "
        f"{top['runs']} runs, {ci}; success {percent(top['success_rate'], 0)})."
    )
    f = c.friedman
    if f["pvalue"] is not None:
        verdict = "the configurations differ" if f["pvalue"] < alpha else "no evidence that the configurations differ"
        lines.append(
            f"Friedman test over {f['n']} blocks: chi2 = {f['statistic']:.3g}, p = {_p(f['pvalue'])}: {verdict}; "
            f"mean ranks closer than CD = {f['cd']:.3g} cannot be told apart (Nemenyi, alpha = {alpha:g})."
        )
    shown = set()
    best = top["configuration"]
    order = s["configuration"].tolist()
    chosen = [(best, other) for other in order[1:]] + [(x, y) for x, y in zip(order[1:], order[2:])]
    for x, y in chosen:
        if (x, y) in shown:
            continue
        shown.add((x, y))
        row = c.pairwise[
            ((c.pairwise.a == x) & (c.pairwise.b == y)) | ((c.pairwise.a == y) & (c.pairwise.b == x))
        ].iloc[0]
        lines.append(_pair_sentence(row, alpha) + ".")
    failed = s[s["success_rate"] == 0]["configuration"].tolist()
    if failed:
        lines.append(f"No path in any run: {'; '.join(failed)}.")
    lines += [f"Note: {n}." for n in c.notes]
    return "\n".join(lines)


def _tables_text(c: Comparison) -> str:
    v = c.value
    s = c.summary
    pct = v == "gap"
    fmt = lambda x: _fmt_value(v, x)  # noqa: E731
    span = lambda a, b: fmt(a) if fmt(a) == fmt(b) else f"{fmt(a)}–{fmt(b)}"  # noqa: E731
    head = pd.DataFrame(
        {
            "configuration": s["configuration"],
            "runs": s["runs"].map(str),
            "success": s["success_rate"].map(lambda x: percent(x, 0)),
            f"median {v}": s[f"{v}_median"].map(fmt),
            "quartiles": [span(a, b) for a, b in zip(s[f"{v}_q1"], s[f"{v}_q3"])],
            f"{100 * c.confidence:g}% CI of median": [
                span(a, b) for a, b in zip(s[f"{v}_median_low"], s[f"{v}_median_high"])
            ],
            "mean rank": s["mean_rank"].map(lambda x: f"{x:.2f}"),
        }
    )
    pw = c.pairwise
    pairs = pd.DataFrame(
        {
            "A": pw["a"],
            "B": pw["b"],
            "pairs": pw["pairs"].map(str),
            "A better": pw["a_better"].map(str),
            "B better": pw["b_better"].map(str),
            "ties": pw["ties"].map(str),
            "ranks A": pw["a_rank_sum"].map(_rank),
            "ranks B": pw["b_rank_sum"].map(_rank),
            "p": pw["p"].map(_p),
            "p (Holm)": pw["p_holm"].map(_p),
            f"better at {c.alpha:g}": pw["better"].map(lambda b: b if isinstance(b, str) else "-"),
        }
    )
    unit = " (gaps in %)" if pct else ""
    return (
        f"per configuration{unit}:\n{text_table(head, left=['configuration'])}\n\n"
        f"paired comparisons (two-sided Wilcoxon signed-rank, Holm over {len(pw)} pairs of configurations; "
        "ranks: the signed-rank sum favouring each side):\n"
        f"{text_table(pairs, left=['A', 'B'])}"
    )
