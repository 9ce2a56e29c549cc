"""The argument parser of ``jaco``: one function per sub-command (``_add_solve`` ...); the options
that several commands share are :mod:`jaco.cli.options`, one helper each."""

from __future__ import annotations

import argparse
import sys

from .args import (
    RaisingParser,
    int_at_least,
    parse_cell,
    parse_nonnegative_int,
    parse_positive_int,
    parse_seconds,
)
from .commands import cmd_compare, cmd_demo, cmd_info, cmd_maps, cmd_planners, cmd_solve, cmd_sweep
from .options import (
    add_map_argument,
    add_param_option,
    add_plot_options,
    add_query_options,
    add_run_options,
    add_seed_option,
    add_seeds_option,
)
from .search import cmd_rerun, cmd_search

DEMO_PLANNER = "mmas"  # on the demo map MMAS comes closer to the optimum than ACS (see --help)


def build_parser() -> argparse.ArgumentParser:
    parser = _global_parser()
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for add in (
        _add_demo,
        _add_solve,
        _add_sweep,
        _add_search,
        _add_compare,
        _add_rerun,
        _add_planners,
        _add_maps,
        _add_info,
    ):
        add(sub)
    return parser


def _global_parser() -> argparse.ArgumentParser:
    """The parser with the options that come before the command."""
    from .. import __version__

    parser = RaisingParser(
        prog="jaco",
        description="Ant colony optimisation path planners on occupancy grids (JAX).",
        epilog="Run 'jaco COMMAND --help' for the options of a command.",
    )
    parser.add_argument("--version", action="version", version=f"jaco {__version__}")
    parser.add_argument(
        "--walk",
        choices=("auto", "native", "jax"),
        default=None,
        help="the ant walk: auto (default: native when built), native (C++ kernel) or jax; "
        "the same results either way (also JACO_WALK)",
    )
    parser.add_argument(
        "--debug",
        action="store_true",
        help="on an internal error (exit code 3), print the traceback instead of one line",
    )
    return parser


def _add_demo(sub) -> None:
    p = sub.add_parser(
        "demo",
        help="plan on the embedded demo map and plot the result",
        description="Run one colony on the embedded 20x30 demo map, compare with the exact optimum "
        f"and write a PNG of both paths. The default planner is {DEMO_PLANNER}: over 32 seeds it "
        "reached a 5.1% mean gap on this map, ACS 5.9%.",
    )
    add_run_options(p, default_planner=DEMO_PLANNER, steplimit=False)
    add_seed_option(p)
    p.add_argument("--out", default="demo.png", metavar="PNG", help="figure to write (default demo.png)")
    p.set_defaults(func=cmd_demo)


def _add_solve(sub) -> None:
    p = sub.add_parser(
        "solve",
        help="plan one path on a map",
        description="Plan one path with one ACO planner and report it beside the exact optimum. "
        "When no ant reaches the goal it prints a hint of what usually helps and exits with 4.",
    )
    add_map_argument(
        p, "map file (.map .yaml .txt .npy .png .pgm ...), named map or a bundled file's bare name; see 'jaco maps'"
    )
    add_query_options(p)
    p.add_argument(
        "--waypoint",
        action="append",
        type=parse_cell,
        metavar="R,C",
        help="visit this cell on the way to the goal (repeatable, visited in the order given)",
    )
    add_run_options(p, default_planner="mmas")
    add_seed_option(p)
    add_param_option(p, "NAME=VALUE", "set a hyperparameter (repeatable), e.g. --param alpha=1.5 --param rho=0.2")
    p.add_argument(
        "--json",
        metavar="OUT",
        help="write the result and its path metrics as JSON ('-': standard output, the summary then goes to stderr)",
    )
    add_plot_options(
        p,
        "write a figure of the map, the ACO path and the exact path in the format its suffix names (.png, .svg, .pdf ...)",
        "the figure format (png, svg, pdf ...) when --plot's name has none: '-' (standard output), a device or a FIFO",
    )
    p.add_argument(
        "--path-csv",
        metavar="OUT",
        help="write the path as CSV: row,col and, on a ROS map, x,y in metres (cell centres)",
    )
    p.add_argument(
        "--record",
        metavar="OUT",
        help="write a JSON run record (map embedded, versions) that 'jaco rerun OUT' reproduces",
    )
    p.set_defaults(func=cmd_solve)


def _add_sweep(sub) -> None:
    p = sub.add_parser(
        "sweep",
        help="hyperparameter sweep: configurations x seeds in one compiled call",
        description="Run every combination of the --param values x seeds, write the table as CSV "
        "and print the best configurations.",
        epilog="Values: a:b:n is n values from a to b inclusive (linspace), a,b,c a list, "
        "a single number a fixed value. Example: jaco sweep demo --param alpha=0.5:3:6 "
        "--param rho=0.1,0.3 --seeds 8 --csv sweep.csv; several planners: --planner mmas --planner acs "
        "(every --param must belong to every planner).",
    )
    add_map_argument(p)
    add_query_options(p)
    add_run_options(p, default_planner="mmas", several=True)
    add_param_option(p, "NAME=VALUES", "a sweep axis (repeatable): NAME=a:b:n, NAME=a,b,c or NAME=x")
    add_seeds_option(p, "N", "configuration")
    p.add_argument(
        "--csv",
        metavar="OUT",
        help="write the tidy table (one row per run) as CSV ('-': standard output, the summary then goes to stderr)",
    )
    _add_sweep_store_options(p)
    p.add_argument(
        "--record",
        metavar="OUT.csv",
        help="write the table as CSV plus a JSON sidecar (OUT.json: arguments, maps, "
        "versions) that 'jaco rerun' reproduces",
    )
    p.set_defaults(func=cmd_sweep)


def _add_sweep_store_options(p) -> None:
    """Where a sweep keeps its finished chunks, and how it cuts them."""
    p.add_argument(
        "--store",
        metavar="FILE.db",
        help="append every finished chunk to this SQLite store: the same command again skips the "
        "finished runs (a killed sweep resumes), and the table equals an uninterrupted sweep; the same "
        "command in several processes or hosts (a shared filesystem) shares the chunks out",
    )
    p.add_argument(
        "--grace-period",
        type=parse_seconds,
        default=None,
        metavar="S",
        help="with --store: a process's claim on a chunk expires after S seconds without its heartbeat, "
        "and another process takes the chunk over (default 60)",
    )
    p.add_argument(
        "--chunk",
        type=parse_positive_int,
        default=None,
        metavar="N",
        help="at most N runs (configurations x seeds) per compiled call (default: as many as fit; "
        "with --store about a tenth of the sweep)",
    )


def _add_search(sub) -> None:
    p = sub.add_parser(
        "search",
        help="adaptive batched search over planners and parameters (Optuna / evosax samplers)",
        description="Search planners (--planner, repeatable) and parameters (--param) for the smallest mean gap to "
        "the exact optimum: a sampler proposes a batch of trials, the batch runs as one compiled call, the "
        "results go back to the sampler. With --storage every trial is stored as its batch finishes and the "
        "same command again resumes (or extends, with more --trials) the study. Needs pip install 'jaco[search]'.",
        epilog="Values: LOW:HIGH a real range, LOW:HIGH:log log-uniform, LOW:HIGH:int integers, a,b,c a list, x a "
        "fixed value. Example: jaco search Berlin_1_256.map --scen Berlin_1_256.map.scen --index 900 --planner iaca "
        "--planner acs --param beta=1:20:log --param rho=0.01:0.5 --trials 256 --batch 64 --seeds 4 --sampler tpe "
        "--storage sqlite:///study.db",
    )
    add_map_argument(p)
    add_query_options(p)
    add_run_options(p, default_planner="mmas", several=True)
    add_param_option(
        p,
        "NAME=RANGE",
        "a search dimension (repeatable): NAME=LOW:HIGH[:log][:int], NAME=a,b,c or NAME=x; "
        "n_ants and n_iters may be searched too",
    )
    _add_search_budget_options(p)
    _add_search_fidelity_options(p)
    _add_search_storage_options(p)
    _add_search_output_options(p)
    p.set_defaults(func=cmd_search)


def _add_search_budget_options(p) -> None:
    """How many trials, how long, in batches of how many, and how each is sampled and scored."""
    p.add_argument(
        "--trials",
        type=parse_positive_int,
        metavar="N",
        help="finished trials to reach (default 128; with --timeout and no --trials: until the timeout)",
    )
    p.add_argument(
        "--timeout",
        type=parse_seconds,
        metavar="SECONDS",
        help="wall-time budget of this command: no new batch starts after it, the running one finishes and is "
        "stored (the first batch always runs); with --trials, whichever comes first",
    )
    p.add_argument(
        "--batch",
        type=parse_positive_int,
        default=32,
        metavar="B",
        help="trials per generation, evaluated as one compiled call (default 32)",
    )
    add_seeds_option(p, "S", "trial")
    p.add_argument(
        "--sampler",
        default="tpe",
        metavar="NAME",
        help="tpe (default), cmaes, random, qmc, grid, gp, nsga2, or evosax:NAME (e.g. evosax:SNES)",
    )
    add_seed_option(p, "the sampler's seed (default 0)")
    p.add_argument(
        "--objective",
        action="append",
        choices=("gap", "length", "turns", "success", "budget"),
        help="what to optimise (default gap; repeat for a Pareto front, e.g. --objective gap --objective turns)",
    )


def _add_search_fidelity_options(p) -> None:
    fid = p.add_argument_group("multi-fidelity over the iterations (--iters is the largest budget)")
    fid.add_argument(
        "--halving",
        action="store_true",
        help="successive halving: many trials at few iterations, the best 1/eta promoted to eta times more",
    )
    fid.add_argument(
        "--hyperband",
        action="store_true",
        help="Hyperband: brackets of successive halving that start at each budget in turn",
    )
    fid.add_argument(
        "--eta", type=int_at_least(2, "an integer >= 2"), default=3, metavar="ETA", help="promotion ratio (default 3)"
    )
    fid.add_argument(
        "--min-iters",
        type=parse_positive_int,
        default=None,
        metavar="N",
        help="smallest budget (default --iters / eta^2)",
    )


def _add_search_storage_options(p) -> None:
    """Where the study lives, and the workers that share it."""
    p.add_argument(
        "--storage",
        metavar="URL",
        help="sqlite:///study.db (or a .db path), journal:FILE (or a .journal path), or a database URL "
        "(postgresql+psycopg://user@host/db): the study lives there, the same command again resumes it, and "
        "several workers (--workers, or commands on other hosts) share it",
    )
    p.add_argument("--study", metavar="NAME", help="study name in the storage (default 'jaco')")
    work = p.add_argument_group("several workers on one study (needs --storage)")
    work.add_argument(
        "--workers",
        type=parse_positive_int,
        default=1,
        metavar="N",
        help="start N local worker processes on the study, each on its share of the cores; one progress "
        "display; Ctrl-C or SIGTERM stops them all (default 1: this process searches)",
    )
    work.add_argument(
        "--worker",
        type=parse_nonnegative_int,
        default=0,
        metavar="I",
        help="this process's worker index when several run the study (one per host or job-array task): its "
        "sampler is seeded --seed + I (default 0)",
    )
    work.add_argument(
        "--heartbeat-interval",
        type=parse_seconds,
        default=30.0,
        metavar="SECONDS",
        help="a worker's heartbeat into the storage (default 30)",
    )
    work.add_argument(
        "--grace-period",
        type=parse_seconds,
        default=None,
        metavar="SECONDS",
        help="a RUNNING trial whose worker's heartbeat is older is taken over by another worker "
        "(default 3 heartbeat intervals)",
    )


def _add_search_output_options(p) -> None:
    p.add_argument(
        "--top", type=parse_positive_int, default=10, metavar="N", help="trials in the summary table (default 10)"
    )
    p.add_argument("--csv", metavar="OUT", help="write the trials table (one row per trial) as CSV")
    add_plot_options(
        p,
        "write the optimisation history (best so far against trials, on a log axis: a failed run's "
        "penalty is far above the gaps of the successful trials, which a linear axis would flatten; "
        "with two objectives the Pareto front) in the format its suffix names",
        "the --plot format (png, svg, pdf ...) when FILE has no suffix: '-', a device or a pipe",
    )
    p.add_argument(
        "--linear",
        action="store_true",
        help="draw the --plot history on a linear axis instead of the default log axis "
        "(symlog, linear near 0, when a value is 0)",
    )


def _add_compare(sub) -> None:
    p = sub.add_parser(
        "compare",
        help="paired statistics on a saved results table: which planner is better, and how sure",
        description="Compare the planners (or configurations) of a table written by 'jaco sweep --csv' "
        "(any layout jaco wrote): per configuration the success rate, the median and quartiles of the "
        "value with a bootstrap interval of the median; for every two configurations the paired "
        "two-sided Wilcoxon signed-rank test over the (query, seed) pairs with Holm's correction; "
        "the Friedman test with the mean ranks and Nemenyi's critical difference (Demsar 2006); and "
        "what the data support, in words. A failed run counts as +inf: worse than any path, and two "
        "failures tie (docs/compare.md).",
        epilog="Example: jaco sweep Berlin_1_256.map --scen Berlin_1_256.map.scen --bucket 85: --count 6 "
        "--planner iaca --planner mmas --param beta=8,16 --seeds 3 --csv b.csv; "
        "jaco compare b.csv --by planner --by beta --cd cd.png --profile profile.png",
    )
    p.add_argument("table", metavar="TABLE.csv", help="a results table (jaco sweep --csv or --record)")
    p.add_argument(
        "--by",
        action="append",
        metavar="COL",
        help="the column naming a configuration (repeatable: --by planner --by beta; default planner; "
        "'variant', its former name, is read as planner)",
    )
    p.add_argument(
        "--value",
        default="gap",
        metavar="COL",
        help="the column compared, lower is better (default gap, a fraction shown in %%)",
    )
    p.add_argument(
        "--where",
        action="append",
        metavar="NAME=VALUE",
        help="keep only the rows where a column has this value (repeatable), e.g. --where beta=16",
    )
    _add_compare_statistics_options(p)
    p.add_argument("--cd", metavar="FILE", help="write the critical-difference diagram (.png, .svg, .pdf ...)")
    p.add_argument("--profile", metavar="FILE", help="write the performance profile (Dolan & More 2002)")
    p.set_defaults(func=cmd_compare)


def _add_compare_statistics_options(p) -> None:
    """The blocks, levels and bootstrap of the comparison."""
    p.add_argument(
        "--blocks",
        choices=("run", "query"),
        default="run",
        help="blocks of the Friedman test: each (query, seed) pair (run, default) or each query, "
        "the median over its seeds (query)",
    )
    p.add_argument("--alpha", type=float, default=0.05, metavar="A", help="level of the tests (default 0.05)")
    p.add_argument(
        "--confidence",
        type=float,
        default=0.95,
        metavar="C",
        help="confidence of the bootstrap interval of the median (default 0.95)",
    )
    p.add_argument(
        "--boot", type=parse_positive_int, default=2000, metavar="N", help="bootstrap resamples (default 2000)"
    )
    add_seed_option(p, "seed of the bootstrap (default 0)")


def _add_rerun(sub) -> None:
    p = sub.add_parser(
        "rerun",
        help="rerun a run or sweep record and check it bit for bit",
        description="Rerun a record written by 'jaco solve --record', 'jaco sweep --record', "
        "Result.save or jaco.research.records.save_sweep, and compare path, length and history (or the "
        "whole sweep table) bit for bit. Exit 0 when it matched, 1 when it did not; a record "
        "written by other jaco/jax versions or on another backend gets a warning line first.",
    )
    p.add_argument(
        "record",
        metavar="RECORD",
        help="run record .json, or a sweep's .csv or .json sidecar, or a "
        "search's storage (sqlite:///study.db, a .db or .journal path) with --trial",
    )
    p.add_argument("--trial", type=parse_nonnegative_int, metavar="N", help="rerun trial N of a stored search study")
    p.add_argument("--study", metavar="NAME", help="the study's name (when the storage holds several)")
    p.set_defaults(func=cmd_rerun)


def _add_planners(sub) -> None:
    p = sub.add_parser(
        "planners",
        aliases=["variants"],
        help="list the registered ACO planners (also: jaco variants)",
        description="One line per planner: name, source (paper and equation numbers), default "
        "parameters. The equations and full references are in docs/algorithms.md.",
    )
    p.add_argument("-v", "--verbose", action="store_true", help="also print each planner's description")
    p.set_defaults(func=cmd_planners)


def _add_maps(sub) -> None:
    p = sub.add_parser(
        "maps",
        help="list the named maps and bundled map files",
        description="List the named maps and bundled map files.",
    )
    p.set_defaults(func=cmd_maps)


def _add_info(sub) -> None:
    p = sub.add_parser(
        "info",
        help="versions, devices and the active ant walk",
        description="Print the jaco, jax and jaxlib versions, the XLA devices and which ant "
        "walk runs: the native C++ kernel or the JAX walk (and why).",
    )
    p.set_defaults(func=cmd_info)


def join_negative_xy(argv):
    """``--start-xy -9,-9`` -> ``--start-xy=-9,-9``: argparse would read ``-9,-9`` as an option,
    and ROS maps often have a negative origin."""
    import re

    argv = list(sys.argv[1:] if argv is None else argv)
    out, i = [], 0
    while i < len(argv):
        if argv[i] in ("--start-xy", "--goal-xy") and i + 1 < len(argv) and re.match(r"-[\d.]", argv[i + 1]):
            out.append(f"{argv[i]}={argv[i + 1]}")
            i += 2
        else:
            out.append(argv[i])
            i += 1
    return out
