"""What a command runs on: the map (a file, a named map or a bundled file) and the query (start and
goal cells, a MovingAI scenario, or world points in metres on a ROS map)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from .args import UsageError


def _bare(spec: str) -> bool:
    """Whether ``spec`` is a bare file name (no folder): only a bare name reaches a bundled file."""
    return "/" not in spec and "\\" not in spec


def _bundled_name(name: str) -> str | None:
    """The bundled file that the bare ``name`` names (``arena``: ``arena.map``), or None."""
    from .. import maps

    return next((n for n in (name, name + ".map", name + ".yaml") if n in maps.BUNDLED), None)


def _not_found(what: str, spec: str) -> UsageError:
    """A path that does not exist: an error, never the bundled copy of the same name (a typo in a
    folder must not run on other data); when a bundled file has that name, how to reach it."""
    copy = _bundled_name(Path(spec.replace("\\", "/")).name)
    hint = f"; a bundled copy exists: use its bare name {copy}" if copy else ""
    return UsageError(f"{what} {spec!r} not found{hint}")


def load_map(spec: str) -> Any:
    """A map from a file path, a name in :data:`jaco.maps.NAMED`, or a bundled file's bare name
    (``den312d.map``, ``arena``; see ``jaco maps``). A path that does not exist is an error, even
    when a bundled file has its name."""
    from .. import maps

    path = Path(spec)
    if path.is_dir():
        raise UsageError(f"map {spec!r} is a directory, not a map file")
    if path.exists():
        return maps.load(path)
    if spec in maps.NAMED:
        return maps.named(spec)
    if _bare(spec) and _bundled_name(spec) is not None:
        return maps.load(maps.bundled(spec))
    if path.suffix.lower() in maps.SUPPORTED_SUFFIXES or not _bare(spec):
        raise _not_found("map file", spec)
    raise UsageError(
        f"unknown map {spec!r}: no such file, and not a named map "
        f"({', '.join(sorted(maps.NAMED))}) or bundled file (see 'jaco maps')"
    )


def _scen_path(spec: str) -> Path:
    """A scenario file: a path that exists, or a bundled file's bare name."""
    from .. import maps

    path = Path(spec)
    if path.exists():
        return path
    if _bare(spec) and spec in maps.BUNDLED:
        return maps.bundled(spec)
    raise _not_found("scenario file", spec)


_SELECTION = ("--index", "--bucket", "--optimal", "--count")


def _selection(args) -> dict:
    return {flag: getattr(args, flag[2:], None) for flag in _SELECTION if getattr(args, flag[2:], None) is not None}


def resolve_queries(grid: Any, args: Any) -> tuple[list, list, list | None, str | None]:
    """``(starts, goals, scenarios, label)``: the queries of a command, from --start/--goal, the
    map's own ``meta``, or the scenarios of --scen chosen by --index / --bucket / --optimal /
    --count (:func:`jaco.maps.select_scenarios`); ``scenarios`` is None without --scen."""
    from .. import maps
    from ..errors import JacoError

    _world_query(grid, args)  # --start-xy / --goal-xy -> --start / --goal cells
    scen = getattr(args, "scen", None)
    chosen = _selection(args)
    if scen is None:
        if chosen:
            raise UsageError(f"{' and '.join(chosen)} need{'s' if len(chosen) == 1 else ''} --scen FILE")
        start = args.start if args.start is not None else grid.meta.get("start")
        goal = args.goal if args.goal is not None else grid.meta.get("goal")
        missing = [w for w, v in (("--start", start), ("--goal", goal)) if v is None]
        if missing:
            raise UsageError(
                f"map {grid.name!r} has no default start/goal: give {' and '.join(missing)} "
                "ROW,COL or --scen FILE --index K"
            )
        return [tuple(start)], [tuple(goal)], None, None
    if args.start is not None or args.goal is not None:
        raise UsageError("give either --start/--goal or --scen with a selection (--index ...), not both")
    path = _scen_path(scen)
    rows = maps.load_scenarios(path)
    if not rows:
        raise UsageError(f"scenario file {str(path)!r} has no scenarios")
    index: list[int] | None = None
    if args.index is not None:
        index = []
        for lo, hi in (r for group in args.index for r in group):
            top = len(rows) - 1 if hi is None else hi
            if lo >= len(rows) or top >= len(rows):
                raise UsageError(
                    f"--index {lo if lo >= len(rows) else top} is out of range: {path.name} has "
                    f"{len(rows)} scenarios (0..{len(rows) - 1})"
                )
            index.extend(range(lo, top + 1))
    elif not chosen:
        index = [0]
    try:
        picked = maps.select_scenarios(rows, index=index, bucket=args.bucket, optimal=args.optimal, count=args.count)
    except JacoError as e:
        raise UsageError(f"{path.name}: {e}") from None
    for sc in picked:
        if (sc.height, sc.width) != tuple(grid.shape):
            raise UsageError(
                f"scenario {sc.index} of {path.name} is for a {sc.height}x{sc.width} map ({sc.map}), "
                f"but map {grid.name!r} is {grid.height}x{grid.width}"
            )
    if len(picked) == 1:
        label = f"{path.name} #{picked[0].index}"
    else:
        lengths = [sc.optimal for sc in picked]
        label = (
            f"{len(picked)} scenarios of {path.name} (#{', #'.join(str(sc.index) for sc in picked[:6])}"
            f"{', ...' if len(picked) > 6 else ''}; optimal lengths {min(lengths):.4g} to {max(lengths):.4g})"
        )
    return [sc.start for sc in picked], [sc.goal for sc in picked], picked, label


def resolve_query(grid: Any, args: Any) -> tuple[Any, Any, Any, str | None]:
    """``(start, goal, scenario or None, scenario label)`` of a command that runs one query
    (:func:`resolve_queries`, which must select exactly one)."""
    starts, goals, scenarios, label = resolve_queries(grid, args)
    if len(starts) != 1:
        raise UsageError(
            f"{args.command} runs one query, but the selection gives {label}: use 'jaco sweep' to run "
            "several, or select one (--index K, --count 1)"
        )
    return starts[0], goals[0], (scenarios[0] if scenarios else None), label


# -- world coordinates (ROS maps): --start-xy / --goal-xy -----------------------------------------
def _map_extent(grid) -> tuple[float, float, float, float]:
    """``(xmin, xmax, ymin, ymax)`` in metres of the map's outer corners."""
    import numpy as np

    res, (ox, oy, yaw) = float(grid.resolution), grid.origin or (0.0, 0.0, 0.0)
    lx = np.array([0.0, grid.width, 0.0, grid.width]) * res
    ly = np.array([0.0, 0.0, grid.height, grid.height]) * res
    xs = ox + np.cos(yaw) * lx - np.sin(yaw) * ly
    ys = oy + np.sin(yaw) * lx + np.cos(yaw) * ly
    return float(xs.min()), float(xs.max()), float(ys.min()), float(ys.max())


def world_cell(grid: Any, xy: Any, flag: str) -> tuple[int, int]:
    """The free cell containing world point ``xy`` (metres), or a :class:`UsageError` saying why
    not: the map has no resolution/origin, the point is off the map, or its cell is not free."""
    cell_flag = flag[: -len("-xy")]
    if grid.resolution is None:
        raise UsageError(
            f"{flag} needs a map with a resolution and origin (a ROS map .yaml); map {grid.name!r} "
            f"has none: give {cell_flag} ROW,COL instead"
        )
    row, col = (int(v) for v in grid.world_to_cell(xy))
    cell = (row, col)
    shown = f"({xy[0]:g}, {xy[1]:g}) m"
    if not grid.in_bounds(cell):
        x0, x1, y0, y1 = _map_extent(grid)
        raise UsageError(
            f"{flag} {shown} is outside map {grid.name!r}, which covers x {x0:g}..{x1:g} m and y {y0:g}..{y1:g} m"
        )
    if not grid.free[cell]:
        occ = grid.meta.get("occupancy")
        what = "unknown (unmapped)" if occ is not None and occ[cell] == -1 else "an obstacle"
        raise UsageError(f"{flag} {shown} lies in cell {cell} of map {grid.name!r}, which is {what}")
    return cell


def _world_query(grid, args) -> None:
    """Turn ``--start-xy`` / ``--goal-xy`` into ``args.start`` / ``args.goal`` cells."""
    pairs = [("--start", "start", getattr(args, "start_xy", None)), ("--goal", "goal", getattr(args, "goal_xy", None))]
    if getattr(args, "scen", None) is not None and any(xy is not None for *_, xy in pairs):
        raise UsageError("give either --start-xy/--goal-xy or --scen/--index, not both")
    for flag, attr, xy in pairs:
        if xy is None:
            continue
        if getattr(args, attr, None) is not None:
            raise UsageError(f"give either {flag} ROW,COL or {flag}-xy X,Y, not both")
        setattr(args, attr, world_cell(grid, xy, f"{flag}-xy"))
