"""The statistics of :func:`jaco.compare`, on arrays that may hold +∞ (a failed run): quantiles and
the bootstrap interval of the median, the Wilcoxon signed-rank test with its signed differences
and rank sums, Holm's adjustment, the Nemenyi critical difference and the performance profile
(the module docstring of :mod:`jaco.research.compare` says how ties and failures count)."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

if TYPE_CHECKING:
    from numpy.typing import ArrayLike


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


def finite_stand_in(values: np.ndarray) -> np.ndarray:
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
