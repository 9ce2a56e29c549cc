"""Images as maps (``.png``, ``.pgm``, ``.ppm``, ``.bmp``), read through Pillow.

A pixel is free when its brightness over the format's largest value (``maxval``) is above a
threshold. Pillow decodes every format; for PGM/PPM it keeps the samples as the file has them when
``maxval`` is 255, or 65535 in a grey map, but stretches any other ``maxval`` to the full 8 or 16
bits (with rounding: a value 50 of ``maxval`` 100 becomes 128 of 255, brighter than half) and cuts
16-bit colour to 8 bits. For those files, and for every plain (ascii, P2/P3) file, whose values
Pillow does not count, :func:`read_pnm` reads the raster itself, so that ``value / maxval`` is
exactly the file's and a file with more or fewer values than its size is refused.
"""

from __future__ import annotations

import os
import re
import warnings
from pathlib import Path

import numpy as np

from ..errors import MapFormatError
from ..grid import Grid

_PNM_CHANNELS = {b"P2": 1, b"P5": 1, b"P3": 3, b"P6": 3}


def _pillow(path: Path) -> tuple[np.ndarray, str]:
    """The decoded pixels and Pillow's mode (palette images expanded, bilevel ones as grey)."""
    try:
        from PIL import Image, UnidentifiedImageError
    except ImportError:  # pragma: no cover - pillow is a dependency
        raise MapFormatError(f"{path.name}: reading this image format needs Pillow") from None
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", Image.DecompressionBombWarning)  # the size is checked below
            img: Image.Image = Image.open(path)
        with img:
            # Pillow's decompression-bomb limit (about 89 million pixels), checked before decoding
            w, h, limit = *img.size, Image.MAX_IMAGE_PIXELS
            if limit is not None and w * h > limit:
                raise Image.DecompressionBombError(
                    f"{w}x{h} = {w * h} pixels, more than PIL.Image.MAX_IMAGE_PIXELS = {limit}"
                )
            img.load()
            if img.mode == "P":
                img = img.convert("RGBA" if "transparency" in img.info else "RGB")
            elif img.mode == "1":
                img = img.convert("L")
            return np.asarray(img), img.mode
    except Image.DecompressionBombError as e:
        raise MapFormatError(f"{path.name}: image too large for a map ({e})") from None
    except (UnidentifiedImageError, OSError, SyntaxError, ValueError, EOFError) as e:
        raise MapFormatError(f"{path.name}: cannot read image ({e})") from None


def _pnm_header(data: bytes, fname: str) -> tuple[bytes, int, int, int, int]:
    """``(magic, width, height, maxval, end of the header)`` of a PGM/PPM file.

    Comments (``#`` to the end of the line) are allowed anywhere in the header. Raises
    :class:`MapFormatError` on a bad magic number or a bad header."""
    magic = data[:2]
    if magic not in _PNM_CHANNELS:
        raise MapFormatError(
            f"{fname}: bad PGM magic number {magic!r}; expected b'P5' (binary) or b'P2' (ascii) (or P6/P3 colour)"
        )
    # Three integers (width, height, maxval) separated by whitespace and/or comments.
    pos, fields = 2, list[int]()
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
    return magic, w, h, maxval, pos


def _pnm_raster(data: bytes, fname: str) -> np.ndarray:
    """The samples ``(H, W[, 3])`` of a PGM/PPM file as written, whatever its ``maxval``.

    Binary data with maxval > 255 is two bytes per sample, big-endian; the ascii forms may hold
    comments in the body too. Raises :class:`MapFormatError` on truncated pixel data or a value
    above maxval."""
    magic, w, h, maxval, pos = _pnm_header(data, fname)
    channels = _PNM_CHANNELS[magic]
    n = w * h * channels
    shape = (h, w, channels) if channels > 1 else (h, w)
    if magic in (b"P5", b"P6"):
        pos += 1  # exactly one whitespace byte separates the header from the raster
        bps = 1 if maxval < 256 else 2
        raster = data[pos : pos + n * bps]
        if len(raster) < n * bps:
            raise MapFormatError(
                f"{fname}: truncated PGM pixel data: {w}x{h} needs {n * bps} bytes, found {len(raster)}"
            )
        values = np.frombuffer(raster, dtype=np.uint8 if bps == 1 else ">u2").astype(np.int64)
    else:
        body = re.sub(rb"#[^\n]*", b" ", data[pos:])
        tokens = body.split()
        if len(tokens) != n:  # a plain (ascii) file holds exactly one image
            what = "truncated PGM pixel data" if len(tokens) < n else "extra PGM pixel values"
            per_pixel = " (3 per pixel)" if channels > 1 else ""
            raise MapFormatError(f"{fname}: {what}: {w}x{h} needs {n} values{per_pixel}, found {len(tokens)}")
        bad = next((t for t in tokens if not t.isdigit()), None)  # "-1", "+5", "1.5" are not samples
        if bad is not None:
            raise MapFormatError(f"{fname}: PGM pixel value {bad!r} is not an integer in 0..maxval")
        values = np.array([int(t) for t in tokens], dtype=np.int64)
    if (values > maxval).any() or (values < 0).any():
        raise MapFormatError(f"{fname}: PGM pixel value above maxval {maxval}")
    return values.reshape(shape)


def read_pnm(path: str | os.PathLike) -> tuple[np.ndarray, int]:
    """Read a PGM/PPM file (P2/P5 grey, P3/P6 colour): ``(values (H, W[, 3]) int64, maxval)``.

    The values are the file's samples, ``0..maxval``. Pillow decodes binary files whose samples
    it keeps as they are (``maxval`` 255, or 65535 in a grey map); the others, and every plain
    (ascii) file, are read by :func:`_pnm_raster` (see the module docstring). Raises
    :class:`MapFormatError` on a bad magic number, a bad header, or pixel data that cannot be
    read, e.g. a plain file with more or fewer values than width x height (x 3).
    """
    path = Path(path)
    data = path.read_bytes()
    magic, _, _, maxval, _ = _pnm_header(data, path.name)
    # Pillow decodes a plain (ascii) file without counting its values: extra ones pass silently
    if magic in (b"P5", b"P6") and (maxval == 255 or (maxval == 65535 and _PNM_CHANNELS[magic] == 1)):
        values, _ = _pillow(path)
        return values.astype(np.int64), maxval
    return _pnm_raster(data, path.name), maxval


def read_image(path: Path) -> tuple[np.ndarray, bool, int]:
    """Pixels ``(H, W, C)`` as float, whether the last channel is alpha, and maxval."""
    if path.suffix.lower() in (".pgm", ".ppm", ".pnm"):
        values, maxval = read_pnm(path)
        if values.ndim == 2:
            values = values[..., None]
        return values.astype(np.float64), False, maxval
    arr, mode = _pillow(path)
    if mode in ("I;16", "I;16B", "I;16L", "I"):
        return arr.astype(np.float64)[..., None], False, 65535
    if mode in ("L", "LA", "RGB", "RGBA"):
        arr = arr.astype(np.float64)
        return (arr if arr.ndim == 3 else arr[..., None]), mode.endswith("A"), 255
    raise MapFormatError(f"{path.name}: unsupported image mode {mode!r}")


def grey(pixels: np.ndarray, has_alpha: bool) -> np.ndarray:
    """Mean of the colour channels (alpha left out)."""
    return pixels[..., :-1].mean(axis=2) if has_alpha else pixels.mean(axis=2)


def load_image(path: Path, *, threshold: float = 0.5, negate: bool = False, cell_size: float = 1.0) -> Grid:
    """An image as a map: free where ``brightness / maxval > threshold`` (``negate``: darkness)."""
    if isinstance(threshold, bool) or not isinstance(threshold, (int, float)) or not 0.0 <= threshold < 1.0:
        raise MapFormatError(f"threshold must be a number in [0, 1), got {threshold!r}")
    pixels, has_alpha, maxval = read_image(path)
    level = grey(pixels, has_alpha) / maxval
    if negate:
        level = 1.0 - level
    return Grid(
        level > threshold,
        name=path.stem,
        cell_size=cell_size,
        meta={"source": path.name, "format": "image", "threshold": threshold, "negate": negate},
    )
