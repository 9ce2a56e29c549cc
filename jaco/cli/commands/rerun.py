"""``jaco rerun`` of a run or sweep record (a stored search's trial: :func:`jaco.cli.search.cmd_rerun`),
and how a rerun is reported."""

from __future__ import annotations

import argparse
import sys
import time
from typing import Any

from ...errors import one_line


def cmd_rerun(args: argparse.Namespace) -> int:
    """Rerun a record; exit 0 when it matched bit for bit, 1 when it did not."""
    from ...research.records import RunRecord, load_run

    rec = load_run(args.record)
    if isinstance(rec, RunRecord):
        c, g = rec.call, rec.grid
        print(
            f"record   {rec.path.name}: {c['variant']} on {g.name} ({g.height}x{g.width}), start "
            f"{tuple(c['start'])} -> goal {tuple(c['goal'])}, seed {c['seed']}, {c['n_ants']} ants x "
            f"{c['n_iters']} iterations"
        )
    else:
        c = rec.call
        print(f"record   {rec.path.name}: sweep of {c['variant']}, {len(rec.table)} rows")
    for w in rec.warnings:
        print(f"jaco: warning: {one_line(w)}", file=sys.stderr)
    return report_rerun(lambda: rec.rerun(warn=False), "the record")


def report_rerun(rerun: Any, what: str) -> int:
    """Run ``rerun()`` (a :class:`jaco.research.records.Rerun`) and say whether it matched
    ``what``: exit 0 when it did, 1 when it did not."""
    t0 = time.perf_counter()
    result = rerun()
    seconds = time.perf_counter() - t0
    if result.matched:
        print(f"rerun    matched {what} bit for bit ({result.what}; {seconds:.2f} s)")
        return 0
    print(f"rerun    did NOT match {what} ({len(result.differences)} difference(s)):")
    for d in result.differences:
        print(f"  {d}")
    return 1
