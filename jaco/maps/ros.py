"""ROS map_server maps: a yaml (image, resolution, origin, thresholds, negate, mode) and an image."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..errors import MapFormatError
from ..grid import Grid
from .files import read_text, require_file
from .image import grey, read_image

_ROS_MODES = ("trinary", "scale", "raw")


def load_ros(path: Path, *, negate: bool | None = None, cell_size: float = 1.0) -> Grid:
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
    fname = path.name
    doc = _ros_yaml(path)
    res, origin = _ros_frame(doc, fname)
    occ_th, free_th = _ros_thresholds(doc, fname)
    yaml_negate = doc.get("negate", 0)
    if yaml_negate not in (0, 1, True, False):
        raise MapFormatError(f"{fname}: negate must be 0 or 1, got {yaml_negate!r}")
    neg = bool(yaml_negate) if negate is None else bool(negate)
    mode = str(doc.get("mode", "trinary")).lower()
    if mode not in _ROS_MODES:
        raise MapFormatError(f"{fname}: unknown mode {doc['mode']!r}; use one of {', '.join(_ROS_MODES)}")

    image = doc["image"]
    if not isinstance(image, str) or not image:
        raise MapFormatError(f"{fname}: image must be a file name, got {image!r}")
    img_path = Path(image) if Path(image).is_absolute() else path.parent / image
    require_file(img_path, "image file", referenced_by=fname)
    pixels, has_alpha, maxval = read_image(img_path)
    # ROS 1 averages alpha in with the colours in trinary mode ("to preserve existing behaviour").
    v = pixels.mean(axis=2) if mode == "trinary" else grey(pixels, has_alpha)
    if neg:
        v = maxval - v
    occ = _occupancy(v, mode, maxval, occ_th, free_th)
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
    return Grid(occ == 0, name=path.stem, cell_size=cell_size, resolution=res, origin=origin, meta=meta)


def _ros_yaml(path: Path) -> dict:
    """The map's yaml document, a mapping with every required key."""
    import yaml

    fname = path.name
    try:
        doc = yaml.safe_load(read_text(path))
    except yaml.YAMLError as e:
        raise MapFormatError(f"{fname}: not valid YAML ({e})") from None
    if not isinstance(doc, dict):
        raise MapFormatError(f"{fname}: a ROS map yaml must be a mapping of keys, got {type(doc).__name__}")
    required = ("image", "resolution", "origin", "occupied_thresh", "free_thresh")
    missing = [k for k in required if k not in doc]
    if missing:
        raise MapFormatError(f"{fname}: missing key(s) {', '.join(missing)} (required: {', '.join(required)})")
    return doc


def _ros_frame(doc: dict, fname: str) -> tuple[float, tuple[float, float, float]]:
    """``resolution`` (metres per cell) and ``origin`` ``(x, y, yaw)``, checked."""
    res = _yaml_number(doc["resolution"], fname, "resolution")
    if not math.isfinite(res) or res <= 0:
        raise MapFormatError(
            f"{fname}: resolution must be a positive number of metres per cell, got {doc['resolution']!r}"
        )
    origin = doc["origin"]
    if not isinstance(origin, (list, tuple)) or len(origin) != 3:
        raise MapFormatError(f"{fname}: origin must be a list [x, y, yaw], got {origin!r}")
    x, y, yaw = (_yaml_number(v, fname, "origin") for v in origin)
    if not all(math.isfinite(v) for v in (x, y, yaw)):
        raise MapFormatError(f"{fname}: origin must be finite, got {doc['origin']!r}")
    return res, (x, y, yaw)


def _ros_thresholds(doc: dict, fname: str) -> tuple[float, float]:
    """``occupied_thresh`` and ``free_thresh``, each in [0, 1], free below occupied."""
    occ_th = _yaml_number(doc["occupied_thresh"], fname, "occupied_thresh")
    free_th = _yaml_number(doc["free_thresh"], fname, "free_thresh")
    for key, th in (("occupied_thresh", occ_th), ("free_thresh", free_th)):
        if not 0.0 <= th <= 1.0:
            raise MapFormatError(f"{fname}: {key} must be in [0, 1], got {th}")
    if free_th >= occ_th:
        raise MapFormatError(f"{fname}: free_thresh ({free_th}) must be below occupied_thresh ({occ_th})")
    return occ_th, free_th


def _occupancy(v: np.ndarray, mode: str, maxval: float, occ_th: float, free_th: float) -> np.ndarray:
    """Read-only int8 codes of the pixel values ``v`` (0 free, 1 occupied, -1 unknown) by ``mode``
    (see :func:`load_ros`)."""
    occ = np.full(v.shape, -1, dtype=np.int8)
    if mode == "raw":
        occ[v <= 100 * free_th] = 0
        occ[(v >= 100 * occ_th) & (v <= 100)] = 1
    else:
        p = (maxval - v) / maxval
        occ[p > occ_th] = 1
        occ[p < free_th] = 0
    occ.setflags(write=False)
    return occ


def _yaml_number(v, fname: str, key: str) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise MapFormatError(f"{fname}: {key} must be a number, got {v!r}")
    return float(v)
