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
from .compare_checks import ByError, check_table, config_label
from .compare_stats import (
    bootstrap_median,
    critical_difference,
    finite_stand_in,
    holm,
    performance_profile,
    quantile,
    signed_differences,
    signed_rank_sums,
    wilcoxon,
)
from .compare_words import tables_text, words

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


class UnequalPairsWarning(UserWarning):
    """Not every configuration of a compared table has a run on every pair: the paired tests use
    the pairs both configurations have, the ranks the complete blocks, the summary every run."""


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
        return tables_text(self)


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
    table, by, pairing, ratio_of = check_table(table, by, value, blocks, pairing, ratio_of)
    for name, x, ok in (("alpha", alpha, 0 < alpha < 1), ("confidence", confidence, 0 < confidence < 1)):
        if isinstance(x, bool) or not isinstance(x, (int, float)) or not ok:
            raise JacoError(f"compare: {name} must be a number in (0, 1), got {x!r}")
    if isinstance(n_boot, bool) or not isinstance(n_boot, (int, np.integer)) or n_boot < 1:
        raise JacoError(f"compare: n_boot must be a positive integer, got {n_boot!r}")
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise JacoError(f"compare: seed must be a non-negative integer, got {seed!r}")

    groups = list(table.groupby(by, sort=False, dropna=False))
    names = [config_label(by, key) for key, _ in groups]
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
    out.text = words(out)
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
    stand_in = finite_stand_in(complete.to_numpy(np.float64).ravel()).reshape(complete.shape)
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
