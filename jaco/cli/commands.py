"""The commands: ``demo``, ``solve``, ``sweep``, ``compare``, ``rerun``, ``planners`` (``variants``), ``maps``, ``info`` (``cmd_*``), and
how a run is reported. Heavy modules are imported inside the functions."""

from __future__ import annotations

import argparse
import contextlib
import functools
import json
import math
import os
import shlex
import sys
import time
from pathlib import Path
from typing import Any

from .args import UsageError, _one_line, parse_params, parse_sweep_params
from .queries import load_map, resolve_queries, resolve_query


def _world_doc(grid, result) -> dict:
    """World-frame fields for ``--json`` on a ROS map (metres, cell centres)."""
    from ..research.record_format import _metres

    start, goal = (grid.cell_to_world(c) for c in (result.start, result.goal))
    return {
        "frame": "map",
        "units": "m",
        "resolution": grid.resolution,
        "origin": list(grid.origin or (0.0, 0.0, 0.0)),
        "start_xy": [_metres(v) for v in start],
        "goal_xy": [_metres(v) for v in goal],
        "length_m": result.length / grid.cell_size * grid.resolution if result.success else None,
        "path_xy": [[_metres(x), _metres(y)] for x, y in result.to_world()],
    }


# -- reporting ------------------------------------------------------------------------------------
def _json_safe(x):
    """Plain JSON types, non-finite floats as None."""
    import numpy as np

    if isinstance(x, dict):
        return {str(k): _json_safe(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_json_safe(v) for v in x]
    if isinstance(x, np.ndarray):
        return _json_safe(x.tolist())
    if isinstance(x, (bool, np.bool_)):
        return bool(x)
    if isinstance(x, (int, np.integer)):
        return int(x)
    if isinstance(x, (float, np.floating)):
        x = float(x)
        return x if math.isfinite(x) else None
    if x is None or isinstance(x, str):
        return x
    return str(x)


def _fmt_len(x: float) -> str:
    return f"{x:.4f}" if math.isfinite(x) else "none"


def _unsigned_zero(text: str) -> str:
    """``"-0.00"`` -> ``"0.00"`` (a float32 length a hair below the optimum rounds to a signed zero)."""
    return text[1:] if text.startswith("-") and not text.strip("-+0.,%") else text


def _dumps(doc, level: int = 0) -> str:
    """JSON with one key per line and every list (a path, a history) on one line."""
    if isinstance(doc, dict) and doc:
        pad = "  " * (level + 1)
        items = ",\n".join(f"{pad}{json.dumps(k)}: {_dumps(v, level + 1)}" for k, v in doc.items())
        return "{\n" + items + "\n" + "  " * level + "}"
    return json.dumps(doc, allow_nan=False)


def _report(grid, result, exact_length, seconds, scenario=None, scen_label=None) -> None:
    """The run as the shell user reads it; a failed run ends with :func:`failure_hint`."""
    from ..engine.result import failure_hint

    w = 9
    print(f"{'map':<{w}} {grid.name} ({grid.height}x{grid.width}, {grid.n_free} free cells)")
    print(f"{'query':<{w}} start {tuple(result.start)} -> goal {tuple(result.goal)}")
    shown = ", ".join(f"{k}={v:g}" for k, v in result.params.items())
    print(
        f"{'planner':<{w}} {result.variant} ({result.n_ants} ants x {result.n_iters} iterations, "
        f"seed {result.seed}; {shown})"
    )
    if result.success:
        pct = 100 * result.gap if math.isfinite(result.gap) else math.nan
        gap = "n/a" if math.isnan(pct) else f"{0.0 if round(pct, 2) == 0 else pct:+.2f}%"  # never -0.00%
        print(f"{'length':<{w}} {_fmt_len(result.length)} (exact optimum {_fmt_len(exact_length)}, gap {gap})")
    else:
        print(f"{'length':<{w}} none: no ant reached the goal (exact optimum {_fmt_len(exact_length)})")
    if scenario is not None:
        print(f"{'scenario':<{w}} {scen_label}: optimal length {scenario.optimal:.4f} (from the .scen file)")
    print(f"{'cells':<{w}} {len(result.path)}")
    best_at = result.best_iteration if result.success else "-"
    print(f"{'best at':<{w}} iteration {best_at} of {result.n_iters}")
    print(f"{'success':<{w}} {'yes' if result.success else 'no'}")
    print(f"{'time':<{w}} {seconds:.2f} s (since the command started: imports, map, JIT compilation and the run)")
    if not result.success:
        import textwrap

        text = failure_hint(result, cli=True)
        print(textwrap.fill(text, 100, initial_indent=f"{'hint':<{w}} ", subsequent_indent=" " * (w + 1)))


def _plot(grid, result, exact_path, exact_length, out, format=None) -> Path:
    from .. import plot

    aco = f"{result.variant} ({result.length:.2f})" if result.success else result.variant
    exact = f"exact ({exact_length:.2f})" if math.isfinite(exact_length) else "exact"
    fig = plot.plot_paths(
        grid,
        {aco: result.path, exact: exact_path},
        start=result.start,
        goal=result.goal,
        title=f"{grid.name}: {result.variant} vs exact optimum",
    )
    return plot.save(fig, out, format)


def _run_and_report(grid, start, goal, args, params, *, scenario=None, scen_label=None):
    from .. import exact
    from ..api import solve

    via = getattr(args, "waypoint", None)  # solve --waypoint R,C (several targets, jaco.waypoints)
    result = solve(
        grid,
        start,
        goal,
        args.planner,
        seed=args.seed,
        n_ants=args.ants,
        n_iters=args.iters,
        steplimit=getattr(args, "steplimit", None),
        waypoints=via,
        **params,
    )
    seconds = time.perf_counter() - args.started  # main's clock: from start-up
    args.finished = True  # from here a failed write says that the run itself finished
    if via:
        from ..waypoints import exact_trip

        exact_length, exact_path = exact_trip(grid, [start, *via, goal])
    else:
        exact_length, exact_path = exact.shortest_path(grid, start, goal)
    _report(grid, result, exact_length, seconds, scenario, scen_label)
    return result, exact_length, exact_path


# -- commands -------------------------------------------------------------------------------------
NO_PATH = 4  # exit code of solve / demo when no ant reached the goal (2: a user mistake)


def _map_inputs(args, grid) -> list:
    """The files a command reads (the map, a ROS map's image, the scenario): no output may name one."""
    out = []
    for spec in (getattr(args, "map", None), getattr(args, "scen", None)):
        if spec is not None and Path(spec).is_file():
            out.append(Path(spec))
    image = grid.meta.get("image") if grid is not None else None
    if isinstance(image, str) and out:
        out.append(out[0].parent / image)
    return out


def _check_outputs(args, grid=None, figures=(), files=()) -> None:
    """Every output flag checked before anything runs (:func:`jaco.outputs.check_output`)."""
    from ..outputs import check_distinct, check_output
    from ..plot import check_figure_path

    inputs = _map_inputs(args, grid)
    named = {}
    for flag, suffixes in files:
        value = getattr(args, flag.lstrip("-").replace("-", "_"))
        if value is not None:
            named[flag] = check_output(value, flag, suffixes=suffixes, inputs=inputs)
    for flag in figures:
        value = getattr(args, flag.lstrip("-").replace("-", "_"))
        if value is not None:
            how = "--plot-format" if flag == "--plot" else "jaco solve demo --plot - --plot-format png"
            named[flag] = check_figure_path(
                value, flag, inputs=inputs, format=getattr(args, "plot_format", None), how=how
            )
    if args.command == "sweep" and "--record" in named:  # the sweep record's JSON sidecar
        named["--record sidecar"] = check_output(
            named["--record"].with_suffix(".json"), "--record sidecar", inputs=inputs
        )
    check_distinct(named)


def _outputs(*flags):
    """A command's output handling (its output flags named): when one writes to standard output
    (``-``, ``/dev/stdout``) the human summary goes to stderr, so stdout holds only the data; an
    output that fails to be written after the run says that the run itself finished."""

    def wrap(cmd):
        @functools.wraps(cmd)
        def run(args):
            from ..errors import OutputError
            from ..outputs import is_stdout, standard_output

            with contextlib.ExitStack() as stack:
                if any(is_stdout(v) for v in (getattr(args, f.lstrip("-").replace("-", "_")) for f in flags) if v):
                    stack.enter_context(standard_output(sys.stdout))
                    stack.enter_context(contextlib.redirect_stdout(sys.stderr))
                try:
                    return cmd(args)
                except OutputError as e:
                    if isinstance(e.__cause__, BrokenPipeError) and sys.stdout is sys.__stdout__:
                        _quiet_stdout()
                    if not getattr(args, "finished", False):
                        raise
                    raise OutputError(
                        f"{e}; the run itself finished (its summary above is complete), "
                        "but this output and any after it were not written"
                    ) from e

        return run

    return wrap


def _quiet_stdout() -> None:
    """After standard output's reader went away: send what Python still holds for it to
    /dev/null, so that exiting does not print a second error about the closed pipe."""
    with contextlib.suppress(OSError, ValueError):
        null = os.open(os.devnull, os.O_WRONLY)
        os.dup2(null, sys.stdout.fileno())
        os.close(null)


@_outputs("--out")
def cmd_demo(args: argparse.Namespace) -> int:
    from .. import maps

    _check_outputs(args, figures=("--out",))
    grid = maps.named("demo")
    result, exact_length, exact_path = _run_and_report(grid, grid.meta["start"], grid.meta["goal"], args, {})
    out = _plot(grid, result, exact_path, exact_length, args.out)
    print(f"wrote {out}")
    return 0 if result.success else NO_PATH


@_outputs("--json", "--plot", "--path-csv", "--record")
def cmd_solve(args: argparse.Namespace) -> int:
    from ..outputs import is_stream

    params = parse_params(args.param)
    if args.path_csv and Path(args.path_csv).suffix.lower() != ".csv" and not is_stream(args.path_csv):
        raise UsageError(f"--path-csv writes CSV: give a file name ending in .csv, got {args.path_csv!r}")
    grid = load_map(args.map)
    start, goal, scenario, label = resolve_query(grid, args)
    _check_outputs(
        args, grid, figures=("--plot",), files=(("--json", None), ("--path-csv", (".csv",)), ("--record", None))
    )
    result, exact_length, exact_path = _run_and_report(
        grid, start, goal, args, params, scenario=scenario, scen_label=label
    )
    if grid.resolution is not None:  # ROS map: the query and length in metres too
        sx, sy = grid.cell_to_world(result.start)
        gx, gy = grid.cell_to_world(result.goal)
        metres = f", length {result.length / grid.cell_size * grid.resolution:.3f} m" if result.success else ""
        print(f"{'world':<9} start ({sx:.3f}, {sy:.3f}) m -> goal ({gx:.3f}, {gy:.3f}) m{metres}")
    if args.json:
        doc = result.to_dict()
        doc["metrics"] = result.metrics()
        if scenario is not None:
            doc["scenario"] = {"label": label, "optimal": scenario.optimal, "bucket": scenario.bucket}
        if grid.resolution is not None:
            doc["world"] = _world_doc(grid, result)
        from ..outputs import write_text

        path = write_text(args.json, _dumps(_json_safe(doc)) + "\n", "--json")
        print(f"wrote {path}")
    if args.plot:
        print(f"wrote {_plot(grid, result, exact_path, exact_length, args.plot, args.plot_format)}")
    if args.path_csv:
        frame = "world" if grid.resolution is not None else "cells"
        print(f"wrote {result.save_path(args.path_csv, frame=frame, format='csv')}")
    if args.record:
        rerun = "" if is_stream(args.record) else f" (rerun it with 'jaco rerun {args.record}')"
        print(f"wrote {result.save(args.record)}{rerun}")
    return 0 if result.success else NO_PATH


@_outputs("--csv", "--record")
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
    _check_outputs(args, grid, files=(("--csv", None), ("--record", (".csv",)), ("--store", None)))
    from ..planners.registry import get_planner
    from ..research.store import counting
    from ..research.sweeps import sweep
    from ..research.tables import short_name

    ledger: dict = {}  # what an interrupt leaves in the store (the last line says)
    args.kept = functools.partial(_sweep_kept, args.store, ledger)
    names = args.planner or [args.default_planner]
    variants = [get_planner(v) for v in names]
    variant = variants[0] if len(variants) == 1 else variants
    several = len(starts) > 1
    start, goal = (starts, goals) if several else (starts[0], goals[0])
    n_configs = len(variants) * (math.prod(len(v) for v in axes.values()) if axes else 1)
    query = f"{len(starts)} queries" if several else f"start {tuple(start)} -> goal {tuple(goal)}"
    print(
        f"sweep {', '.join(short_name(v.name) for v in variants)} on {grid.name} ({grid.height}x{grid.width}), {query}: "
        f"{n_configs} configurations x {args.seeds} seeds, {args.ants} ants x {args.iters} iterations",
        flush=True,
    )
    if scenarios is not None:
        print(f"queries: {label}", flush=True)
    with counting(ledger):
        table = sweep(
            grid,
            start,
            goal,
            variant,
            axes,
            args.seeds,
            n_ants=args.ants,
            n_iters=args.iters,
            steplimit=args.steplimit,  # progress: a bar on a terminal
            store=args.store,
            chunk=args.chunk,
            grace_period=args.grace_period,
        )
    args.kept = None
    seconds = time.perf_counter() - args.started
    args.finished = True
    print(f"{len(table)} runs in {seconds:.2f} s (since the command started: imports, JIT compilation and the runs)")
    if args.store:
        plans = table.attrs["sweep"].values() if len(variants) > 1 else [table.attrs["sweep"]]
        resumed = sum(p.get("resumed_runs", 0) for p in plans)
        print(
            f"store {args.store}: {resumed} runs were already stored or ran in other processes, "
            f"{len(table) - resumed} ran here"
        )
    if scenarios is not None and not several:
        print(f"scenario {label}: optimal length {scenarios[0].optimal:.4f} (from the .scen file)")
    if args.csv:
        from ..outputs import write_text
        from ..research.tables import csv_text

        path = write_text(args.csv, csv_text(table), "--csv")
        print(f"wrote {path}")
    if args.record:
        from ..research.records import save_sweep

        sidecar = save_sweep(
            table,
            args.record,
            grid,
            start,
            goal,
            variant,
            axes,
            args.seeds,
            n_ants=args.ants,
            n_iters=args.iters,
            steplimit=args.steplimit,
        )
        print(f"wrote {args.record} and {sidecar} (rerun them with 'jaco rerun {sidecar}')")
    _print_sweep_summary(table, variants, axes, several)
    if n_configs > 1 and (args.csv or args.record):
        # every swept column, so that the command runs as printed
        by = " ".join(f"--by {c}" for c in ["planner", *(k for k, v in axes.items() if len(v) > 1)])
        what = "planners" if len(variants) > 1 else "configurations"
        print(f"\ncompare the {what} with paired tests: jaco compare {shlex.quote(str(args.csv or args.record))} {by}")
    return 0


def _sweep_kept(store, ledger) -> str:
    """What an interrupted sweep kept (``ledger``: :func:`jaco.research.store.counting`'s) and how
    to go on, for the line ``jaco: interrupted: ...``."""
    if store is None:
        return "nothing was kept (add --store FILE to keep finished chunks)"
    runs = sum(n for sweeps in ledger.values() for n in sweeps.values())
    if not runs:
        return f"no chunk had finished, nothing new stored in {store}; the same command resumes"
    return f"{runs} run{'s' if runs != 1 else ''} stored in {store}; the same command resumes"


def _print_sweep_summary(table, variants, axes, several) -> None:
    """The best configurations (over every query when there are several) and the best one."""
    from ..research.sweeps import summarize
    from ..research.tables import percent, short_name

    swept = (["planner"] if len(variants) > 1 else []) + list(axes)
    by = swept + ["config"] if several else None  # several queries: one row per configuration
    summary = (
        summarize(table, by=by if by else None)
        .sort_values(["success_rate", "gap_median", "gap_mean"], ascending=[False, True, True], kind="stable")
        .reset_index(drop=True)
    )
    shown_by = swept or list(variants[0].params)
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
    winner = _variant_of(best, variants)
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


def _variant_of(row, variants):
    """The planner of a summary row (the one planner of the sweep, or the row's ``planner``)."""
    from ..planners.registry import get_planner

    return get_planner(row["planner"]) if len(variants) > 1 else variants[0]


def _summary_table(shown, swept, lengths: bool = True) -> str:
    """The sweep's summary as text: a planner by its short name, left-aligned; a configuration
    that failed on every seed reads "failed" in its length and gap columns (never inf or NaN), a
    missing value "-"; gaps in %, integers as integers."""
    import pandas as pd

    from ..research.tables import number, short_name, text_table

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


def cmd_compare(args: argparse.Namespace) -> int:
    """Paired statistics on a saved results table (jaco.research.compare)."""
    import warnings

    from ..research.compare import ByError, UnequalPairsWarning, compare
    from ..research.tables import FORMER_PLANNER, PLANNER, read_table

    figures = [f for f in ("--cd", "--profile") if getattr(args, f[2:]) is not None]
    _check_outputs(args, figures=figures)
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
            print(f"jaco: warning: {_one_line(str(w.message))}", file=sys.stderr)
        else:
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    print(f"table   {Path(args.table).name}: {len(table)} runs; bootstrap: {args.boot} resamples, seed {args.seed}")
    print()
    print(result.table())
    print()
    print(result.text)
    from .. import plot

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


def cmd_rerun(args: argparse.Namespace) -> int:
    """Rerun a record; exit 0 when it matched bit for bit, 1 when it did not."""
    from ..research.records import RunRecord, load_run

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
        print(f"jaco: warning: {_one_line(w)}", file=sys.stderr)
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


def cmd_planners(args: argparse.Namespace) -> int:
    from ..planners.registry import PLANNERS

    width = max(len(name) for name in PLANNERS)  # the sources column starts at one place
    for v in PLANNERS.values():
        print(v.describe(width))
        if args.verbose:
            import textwrap

            print(textwrap.indent(textwrap.fill(v.doc, 96), "    "))
            print()
    return 0


def cmd_maps(args: argparse.Namespace) -> int:
    from .. import maps

    print("named maps (start/goal built in):")
    for name in maps.NAMED:
        g = maps.named(name)
        print(f"  {name:14s} {g.height:>3d}x{g.width:<3d}  start {g.meta['start']} -> goal {g.meta['goal']}")
    folders: dict = {}  # each folder that holds bundled files, as it is on disk, with its files
    for name in maps.BUNDLED:
        folders.setdefault(maps.bundled(name).parent, []).append(name)
    for folder, names in folders.items():
        print(f"\nbundled files in {folder}:")
        for name in names:
            print(f"  {name}")
    print(
        "\nA MAP argument is a file path, a named map, or a bundled file's bare name (no folder), e.g.\n"
        "  jaco solve random-32-32-10.map --scen random-32-32-10-even-10.scen --index 34"
    )
    return 0


def cmd_info(args: argparse.Namespace) -> int:
    import platform

    import jax
    import jaxlib
    import numpy as np

    from .. import __version__
    from ..engine import native

    print(f"jaco {__version__}")
    print(
        f"jax {jax.__version__}, jaxlib {jaxlib.__version__}, numpy {np.__version__}, "
        f"python {platform.python_version()} ({platform.machine()})"
    )
    devices = jax.devices()
    print(f"devices: {len(devices)} x {devices[0].platform} ({', '.join(str(d) for d in devices)})")
    walk = native.active_walk()
    if walk == "native":
        print("walk: native (the C++ kernel through jax.ffi on CPU; the JAX walk elsewhere)")
    elif native.available():
        print("walk: jax (chosen with --walk, jaco.set_walk or JACO_WALK; the native walk is built)")
    else:
        print(f"walk: jax ({native.unavailable_reason()}; the JAX walk gives the same results, slower on CPU)")
    if native.available():  # the lane kernels' instruction sets (JACO_NATIVE_ISA chooses; same moves in each)
        print("native instruction sets: " + ", ".join(f"{name} ({state})" for name, state in native.isas().items()))
    return 0
