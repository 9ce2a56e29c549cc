"""MovingAI benchmark files (Sturtevant 2012): grid maps ``.map`` and scenarios ``.scen``."""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import JacoError, MapFormatError
from ..grid import Grid
from ..outputs import as_path
from .files import read_text, require_file

# MovingAI terrain: '.' ground, 'G' ground, 'S' swamp (passable); '@'/'O' out of bounds,
# 'T' trees, 'W' water (blocked). The benchmark's optimal lengths use exactly this split.
MOVINGAI_PASSABLE = ".GS"
MOVINGAI_BLOCKED = "@OTW"


def load_movingai(path: Path, *, cell_size: float = 1.0) -> Grid:
    """MovingAI grid map: ``type``, ``height H``, ``width W``, ``map``, then H rows of W symbols.

    ``height``/``width`` may come in either order. CRLF line ends are accepted. Blank lines after
    the last row are ignored; anything else in the wrong place is an error with its line number.
    """
    fname = path.name
    # splitlines() would also split on \x0b, \x0c, ...; only \n (with an optional \r) ends a line.
    lines = read_text(path).split("\n")
    lines = [ln[:-1] if ln.endswith("\r") else ln for ln in lines]

    def header_line(i: int, expect: str) -> list[str]:
        if i >= len(lines) or (i == len(lines) - 1 and lines[i] == ""):
            raise MapFormatError(f"{fname} line {i + 1}: expected {expect}, found end of file (truncated header)")
        return lines[i].split()

    words = header_line(0, "'type octile'")
    if len(words) != 2 or words[0] != "type":
        raise MapFormatError(f"{fname} line 1: expected 'type octile', found {lines[0]!r}")
    map_type = words[1]
    sizes: dict[str, int] = {}
    for i in (1, 2):
        missing = [k for k in ("height", "width") if k not in sizes]
        expect = " or ".join(f"'{k} <integer>'" for k in missing)
        words = header_line(i, expect)
        if len(words) != 2 or words[0] not in missing:
            raise MapFormatError(f"{fname} line {i + 1}: expected {expect}, found {lines[i]!r}")
        try:
            value = int(words[1])
        except ValueError:
            raise MapFormatError(f"{fname} line {i + 1}: {words[0]} must be an integer, found {words[1]!r}") from None
        if value < 1:
            raise MapFormatError(f"{fname} line {i + 1}: {words[0]} must be positive, found {value}")
        sizes[words[0]] = value
    words = header_line(3, "'map'")
    if words != ["map"]:
        raise MapFormatError(f"{fname} line 4: expected 'map', found {lines[3]!r}")
    h, w = sizes["height"], sizes["width"]

    rows = lines[4:]
    while rows and rows[-1].strip() == "":  # trailing blank lines / final newline
        rows.pop()
    if len(rows) != h:
        raise MapFormatError(
            f"{fname}: header says height {h} but {len(rows)} map rows follow (lines 5..{4 + len(rows)})"
        )
    for r, row in enumerate(rows):
        if len(row) != w:
            raise MapFormatError(f"{fname} line {5 + r}: row {r} has {len(row)} cells, header says width {w}")
    try:
        raw = np.frombuffer("".join(rows).encode("ascii"), dtype=np.uint8).reshape(h, w)
    except UnicodeEncodeError as e:
        r, c = divmod(e.start, w)
        raise MapFormatError(f"{fname} line {5 + r} column {c + 1}: unknown map symbol {rows[r][c]!r}") from None
    lut = np.full(256, -1, dtype=np.int8)
    lut[np.frombuffer(MOVINGAI_PASSABLE.encode(), np.uint8)] = 1
    lut[np.frombuffer(MOVINGAI_BLOCKED.encode(), np.uint8)] = 0
    code = lut[raw]
    if (code < 0).any():
        r, c = (int(v) for v in np.argwhere(code < 0)[0])
        raise MapFormatError(
            f"{fname} line {5 + r} column {c + 1}: unknown map symbol {rows[r][c]!r} "
            f"(passable: {' '.join(MOVINGAI_PASSABLE)}; blocked: {' '.join(MOVINGAI_BLOCKED)})"
        )
    return Grid(
        code == 1,
        name=path.stem,
        cell_size=cell_size,
        meta={"source": fname, "format": "movingai", "type": map_type},
    )


@dataclass(frozen=True)
class Scenario:
    """One row of a MovingAI ``.scen`` file.

    ``start`` and ``goal`` are ``(row, col)`` cells (the file's x is the column, y the row);
    ``optimal`` is the benchmark's optimal octile length (8-connected, no corner cutting);
    ``map`` is the map file name as written in the row; ``index`` the scenario's position in its
    file (0 for the first scenario; ``jaco solve --scen F --index K`` takes the K-th).
    """

    bucket: int
    map: str
    width: int
    height: int
    start: tuple[int, int]
    goal: tuple[int, int]
    optimal: float
    index: int = 0


def load_scenarios(path: str | os.PathLike) -> list[Scenario]:
    """Read a MovingAI ``.scen`` file: ``version 1`` (or ``1.0``) then 9 tab-separated columns.

    Columns: bucket, map file, map width, map height, start x, start y, goal x, goal y, optimal
    length. Blank lines are skipped. Raises :class:`MapFormatError` with the line number on a
    malformed row, or when a start/goal lies outside the width x height it declares.
    """
    path = as_path(path, "scenario file", MapFormatError)
    require_file(path, "scenario file")
    fname = path.name
    lines = [ln.rstrip("\r") for ln in read_text(path).split("\n")]
    if not lines or lines[0].split() not in (["version", "1"], ["version", "1.0"]):
        first = lines[0] if lines else ""
        raise MapFormatError(f"{fname} line 1: expected 'version 1', found {first!r}")
    out: list[Scenario] = []
    for i, line in enumerate(lines[1:], start=2):
        if not line.strip():
            continue
        cols = line.split("\t")
        if len(cols) != 9:
            cols = line.split()  # tolerate space-separated files (map names without spaces)
        if len(cols) != 9:
            raise MapFormatError(
                f"{fname} line {i}: expected 9 tab-separated columns "
                f"(bucket, map, width, height, start x, start y, goal x, goal y, optimal), "
                f"found {len(line.split(chr(9)))}"
            )
        try:
            bucket, width, height, sx, sy, gx, gy = (int(cols[k]) for k in (0, 2, 3, 4, 5, 6, 7))
            optimal = float(cols[8])
        except ValueError:
            raise MapFormatError(
                f"{fname} line {i}: columns 1 and 3-8 must be integers and column 9 a number, found {line!r}"
            ) from None
        if not math.isfinite(optimal) or optimal < 0:
            raise MapFormatError(f"{fname} line {i}: optimal length must be a number >= 0, found {cols[8]!r}")
        for what, x, y in (("start", sx, sy), ("goal", gx, gy)):
            if not (0 <= x < width and 0 <= y < height):
                raise MapFormatError(
                    f"{fname} line {i}: {what} x={x}, y={y} is outside the declared {width}x{height} map"
                )
        out.append(Scenario(bucket, cols[1].strip(), width, height, (sy, sx), (gy, gx), optimal, len(out)))
    return out


def _bounds(value, what: str, cast) -> tuple:
    """``(lo, hi)`` inclusive, either end None (open), from a number or a pair."""
    if isinstance(value, (tuple, list)) and len(value) == 2:
        lo, hi = value
    elif isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, bool):
        lo = hi = value
    else:
        raise JacoError(f"{what} must be a number or a (low, high) pair with None for an open end, got {value!r}")
    try:
        lo, hi = (None if v is None else cast(v) for v in (lo, hi))
    except (TypeError, ValueError):
        raise JacoError(
            f"{what} must be a number or a (low, high) pair with None for an open end, got {value!r}"
        ) from None
    if lo is not None and hi is not None and lo > hi:
        raise JacoError(f"{what}: low {lo} is above high {hi}")
    return lo, hi


def _within(x, lo, hi) -> bool:
    return (lo is None or x >= lo) and (hi is None or x <= hi)


def select_scenarios(
    scenarios: list[Scenario] | tuple[Scenario, ...] | str | os.PathLike,
    *,
    index: Any = None,
    bucket: Any = None,
    optimal: Any = None,
    count: int | None = None,
) -> list[Scenario]:
    """The scenarios (of :func:`load_scenarios`, or a ``.scen`` path) that a sweep should run.

    ``index``: an int or a list of ints, positions in the file (``Scenario.index``), in the order
    given; ``bucket``: an int or an inclusive ``(low, high)`` pair, either end None for open
    (``(80, None)``: bucket 80 and above); ``optimal``: an inclusive ``(low, high)`` range of the
    optimal length; ``count``: then keep ``count`` scenarios spread evenly over the optimal lengths
    of those left (the shortest, the longest and evenly spaced ranks between; all of them when
    there are fewer). Filters combine; the result keeps the file's order (or ``index``'s). An
    empty selection is a :class:`~jaco.errors.JacoError` that says what the file holds.

    >>> import jaco
    >>> scen = jaco.maps.load_scenarios(jaco.maps.bundled("Berlin_1_256.map.scen"))
    >>> long = jaco.maps.select_scenarios(scen, bucket=(85, None), count=4)
    >>> [s.index for s in long], [round(s.optimal) for s in long]
    ([858, 870, 885, 901], [340, 348, 355, 363])
    """
    if not isinstance(scenarios, (list, tuple)):
        scenarios = load_scenarios(scenarios)
    picked = list(scenarios)
    if not picked:
        raise JacoError("select_scenarios: no scenarios to select from")
    if index is not None:
        wanted = [index] if isinstance(index, (int, np.integer)) and not isinstance(index, bool) else list(index)
        by_index = {s.index: s for s in picked}
        for k in wanted:
            if isinstance(k, bool) or not isinstance(k, (int, np.integer)):
                raise JacoError(f"index must be an int or a list of ints, got {k!r}")
            if k not in by_index:
                raise JacoError(
                    f"index {k} is out of range: there are {len(picked)} scenarios ({min(by_index)}..{max(by_index)})"
                )
        picked = [by_index[int(k)] for k in dict.fromkeys(wanted)]
    filters = []
    if bucket is not None:
        lo, hi = _bounds(bucket, "bucket", int)
        filters.append(("bucket", lo, hi))
    if optimal is not None:
        lo, hi = _bounds(optimal, "optimal", float)
        filters.append(("optimal", lo, hi))
    kept = [s for s in picked if all(_within(getattr(s, k), lo, hi) for k, lo, hi in filters)]
    if not kept:
        said = " and ".join(f"{k} {'' if lo is None else lo}..{'' if hi is None else hi}" for k, lo, hi in filters)
        buckets = [s.bucket for s in picked]
        lengths = [s.optimal for s in picked]
        raise JacoError(
            f"no scenario has {said}: the {len(picked)} scenarios have buckets {min(buckets)}..{max(buckets)} "
            f"and optimal lengths {min(lengths):.4g}..{max(lengths):.4g}"
        )
    if count is not None:
        if isinstance(count, bool) or not isinstance(count, (int, np.integer)) or count < 1:
            raise JacoError(f"count must be a positive integer, got {count!r}")
        if count < len(kept):
            by_length = sorted(range(len(kept)), key=lambda i: (kept[i].optimal, i))
            ranks = np.unique(np.round(np.linspace(0, len(kept) - 1, int(count))).astype(int))
            chosen = sorted(by_length[r] for r in ranks)
            kept = [kept[i] for i in chosen]
    return kept
