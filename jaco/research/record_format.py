"""The files a run writes: run records (:meth:`jaco.Result.save`) and paths
(:meth:`jaco.Result.save_path`), and the pieces of the record format that reading needs too.

A run record is one JSON file: the call (variant, seed, sizes, parameters, start, goal,
waypoints), the map embedded (text rows up to :data:`EMBED_ROWS_MAX` cells, above that a packed
bit mask) with its sha256 (:func:`map_hash`) and, when it is a named map or a bundled file, that
name, the result and its history, and the versions that decide whether a rerun can be bit-identical
(docs/records.md has the format). Loading and rerunning records, and sweep records, are in
:mod:`jaco.research.records`.

:class:`jaco.Result` delegates its ``save`` and ``save_path`` here, so this module reads a result
by its attributes and never imports the engine's run, :mod:`jaco.api` or
:mod:`jaco.research.records`.
"""

from __future__ import annotations

import base64
import hashlib
import json
import math
import platform
import zlib
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

from ..errors import JacoError, ProblemError
from ..grid import Grid
from ..outputs import check_output, write_text

__all__ = [
    "CHECKED_VERSIONS",
    "EMBED_ROWS_MAX",
    "FORMAT",
    "FORMAT_VERSION",
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

FORMAT = "jaco-record"
FORMAT_VERSION = 2
#: Why a record of an older format no longer reruns bit for bit (the file itself still loads).
FORMAT_CHANGES = {
    2: "its random numbers were drawn as one uniform table per iteration; since format 2 each "
       "uniform is Threefry of the iteration key, the ant and the step, so the rerun draws other "
       "numbers and takes other paths (rerun it with the jaco that wrote it to reproduce it)",
}
#: Maps with at most this many cells are embedded as text rows ('.' free, '@' blocked), larger
#: ones as a base64 zlib-compressed bit mask (np.packbits, row-major).
EMBED_ROWS_MAX = 65536
#: Versions whose difference is reported before a rerun (bit-for-bit equality is promised only
#: for the same jaco, jax, jaxlib and backend).
CHECKED_VERSIONS = ("jaco", "jax", "jaxlib", "backend")


class RecordError(JacoError):
    """A record file that cannot be read or used (missing, not a jaco record, inconsistent)."""


class RecordWarning(UserWarning):
    """A record written by other versions, or whose map no longer matches its hash."""


# -- versions -------------------------------------------------------------------------------
def versions() -> dict:
    """Versions that decide whether a rerun can be bit-identical (read at call time)."""
    import jax
    import pandas

    import jaco

    try:
        import jaxlib

        jaxlib_version = jaxlib.__version__
    except (ImportError, AttributeError):  # pragma: no cover - jaxlib ships with jax
        jaxlib_version = None
    return {
        "jaco": jaco.__version__,
        "jax": jax.__version__,
        "jaxlib": jaxlib_version,
        "backend": jax.default_backend(),
        "numpy": np.__version__,
        "pandas": pandas.__version__,
        "python": platform.python_version(),
    }


def version_warnings(recorded: dict, format_version: int = FORMAT_VERSION) -> list[str]:
    """One line per checked version that differs between a record and this installation, and
    one per format change since the record's format version."""
    now = versions()
    out = [
        f"record format {format_version}, this jaco writes format {FORMAT_VERSION}: {why}"
        for version, why in sorted(FORMAT_CHANGES.items())
        if format_version < version
    ]
    for k in CHECKED_VERSIONS:
        old, new = recorded.get(k), now.get(k)
        if old != new:
            out.append(
                f"record written with {k} {old}, this is {k} {new}: "
                "the rerun may differ in floating point rounding"
            )
    return out


# -- maps -----------------------------------------------------------------------------------
def _frame(grid: Grid) -> dict:
    return {
        "shape": [int(grid.height), int(grid.width)],
        "cell_size": float(grid.cell_size),
        "resolution": None if grid.resolution is None else float(grid.resolution),
        "origin": None if grid.origin is None else [float(v) for v in grid.origin],
    }


def map_hash(grid: Grid) -> str:
    """sha256 (hex) of a map: a canonical JSON header (shape, cell_size, resolution, origin;
    sorted keys, no spaces), a newline, then the free mask as one byte per cell, row-major.

    >>> map_hash(Grid.from_rows(["..", ".#"]))[:12]
    '571ae8eb7897'
    """
    header = json.dumps(_frame(grid), sort_keys=True, separators=(",", ":")).encode()
    return hashlib.sha256(header + b"\n" + grid.free.astype(np.uint8).tobytes()).hexdigest()


def _source(grid: Grid, digest: str) -> dict | None:
    """``{"named": name}`` or ``{"bundled": file}`` when the grid is exactly that map."""
    from .. import maps

    if grid.name in maps.NAMED:
        try:
            if map_hash(maps.named(grid.name).replace(cell_size=grid.cell_size)) == digest:
                return {"named": grid.name}
        except JacoError:  # pragma: no cover - named maps always build
            pass
    src = grid.meta.get("source")
    if isinstance(src, str) and src in maps.BUNDLED and Path(src).suffix.lower() in maps.SUPPORTED_SUFFIXES:
        try:
            if map_hash(maps.load_bundled(src, cell_size=grid.cell_size)) == digest:
                return {"bundled": src}
        except JacoError:  # pragma: no cover
            pass
    return None


def map_entry(grid: Grid) -> dict:
    """The record's description of a map: frame, hash, source name if any, embedded mask."""
    digest = map_hash(grid)
    entry = {"name": grid.name, **_frame(grid), "sha256": digest, "source": _source(grid, digest)}
    if grid.n_cells <= EMBED_ROWS_MAX:
        entry["rows"] = grid.to_rows()
    else:
        packed = np.packbits(grid.free.ravel()).tobytes()
        entry["packed"] = base64.b64encode(zlib.compress(packed, 9)).decode("ascii")
    return entry


def grid_from_entry(entry: dict, where: str) -> tuple[Grid, list[str]]:
    """Rebuild the embedded map; warnings when it (or its named/bundled source) no longer has the
    recorded hash."""
    from .. import maps

    try:
        h, w = (int(v) for v in entry["shape"])
        if "rows" in entry:
            free = Grid.from_rows(entry["rows"]).free
        elif "packed" in entry:
            bits = np.frombuffer(zlib.decompress(base64.b64decode(entry["packed"])), np.uint8)
            free = np.unpackbits(bits)[: h * w].reshape(h, w).astype(bool)
        else:
            raise KeyError("rows")
        origin = entry.get("origin")
        grid = Grid(
            free,
            name=str(entry.get("name", "grid")),
            cell_size=float(entry.get("cell_size", 1.0)),
            resolution=None if entry.get("resolution") is None else float(entry["resolution"]),
            origin=None if origin is None else tuple(float(v) for v in origin),
        )
    except (KeyError, TypeError, ValueError, zlib.error, JacoError) as e:
        raise RecordError(f"{where}: the embedded map cannot be read ({type(e).__name__}: {e})") from None
    if grid.shape != (h, w):
        raise RecordError(f"{where}: the embedded map is {grid.shape}, the record says {(h, w)}")
    notes = []
    digest = map_hash(grid)
    if digest != entry.get("sha256"):
        notes.append(
            f"map {grid.name!r}: the embedded map has sha256 {digest[:12]}…, the record says "
            f"{str(entry.get('sha256'))[:12]}…: the record was modified"
        )
    src = entry.get("source") or {}
    try:
        if "named" in src:
            now = maps.named(src["named"]).replace(cell_size=grid.cell_size)
        elif "bundled" in src:
            now = maps.load_bundled(src["bundled"], cell_size=grid.cell_size)
        else:
            now = None
    except JacoError as e:
        now = None
        notes.append(f"map {grid.name!r}: its source {src} is no longer available ({e}); using the embedded copy")
    if now is not None and map_hash(now) != entry.get("sha256"):
        notes.append(
            f"map {grid.name!r}: {src} has changed since the record was written "
            "(its sha256 differs); rerunning on the embedded copy"
        )
    return grid, notes


# -- JSON helpers ---------------------------------------------------------------------------
def _num(x):
    """A float for JSON: finite as is (repr round-trips), +inf as null, -inf/nan as strings."""
    x = float(x)
    if math.isfinite(x):
        return x
    return None if x == math.inf else str(x)


def _unnum(x) -> float:
    return math.inf if x is None else float(x)


def _dumps(x, indent: int = 0) -> str:
    """Readable, strict JSON: mappings one key per line, lists of numbers (and lists of pairs)
    on one line, lists of strings (map rows) one per line."""
    pad, inner = " " * indent, " " * (indent + 1)
    scalar = lambda v: v is None or isinstance(v, (bool, int, float))  # noqa: E731
    if isinstance(x, dict):
        if not x:
            return "{}"
        items = [f"{inner}{json.dumps(str(k))}: {_dumps(v, indent + 1)}" for k, v in x.items()]
        return "{\n" + ",\n".join(items) + "\n" + pad + "}"
    if isinstance(x, list):
        if all(scalar(v) or (isinstance(v, list) and all(scalar(u) for u in v)) for v in x):
            return json.dumps(x, allow_nan=False)
        return "[\n" + ",\n".join(inner + _dumps(v, indent + 1) for v in x) + "\n" + pad + "]"
    return json.dumps(x, allow_nan=False)


def _write_json(doc: dict, path: Path, what: str = "record") -> Path:
    path = check_output(path, what)
    text = _dumps(doc) + "\n"
    json.loads(text)  # never write a file that does not read back
    return write_text(path, text)


def _header(kind: str) -> dict:
    return {
        "format": FORMAT,
        "format_version": FORMAT_VERSION,
        "kind": kind,
        "created": datetime.now(timezone.utc).isoformat(timespec="seconds"),
        "versions": versions(),
    }


def _cells(x):
    """A (row, col) pair, a list of pairs, or None, as JSON lists of ints."""
    if x is None:
        return None
    a = np.asarray(x)
    if a.dtype.kind not in "iu" and not np.all(a == np.round(a)):
        raise RecordError(f"cells must be integers, got {x!r}")
    return a.astype(np.int64).tolist()


def _uncells(x):
    if x is None:
        return None
    a = np.asarray(x, dtype=np.int64)
    if a.ndim == 1:
        return tuple(int(v) for v in a)
    return [tuple(int(v) for v in row) for row in a]


# -- runs -----------------------------------------------------------------------------------
_HISTORY_DTYPE = np.float32


def recordable_name(variant) -> str:
    """The name a record stores for ``variant`` (a name or a Variant): one the registry resolves
    to that same planner — a registered planner, a composition of :func:`jaco.compose`, or a
    registered planner with another cost (``"acs+multi"``). Anything else cannot be rerun."""
    from ..planners.registry import get_variant

    name = variant if isinstance(variant, str) else variant.name
    try:
        same = get_variant(name) is variant or isinstance(variant, str)
    except JacoError:
        same = False
    if not same:
        raise RecordError(
            f"variant {name!r} is neither registered nor a composition (jaco.compose): a record can "
            "only be rerun with a planner the registry finds by name"
        )
    return name


def save_run(result, path) -> Path:
    """Write ``result`` (a :class:`jaco.Result` from :func:`jaco.solve`) as a JSON record."""
    path = check_output(path, "record")
    if result.grid is None:
        raise RecordError("this Result has no grid (it was not made by jaco.solve): cannot record its map")
    recordable_name(result.variant)
    waypoints = getattr(result, "waypoints", None)
    pher = result.pheromone
    doc = _header("run")
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
        "start": _cells(result.start),
        "goal": _cells(result.goal),
        "waypoints": _cells(list(waypoints)) if waypoints is not None and len(waypoints) else None,
    }
    doc["map"] = map_entry(result.grid)
    doc["result"] = {
        "success": bool(result.success),
        "path": np.asarray(result.path, np.int64).tolist(),
        "length": _num(result.length),
        "cost": _num(result.cost),
        "optimal": _num(result.optimal),
        "gap": _num(result.gap),
        "best_iteration": int(result.best_iteration),
        "coverage": _num(result.coverage),
        "history": {k: [_num(x) for x in np.asarray(v)] for k, v in result.history.items()},
        "history_dtype": {k: str(np.asarray(v).dtype) for k, v in result.history.items()},
        "pheromone_sha256": None if pher is None else hashlib.sha256(np.ascontiguousarray(pher).tobytes()).hexdigest(),
    }
    return _write_json(doc, path)


# -- paths in world coordinates (ROS) -------------------------------------------------------
def _metres(v) -> float:
    """World coordinates rounded to the nanometre: 0.475, not 0.47500000000000003."""
    return round(float(v), 9)


def save_path(result, path, frame: str | None = None) -> Path:
    """Write ``result``'s path as CSV or JSON (by the suffix of ``path``).

    ``frame="world"``: columns ``row,col,x,y``, x and y in metres at the cell centres, from the
    map's ``resolution`` and ``origin`` (:meth:`jaco.Grid.cell_to_world`; row 0 is the top of the
    image, i.e. the largest y). ``frame="cells"``: ``row,col`` only. Default: world when the map
    has a resolution. The JSON holds the map name, frame, resolution, origin, length and the
    points as ``[[row, col], ...]`` (``cells``) and ``[[x, y], ...]`` (``xy``), and in the world
    frame ``length_m`` (the length in metres: cell units × resolution). Coordinates are rounded
    to 1e-9 m.
    """
    path = check_output(path, "path file", suffixes=(".csv", ".json"))
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
    suffix = path.suffix.lower()
    cells = np.asarray(result.path, np.int64).reshape(-1, 2)
    xy = grid.cell_to_world(cells) if frame == "world" else None
    if suffix == ".csv":
        lines = ["row,col,x,y" if xy is not None else "row,col"]
        for i, (r, c) in enumerate(cells):
            row = f"{int(r)},{int(c)}"
            if xy is not None:
                row += f",{_metres(xy[i, 0])!r},{_metres(xy[i, 1])!r}"
            lines.append(row)
        return write_text(path, "\n".join(lines) + "\n")
    doc = {
        "map": grid.name,
        "frame": frame,
        "units": "m" if frame == "world" else "cells",
        "resolution": None if grid.resolution is None else float(grid.resolution),
        "origin": None if grid.origin is None else [float(v) for v in grid.origin],
        "success": bool(result.success),
        "length": _num(result.length),
        "cells": cells.tolist(),
    }
    if xy is not None:
        doc["length_m"] = _num(result.length / grid.cell_size * grid.resolution)
        doc["xy"] = [[_metres(x), _metres(y)] for x, y in xy]
    return _write_json(doc, path, "path file")
