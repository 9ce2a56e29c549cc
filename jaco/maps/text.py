"""Plain maps: text (``.`` free, ``#`` or ``@`` blocked) and numpy ``.npy`` arrays (True / 1 = free)."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ..errors import MapFormatError
from ..grid import Grid
from ..outputs import check_output, write_text
from .files import read_text


def load_text(path: Path, *, cell_size: float = 1.0) -> Grid:
    try:
        return Grid.from_rows(
            read_text(path),
            name=path.stem,
            cell_size=cell_size,
            meta={"source": path.name, "format": "text"},
        )
    except MapFormatError as e:
        raise MapFormatError(f"{path.name}: {e}") from None


def save_text(grid: Grid, path: str | os.PathLike) -> Path:
    """Write ``grid`` as a text map (``.`` free, ``@`` blocked); :func:`load` reads it back."""
    path = check_output(path, "text map", suffixes=(".txt",))
    return write_text(path, "\n".join(grid.to_rows()) + "\n", "text map")


def load_npy(path: Path, *, cell_size: float = 1.0) -> Grid:
    """A 2-D ``.npy`` array: bool (True = free) or integers in {0, 1} (1 = free)."""
    try:
        arr = np.load(path, allow_pickle=False)
    except (ValueError, OSError, EOFError) as e:
        raise MapFormatError(f"{path.name}: not a readable .npy array ({e})") from None
    if arr.ndim != 2 or arr.size == 0:
        raise MapFormatError(f"{path.name}: a map array must be 2-D and non-empty, got shape {arr.shape}")
    if arr.dtype != np.bool_:
        if arr.dtype.kind not in "iu" or not np.isin(arr, (0, 1)).all():
            raise MapFormatError(
                f"{path.name}: a map array must be bool or 0/1 integers (1 = free), got dtype "
                f"{arr.dtype} with values {np.unique(arr)[:5].tolist()}"
            )
    meta = {"source": path.name, "format": "npy"}
    return Grid(arr.astype(bool), name=path.stem, cell_size=cell_size, meta=meta)
