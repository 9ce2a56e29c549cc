"""A record's map: the grid embedded (text rows, or a packed bit mask for large maps) with its
sha256 and the name of the named or bundled map it is, and the grid rebuilt from that entry."""

from __future__ import annotations

import base64
import hashlib
import json
import zlib
from pathlib import Path

import numpy as np

from ..errors import JacoError
from ..grid import Grid
from .record_errors import RecordError

#: Maps with at most this many cells are embedded as text rows ('.' free, '@' blocked), larger
#: ones as a base64 zlib-compressed bit mask (np.packbits, row-major).
EMBED_ROWS_MAX = 65536


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
