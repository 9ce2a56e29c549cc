"""``jaco sweep``: configurations x seeds x queries in compiled calls, the table written, the best
configurations printed."""

from __future__ import annotations

import argparse
import functools
import math
import shlex
import time
from pathlib import Path

from ..args import UsageError, parse_sweep_params
from ..output_flags import check_outputs, handles_outputs
from ..queries import load_map, resolve_queries


@handles_outputs("--csv", "--record")
def cmd_sweep(args: argparse.Namespace) -> int:
    axes = parse_sweep_params(args.param)
    if args.record and Path(args.record).suffix.lower() != ".csv":
        raise UsageError(
            f"--record writes the table as CSV plus a .json sidecar: give a name ending in .csv, got {args.record!r}"
        )
    if args.grace_period is not None and not args.store:
        raise UsageError("--grace-period is for a shared store: give --store FILE.db too")
    grid = load_map(args.map)
    starts, goals, scenarios, label = resolve_queries(grid, args)
    check_outputs(args, grid, files=(("--csv", None), ("--record", (".csv",)), ("--store", None)))
    from ...planners.registry import get_planner
    from ...research.store import counting
    from ...research.sweeps import sweep

    ledger: dict = {}  # what an interrupt leaves in the store (the last line says)
    args.kept = functools.partial(_sweep_kept, args.store, ledger)
    planners = [get_planner(v) for v in args.planner or [args.default_planner]]
    planner = planners[0] if len(planners) == 1 else planners
    several = len(starts) > 1
    start, goal = (starts, goals) if several else (starts[0], goals[0])
    n_configs = len(planners) * (math.prod(len(v) for v in axes.values()) if axes else 1)
    _print_sweep_plan(args, grid, planners, start, goal, n_configs, len(starts), scenarios, label)
    # the sweep's call, which --record writes down for 'jaco rerun'
    call = (grid, start, goal, planner, axes, args.seeds)
    sizes = {"n_ants": args.ants, "n_iters": args.iters, "steplimit": args.steplimit}
    with counting(ledger):  # progress left at its default: a bar on a terminal
        table = sweep(*call, **sizes, store=args.store, chunk=args.chunk, grace_period=args.grace_period)
    args.kept = None
    seconds = time.perf_counter() - args.started
    args.finished = True
    print(f"{len(table)} runs in {seconds:.2f} s (since the command started: imports, JIT compilation and the runs)")
    if args.store:
        _print_store_share(args.store, table, several_planners=len(planners) > 1)
    if scenarios is not None and not several:
        print(f"scenario {label}: optimal length {scenarios[0].optimal:.4f} (from the .scen file)")
    _write_sweep_outputs(args, table, call, sizes)
    _print_sweep_summary(table, planners, axes, several)
    if n_configs > 1 and (args.csv or args.record):
        # every swept column, so that the command runs as printed
        by = " ".join(f"--by {c}" for c in ["planner", *(k for k, v in axes.items() if len(v) > 1)])
        what = "planners" if len(planners) > 1 else "configurations"
        print(f"\ncompare the {what} with paired tests: jaco compare {shlex.quote(str(args.csv or args.record))} {by}")
    return 0


def _print_sweep_plan(args, grid, planners, start, goal, n_configs, n_queries, scenarios, label) -> None:
    """The first lines: what runs on which map and queries, how many configurations and seeds."""
    from ...research.tables import short_name

    query = f"{n_queries} queries" if n_queries > 1 else f"start {tuple(start)} -> goal {tuple(goal)}"
    print(
        f"sweep {', '.join(short_name(v.name) for v in planners)} on {grid.name} ({grid.height}x{grid.width}), {query}: "
        f"{n_configs} configurations x {args.seeds} seeds, {args.ants} ants x {args.iters} iterations",
        flush=True,
    )
    if scenarios is not None:
        print(f"queries: {label}", flush=True)


def _print_store_share(store, table, several_planners: bool) -> None:
    """How many of the runs the store already had (or other processes ran), how many ran here."""
    plans = table.attrs["sweep"].values() if several_planners else [table.attrs["sweep"]]
    resumed = sum(p.get("resumed_runs", 0) for p in plans)
    print(
        f"store {store}: {resumed} runs were already stored or ran in other processes, {len(table) - resumed} ran here"
    )


def _write_sweep_outputs(args, table, call, sizes) -> None:
    """``--csv`` (the table) and ``--record`` (the table and its JSON sidecar: the sweep's ``call``
    and ``sizes``)."""
    if args.csv:
        from ...outputs import write_text
        from ...research.tables import csv_text

        path = write_text(args.csv, csv_text(table), "--csv")
        print(f"wrote {path}")
    if args.record:
        from ...research.records import save_sweep

        sidecar = save_sweep(table, args.record, *call, **sizes)
        print(f"wrote {args.record} and {sidecar} (rerun them with 'jaco rerun {sidecar}')")


def _sweep_kept(store, ledger) -> str:
    """What an interrupted sweep kept (``ledger``: :func:`jaco.research.store.counting`'s) and how
    to go on, for the line ``jaco: interrupted: ...``."""
    if store is None:
        return "nothing was kept (add --store FILE to keep finished chunks)"
    runs = sum(n for sweeps in ledger.values() for n in sweeps.values())
    if not runs:
        return f"no chunk had finished, nothing new stored in {store}; the same command resumes"
    return f"{runs} run{'s' if runs != 1 else ''} stored in {store}; the same command resumes"


def _print_sweep_summary(table, planners, axes, several) -> None:
    """The best configurations (over every query when there are several) and the best one."""
    from ...research.sweeps import summarize
    from ...research.tables import percent, short_name

    swept = (["planner"] if len(planners) > 1 else []) + list(axes)
    by = swept + ["config"] if several else None  # several queries: one row per configuration
    summary = (
        summarize(table, by=by if by else None)
        .sort_values(["success_rate", "gap_median", "gap_mean"], ascending=[False, True, True], kind="stable")
        .reset_index(drop=True)
    )
    shown_by = swept or list(planners[0].params)
    over = "every query's seeds" if several else "the seeds"
    print(
        f"\ntop {min(10, len(summary))} of {len(summary)} configurations over {over} (by success rate, then median "
        "gap, then mean gap, over the successful runs; gaps in % of the optimum):"
    )
    print(_summary_table(summary.head(10), shown_by, lengths=not several))
    best = summary.iloc[0]
    if best["success_rate"] == 0:
        optimum = "" if several else f" (optimum {table['optimal'].iloc[0]:.4f})"
        print(f"\nno configuration reached the goal{optimum}: every run failed")
        return
    winner = _planner_of(best, planners)
    conf = " ".join(f"{k}={best[k]:g}" for k in axes)
    rest = "other parameters at their defaults" if axes else "default parameters"
    print(f"\nbest: {short_name(winner.name)} {conf}".rstrip() + f" ({rest})")
    if short_name(winner.name) != winner.name:
        print(f"      planner {winner.name}")
    length = (
        "" if several else (f"median length {best['length_median']:.4f} (optimum {table['optimal'].iloc[0]:.4f}), ")
    )
    print(
        f"      {length}median gap {percent(best['gap_median'], 2)} (quartiles {percent(best['gap_q1'], 2)} to "
        f"{percent(best['gap_q3'], 2)}) over the successful runs, success {100 * best['success_rate']:.0f}% "
        f"of {int(best['runs'])} runs"
    )


def _planner_of(row, planners):
    """The planner of a summary row (the one planner of the sweep, or the row's ``planner``)."""
    from ...planners.registry import get_planner

    return get_planner(row["planner"]) if len(planners) > 1 else planners[0]


def _unsigned_zero(text: str) -> str:
    """``"-0.00"`` -> ``"0.00"`` (a float32 length a hair below the optimum rounds to a signed zero)."""
    return text[1:] if text.startswith("-") and not text.strip("-+0.,%") else text


def _summary_table(shown, swept, lengths: bool = True) -> str:
    """The sweep's summary as text: a planner by its short name, left-aligned; a configuration
    that failed on every seed reads "failed" in its length and gap columns (never inf or NaN), a
    missing value "-"; gaps in %, integers as integers."""
    import pandas as pd

    from ...research.tables import number, short_name, text_table

    failed = shown["success_rate"] == 0
    text = pd.DataFrame({k: shown[k].map(short_name if k == "planner" else number) for k in swept})
    text["success_%"] = (100 * shown["success_rate"]).map(lambda x: f"{x:.0f}")
    columns = (["length_median", "length_min"] if lengths else []) + ["gap_median", "gap_q1", "gap_q3", "gap_mean"]
    for col in columns:
        scale = 100 if col.startswith("gap") else 1
        values = (scale * shown[col]).map(lambda x: "-" if math.isnan(x) else _unsigned_zero(f"{x:.4g}"))
        text[col + ("_%" if col.startswith("gap") else "")] = values.where(~failed, "failed")
    text["runs"] = shown["runs"].map(str)
    return text_table(text, left=["planner"])
