"""``jaco demo`` and ``jaco solve``: one run, reported beside the exact optimum, and its outputs."""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

from ..args import UsageError, parse_params
from ..output_flags import check_outputs, handles_outputs
from ..queries import load_map, resolve_query

NO_PATH = 4  # exit code of solve / demo when no ant reached the goal (2: a user mistake)


def _world_doc(grid, result) -> dict:
    """World-frame fields for ``--json`` on a ROS map (metres, cell centres)."""
    from ...research.record_format import metres

    start, goal = (grid.cell_to_world(c) for c in (result.start, result.goal))
    return {
        "frame": "map",
        "units": "m",
        "resolution": grid.resolution,
        "origin": list(grid.origin or (0.0, 0.0, 0.0)),
        "start_xy": [metres(v) for v in start],
        "goal_xy": [metres(v) for v in goal],
        "length_m": result.length / grid.cell_size * grid.resolution if result.success else None,
        "path_xy": [[metres(x), metres(y)] for x, y in result.to_world()],
    }


def _fmt_len(x: float) -> str:
    return f"{x:.4f}" if math.isfinite(x) else "none"


def _dumps(doc, level: int = 0) -> str:
    """JSON with one key per line and every list (a path, a history) on one line."""
    if isinstance(doc, dict) and doc:
        pad = "  " * (level + 1)
        items = ",\n".join(f"{pad}{json.dumps(k)}: {_dumps(v, level + 1)}" for k, v in doc.items())
        return "{\n" + items + "\n" + "  " * level + "}"
    return json.dumps(doc, allow_nan=False)


def _report(grid, result, exact_length, seconds, scenario=None, scen_label=None) -> None:
    """The run as the shell user reads it; a failed run ends with :func:`failure_hint`."""
    from ...engine.result import failure_hint

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
    from ... import plot

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
    from ... import exact
    from ...api import solve

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
        from ...waypoints import exact_trip

        exact_length, exact_path = exact_trip(grid, [start, *via, goal])
    else:
        exact_length, exact_path = exact.shortest_path(grid, start, goal)
    _report(grid, result, exact_length, seconds, scenario, scen_label)
    return result, exact_length, exact_path


@handles_outputs("--out")
def cmd_demo(args: argparse.Namespace) -> int:
    from ... import maps

    check_outputs(args, figures=("--out",))
    grid = maps.named("demo")
    result, exact_length, exact_path = _run_and_report(grid, grid.meta["start"], grid.meta["goal"], args, {})
    out = _plot(grid, result, exact_path, exact_length, args.out)
    print(f"wrote {out}")
    return 0 if result.success else NO_PATH


@handles_outputs("--json", "--plot", "--path-csv", "--record")
def cmd_solve(args: argparse.Namespace) -> int:
    from ...outputs import is_stream

    params = parse_params(args.param)
    if args.path_csv and Path(args.path_csv).suffix.lower() != ".csv" and not is_stream(args.path_csv):
        raise UsageError(f"--path-csv writes CSV: give a file name ending in .csv, got {args.path_csv!r}")
    grid = load_map(args.map)
    start, goal, scenario, label = resolve_query(grid, args)
    check_outputs(
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
        _write_json(args, grid, result, scenario, label)
    if args.plot:
        print(f"wrote {_plot(grid, result, exact_path, exact_length, args.plot, args.plot_format)}")
    if args.path_csv:
        frame = "world" if grid.resolution is not None else "cells"
        print(f"wrote {result.save_path(args.path_csv, frame=frame, format='csv')}")
    if args.record:
        rerun = "" if is_stream(args.record) else f" (rerun it with 'jaco rerun {args.record}')"
        print(f"wrote {result.save(args.record)}{rerun}")
    return 0 if result.success else NO_PATH


def _write_json(args, grid, result, scenario, label) -> None:
    """``solve --json``: the result, its path metrics, the scenario and (ROS maps) the world frame,
    numbers in jaco's one JSON encoding (:func:`jaco.research.record_json.plain_json`)."""
    from ...outputs import write_text
    from ...research.record_json import plain_json

    doc = result.to_dict()
    doc["metrics"] = result.metrics()
    if scenario is not None:
        doc["scenario"] = {"label": label, "optimal": scenario.optimal, "bucket": scenario.bucket}
    if grid.resolution is not None:
        doc["world"] = _world_doc(grid, result)
    path = write_text(args.json, _dumps(plain_json(doc)) + "\n", "--json")
    print(f"wrote {path}")
