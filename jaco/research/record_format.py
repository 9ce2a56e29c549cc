"""The files a run writes: run records (:meth:`jaco.Result.save`) and paths
(:meth:`jaco.Result.save_path`), and the pieces of the record format that reading needs too.

A run record is one JSON file: the call (planner, seed, sizes, parameters, start, goal,
waypoints), the map embedded (text rows up to :data:`EMBED_ROWS_MAX` cells, above that a packed
bit mask) with its sha256 (:func:`map_hash`) and, when it is a named map or a bundled file, that
name, the result and its history, and the versions that decide whether a rerun can be bit-identical
(docs/records.md has the format). Loading and rerunning records, and sweep records, are in
:mod:`jaco.research.records`.

The format's pieces live in modules of their own, and every name is importable from here too:
the versions and header (:mod:`.record_versions`), the embedded map (:mod:`.record_map`), JSON
numbers and text (:mod:`.record_json`), the schema checked on load (:mod:`.record_schema`) and the
errors (:mod:`.record_errors`).

:class:`jaco.Result` delegates its ``save`` and ``save_path`` here, so this module reads a result
by its attributes and never imports the engine's run, :mod:`jaco.api` or
:mod:`jaco.research.records`.
"""

from __future__ import annotations

import hashlib
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import JacoError, ProblemError
from ..outputs import check_output, write_text
from .record_errors import RecordError, RecordWarning
from .record_json import cells_to_json, json_number, write_json
from .record_map import EMBED_ROWS_MAX, grid_from_entry, map_entry, map_hash
from .record_schema import check_record
from .record_versions import CHECKED_VERSIONS, FORMAT, FORMAT_VERSION, record_header, version_warnings, versions

__all__ = [
    "CHECKED_VERSIONS",
    "EMBED_ROWS_MAX",
    "FORMAT",
    "FORMAT_VERSION",
    "check_record",
    "grid_from_entry",
    "map_entry",
    "map_hash",
    "recordable_name",
    "RecordError",
    "RecordWarning",
    "save_path",
    "save_run",
    "version_warnings",
    "versions",
]

# -- runs -----------------------------------------------------------------------------------
_HISTORY_DTYPE = np.float32


def recordable_name(planner: Any) -> str:
    """The name a record stores for ``planner`` (a name or a Planner): one the registry resolves
    to that same planner — a registered planner, a composition of :func:`jaco.compose`, or a
    registered planner with another cost (``"acs+multi"``). Anything else cannot be rerun."""
    from ..planners.registry import get_planner

    name = planner if isinstance(planner, str) else planner.name
    try:
        same = get_planner(name) is planner or isinstance(planner, str)
    except JacoError:
        same = False
    if not same:
        raise RecordError(
            f"planner {name!r} is neither registered nor a composition (jaco.compose): a record can "
            "only be rerun with a planner the registry finds by name"
        )
    return name


def save_run(result: Any, path: Any) -> Path:
    """Write ``result`` (a :class:`jaco.Result` from :func:`jaco.solve`) as a JSON record."""
    path = check_output(path, "record")
    if result.grid is None:
        raise RecordError("this Result has no grid (it was not made by jaco.solve): cannot record its map")
    recordable_name(result.variant)
    waypoints = getattr(result, "waypoints", None)
    pher = result.pheromone
    doc = record_header("run")
    doc["call"] = {
        "variant": result.variant,
        "seed": int(result.seed),
        "n_ants": int(result.n_ants),
        "n_iters": int(result.n_iters),
        "steplimit": int(result.steplimit),
        "connectivity": int(getattr(result, "connectivity", 8)),
        # False, True (final pheromone (M,)) or "history" (one row per iteration (n_iters, M))
        "keep_pheromone": False if pher is None else "history" if np.ndim(pher) == 2 else True,
        "params": {k: float(v) for k, v in result.params.items()},
        "start": cells_to_json(result.start),
        "goal": cells_to_json(result.goal),
        "waypoints": cells_to_json(list(waypoints)) if waypoints is not None and len(waypoints) else None,
    }
    doc["map"] = map_entry(result.grid)
    doc["result"] = {
        "success": bool(result.success),
        "path": np.asarray(result.path, np.int64).tolist(),
        "length": json_number(result.length),
        "cost": json_number(result.cost),
        "optimal": json_number(result.optimal),
        "gap": json_number(result.gap),
        "best_iteration": int(result.best_iteration),
        "coverage": json_number(result.coverage),
        "history": {k: [json_number(x) for x in np.asarray(v)] for k, v in result.history.items()},
        "history_dtype": {k: str(np.asarray(v).dtype) for k, v in result.history.items()},
        "pheromone_sha256": None if pher is None else hashlib.sha256(np.ascontiguousarray(pher).tobytes()).hexdigest(),
    }
    return write_json(doc, path)


# -- paths in world coordinates (ROS) -------------------------------------------------------
def metres(v) -> float:
    """World coordinates rounded to the nanometre: 0.475, not 0.47500000000000003."""
    return round(float(v), 9)


def save_path(result: Any, path: Any, frame: str | None = None, format: str | None = None) -> Path:
    """Write ``result``'s path as CSV or JSON: ``format`` ``"csv"`` or ``"json"``, by default the
    suffix of ``path`` (``-``, a device or a FIFO has none: give ``format``).

    ``frame="world"``: columns ``row,col,x,y``, x and y in metres at the cell centres, from the
    map's ``resolution`` and ``origin`` (:meth:`jaco.Grid.cell_to_world`; row 0 is the top of the
    image, i.e. the largest y). ``frame="cells"``: ``row,col`` only. Default: world when the map
    has a resolution. The JSON holds the map name, frame, resolution, origin, length and the
    points as ``[[row, col], ...]`` (``cells``) and ``[[x, y], ...]`` (``xy``), and in the world
    frame ``length_m`` (the length in metres: cell units × resolution). Coordinates are rounded
    to 1e-9 m.
    """
    path = check_output(path, "path file", suffixes=(".csv", ".json"), format=format)
    grid = result.grid
    if grid is None:
        raise RecordError("this Result has no grid: cannot write its path")
    if frame is None:
        frame = "world" if grid.resolution is not None else "cells"
    if frame not in ("world", "cells"):
        raise JacoError(f"frame must be 'world' or 'cells', got {frame!r}")
    if frame == "world" and grid.resolution is None:
        raise ProblemError(
            f"map {grid.name!r} has no resolution/origin: world coordinates need a ROS map (use frame='cells')"
        )
    suffix = "." + format.lower() if format is not None else path.suffix.lower()
    cells = np.asarray(result.path, np.int64).reshape(-1, 2)
    xy = grid.cell_to_world(cells) if frame == "world" else None
    if suffix == ".csv":
        lines = ["row,col,x,y" if xy is not None else "row,col"]
        for i, (r, c) in enumerate(cells):
            row = f"{int(r)},{int(c)}"
            if xy is not None:
                row += f",{metres(xy[i, 0])!r},{metres(xy[i, 1])!r}"
            lines.append(row)
        return write_text(path, "\n".join(lines) + "\n", "path file")
    doc = {
        "map": grid.name,
        "frame": frame,
        "units": "m" if frame == "world" else "cells",
        "resolution": None if grid.resolution is None else float(grid.resolution),
        "origin": None if grid.origin is None else [float(v) for v in grid.origin],
        "success": bool(result.success),
        "length": json_number(result.length),
        "cells": cells.tolist(),
    }
    if xy is not None:
        doc["length_m"] = json_number(result.length / grid.cell_size * grid.resolution)
        doc["xy"] = [[metres(x), metres(y)] for x, y in xy]
    return write_json(doc, path, "path file")
