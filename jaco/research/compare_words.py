"""A comparison in words and as text tables for a terminal (:attr:`Comparison.text`,
:meth:`Comparison.table`): which configuration is better than which, how sure, over what."""

from __future__ import annotations

import math

import pandas as pd

from .tables import number, percent, text_table


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


def words(c) -> str:
    """What the data of the :class:`~jaco.research.compare.Comparison` ``c`` support, one sentence a line."""
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


def tables_text(c) -> str:
    """The summary and the paired tests of the comparison ``c`` as text tables."""
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
