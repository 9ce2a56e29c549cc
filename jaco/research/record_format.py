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
from typing import Any

import numpy as np

from ..errors import JacoError, ProblemError
from ..grid import Grid
from ..outputs import check_output, write_text

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

FORMAT = "jaco-record"
FORMAT_VERSION = 4
#: Why a record of an older format no longer reruns bit for bit (the file itself still loads).
#: Formats 3 and 4 changed no rerun: a sweep record's ``steplimit: null`` (the default) means the
#: default of the jaco that wrote it, and reruns so (:func:`jaco.engine.checks.legacy_steplimit`):
#: before format 3, 4·(H + W) at most the free cells for every planner; in format 3 twice that
#: for backtracking ants; since format 4 :func:`jaco.engine.checks.default_steplimit`.
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
                f"record written with {k} {old}, this is {k} {new}: the rerun may differ in floating point rounding"
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
            origin=None if origin is None else (float(origin[0]), float(origin[1]), float(origin[2])),
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


def _json_text(doc: dict) -> str:
    text = _dumps(doc) + "\n"
    json.loads(text)  # never write a file that does not read back
    return text


def _write_json(doc: dict, path: Path, what: str = "record") -> Path:
    path = check_output(path, what)
    return write_text(path, _json_text(doc), what)


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


def recordable_name(variant: Any) -> str:
    """The name a record stores for ``variant`` (a name or a Planner): one the registry resolves
    to that same planner — a registered planner, a composition of :func:`jaco.compose`, or a
    registered planner with another cost (``"acs+multi"``). Anything else cannot be rerun."""
    from ..planners.registry import get_planner

    name = variant if isinstance(variant, str) else variant.name
    try:
        same = get_planner(name) is variant or isinstance(variant, str)
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
                row += f",{_metres(xy[i, 0])!r},{_metres(xy[i, 1])!r}"
            lines.append(row)
        return write_text(path, "\n".join(lines) + "\n", "path file")
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


# -- the schema a record must have (checked on load) ----------------------------------------
def _is_int(v) -> bool:
    return isinstance(v, int) and not isinstance(v, bool)


def _is_num(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def _is_float_entry(v) -> bool:
    """A float as :func:`_num` writes it: a number, null (+inf) or "-inf" / "nan"."""
    return v is None or _is_num(v) or v in ("-inf", "nan", "inf")


def _is_pair(v) -> bool:
    return isinstance(v, list) and len(v) == 2 and all(_is_int(x) for x in v)


def _list_of(pred):
    return lambda v: isinstance(v, list) and all(pred(x) for x in v)


def _map_of(pred):
    return lambda v: isinstance(v, dict) and all(isinstance(k, str) and pred(x) for k, x in v.items())


def _maybe(pred):
    return lambda v: v is None or pred(v)


def _either(*preds):
    return lambda v: any(p(v) for p in preds)


def _int_in(lo, hi):
    return lambda v: _is_int(v) and lo <= v < hi


def _is_dtype(v) -> bool:
    return v in ("float16", "float32", "float64")


_STR, _POS_INT = (lambda v: isinstance(v, str)), _int_in(1, 2**31)
_PAIRS = _either(_is_pair, _list_of(_is_pair))
_AXES = _map_of(_either(_is_num, _list_of(_is_num)))
# field: (check, what it must be, required)
_HEADER = {
    "format": (_STR, "a string", True),
    "format_version": (_int_in(0, 2**31), "an integer >= 0", False),
    "kind": (lambda v: v in ("run", "sweep"), "'run' or 'sweep'", True),
    "created": (_STR, "a string", False),
    "versions": (_map_of(_maybe(_STR)), "a mapping of names to version strings", False),
}
_MAP = {
    "name": (_STR, "a string", False),
    "shape": (
        lambda v: isinstance(v, list) and len(v) == 2 and all(_int_in(1, 2**31)(x) for x in v),
        "[height, width], two positive integers",
        True,
    ),
    "cell_size": (lambda v: _is_num(v) and v > 0, "a positive number", False),
    "resolution": (_maybe(lambda v: _is_num(v) and v > 0), "a positive number or null", False),
    "origin": (
        _maybe(lambda v: isinstance(v, list) and len(v) == 3 and all(_is_num(x) for x in v)),
        "[x, y, yaw] or null",
        False,
    ),
    "sha256": (_maybe(_STR), "a string", False),
    "source": (_maybe(_map_of(_STR)), "a mapping or null", False),
    "rows": (_list_of(_STR), "a list of strings", False),
    "packed": (_STR, "a base64 string", False),
}
_RUN_CALL = {
    "variant": (_STR, "a planner name (a string)", True),
    "seed": (_int_in(0, 2**32), "an integer in [0, 2**32)", True),
    "n_ants": (_POS_INT, "a positive integer", True),
    "n_iters": (_POS_INT, "a positive integer", True),
    "steplimit": (_POS_INT, "a positive integer", True),
    "connectivity": (lambda v: v in (4, 8) and _is_int(v), "4 or 8", False),
    "keep_pheromone": (lambda v: isinstance(v, bool) or v == "history", "true, false or 'history'", False),
    "params": (_map_of(_is_num), "a mapping of parameter names to numbers", True),
    "start": (_is_pair, "[row, col], two integers", True),
    "goal": (_is_pair, "[row, col], two integers", True),
    "waypoints": (_maybe(_list_of(_is_pair)), "a list of [row, col] pairs or null", False),
}
_RESULT = {
    "success": (lambda v: isinstance(v, bool), "true or false", True),
    "path": (_list_of(_is_pair), "a list of [row, col] pairs", True),
    **{k: (_is_float_entry, "a number, null or '-inf'/'nan'", True) for k in ("length", "cost", "optimal", "coverage")},
    "gap": (_is_float_entry, "a number, null or '-inf'/'nan'", False),
    "best_iteration": (_int_in(-1, 2**31), "an integer >= -1", True),
    "history": (_map_of(_list_of(_is_float_entry)), "a mapping of names to lists of numbers", True),
    "history_dtype": (_map_of(_is_dtype), "a mapping of names to float dtypes", False),
    "pheromone_sha256": (_maybe(_STR), "a string or null", False),
}
_SWEEP_CALL = {
    "grid": (
        lambda v: isinstance(v, dict) or (isinstance(v, list) and v and all(isinstance(x, dict) for x in v)),
        "a map entry or a non-empty list of them",
        True,
    ),
    "start": (_PAIRS, "[row, col] or a list of them", True),
    "goal": (_PAIRS, "[row, col] or a list of them", True),
    "variant": (
        _either(_STR, lambda v: isinstance(v, list) and v and all(isinstance(x, str) for x in v)),
        "a planner name or a list of names",
        True,
    ),
    "params": (
        _either(_AXES, lambda v: isinstance(v, dict) and list(v) == ["design"] and _AXES(v["design"])),
        "a mapping of parameter names to lists of numbers",
        True,
    ),
    "seeds": (
        _either(_POS_INT, lambda v: isinstance(v, list) and v and all(_int_in(0, 2**32)(x) for x in v)),
        "a positive count or a list of integers in [0, 2**32)",
        True,
    ),
    "n_ants": (_POS_INT, "a positive integer", True),
    "n_iters": (_POS_INT, "a positive integer", True),
    "steplimit": (_maybe(_POS_INT), "a positive integer or null", True),
    "connectivity": (lambda v: v in (4, 8) and _is_int(v), "4 or 8", False),
    "memory_budget": (lambda v: _is_int(v) and v >= 1, "a positive integer", False),
}
_TABLE = {
    "file": (lambda v: isinstance(v, str) and v and "/" not in v and "\\" not in v, "a file name", True),
    "rows": (_int_in(0, 2**63), "an integer >= 0", False),
    "columns": (_list_of(_STR), "a list of strings", False),
    "sha256": (_maybe(_STR), "a string", False),
}


def _show(v) -> str:
    text = repr(v)
    return f"{type(v).__name__} {text if len(text) <= 60 else text[:57] + '...'}"


def _check_fields(obj, schema: dict, where: str, name: str) -> None:
    if not isinstance(obj, dict):
        raise RecordError(f"{name}: field {where} must be a mapping (JSON object), got {_show(obj)}")
    for key, (ok, expected, required) in schema.items():
        field_name = f"{where}.{key}" if where else key
        if key not in obj:
            if required:
                raise RecordError(f"{name}: field {field_name} is missing")
            continue
        if not ok(obj[key]):
            raise RecordError(f"{name}: field {field_name} must be {expected}, got {_show(obj[key])}")


def check_record(doc: Any, name: str) -> None:
    """A :class:`RecordError` naming the first field of a loaded record (``doc``, parsed JSON)
    whose type or value does not fit the format (docs/records.md, "Schema")."""
    _check_fields(doc, _HEADER, "", name)
    if doc["kind"] == "run":
        _check_fields(doc.get("call"), _RUN_CALL, "call", name)
        _check_fields(doc.get("map"), _MAP, "map", name)
        _check_fields(doc.get("result"), _RESULT, "result", name)
        maps = [("map", doc["map"])]
    else:
        _check_fields(doc.get("call"), _SWEEP_CALL, "call", name)
        _check_fields(doc.get("table"), _TABLE, "table", name)
        grid = doc["call"]["grid"]
        maps = [("call.grid", grid)] if isinstance(grid, dict) else [(f"call.grid[{i}]", g) for i, g in enumerate(grid)]
    for where, entry in maps:
        _check_fields(entry, _MAP, where, name)
        if "rows" not in entry and "packed" not in entry:
            raise RecordError(f"{name}: field {where} has neither rows nor packed (the embedded map)")
