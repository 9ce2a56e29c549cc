"""The argument parser of ``jaco``: one sub-command per :mod:`jaco.cli.commands` function."""

from __future__ import annotations

import argparse
import sys

from .args import _cell, _nonneg_int, _Parser, _pos_int, _seed, _xy
from .commands import cmd_demo, cmd_info, cmd_maps, cmd_rerun, cmd_solve, cmd_sweep, cmd_variants

DEMO_VARIANT = "mmas"  # on the demo map MMAS comes closer to the optimum than ACS (see --help)
DEFAULT_ANTS = 50
DEFAULT_ITERS = 100


def _variant_names() -> str:
    from ..planners.registry import VARIANTS

    return ", ".join(VARIANTS)


def _add_run_options(p, *, default_variant: str, steplimit: bool = True, several: bool = False) -> None:
    if several:  # a sweep may run several planners, a categorical axis of the table
        p.add_argument("--variant", action="append", metavar="V",
                       help=f"ACO variant, repeatable to sweep over planners (default {default_variant}; "
                       f"one of: {_variant_names()}, or a composition 'compose(construct=..., rule=...)'; "
                       "'<name>+shortcut' adds local search)")
        p.set_defaults(default_variant=default_variant)
    else:
        p.add_argument("--variant", default=default_variant, metavar="V",
                       help=f"ACO variant (default {default_variant}; one of: {_variant_names()}; "
                       "'<name>+shortcut' adds local search)")
    p.add_argument("--ants", type=_pos_int, default=DEFAULT_ANTS, metavar="N",
                   help=f"ants per iteration (default {DEFAULT_ANTS})")
    p.add_argument("--iters", type=_pos_int, default=DEFAULT_ITERS, metavar="N",
                   help=f"iterations (default {DEFAULT_ITERS})")
    if steplimit:
        p.add_argument("--steplimit", type=_pos_int, default=None, metavar="N",
                       help="most steps an ant may take (default 4*(H+W), at most the free cells; "
                       "for backtracking ants 8*max(H+W, the free cells' extent), at most twice the free cells)")


def _add_query_options(p) -> None:
    q = p.add_argument_group("start and goal (default: the named map's own)")
    q.add_argument("--start", type=_cell, metavar="R,C", help="start cell as ROW,COL")
    q.add_argument("--goal", type=_cell, metavar="R,C", help="goal cell as ROW,COL")
    q.add_argument("--start-xy", type=_xy, metavar="X,Y",
                   help="start as a world point in metres (ROS maps: from the yaml's resolution and "
                   "origin), e.g. --start-xy -9.5,-9.5")
    q.add_argument("--goal-xy", type=_xy, metavar="X,Y", help="goal as a world point in metres (ROS maps)")
    q.add_argument("--scen", metavar="FILE",
                   help="MovingAI .scen file (a path or a bundled file name): take start/goal from it")
    q.add_argument("--index", type=_nonneg_int, metavar="K", help="row of --scen to use (default 0)")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="jaco",
        description="Ant colony optimisation path planners on occupancy grids (JAX).",
        epilog="Run 'jaco COMMAND --help' for the options of a command.",
    )
    from .. import __version__

    parser.add_argument("--version", action="version", version=f"jaco {__version__}")
    parser.add_argument("--walk", choices=("auto", "native", "jax"), default=None,
                        help="the ant walk: auto (default: native when built), native (C++ kernel) or jax; "
                        "the same results either way (also JACO_WALK)")
    parser.add_argument("--debug", action="store_true",
                        help="on an internal error (exit code 3), print the traceback instead of one line")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)

    p = sub.add_parser(
        "demo", help="plan on the embedded demo map and plot the result",
        description="Run one colony on the embedded 20x30 demo map, compare with the exact optimum "
        f"and write a PNG of both paths. The default variant is {DEMO_VARIANT}: over 32 seeds it "
        "reached a 5.1% mean gap on this map, ACS 5.9%.",
    )
    _add_run_options(p, default_variant=DEMO_VARIANT, steplimit=False)
    p.add_argument("--seed", type=_seed, default=0, metavar="S", help="random seed (default 0)")
    p.add_argument("--out", default="demo.png", metavar="PNG", help="figure to write (default demo.png)")
    p.set_defaults(func=cmd_demo)

    p = sub.add_parser(
        "solve", help="plan one path on a map",
        description="Plan one path with one ACO variant and report it beside the exact optimum. "
        "When no ant reaches the goal it prints a hint of what usually helps and exits with 4.",
    )
    p.add_argument("map", metavar="MAP",
                   help="map file (.map .yaml .txt .npy .png .pgm ...), named map or bundled file; see 'jaco maps'")
    _add_query_options(p)
    p.add_argument("--waypoint", action="append", type=_cell, metavar="R,C",
                   help="visit this cell on the way to the goal (repeatable, visited in the order given)")
    _add_run_options(p, default_variant="mmas")
    p.add_argument("--seed", type=_seed, default=0, metavar="S", help="random seed (default 0)")
    p.add_argument("--param", action="append", metavar="NAME=VALUE",
                   help="set a hyperparameter (repeatable), e.g. --param alpha=1.5 --param rho=0.2")
    p.add_argument("--json", metavar="OUT", help="write the result and its path metrics as JSON")
    p.add_argument("--plot", metavar="FILE", help="write a figure of the map, the ACO path and the exact path "
                   "in the format its suffix names (.png, .svg, .pdf ...)")
    p.add_argument("--path-csv", metavar="OUT",
                   help="write the path as CSV: row,col and, on a ROS map, x,y in metres (cell centres)")
    p.add_argument("--record", metavar="OUT",
                   help="write a JSON run record (map embedded, versions) that 'jaco rerun OUT' reproduces")
    p.set_defaults(func=cmd_solve)

    p = sub.add_parser(
        "sweep", help="hyperparameter sweep: configurations x seeds in one compiled call",
        description="Run every combination of the --param values x seeds, write the table as CSV "
        "and print the best configurations.",
        epilog="Values: a:b:n is n values from a to b inclusive (linspace), a,b,c a list, "
        "a single number a fixed value. Example: jaco sweep demo --param alpha=0.5:3:6 "
        "--param rho=0.1,0.3 --seeds 8 --csv sweep.csv; several planners: --variant mmas --variant acs "
        "(every --param must belong to every planner).",
    )
    p.add_argument("map", metavar="MAP", help="map file, named map or bundled file; see 'jaco maps'")
    _add_query_options(p)
    _add_run_options(p, default_variant="mmas", several=True)
    p.add_argument("--param", action="append", metavar="NAME=VALUES",
                   help="a sweep axis (repeatable): NAME=a:b:n, NAME=a,b,c or NAME=x")
    p.add_argument("--seeds", type=_pos_int, default=4, metavar="N",
                   help="seeds 0..N-1 per configuration (default 4)")
    p.add_argument("--csv", metavar="OUT", help="write the tidy table (one row per run) as CSV")
    p.add_argument("--record", metavar="OUT.csv",
                   help="write the table as CSV plus a JSON sidecar (OUT.json: arguments, maps, "
                   "versions) that 'jaco rerun' reproduces")
    p.set_defaults(func=cmd_sweep)

    p = sub.add_parser(
        "rerun", help="rerun a run or sweep record and check it bit for bit",
        description="Rerun a record written by 'jaco solve --record', 'jaco sweep --record', "
        "Result.save or jaco.records.save_sweep, and compare path, length and history (or the "
        "whole sweep table) bit for bit. Exit 0 when it matched, 1 when it did not; a record "
        "written by other jaco/jax versions or on another backend gets a warning line first.",
    )
    p.add_argument("record", metavar="RECORD", help="run record .json, or a sweep's .csv or .json sidecar")
    p.set_defaults(func=cmd_rerun)

    p = sub.add_parser("variants", help="list the registered ACO variants",
                       description="One line per variant: name, source (paper and equation numbers), default "
                                   "parameters. The equations and full references are in docs/algorithms.md.")
    p.add_argument("-v", "--verbose", action="store_true", help="also print each variant's description")
    p.set_defaults(func=cmd_variants)

    p = sub.add_parser("maps", help="list the named maps and bundled map files",
                       description="List the named maps and bundled map files.")
    p.set_defaults(func=cmd_maps)

    p = sub.add_parser("info", help="versions, devices and the active ant walk",
                       description="Print the jaco, jax and jaxlib versions, the XLA devices and which ant "
                       "walk runs: the native C++ kernel or the JAX walk (and why).")
    p.set_defaults(func=cmd_info)
    return parser


def _join_negative_xy(argv):
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
