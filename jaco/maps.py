"""Maps: file loaders, the bundled benchmark maps, and seeded generators of the papers' test maps.

Loaders (:func:`load` dispatches on the file suffix)

* MovingAI ``.map`` (Sturtevant 2012): ``.``, ``G``, ``S`` passable; ``@``, ``O``, ``T``, ``W``
  blocked.
* ROS map_server ``.yaml`` + image (PGM P2/P5 read here, PNG etc. through Pillow), with the
  trinary/scale/raw rules of ROS 1 ``map_server/src/image_loader.cpp``. Unknown cells are not free.
* Plain text ``.txt``: ``.`` free, ``#`` or ``@`` blocked (:func:`save_text` writes it).
* numpy ``.npy``: a 2-D boolean array, or integers in {0, 1}; True / 1 = free.
* Images ``.png``, ``.pgm``, ``.ppm``, ``.bmp``: a pixel is free when its brightness is above a
  threshold.

:func:`load_scenarios` reads MovingAI ``.scen`` files (9 tab-separated columns, ``version 1``).

Every file-format problem raises :class:`~jaco.errors.MapFormatError` naming the file (and the line
where there is one). The package never reads outside ``jaco/data`` at run time: :func:`bundled` and
:func:`load_bundled` give the bundled copies (see ``jaco/data/*/SOURCES.md`` for their origin).

Generators (all seeded with ``numpy.random.default_rng``; every named map is connected start to goal
under 8-connected moves without corner cutting, and carries ``meta["start"]`` / ``meta["goal"]``):
:func:`random_map`, :func:`utrap`, :func:`wall`, :func:`circle`, :func:`h_shape`, :func:`s_shape`,
:func:`simple_20`, :func:`complex_30`, :func:`demo`; the registry :data:`NAMED` and :func:`named`.
"""

from __future__ import annotations

import math
import numbers
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

from .errors import MapFormatError, ProblemError
from .grid import Grid

DATA_DIR = Path(__file__).parent / "data"

#: Every bundled data file, by file name (``SOURCES.md`` attribution files excluded).
BUNDLED: tuple[str, ...] = tuple(
    sorted(
        p.name
        for sub in ("movingai", "ros")
        for p in (DATA_DIR / sub).glob("*")
        if p.is_file() and p.name != "SOURCES.md"
    )
)

SUPPORTED_SUFFIXES = (".map", ".yaml", ".yml", ".txt", ".npy", ".png", ".pgm", ".ppm", ".bmp")

# MovingAI terrain: '.' ground, 'G' ground, 'S' swamp (passable); '@'/'O' out of bounds,
# 'T' trees, 'W' water (blocked). The benchmark's optimal lengths use exactly this split.
MOVINGAI_PASSABLE = ".GS"
MOVINGAI_BLOCKED = "@OTW"

_ROS_MODES = ("trinary", "scale", "raw")


# ------------------------------------------------------------------------------------------------
# bundled files
# ------------------------------------------------------------------------------------------------
def bundled(name: str) -> Path:
    """Path of a bundled data file, e.g. ``bundled("random-32-32-10.map")``.

    ``name`` is a file name from :data:`BUNDLED` (a leading ``movingai/`` or ``ros/`` is accepted).
    Without a suffix, ``name + ".map"`` and then ``name + ".yaml"`` are tried, so
    ``bundled("arena")`` is ``arena.map`` and ``bundled("depot")`` is ``depot.yaml``.
    """
    base = str(name).replace("\\", "/").split("/")[-1]
    for candidate in (base, base + ".map", base + ".yaml"):
        for sub in ("movingai", "ros"):
            p = DATA_DIR / sub / candidate
            if candidate in BUNDLED and p.is_file():
                return p
    raise MapFormatError(f"no bundled map file {name!r}; bundled files: {', '.join(BUNDLED)}")


def load_bundled(name: str, **kw) -> Grid:
    """``load(bundled(name), **kw)``: a bundled map as a :class:`Grid`."""
    return load(bundled(name), **kw)


# ------------------------------------------------------------------------------------------------
# dispatch
# ------------------------------------------------------------------------------------------------
def load(
    path,
    *,
    name: str | None = None,
    cell_size: float = 1.0,
    threshold: float = 0.5,
    negate: bool | None = None,
) -> Grid:
    """Read a map file into a :class:`Grid`, choosing the reader by the file suffix.

    Parameters
    ----------
    path : str or Path
        ``.map`` (MovingAI), ``.yaml``/``.yml`` (ROS map_server), ``.txt`` (``.`` free, ``#``/``@``
        blocked), ``.npy`` (bool or 0/1 integers, True/1 = free), or an image ``.png``, ``.pgm``,
        ``.ppm``, ``.bmp``.
    name : str, optional
        Grid name; defaults to the file stem.
    cell_size : float
        Passed to :class:`Grid` (scales reported lengths only).
    threshold : float
        Images only: a pixel is free when ``brightness / maxval > threshold`` (white free).
    negate : bool, optional
        Images: invert brightness first (black free). ROS yaml: overrides the yaml's ``negate``.

    Raises
    ------
    MapFormatError
        Missing file, unsupported suffix, or a malformed file (the message names the file and,
        for text formats, the line).
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix == ".scen":
        raise MapFormatError(f"{path.name} is a scenario file: read it with load_scenarios()")
    if suffix not in SUPPORTED_SUFFIXES:
        raise MapFormatError(
            f"unsupported map file suffix {path.suffix or '(none)'!r} for {path.name}; "
            f"supported: {', '.join(SUPPORTED_SUFFIXES)}"
        )
    _require_file(path, "map file")
    kw = {"cell_size": cell_size}
    if suffix == ".map":
        grid = _load_movingai(path, **kw)
    elif suffix in (".yaml", ".yml"):
        grid = _load_ros(path, negate=negate, **kw)
    elif suffix == ".txt":
        grid = _load_text(path, **kw)
    elif suffix == ".npy":
        grid = _load_npy(path, **kw)
    else:
        grid = _load_image(path, threshold=threshold, negate=bool(negate), **kw)
    return grid.replace(name=name) if name is not None else grid


def _require_file(path: Path, what: str, referenced_by: str | None = None) -> None:
    if not path.is_file():
        why = "is a directory, not a file" if path.is_dir() else "not found"
        extra = f" (referenced by {referenced_by})" if referenced_by else ""
        hint = ""
        if not referenced_by and path.name in BUNDLED:
            hint = f"; a bundled copy exists: load_bundled({path.name!r})"
        raise MapFormatError(f"{what} {str(path)!r} {why}{extra}{hint}")


def _read_text(path: Path) -> str:
    try:
        return path.read_bytes().decode("utf-8")
    except UnicodeDecodeError as e:
        raise MapFormatError(
            f"{path.name} is not a text file (byte {e.start} is not UTF-8)"
        ) from None


# ------------------------------------------------------------------------------------------------
# MovingAI .map
# ------------------------------------------------------------------------------------------------
def _load_movingai(path: Path, *, cell_size: float = 1.0) -> Grid:
    """MovingAI grid map: ``type``, ``height H``, ``width W``, ``map``, then H rows of W symbols.

    ``height``/``width`` may come in either order. CRLF line ends are accepted. Blank lines after
    the last row are ignored; anything else in the wrong place is an error with its line number.
    """
    fname = path.name
    # splitlines() would also split on \x0b, \x0c, ...; only \n (with an optional \r) ends a line.
    lines = _read_text(path).split("\n")
    lines = [ln[:-1] if ln.endswith("\r") else ln for ln in lines]

    def header_line(i: int, expect: str) -> list[str]:
        if i >= len(lines) or (i == len(lines) - 1 and lines[i] == ""):
            raise MapFormatError(
                f"{fname} line {i + 1}: expected {expect}, found end of file (truncated header)"
            )
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
            raise MapFormatError(
                f"{fname} line {i + 1}: {words[0]} must be an integer, found {words[1]!r}"
            ) from None
        if value < 1:
            raise MapFormatError(
                f"{fname} line {i + 1}: {words[0]} must be positive, found {value}"
            )
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
            f"{fname}: header says height {h} but {len(rows)} map rows follow "
            f"(lines 5..{4 + len(rows)})"
        )
    for r, row in enumerate(rows):
        if len(row) != w:
            raise MapFormatError(
                f"{fname} line {5 + r}: row {r} has {len(row)} cells, header says width {w}"
            )
    try:
        raw = np.frombuffer("".join(rows).encode("ascii"), dtype=np.uint8).reshape(h, w)
    except UnicodeEncodeError as e:
        r, c = divmod(e.start, w)
        raise MapFormatError(
            f"{fname} line {5 + r} column {c + 1}: unknown map symbol {rows[r][c]!r}"
        ) from None
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


# ------------------------------------------------------------------------------------------------
# MovingAI .scen
# ------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Scenario:
    """One row of a MovingAI ``.scen`` file.

    ``start`` and ``goal`` are ``(row, col)`` cells (the file's x is the column, y the row);
    ``optimal`` is the benchmark's optimal octile length (8-connected, no corner cutting);
    ``map`` is the map file name as written in the row.
    """

    bucket: int
    map: str
    width: int
    height: int
    start: tuple[int, int]
    goal: tuple[int, int]
    optimal: float


def load_scenarios(path) -> list[Scenario]:
    """Read a MovingAI ``.scen`` file: ``version 1`` (or ``1.0``) then 9 tab-separated columns.

    Columns: bucket, map file, map width, map height, start x, start y, goal x, goal y, optimal
    length. Blank lines are skipped. Raises :class:`MapFormatError` with the line number on a
    malformed row, or when a start/goal lies outside the width x height it declares.
    """
    path = Path(path)
    _require_file(path, "scenario file")
    fname = path.name
    lines = [ln.rstrip("\r") for ln in _read_text(path).split("\n")]
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
            bucket, width, height, sx, sy, gx, gy = (
                int(cols[k]) for k in (0, 2, 3, 4, 5, 6, 7)
            )
            optimal = float(cols[8])
        except ValueError:
            raise MapFormatError(
                f"{fname} line {i}: columns 1 and 3-8 must be integers and column 9 a number, "
                f"found {line!r}"
            ) from None
        if not math.isfinite(optimal) or optimal < 0:
            raise MapFormatError(
                f"{fname} line {i}: optimal length must be a number >= 0, found {cols[8]!r}"
            )
        for what, x, y in (("start", sx, sy), ("goal", gx, gy)):
            if not (0 <= x < width and 0 <= y < height):
                raise MapFormatError(
                    f"{fname} line {i}: {what} x={x}, y={y} is outside the declared "
                    f"{width}x{height} map"
                )
        out.append(
            Scenario(bucket, cols[1].strip(), width, height, (sy, sx), (gy, gx), optimal)
        )
    return out


# ------------------------------------------------------------------------------------------------
# ROS map_server .yaml + image
# ------------------------------------------------------------------------------------------------
def _load_ros(path: Path, *, negate: bool | None = None, cell_size: float = 1.0) -> Grid:
    """ROS map_server map: a yaml (image, resolution, origin, thresholds, negate, mode) + image.

    A pixel's value ``v`` is the mean of its channels (in ``trinary`` mode alpha is averaged in, as
    ROS 1 does; otherwise alpha is left out); with ``negate``, ``v`` becomes ``maxval - v`` first.

    * ``trinary`` (default) and ``scale``: occupancy ``p = (maxval - v) / maxval``;
      ``p > occupied_thresh`` occupied, ``p < free_thresh`` free, else unknown. (ROS ``scale`` mode
      turns the in-between band into costs 1..99; a binary grid has no partial costs, so here
      those cells are not free and are coded -1 like unknown.)
    * ``raw``: the value itself is the occupancy in percent, as ROS 1 copies it into the map:
      ``v > 100`` unknown (Nav2's rule; ROS 1 would store 255 as -1), ``v <= 100 * free_thresh``
      free, ``v >= 100 * occupied_thresh`` occupied, anything between unknown.

    Row 0 of the grid is the top row of the image; ``Grid.cell_to_world`` applies ``resolution``
    and ``origin``. ``meta["occupancy"]`` holds int8 codes: 0 free, 1 occupied, -1 unknown.
    Only code 0 is free in the grid.
    """
    import yaml

    fname = path.name
    try:
        doc = yaml.safe_load(_read_text(path))
    except yaml.YAMLError as e:
        raise MapFormatError(f"{fname}: not valid YAML ({e})") from None
    if not isinstance(doc, dict):
        raise MapFormatError(
            f"{fname}: a ROS map yaml must be a mapping of keys, got {type(doc).__name__}"
        )
    required = ("image", "resolution", "origin", "occupied_thresh", "free_thresh")
    missing = [k for k in required if k not in doc]
    if missing:
        raise MapFormatError(
            f"{fname}: missing key(s) {', '.join(missing)} (required: {', '.join(required)})"
        )

    res = _yaml_number(doc["resolution"], fname, "resolution")
    if not math.isfinite(res) or res <= 0:
        raise MapFormatError(
            f"{fname}: resolution must be a positive number of metres per cell, "
            f"got {doc['resolution']!r}"
        )
    origin = doc["origin"]
    if not isinstance(origin, (list, tuple)) or len(origin) != 3:
        raise MapFormatError(f"{fname}: origin must be a list [x, y, yaw], got {origin!r}")
    origin = tuple(_yaml_number(v, fname, "origin") for v in origin)
    if not all(math.isfinite(v) for v in origin):
        raise MapFormatError(f"{fname}: origin must be finite, got {doc['origin']!r}")
    occ_th = _yaml_number(doc["occupied_thresh"], fname, "occupied_thresh")
    free_th = _yaml_number(doc["free_thresh"], fname, "free_thresh")
    for key, v in (("occupied_thresh", occ_th), ("free_thresh", free_th)):
        if not 0.0 <= v <= 1.0:
            raise MapFormatError(f"{fname}: {key} must be in [0, 1], got {v}")
    if free_th >= occ_th:
        raise MapFormatError(
            f"{fname}: free_thresh ({free_th}) must be below occupied_thresh ({occ_th})"
        )
    yaml_negate = doc.get("negate", 0)
    if yaml_negate not in (0, 1, True, False):
        raise MapFormatError(f"{fname}: negate must be 0 or 1, got {yaml_negate!r}")
    neg = bool(yaml_negate) if negate is None else bool(negate)
    mode = str(doc.get("mode", "trinary")).lower()
    if mode not in _ROS_MODES:
        raise MapFormatError(
            f"{fname}: unknown mode {doc['mode']!r}; use one of {', '.join(_ROS_MODES)}"
        )

    image = doc["image"]
    if not isinstance(image, str) or not image:
        raise MapFormatError(f"{fname}: image must be a file name, got {image!r}")
    img_path = Path(image) if Path(image).is_absolute() else path.parent / image
    _require_file(img_path, "image file", referenced_by=fname)
    pixels, has_alpha, maxval = _read_image(img_path)
    # ROS 1 averages alpha in with the colours in trinary mode ("to preserve existing behaviour").
    v = pixels.mean(axis=2) if mode == "trinary" else _grey(pixels, has_alpha)
    if neg:
        v = maxval - v
    occ = np.full(v.shape, -1, dtype=np.int8)
    if mode == "raw":
        occ[v <= 100 * free_th] = 0
        occ[(v >= 100 * occ_th) & (v <= 100)] = 1
    else:
        p = (maxval - v) / maxval
        occ[p > occ_th] = 1
        occ[p < free_th] = 0
    occ.setflags(write=False)
    meta = {
        "source": fname,
        "format": "ros",
        "image": img_path.name,
        "mode": mode,
        "negate": neg,
        "occupied_thresh": occ_th,
        "free_thresh": free_th,
        "occupancy": occ,
    }
    return Grid(
        occ == 0, name=path.stem, cell_size=cell_size, resolution=res, origin=origin, meta=meta
    )


def _yaml_number(v, fname: str, key: str) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise MapFormatError(f"{fname}: {key} must be a number, got {v!r}")
    return float(v)


# ------------------------------------------------------------------------------------------------
# images: PNM read here (Pillow cannot read ascii P2), everything else through Pillow
# ------------------------------------------------------------------------------------------------
_PNM_CHANNELS = {b"P2": 1, b"P5": 1, b"P3": 3, b"P6": 3}


def read_pnm(path) -> tuple[np.ndarray, int]:
    """Read a PGM/PPM file (P2/P5 grey, P3/P6 colour): ``(values (H, W[, 3]) int64, maxval)``.

    Comments (``#`` to the end of the line) are allowed anywhere in the header, and in the body of
    the ascii forms. Binary data with maxval > 255 is two bytes per sample, big-endian. Raises
    :class:`MapFormatError` on a bad magic number, a bad header, or truncated pixel data.
    """
    path = Path(path)
    fname = path.name
    data = path.read_bytes()
    magic = data[:2]
    if magic not in _PNM_CHANNELS:
        raise MapFormatError(
            f"{fname}: bad PGM magic number {magic!r}; expected b'P5' (binary) or b'P2' (ascii) "
            f"(or P6/P3 colour)"
        )
    channels = _PNM_CHANNELS[magic]
    # Header: three integers (width, height, maxval) separated by whitespace and/or comments.
    pos, fields = 2, []
    if pos >= len(data) or data[pos : pos + 1] not in b" \t\r\n#":
        raise MapFormatError(f"{fname}: malformed PGM header after the magic number")
    while len(fields) < 3:
        while pos < len(data) and data[pos : pos + 1] in b" \t\r\n\v\f":
            pos += 1
        if pos < len(data) and data[pos : pos + 1] == b"#":
            end = data.find(b"\n", pos)
            pos = len(data) if end < 0 else end + 1
            continue
        start = pos
        while pos < len(data) and data[pos : pos + 1] not in b" \t\r\n\v\f#":
            pos += 1
        token = data[start:pos]
        if not token:
            raise MapFormatError(f"{fname}: truncated PGM header (needs width, height and maxval)")
        if not token.isdigit():
            raise MapFormatError(f"{fname}: PGM header field {token!r} is not a positive integer")
        fields.append(int(token))
    w, h, maxval = fields
    if w < 1 or h < 1:
        raise MapFormatError(f"{fname}: PGM size must be positive, got {w}x{h}")
    if not 1 <= maxval <= 65535:
        raise MapFormatError(f"{fname}: PGM maxval must be in 1..65535, got {maxval}")
    n = w * h * channels
    shape = (h, w, channels) if channels > 1 else (h, w)
    if magic in (b"P5", b"P6"):
        pos += 1  # exactly one whitespace byte separates the header from the raster
        bps = 1 if maxval < 256 else 2
        raster = data[pos : pos + n * bps]
        if len(raster) < n * bps:
            raise MapFormatError(
                f"{fname}: truncated PGM pixel data: {w}x{h} needs {n * bps} bytes, "
                f"found {len(raster)}"
            )
        values = np.frombuffer(raster, dtype=np.uint8 if bps == 1 else ">u2").astype(np.int64)
    else:
        body = re.sub(rb"#[^\n]*", b" ", data[pos:])
        tokens = body.split()
        if len(tokens) < n:
            raise MapFormatError(
                f"{fname}: truncated PGM pixel data: {w}x{h} needs {n} values, found {len(tokens)}"
            )
        if len(tokens) > n:
            raise MapFormatError(
                f"{fname}: PGM has {len(tokens)} pixel values, {w}x{h} needs {n}"
            )
        try:
            values = np.array([int(t) for t in tokens], dtype=np.int64)
        except ValueError:
            bad = next(t for t in tokens if not t.isdigit())
            raise MapFormatError(f"{fname}: PGM pixel value {bad!r} is not an integer") from None
    if (values > maxval).any() or (values < 0).any():
        raise MapFormatError(f"{fname}: PGM pixel value above maxval {maxval}")
    return values.reshape(shape), maxval


def _read_image(path: Path) -> tuple[np.ndarray, bool, int]:
    """Pixels ``(H, W, C)`` as float, whether the last channel is alpha, and maxval."""
    if path.suffix.lower() in (".pgm", ".ppm", ".pnm"):
        values, maxval = read_pnm(path)
        if values.ndim == 2:
            values = values[..., None]
        return values.astype(np.float64), False, maxval
    try:
        from PIL import Image, UnidentifiedImageError
    except ImportError:  # pragma: no cover - pillow is a dependency
        raise MapFormatError(f"{path.name}: reading this image format needs Pillow") from None
    try:
        with Image.open(path) as img:
            img.load()
            if img.mode == "P":
                img = img.convert("RGBA" if "transparency" in img.info else "RGB")
            elif img.mode == "1":
                img = img.convert("L")
            mode = img.mode
            arr = np.asarray(img)
    except (UnidentifiedImageError, OSError, SyntaxError) as e:
        raise MapFormatError(f"{path.name}: cannot read image ({e})") from None
    if mode in ("I;16", "I;16B", "I;16L", "I"):
        return arr.astype(np.float64)[..., None], False, 65535
    if mode in ("L", "LA", "RGB", "RGBA"):
        arr = arr.astype(np.float64)
        return (arr if arr.ndim == 3 else arr[..., None]), mode.endswith("A"), 255
    raise MapFormatError(f"{path.name}: unsupported image mode {mode!r}")


def _grey(pixels: np.ndarray, has_alpha: bool) -> np.ndarray:
    """Mean of the colour channels (alpha left out)."""
    return pixels[..., :-1].mean(axis=2) if has_alpha else pixels.mean(axis=2)


def _load_image(
    path: Path, *, threshold: float = 0.5, negate: bool = False, cell_size: float = 1.0
) -> Grid:
    """An image as a map: free where ``brightness / maxval > threshold`` (``negate``: darkness)."""
    if not 0.0 <= threshold < 1.0:
        raise MapFormatError(f"threshold must be in [0, 1), got {threshold}")
    pixels, has_alpha, maxval = _read_image(path)
    level = _grey(pixels, has_alpha) / maxval
    if negate:
        level = 1.0 - level
    return Grid(
        level > threshold,
        name=path.stem,
        cell_size=cell_size,
        meta={"source": path.name, "format": "image", "threshold": threshold, "negate": negate},
    )


# ------------------------------------------------------------------------------------------------
# plain text and numpy
# ------------------------------------------------------------------------------------------------
def _load_text(path: Path, *, cell_size: float = 1.0) -> Grid:
    try:
        return Grid.from_rows(
            _read_text(path),
            name=path.stem,
            cell_size=cell_size,
            meta={"source": path.name, "format": "text"},
        )
    except MapFormatError as e:
        raise MapFormatError(f"{path.name}: {e}") from None


def save_text(grid: Grid, path) -> Path:
    """Write ``grid`` as a text map (``.`` free, ``@`` blocked); :func:`load` reads it back."""
    path = Path(path)
    path.write_text("\n".join(grid.to_rows()) + "\n", encoding="utf-8")
    return path


def _load_npy(path: Path, *, cell_size: float = 1.0) -> Grid:
    """A 2-D ``.npy`` array: bool (True = free) or integers in {0, 1} (1 = free)."""
    try:
        arr = np.load(path, allow_pickle=False)
    except (ValueError, OSError, EOFError) as e:
        raise MapFormatError(f"{path.name}: not a readable .npy array ({e})") from None
    if arr.ndim != 2 or arr.size == 0:
        raise MapFormatError(
            f"{path.name}: a map array must be 2-D and non-empty, got shape {arr.shape}"
        )
    if arr.dtype != np.bool_:
        if arr.dtype.kind not in "iu" or not np.isin(arr, (0, 1)).all():
            raise MapFormatError(
                f"{path.name}: a map array must be bool or 0/1 integers (1 = free), got dtype "
                f"{arr.dtype} with values {np.unique(arr)[:5].tolist()}"
            )
    meta = {"source": path.name, "format": "npy"}
    return Grid(arr.astype(bool), name=path.stem, cell_size=cell_size, meta=meta)


# ------------------------------------------------------------------------------------------------
# generators
# ------------------------------------------------------------------------------------------------
def _connected(grid: Grid, start, goal) -> bool:
    """Is ``goal`` reachable from ``start`` (8-connected, no corner cutting)?"""
    from .exact import reachable

    return bool(reachable(grid, start)[goal[0], goal[1]])


def _hw(size_or_hw) -> tuple[int, int]:
    if isinstance(size_or_hw, (tuple, list)):
        if len(size_or_hw) != 2:
            raise ProblemError(f"size must be an int or (height, width), got {size_or_hw!r}")
        h, w = size_or_hw
    else:
        h = w = size_or_hw
    if int(h) != h or int(w) != w or h < 1 or w < 1:
        raise ProblemError(f"map size must be positive integers, got {size_or_hw!r}")
    return int(h), int(w)


def _cell_arg(cell, h: int, w: int, what: str) -> tuple[int, int]:
    r, c = (int(v) for v in cell)
    if not (0 <= r < h and 0 <= c < w):
        raise ProblemError(f"{what} {(r, c)} is outside the {h}x{w} map")
    return r, c


def random_map(
    size_or_hw,
    p: float,
    seed: int,
    start=None,
    goal=None,
    *,
    method: str = "resample",
    max_tries: int = 1000,
) -> Grid:
    """A random map with obstacle ratio ``p`` whose ``start`` and ``goal`` are connected.

    Exactly ``round(p * H * W)`` cells are blocked (never ``start`` or ``goal``), drawn uniformly
    without replacement by ``numpy.random.default_rng(seed)``; the same arguments always give the
    same map.

    How a path is guaranteed (``method``):

    * ``"resample"`` (default): if ``goal`` is not reachable from ``start`` (8-connected moves, no
      corner cutting, :func:`jaco.exact.reachable`), draw a whole new map from the same seeded
      generator; give up with :class:`ProblemError` after ``max_tries`` draws. The map is an
      unconditioned draw given connectivity. Note that without corner cutting connectivity equals
      4-connectivity, whose percolation threshold is about 41 % obstacles: around p = 0.5 on
      30x30 and larger, resampling essentially never succeeds.
    * ``"carve"``: draw once, then clear a uniformly random monotone staircase (4-connected steps,
      each toward the goal) from ``start`` to ``goal``, and block as many other random free cells
      as the carving cleared, so the ratio stays exact (short of it only when the map is too small
      to hold the obstacles beside the corridor). Works for any ``p`` < 0.9, but the map then
      contains one planted corridor.

    Parameters
    ----------
    size_or_hw : int or (int, int)
        Side of a square map, or ``(H, W)``.
    p : float
        Obstacle ratio in [0, 0.9).
    seed : int
        Seed of the generator.
    start, goal : (row, col), optional
        Default to opposite corners ``(0, 0)`` and ``(H - 1, W - 1)``.

    Returns
    -------
    Grid
        Named ``random-{H}x{W}-p{p}-s{seed}``; ``meta`` has ``start``, ``goal``, ``p``, ``seed``,
        ``method`` and ``tries`` (draws used).
    """
    h, w = _hw(size_or_hw)
    if not (isinstance(p, numbers.Real) and 0.0 <= p < 0.9):
        raise ProblemError(f"obstacle ratio p must be in [0, 0.9), got {p!r}")
    if method not in ("resample", "carve"):
        raise ProblemError(f"method must be 'resample' or 'carve', got {method!r}")
    if int(max_tries) < 1:
        raise ProblemError(f"max_tries must be >= 1, got {max_tries!r}")
    start = _cell_arg((0, 0) if start is None else start, h, w, "start")
    goal = _cell_arg((h - 1, w - 1) if goal is None else goal, h, w, "goal")
    rng = np.random.default_rng(seed)
    n = h * w
    protected = {start[0] * w + start[1], goal[0] * w + goal[1]}
    allowed = np.ones(n, dtype=bool)
    allowed[list(protected)] = False
    candidates = np.flatnonzero(allowed)
    k = min(int(round(p * n)), candidates.size)
    name = f"random-{h}x{w}-p{p:g}-s{seed}"
    meta = {"start": start, "goal": goal, "p": float(p), "seed": seed, "method": method}

    tries = 1 if method == "carve" else int(max_tries)
    for attempt in range(1, tries + 1):
        flat = np.ones(n, dtype=bool)
        flat[rng.permutation(candidates)[:k]] = False
        if method == "carve":
            flat = _carve(flat, h, w, start, goal, rng, protected)
        grid = Grid(flat.reshape(h, w), name=name, meta={**meta, "tries": attempt})
        if _connected(grid, start, goal):
            return grid
    if method == "carve":  # pragma: no cover - the staircase always connects
        raise AssertionError("carved map is not connected")
    raise ProblemError(
        f"no {h}x{w} map with obstacle ratio {p} connects {start} to {goal} in {max_tries} draws "
        f"(seed {seed}); lower p, raise max_tries, or use method='carve'"
    )


def _carve(flat, h, w, start, goal, rng, protected) -> np.ndarray:
    """Clear a random monotone staircase start -> goal, then re-block as many cells elsewhere."""
    dr, dc = goal[0] - start[0], goal[1] - start[1]
    steps = np.array([0] * abs(dr) + [1] * abs(dc))
    rng.shuffle(steps)  # a uniformly random monotone lattice path
    r, c = start
    path = [r * w + c]
    for s in steps:
        if s == 0:
            r += int(np.sign(dr))
        else:
            c += int(np.sign(dc))
        path.append(r * w + c)
    path = np.array(path)
    cleared = int((~flat[path]).sum())
    flat = flat.copy()
    flat[path] = True
    if cleared:
        keep_free = np.zeros_like(flat)
        keep_free[path] = True
        keep_free[list(protected)] = True
        spare = np.flatnonzero(flat & ~keep_free)
        flat[rng.choice(spare, size=min(cleared, spare.size), replace=False)] = False
    return flat


def _with_endpoints(free: np.ndarray, name: str, start, goal, **meta) -> Grid:
    grid = Grid(free, name=name, meta={"start": tuple(start), "goal": tuple(goal), **meta})
    if not (grid.is_free(start) and grid.is_free(goal) and _connected(grid, start, goal)):
        raise ProblemError(f"map {name!r}: goal {goal} is not reachable from start {start}")
    return grid


def utrap(size: int = 20) -> Grid:
    """A square map with a concave U-shaped trap (thesis §5: 15x15, 20x20, 30x30).

    The U is a one-cell-thick wall: two horizontal arms and a vertical back wall on the right;
    its opening faces left, away from the goal on the right edge. The start is in the middle of
    the pocket, so a walker that greedily heads for the goal runs into the back wall and must
    first walk out of the opening and around an arm. ``meta["start"]`` = middle of the pocket,
    ``meta["goal"]`` = ``(size // 2, size - 1)``; ``meta["trap"]`` = ``(top, bottom, left, right)``
    rows/columns of the U's walls.
    """
    n = int(size)
    if n < 7:
        raise ProblemError(f"a U trap needs size >= 7, got {size}")
    m = max(2, n // 5)  # free margin around the trap
    top, bottom, left, right = m, n - 1 - m, m, n - 1 - m
    free = np.ones((n, n), dtype=bool)
    free[top, left : right + 1] = False
    free[bottom, left : right + 1] = False
    free[top : bottom + 1, right] = False
    start = (n // 2, (left + right) // 2)
    goal = (n // 2, n - 1)
    return _with_endpoints(free, f"utrap-{n}", start, goal, trap=(top, bottom, left, right))


def _corners(n: int):
    return (0, 0), (n - 1, n - 1)


def wall(size: int = 40) -> Grid:
    """Thesis fig. 4-9 "Wall": a 2-thick wall across the middle row band with one gap at 3/4 width.

    Start ``(0, 0)``, goal ``(size-1, size-1)``.
    """
    n = int(size)
    free = np.ones((n, n), dtype=bool)
    free[n // 2 - 1 : n // 2 + 1, :] = False
    g0 = (3 * n) // 4
    free[n // 2 - 1 : n // 2 + 1, g0 : g0 + max(2, n // 10)] = True
    return _with_endpoints(free, f"wall-{n}", *_corners(n))


def circle(size: int = 40) -> Grid:
    """Thesis fig. 4-9 "Circle": a disc of radius size/4 in the centre.

    Start ``(0, 0)``, goal ``(size-1, size-1)``.
    """
    n = int(size)
    rr, cc = np.mgrid[0:n, 0:n]
    c = (n - 1) / 2
    free = np.hypot(rr - c, cc - c) > n / 4
    return _with_endpoints(free, f"circle-{n}", *_corners(n))


def h_shape(size: int = 40) -> Grid:
    """Thesis fig. 4-9 "H": two 2-wide vertical bars joined by a crossbar in the middle.

    The H's upper pocket opens toward the start ``(0, 0)`` and the crossbar blocks the diagonal to
    the goal ``(size-1, size-1)``, so it also acts as a trap.
    """
    n = int(size)
    free = np.ones((n, n), dtype=bool)
    r0, r1 = n // 5, n - n // 5  # bar rows [r0, r1)
    a, b = n // 4, n - n // 4  # left bar starts at a, right bar ends at b (exclusive)
    free[r0:r1, a : a + 2] = False
    free[r0:r1, b - 2 : b] = False
    free[n // 2 - 1 : n // 2 + 1, a:b] = False
    return _with_endpoints(free, f"h-{n}", *_corners(n))


def s_shape(size: int = 40) -> Grid:
    """Thesis fig. 4-9 "S": three 2-thick horizontal bars joined left-top and right-bottom.

    The upper pocket opens right, the lower pocket left. Start ``(0, 0)``, goal opposite.
    """
    n = int(size)
    free = np.ones((n, n), dtype=bool)
    a, b, mid = n // 5, n - n // 5, n // 2
    free[a : a + 2, a:b] = False  # top bar
    free[a : mid + 1, a : a + 2] = False  # upper-left upright
    free[mid - 1 : mid + 1, a:b] = False  # middle bar
    free[mid - 1 : b, b - 2 : b] = False  # lower-right upright
    free[b - 2 : b, a:b] = False  # bottom bar
    return _with_endpoints(free, f"s-{n}", *_corners(n))


def _rect_map(h, w, n_rects, sides, seed, start, goal, name) -> Grid:
    """Axis-aligned rectangles of random sides in ``sides`` placed by ``default_rng(seed)``.

    Rectangles keep clear of ``start``/``goal``; a layout that disconnects them is redrawn.
    """
    rng = np.random.default_rng(seed)
    for _ in range(1000):
        free = np.ones((h, w), dtype=bool)
        placed = 0
        while placed < n_rects:
            rh, rw = (int(v) for v in rng.integers(sides[0], sides[1] + 1, size=2))
            r0, c0 = int(rng.integers(0, h - rh + 1)), int(rng.integers(0, w - rw + 1))
            if any(r0 - 1 <= r <= r0 + rh and c0 - 1 <= c <= c0 + rw for r, c in (start, goal)):
                continue  # keep a free ring around the endpoints
            free[r0 : r0 + rh, c0 : c0 + rw] = False
            placed += 1
        grid = Grid(free, name=name, meta={"start": start, "goal": goal, "seed": seed})
        if _connected(grid, start, goal):
            return grid
    raise ProblemError(f"could not draw a connected {name}")  # pragma: no cover


def simple_20() -> Grid:
    """Look-alike of seed 003's 20x20 "simple" map: a few scattered rectangles (seed 3020).

    The paper gives start (0, 0) and goal (20, 20) as lattice corners with y up, i.e. the
    bottom-left and top-right cells: start ``(19, 0)``, goal ``(0, 19)`` as (row, col).
    """
    return _rect_map(20, 20, 7, (2, 4), 3020, (19, 0), (0, 19), "simple-20")


def complex_30() -> Grid:
    """Look-alike of seed 003's 30x30 "complex" map: many rectangles of sides 2..6 (seed 3030).

    The paper's start (0, 30) and goal (30, 0) are lattice corners with y up, i.e. the top-left and
    bottom-right cells: start ``(0, 0)``, goal ``(29, 29)`` as (row, col).
    """
    return _rect_map(30, 30, 18, (2, 6), 3030, (0, 0), (29, 29), "complex-30")


# A small default map (20 x 30) for examples and the CLI: two offset walls and a block, so the
# optimal path snakes over the first wall and under the second rather than going straight.
DEMO_ROWS = (
    ".........#....................",
    ".........#....................",
    ".........#....................",
    ".........#..........#.........",
    ".........#..........#.........",
    "....................#.........",
    "....................#.........",
    "....................#.........",
    ".............####...#.........",
    ".........#...####...#.........",
    ".........#...####...#.........",
    ".........#...####...#.........",
    ".........#..........#.........",
    ".........#..........#.........",
    ".........#..........#.........",
    ".........#..........#.........",
    ".........#..........#.........",
    ".........#..........#.........",
    ".........#....................",
    ".........#....................",
)
DEMO_START = (17, 2)
DEMO_GOAL = (2, 27)


def demo() -> Grid:
    """The embedded 20x30 demo map (:data:`DEMO_ROWS`), start ``(17, 2)``, goal ``(2, 27)``."""
    grid = Grid.from_rows(DEMO_ROWS)
    return _with_endpoints(grid.free, "demo", DEMO_START, DEMO_GOAL)


def _named_random(size: int, p: float) -> Callable[[], Grid]:
    # p = 0.5 is above the connectivity threshold (see random_map): those maps are carved.
    method = "carve" if p >= 0.5 else "resample"

    def make() -> Grid:
        g = random_map(size, p, seed=size * 100 + int(round(p * 100)), method=method)
        return g.replace(name=f"random-{size}-{int(round(p * 100)):02d}")

    make.__doc__ = f"{size}x{size} random map, obstacle ratio {p} ({method})."
    return make


#: Named maps: name -> zero-argument function that builds the :class:`Grid`.
NAMED: dict[str, Callable[[], Grid]] = {
    "demo": demo,
    "utrap-15": lambda: utrap(15),
    "utrap-20": lambda: utrap(20),
    "utrap-30": lambda: utrap(30),
    "wall-40": lambda: wall(40),
    "circle-40": lambda: circle(40),
    "h-40": lambda: h_shape(40),
    "s-40": lambda: s_shape(40),
    "simple-20": simple_20,
    "complex-30": complex_30,
    **{
        f"random-{n}-{int(round(p * 100)):02d}": _named_random(n, p)
        for n in (20, 30, 40)
        for p in (0.05, 0.1, 0.3, 0.5)
    },
}


def named(name: str) -> Grid:
    """Build the named map ``name`` (see :data:`NAMED`); its start/goal are in ``meta``."""
    try:
        make = NAMED[name]
    except (KeyError, TypeError):
        raise ProblemError(
            f"unknown map name {name!r}; valid names: {', '.join(sorted(NAMED))}"
        ) from None
    return make()


__all__ = [
    "BUNDLED",
    "DATA_DIR",
    "NAMED",
    "Scenario",
    "bundled",
    "circle",
    "complex_30",
    "demo",
    "h_shape",
    "load",
    "load_bundled",
    "load_scenarios",
    "named",
    "random_map",
    "read_pnm",
    "s_shape",
    "save_text",
    "simple_20",
    "utrap",
    "wall",
]
