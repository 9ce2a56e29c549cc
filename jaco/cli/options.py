"""Options that several commands share (the map, start and goal, the planner and its run, seeds,
``--param``, ``--plot``): one helper each, so that every command spells them alike."""

from __future__ import annotations

from .args import (
    parse_bucket,
    parse_cell,
    parse_indices,
    parse_optimal_range,
    parse_positive_int,
    parse_seed,
    parse_world_point,
)

DEFAULT_ANTS = 50
DEFAULT_ITERS = 100
MAP_HELP = "map file, named map or a bundled file's bare name; see 'jaco maps'"


def _planner_names() -> str:
    from ..planners.registry import PLANNERS

    return ", ".join(PLANNERS)


def add_map_argument(p, help: str = MAP_HELP) -> None:
    p.add_argument("map", metavar="MAP", help=help)


def add_seed_option(p, help: str = "random seed (default 0)") -> None:
    p.add_argument("--seed", type=parse_seed, default=0, metavar="S", help=help)


def add_seeds_option(p, metavar: str, per: str) -> None:
    """``--seeds N``: the seeds 0..N-1 of each configuration or trial."""
    p.add_argument(
        "--seeds",
        type=parse_positive_int,
        default=4,
        metavar=metavar,
        help=f"seeds 0..{metavar}-1 per {per} (default 4)",
    )


def add_param_option(p, metavar: str, help: str) -> None:
    p.add_argument("--param", action="append", metavar=metavar, help=help)


def add_plot_options(p, plot_help: str, format_help: str) -> None:
    p.add_argument("--plot", metavar="FILE", help=plot_help)
    p.add_argument("--plot-format", metavar="FMT", help=format_help)


def _add_planner_option(p, default_planner: str, several: bool) -> None:
    if several:  # a sweep may run several planners, a categorical axis of the table
        p.add_argument(
            "--planner",
            "--variant",
            dest="planner",
            action="append",
            metavar="P",
            help=f"ACO planner (--variant: its former name), repeatable to sweep over planners (default {default_planner}; "
            f"one of: {_planner_names()}, or a composition 'compose(construct=..., rule=...)'; "
            "'<name>+shortcut' adds local search)",
        )
        p.set_defaults(default_planner=default_planner)
    else:
        p.add_argument(
            "--planner",
            "--variant",
            dest="planner",
            default=default_planner,
            metavar="P",
            help=f"ACO planner (--variant: its former name; default {default_planner}; one of: {_planner_names()}; "
            "'<name>+shortcut' adds local search)",
        )


def add_run_options(p, *, default_planner: str, steplimit: bool = True, several: bool = False) -> None:
    _add_planner_option(p, default_planner, several)
    p.add_argument(
        "--ants",
        type=parse_positive_int,
        default=DEFAULT_ANTS,
        metavar="N",
        help=f"ants per iteration (default {DEFAULT_ANTS})",
    )
    p.add_argument(
        "--iters",
        type=parse_positive_int,
        default=DEFAULT_ITERS,
        metavar="N",
        help=f"iterations (default {DEFAULT_ITERS})",
    )
    if steplimit:
        p.add_argument(
            "--steplimit",
            type=parse_positive_int,
            default=None,
            metavar="N",
            help="most steps an ant may take (default 4*(H+W), at most the free cells; "
            "for backtracking ants 8*max(H+W, the free cells' extent), at most twice the free cells)",
        )


def add_query_options(p) -> None:
    q = p.add_argument_group("start and goal (default: the named map's own)")
    q.add_argument("--start", type=parse_cell, metavar="R,C", help="start cell as ROW,COL")
    q.add_argument("--goal", type=parse_cell, metavar="R,C", help="goal cell as ROW,COL")
    q.add_argument(
        "--start-xy",
        type=parse_world_point,
        metavar="X,Y",
        help="start as a world point in metres (ROS maps: from the yaml's resolution and "
        "origin), e.g. --start-xy -9.5,-9.5",
    )
    q.add_argument(
        "--goal-xy", type=parse_world_point, metavar="X,Y", help="goal as a world point in metres (ROS maps)"
    )
    _add_scenario_options(q)


def _add_scenario_options(q) -> None:
    """Which scenarios of a MovingAI .scen file: by position, bucket or optimal length."""
    q.add_argument(
        "--scen",
        metavar="FILE",
        help="MovingAI .scen file (a path, or a bundled file's bare name): take start/goal from it",
    )
    q.add_argument(
        "--index",
        type=parse_indices,
        action="append",
        metavar="K",
        help="scenario of --scen by position: K, K,L,M or LO:HI (both ends included), repeatable "
        "(default 0 when no other selection is given)",
    )
    q.add_argument(
        "--bucket",
        type=parse_bucket,
        metavar="B",
        help="scenarios of --scen in bucket B, or LO:HI, LO: or :HI (both ends included), e.g. --bucket 80:",
    )
    q.add_argument(
        "--optimal",
        type=parse_optimal_range,
        metavar="LO:HI",
        help="scenarios of --scen whose optimal length is in LO:HI (LO: or :HI for an open end)",
    )
    q.add_argument(
        "--count",
        type=parse_positive_int,
        metavar="N",
        help="of the scenarios selected, N spread evenly over their optimal lengths",
    )
