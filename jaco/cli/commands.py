"""The commands: ``demo``, ``solve``, ``sweep``, ``rerun``, ``variants``, ``maps``, ``info`` (``cmd_*``), and
how a run is reported. Heavy modules are imported inside the functions."""

from __future__ import annotations

import json
import math
import sys
import time
from pathlib import Path

from .args import UsageError, _one_line, parse_params, parse_sweep_params
from .queries import load_map, resolve_query


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


def _report(grid, result, exact_length, seconds, scenario=None, scen_label=None) -> None:
    w = 9
    print(f"{'map':<{w}} {grid.name} ({grid.height}x{grid.width}, {grid.n_free} free cells)")
    print(f"{'query':<{w}} start {tuple(result.start)} -> goal {tuple(result.goal)}")
    shown = ", ".join(f"{k}={v:g}" for k, v in result.params.items())
    print(
        f"{'variant':<{w}} {result.variant} ({result.n_ants} ants x {result.n_iters} iterations, "
        f"seed {result.seed}; {shown})"
    )
    if result.success:
        gap = "n/a" if not math.isfinite(result.gap) else f"{100 * result.gap:+.2f}%"
        print(f"{'length':<{w}} {_fmt_len(result.length)} (exact optimum {_fmt_len(exact_length)}, gap {gap})")
    else:
        print(f"{'length':<{w}} none: no ant reached the goal (exact optimum {_fmt_len(exact_length)})")
    if scenario is not None:
        print(f"{'scenario':<{w}} {scen_label}: optimal length {scenario.optimal:.4f} (from the .scen file)")
    print(f"{'cells':<{w}} {len(result.path)}")
    best_at = result.best_iteration if result.success else "-"
    print(f"{'best at':<{w}} iteration {best_at} of {result.n_iters}")
    print(f"{'success':<{w}} {'yes' if result.success else 'no'}")
    print(f"{'time':<{w}} {seconds:.2f} s (including JIT compilation)")


def _plot(grid, result, exact_path, exact_length, out) -> Path:
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
    return plot.save(fig, out)


def _run_and_report(grid, start, goal, args, params, *, scenario=None, scen_label=None):
    from .. import exact
    from ..api import solve

    via = getattr(args, "waypoint", None)  # solve --waypoint R,C (several targets, jaco.waypoints)
    t0 = time.perf_counter()
    result = solve(
        grid, start, goal, args.variant,
        seed=args.seed, n_ants=args.ants, n_iters=args.iters,
        steplimit=getattr(args, "steplimit", None), waypoints=via, **params,
    )
    seconds = time.perf_counter() - t0
    if via:
        from ..waypoints import exact_trip

        exact_length, exact_path = exact_trip(grid, [start, *via, goal])
    else:
        exact_length, exact_path = exact.shortest_path(grid, start, goal)
    _report(grid, result, exact_length, seconds, scenario, scen_label)
    return result, exact_length, exact_path


# -- commands -------------------------------------------------------------------------------------
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
            named[flag] = check_figure_path(value, flag, inputs=inputs)
    if args.command == "sweep" and "--record" in named:  # the sweep record's JSON sidecar
        named["--record sidecar"] = check_output(named["--record"].with_suffix(".json"), "--record sidecar", inputs=inputs)
    check_distinct(named)


def cmd_demo(args) -> int:
    from .. import maps

    _check_outputs(args, figures=("--out",))
    grid = maps.named("demo")
    result, exact_length, exact_path = _run_and_report(grid, grid.meta["start"], grid.meta["goal"], args, {})
    out = _plot(grid, result, exact_path, exact_length, args.out)
    print(f"wrote {out}")
    return 0


def cmd_solve(args) -> int:
    params = parse_params(args.param)
    if args.path_csv and Path(args.path_csv).suffix.lower() != ".csv":
        raise UsageError(f"--path-csv writes CSV: give a file name ending in .csv, got {args.path_csv!r}")
    grid = load_map(args.map)
    start, goal, scenario, label = resolve_query(grid, args)
    _check_outputs(args, grid, figures=("--plot",), files=(("--json", None), ("--path-csv", (".csv",)), ("--record", None)))
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

        path = write_text(args.json, json.dumps(_json_safe(doc), indent=2, allow_nan=False) + "\n")
        print(f"wrote {path}")
    if args.plot:
        print(f"wrote {_plot(grid, result, exact_path, exact_length, args.plot)}")
    if args.path_csv:
        print(f"wrote {result.save_path(args.path_csv, frame='world' if grid.resolution is not None else 'cells')}")
    if args.record:
        print(f"wrote {result.save(args.record)} (rerun it with 'jaco rerun {args.record}')")
    return 0


def cmd_sweep(args) -> int:
    axes = parse_sweep_params(args.param)
    if args.record and Path(args.record).suffix.lower() != ".csv":
        raise UsageError(f"--record writes the table as CSV plus a .json sidecar: give a name ending in .csv, got {args.record!r}")
    grid = load_map(args.map)
    start, goal, scenario, label = resolve_query(grid, args)
    _check_outputs(args, grid, files=(("--csv", None), ("--record", (".csv",))))
    import pandas as pd

    from ..planners.registry import get_variant
    from ..research.sweeps import summarize, sweep

    variant = get_variant(args.variant)
    n_configs = math.prod(len(v) for v in axes.values()) if axes else 1
    print(
        f"sweep {variant.name} on {grid.name} ({grid.height}x{grid.width}), start {tuple(start)} -> "
        f"goal {tuple(goal)}: {n_configs} configurations x {args.seeds} seeds, "
        f"{args.ants} ants x {args.iters} iterations",
        flush=True,
    )
    t0 = time.perf_counter()
    table = sweep(
        grid, start, goal, variant, axes, args.seeds,
        n_ants=args.ants, n_iters=args.iters, steplimit=args.steplimit, progress=True,
    )
    seconds = time.perf_counter() - t0
    print(f"{len(table)} runs in {seconds:.2f} s (including JIT compilation)")
    if scenario is not None:
        print(f"scenario {label}: optimal length {scenario.optimal:.4f} (from the .scen file)")
    if args.csv:
        from ..outputs import write_text

        path = write_text(args.csv, table.to_csv(index=False, lineterminator="\n"))
        print(f"wrote {path}")
    if args.record:
        from ..research.records import save_sweep

        sidecar = save_sweep(
            table, args.record, grid, start, goal, variant, axes, args.seeds,
            n_ants=args.ants, n_iters=args.iters, steplimit=args.steplimit,
        )
        print(f"wrote {args.record} and {sidecar} (rerun them with 'jaco rerun {sidecar}')")
    summary = summarize(table).sort_values(["gap_mean", "length_mean"], kind="stable").reset_index(drop=True)
    swept = [k for k in axes] or list(variant.params)
    cols = swept + ["length_mean", "length_std", "length_min", "success_rate", "gap_mean", "runs"]
    shown = summary[cols].head(10).rename(columns={"gap_mean": "gap_mean_%"})
    shown["gap_mean_%"] = 100 * shown["gap_mean_%"]
    with pd.option_context("display.width", 200, "display.max_columns", 50):
        print(f"\ntop {len(shown)} of {len(summary)} configurations (by mean gap, then mean length):")
        print(shown.to_string(index=False, float_format=lambda x: f"{x:.4g}"))
    best = summary.iloc[0]
    conf = ", ".join(f"{k}={best[k]:g}" for k in variant.params)
    gap = f"{100 * best['gap_mean']:.2f}%" if math.isfinite(best["gap_mean"]) else "inf (some runs failed)"
    print(
        f"\nbest: {variant.name} {conf}\n      mean length {best['length_mean']:.4f} "
        f"(optimum {table['optimal'].iloc[0]:.4f}), mean gap {gap}, "
        f"success {100 * best['success_rate']:.0f}% over {int(best['runs'])} seeds"
    )
    return 0


def cmd_rerun(args) -> int:
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
    t0 = time.perf_counter()
    rerun = rec.rerun(warn=False)
    seconds = time.perf_counter() - t0
    if rerun.matched:
        print(f"rerun    matched the record bit for bit ({rerun.what}; {seconds:.2f} s)")
        return 0
    print(f"rerun    did NOT match the record ({len(rerun.differences)} difference(s)):")
    for d in rerun.differences:
        print(f"  {d}")
    return 1


def cmd_variants(args) -> int:
    from ..planners.registry import VARIANTS

    for v in VARIANTS.values():
        print(v.describe())
        if args.verbose:
            import textwrap

            print(textwrap.indent(textwrap.fill(v.doc, 96), "    "))
            print()
    return 0


def cmd_maps(args) -> int:
    from .. import maps

    print("named maps (start/goal built in):")
    for name in maps.NAMED:
        g = maps.named(name)
        print(f"  {name:14s} {g.height:>3d}x{g.width:<3d}  start {g.meta['start']} -> goal {g.meta['goal']}")
    print(f"\nbundled files ({maps.DATA_DIR}):")
    for name in maps.BUNDLED:
        print(f"  {name}")
    print(
        "\nA MAP argument is a file path, a named map, or a bundled file name, e.g.\n"
        "  jaco solve random-32-32-10.map --scen random-32-32-10-even-10.scen --index 5"
    )
    return 0


def cmd_info(args) -> int:
    import platform

    import jax
    import jaxlib
    import numpy as np

    from .. import __version__
    from ..engine import native

    print(f"jaco {__version__}")
    print(f"jax {jax.__version__}, jaxlib {jaxlib.__version__}, numpy {np.__version__}, "
          f"python {platform.python_version()} ({platform.machine()})")
    devices = jax.devices()
    print(f"devices: {len(devices)} x {devices[0].platform} ({', '.join(str(d) for d in devices)})")
    walk = native.active_walk()
    if walk == "native":
        print("walk: native (the C++ kernel through jax.ffi on CPU; the JAX walk elsewhere)")
    elif native.available():
        print("walk: jax (chosen with --walk, jaco.set_walk or JACO_WALK; the native walk is built)")
    else:
        print(f"walk: jax ({native.unavailable_reason()}; the JAX walk gives the same results, slower on CPU)")
    return 0
