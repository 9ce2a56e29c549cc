"""Maps: file loaders, the bundled benchmark maps, and seeded generators of the papers' test maps.

Loaders (:func:`load` dispatches on the file suffix)

* MovingAI ``.map`` (Sturtevant 2012): ``.``, ``G``, ``S`` passable; ``@``, ``O``, ``T``, ``W``
  blocked.
* ROS map_server ``.yaml`` + image (through Pillow, :mod:`jaco.maps.image`), with the
  trinary/scale/raw rules of ROS 1 ``map_server/src/image_loader.cpp``. Unknown cells are not free.
* Plain text ``.txt``: ``.`` free, ``#`` or ``@`` blocked (:func:`save_text` writes it).
* numpy ``.npy``: a 2-D boolean array, or integers in {0, 1}; True / 1 = free.
* Images ``.png``, ``.pgm``, ``.ppm``, ``.bmp``: a pixel is free when its brightness is above a
  threshold.

:func:`load_scenarios` reads MovingAI ``.scen`` files (9 tab-separated columns, ``version 1``);
:func:`select_scenarios` picks queries from them by position, bucket, optimal length or as n
spread over the lengths.

Every file-format problem raises :class:`~jaco.errors.MapFormatError` naming the file (and the line
where there is one). The package never reads outside ``jaco/maps/data`` at run time: :func:`bundled`
and :func:`load_bundled` give the bundled copies (see ``jaco/maps/data/*/SOURCES.md`` for their
origin).

Generators (all seeded with ``numpy.random.default_rng``; every named map is connected start to goal
under 8-connected moves without corner cutting, and carries ``meta["start"]`` / ``meta["goal"]``):
:func:`random_map`, :func:`utrap`, :func:`wall`, :func:`circle`, :func:`h_shape`, :func:`s_shape`,
:func:`simple_20`, :func:`complex_30`, :func:`demo`; the registry :data:`NAMED` and :func:`named`.

Modules: :mod:`.files` (bundled data, shared file checks), the formats :mod:`.movingai`,
:mod:`.ros`, :mod:`.image`, :mod:`.text` (text and ``.npy``), :mod:`.generators` and
:mod:`.catalogue` (the named maps). This module is the public face: every name below.
"""

from __future__ import annotations

import os
from typing import Any

from ..errors import MapFormatError
from ..grid import Grid
from ..outputs import as_path
from .catalogue import DEMO_GOAL, DEMO_ROWS, DEMO_START, NAMED, demo, named
from .files import BUNDLED, DATA_DIR, SUPPORTED_SUFFIXES, bundled, require_file
from .generators import circle, complex_30, h_shape, random_map, s_shape, simple_20, utrap, wall
from .image import load_image, read_pnm
from .movingai import MOVINGAI_BLOCKED, MOVINGAI_PASSABLE, Scenario, load_movingai, load_scenarios, select_scenarios
from .ros import load_ros
from .text import load_npy, load_text, save_text


def load(
    path: str | os.PathLike,
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
    path = as_path(path, "map file", MapFormatError)
    if isinstance(threshold, bool) or not isinstance(threshold, (int, float)) or not 0.0 <= threshold < 1.0:
        raise MapFormatError(f"threshold must be a number in [0, 1), got {threshold!r}")
    suffix = path.suffix.lower()
    if suffix == ".scen":
        raise MapFormatError(f"{path.name} is a scenario file: read it with load_scenarios()")
    if suffix not in SUPPORTED_SUFFIXES:
        raise MapFormatError(
            f"unsupported map file suffix {path.suffix or '(none)'!r} for {path.name}; "
            f"supported: {', '.join(SUPPORTED_SUFFIXES)}"
        )
    require_file(path, "map file")
    kw = {"cell_size": cell_size}
    if suffix == ".map":
        grid = load_movingai(path, **kw)
    elif suffix in (".yaml", ".yml"):
        grid = load_ros(path, negate=negate, **kw)
    elif suffix == ".txt":
        grid = load_text(path, **kw)
    elif suffix == ".npy":
        grid = load_npy(path, **kw)
    else:
        grid = load_image(path, threshold=threshold, negate=bool(negate), **kw)
    return grid.replace(name=name) if name is not None else grid


def load_bundled(name: str, **kw: Any) -> Grid:
    """``load(bundled(name), **kw)``: a bundled map as a :class:`Grid`."""
    return load(bundled(name), **kw)


__all__ = [
    "BUNDLED",
    "DATA_DIR",
    "DEMO_GOAL",
    "DEMO_ROWS",
    "DEMO_START",
    "MOVINGAI_BLOCKED",
    "MOVINGAI_PASSABLE",
    "NAMED",
    "SUPPORTED_SUFFIXES",
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
    "select_scenarios",
    "simple_20",
    "utrap",
    "wall",
]
