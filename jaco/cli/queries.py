"""What a command runs on: the map (a file, a named map or a bundled file) and the query (start and
goal cells, a MovingAI scenario, or world points in metres on a ROS map)."""

from __future__ import annotations

from pathlib import Path

from .args import UsageError


def load_map(spec: str):
    """A map from a file path, a name in :data:`jaco.maps.NAMED`, or a bundled file name."""
    from .. import maps

    path = Path(spec)
    if path.is_dir():
        raise UsageError(f"map {spec!r} is a directory, not a map file")
    if path.exists():
        return maps.load(path)
    if spec in maps.NAMED:
        return maps.named(spec)
    base = spec.replace("\\", "/").split("/")[-1]
    if base in maps.BUNDLED or base + ".map" in maps.BUNDLED or base + ".yaml" in maps.BUNDLED:
        return maps.load(maps.bundled(spec))
    if path.suffix.lower() in maps.SUPPORTED_SUFFIXES or "/" in spec or "\\" in spec:
        return maps.load(path)  # raises the loader's "not found" message
    raise UsageError(
        f"unknown map {spec!r}: no such file, and not a named map "
        f"({', '.join(sorted(maps.NAMED))}) or bundled file (see 'jaco maps')"
    )


def _scen_path(spec: str) -> Path:
    from .. import maps

    path = Path(spec)
    if not path.exists() and path.name in maps.BUNDLED:
        return maps.bundled(path.name)
    return path


def resolve_query(grid, args):
    """``(start, goal, scenario or None, scenario label)`` from --start/--goal, --scen/--index or
    the map's own ``meta``."""
    from .. import maps

    _world_query(grid, args)  # --start-xy / --goal-xy -> --start / --goal cells
    scen = getattr(args, "scen", None)
    if scen is None:
        if args.index is not None:
            raise UsageError("--index needs --scen FILE")
        start = args.start if args.start is not None else grid.meta.get("start")
        goal = args.goal if args.goal is not None else grid.meta.get("goal")
        missing = [w for w, v in (("--start", start), ("--goal", goal)) if v is None]
        if missing:
            raise UsageError(
                f"map {grid.name!r} has no default start/goal: give {' and '.join(missing)} "
                "ROW,COL or --scen FILE --index K"
            )
        return tuple(start), tuple(goal), None, None
    if args.start is not None or args.goal is not None:
        raise UsageError("give either --start/--goal or --scen/--index, not both")
    path = _scen_path(scen)
    rows = maps.load_scenarios(path)
    k = 0 if args.index is None else args.index
    if not rows:
        raise UsageError(f"scenario file {str(path)!r} has no scenarios")
    if not 0 <= k < len(rows):
        raise UsageError(f"--index {k} is out of range: {path.name} has {len(rows)} scenarios (0..{len(rows) - 1})")
    sc = rows[k]
    if (sc.height, sc.width) != tuple(grid.shape):
        raise UsageError(
            f"scenario {k} of {path.name} is for a {sc.height}x{sc.width} map ({sc.map}), "
            f"but map {grid.name!r} is {grid.height}x{grid.width}"
        )
    return sc.start, sc.goal, sc, f"{path.name} #{k}"


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


def world_cell(grid, xy, flag: str) -> tuple[int, int]:
    """The free cell containing world point ``xy`` (metres), or a :class:`UsageError` saying why
    not: the map has no resolution/origin, the point is off the map, or its cell is not free."""
    cell_flag = flag[: -len("-xy")]
    if grid.resolution is None:
        raise UsageError(
            f"{flag} needs a map with a resolution and origin (a ROS map .yaml); map {grid.name!r} "
            f"has none: give {cell_flag} ROW,COL instead"
        )
    cell = tuple(int(v) for v in grid.world_to_cell(xy))
    shown = f"({xy[0]:g}, {xy[1]:g}) m"
    if not grid.in_bounds(cell):
        x0, x1, y0, y1 = _map_extent(grid)
        raise UsageError(
            f"{flag} {shown} is outside map {grid.name!r}, which covers x {x0:g}..{x1:g} m and "
            f"y {y0:g}..{y1:g} m"
        )
    if not grid.free[cell]:
        occ = grid.meta.get("occupancy")
        what = "unknown (unmapped)" if occ is not None and occ[cell] == -1 else "an obstacle"
        raise UsageError(f"{flag} {shown} lies in cell {cell} of map {grid.name!r}, which is {what}")
    return cell


def _world_query(grid, args) -> None:
    """Turn ``--start-xy`` / ``--goal-xy`` into ``args.start`` / ``args.goal`` cells."""
    pairs = [("--start", "start", getattr(args, "start_xy", None)),
             ("--goal", "goal", getattr(args, "goal_xy", None))]
    if getattr(args, "scen", None) is not None and any(xy is not None for *_, xy in pairs):
        raise UsageError("give either --start-xy/--goal-xy or --scen/--index, not both")
    for flag, attr, xy in pairs:
        if xy is None:
            continue
        if getattr(args, attr, None) is not None:
            raise UsageError(f"give either {flag} ROW,COL or {flag}-xy X,Y, not both")
        setattr(args, attr, world_cell(grid, xy, f"{flag}-xy"))
