"""``jaco compare``: paired statistics on a saved results table (:mod:`jaco.research.compare`)."""

from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path

from ...errors import one_line
from ..args import UsageError
from ..output_flags import check_outputs


def cmd_compare(args: argparse.Namespace) -> int:
    """Paired statistics on a saved results table (jaco.research.compare)."""
    import warnings

    from ...research.compare import ByError, UnequalPairsWarning, compare
    from ...research.tables import FORMER_PLANNER, PLANNER, read_table

    figures = [f for f in ("--cd", "--profile") if getattr(args, f[2:]) is not None]
    check_outputs(args, figures=figures)
    table = read_table(args.table)  # an older table's "variant" column is "planner"
    by = args.by or [PLANNER]
    if FORMER_PLANNER in by and FORMER_PLANNER not in table.columns:
        by = [PLANNER if b == FORMER_PLANNER else b for b in by]  # --by variant: the former name
    if args.where:
        table = _where(table, args.where)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", UnequalPairsWarning)
        try:
            result = compare(
                table,
                by=by,
                value=args.value,
                blocks=args.blocks,
                alpha=args.alpha,
                confidence=args.confidence,
                n_boot=args.boot,
                seed=args.seed,
            )
        except ByError as e:  # the columns that tell the configurations apart, as options
            options = " ".join(f"--by {shlex.quote(str(c))}" for c in e.by)
            raise UsageError(str(e).replace(f"by={e.by!r}", options)) from None
    for w in caught:  # a jaco warning line, not Python's with a source line (the words repeat it as a note)
        if issubclass(w.category, UnequalPairsWarning):
            print(f"jaco: warning: {one_line(str(w.message))}", file=sys.stderr)
        else:
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    print(f"table   {Path(args.table).name}: {len(table)} runs; bootstrap: {args.boot} resamples, seed {args.seed}")
    print()
    print(result.table())
    print()
    print(result.text)
    from ... import plot

    if args.cd:
        print(f"wrote {plot.save(plot.plot_critical_difference(result), args.cd)}")
    if args.profile:
        print(f"wrote {plot.save(plot.plot_performance_profile(result), args.profile)}")
    return 0


def _where(table, items):
    """Rows of ``table`` where each ``NAME=VALUE`` holds (numbers compared as numbers)."""
    import numpy as np

    for item in items:
        name, sep, value = item.partition("=")
        name, value = name.strip(), value.strip()
        if not sep or not name:
            raise UsageError(f"--where expects NAME=VALUE (e.g. beta=16), got {item!r}")
        if name == "variant" and name not in table.columns and "planner" in table.columns:
            name = "planner"  # the planner column's former name
        if name not in table.columns:
            raise UsageError(
                f"--where {item}: no column {name!r} in the table (columns: {', '.join(map(str, table.columns))})"
            )
        col = table[name]
        if col.dtype.kind in "iuf":
            try:
                mask = np.isclose(col.to_numpy(float), float(value), rtol=1e-6, atol=0)
            except ValueError:
                raise UsageError(f"--where {item}: column {name!r} holds numbers, {value!r} is not one") from None
        else:
            mask = (col.astype(str) == value).to_numpy()
        if not mask.any():
            raise UsageError(f"--where {item}: no row has {name} = {value}")
        table = table[mask]
    return table
