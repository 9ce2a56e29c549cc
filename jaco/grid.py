"""The occupancy grid a user hands to jaco.

Cells are ``(row, col)`` with row 0 at the top, as an image is shown; the flat index of a cell is
``row * W + col`` (thesis eq. 3-1). Cells are unit squares: ``cell_size`` only scales the lengths
jaco reports (the thesis uses 10). Maps read from ROS map_server files also carry ``resolution``
(metres per cell) and ``origin`` (x, y, yaw of the lower-left corner of the lower-left cell), so
cells convert to world coordinates and back.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from functools import cached_property
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from .errors import MapFormatError, ProblemError

#: A cell as ``(row, col)``: a tuple, list or array of two integers.
Cell = Sequence[int] | np.ndarray

FREE_TEXT = "."
BLOCKED_TEXT = "#@"


@dataclass(frozen=True, eq=False)
class Grid:
    """A 2-D occupancy grid: ``free[row, col]`` is True where a robot may stand."""

    free: np.ndarray
    name: str = "grid"
    cell_size: float = 1.0
    resolution: float | None = None
    origin: tuple[float, float, float] | None = None
    meta: dict = field(default_factory=dict)

    def __post_init__(self):
        try:
            free = np.asarray(self.free)
        except (TypeError, ValueError):  # ragged rows
            raise ProblemError("a grid needs a rectangular 2-D free mask; its rows have different lengths") from None
        if free.dtype == object:
            raise ProblemError("a grid needs a rectangular 2-D boolean free mask (or 0/1 integers), got objects")
        if free.ndim != 2:
            raise ProblemError(f"a grid needs a 2-D free mask, got shape {free.shape}")
        if free.shape[0] < 1 or free.shape[1] < 1:
            raise ProblemError(f"a grid needs at least one cell, got shape {free.shape}")
        if free.dtype != np.bool_:
            if free.dtype.kind not in "biu" or not np.isin(free, (0, 1)).all():
                raise ProblemError(f"the free mask must be boolean (or 0/1 integers), got dtype {free.dtype}")
            free = free.astype(bool)
        if isinstance(self.cell_size, bool) or not isinstance(self.cell_size, (int, float, np.integer, np.floating)):
            raise ProblemError(
                f"cell_size must be a positive number (float), got {type(self.cell_size).__name__} {self.cell_size!r}"
            )
        # a Python int past int64 is no number numpy computes with (and np.isfinite refuses it)
        if isinstance(self.cell_size, int) and not 0 < self.cell_size < 2**63:
            raise ProblemError(f"cell_size must be a positive number below 2**63, got {self.cell_size}")
        if not np.isfinite(self.cell_size) or self.cell_size <= 0:
            raise ProblemError(f"cell_size must be a positive number, got {self.cell_size}")
        if not isinstance(self.name, str):
            raise ProblemError(f"name must be a str, got {type(self.name).__name__} {self.name!r}")
        if not isinstance(self.meta, dict):
            raise ProblemError(f"meta must be a dict, got {type(self.meta).__name__}")
        free = np.ascontiguousarray(free)
        free.setflags(write=False)
        object.__setattr__(self, "free", free)

    # -- constructors ------------------------------------------------------------------------
    @classmethod
    def from_array(cls, free: np.ndarray, **meta: Any) -> Grid:
        """A grid from a boolean mask ``(H, W)``, True = free."""
        return cls(free, **meta)  # checked (and made an array) by __post_init__

    @classmethod
    def from_rows(cls, rows: Sequence[str], **meta: Any) -> Grid:
        """A grid from text rows: ``.`` free, ``#`` or ``@`` blocked. All rows must be equally long.

        ``rows`` is a list of strings or one string of lines (``\n`` or ``\r\n`` line ends); blank
        lines at the start and end are ignored."""
        if isinstance(rows, str):
            rows = rows.split("\n")
        elif isinstance(rows, (bytes, bytearray)) or not hasattr(rows, "__iter__"):
            raise MapFormatError(f"a text map is a str or a list of str rows, got {type(rows).__name__}")
        rows = list(rows)
        for i, r in enumerate(rows):
            if not isinstance(r, str):
                raise MapFormatError(f"a text map is a str or a list of str rows; row {i} is {type(r).__name__} {r!r}")
        rows = [r[:-1] if r.endswith("\r") else r for r in rows]
        while rows and not rows[-1].strip():
            rows.pop()
        while rows and not rows[0].strip():
            rows.pop(0)
        if not rows:
            raise MapFormatError("a text map needs at least one row")
        width = len(rows[0])
        for i, r in enumerate(rows):
            if len(r) != width:
                raise MapFormatError(f"row {i} has {len(r)} cells, row 0 has {width}")
            bad = set(r) - set(FREE_TEXT + BLOCKED_TEXT)
            if bad:
                raise MapFormatError(
                    f"unknown map symbol {sorted(bad)[0]!r} in row {i}; use '.' (free) or '#'/'@' (blocked)"
                )
        free = np.array([[ch == FREE_TEXT for ch in r] for r in rows], dtype=bool)
        return cls(free, **meta)

    # -- shape and indexing ------------------------------------------------------------------
    @property
    def shape(self) -> tuple[int, int]:
        return self.free.shape

    @property
    def height(self) -> int:
        return self.free.shape[0]

    @property
    def width(self) -> int:
        return self.free.shape[1]

    @property
    def n_cells(self) -> int:
        return self.free.size

    @cached_property
    def n_free(self) -> int:  # counted once: the cells cannot change
        return int(self.free.sum())

    def index(self, cell: Cell) -> int:
        """Flat index ``row * W + col`` of a ``(row, col)`` cell."""
        r, c = cell
        return int(r) * self.width + int(c)

    def cell(self, index: int) -> tuple[int, int]:
        """``(row, col)`` of a flat index."""
        return divmod(int(index), self.width)

    def in_bounds(self, cell: Cell) -> bool:
        r, c = cell
        return 0 <= r < self.height and 0 <= c < self.width

    def check_cell(self, cell: Cell, what: str = "cell") -> tuple[int, int]:
        """``cell`` as a ``(row, col)`` pair of ints, or a :class:`ProblemError` saying why not: not
        a pair of integers, outside the map, or on an obstacle."""
        try:
            values = list(cell)
            if len(values) != 2 or any(isinstance(v, (str, bytes, bool, np.bool_)) for v in values):
                raise ValueError
            r, c = (int(v) for v in values)
            if (r, c) != tuple(float(v) for v in values):
                raise ValueError
        except (TypeError, ValueError, OverflowError):
            raise ProblemError(f"{what} must be a (row, col) pair of integers, got {cell!r}") from None
        if not self.in_bounds((r, c)):
            raise ProblemError(
                f"{what} {(r, c)} is outside the {self.height}x{self.width} map "
                f"(rows 0..{self.height - 1}, cols 0..{self.width - 1})"
            )
        if not self.free[r, c]:
            raise ProblemError(f"{what} {(r, c)} is on an obstacle")
        return r, c

    def is_free(self, cell: Cell) -> bool:
        return self.in_bounds(cell) and bool(self.free[cell[0], cell[1]])

    def clearance(self) -> np.ndarray:
        """Distance ``(H, W)`` from each cell centre to the nearest blocked cell centre, in cells.

        The outside of the map counts as blocked (a robot cannot leave it), so a cell on the border
        has clearance at most 1; blocked cells have 0. Computed once per grid and cached.
        """
        cached = self.meta.get("_clearance")
        if cached is None:
            from scipy.ndimage import distance_transform_edt

            padded = np.pad(self.free, 1, constant_values=False)
            cached = distance_transform_edt(padded)[1:-1, 1:-1].astype(np.float32)
            cached.setflags(write=False)
            self.meta["_clearance"] = cached
        return cached

    def to_rows(self) -> list[str]:
        """The grid as text rows (``.`` free, ``@`` blocked)."""
        return ["".join("." if f else "@" for f in row) for row in self.free]

    def replace(self, **changes: Any) -> Grid:
        """A copy with ``changes``. The copy's meta holds this grid's own entries, not what jaco
        keeps on the grid for its queries (keys starting with ``_``): another mask has other ones."""
        changes.setdefault("meta", self._own_meta())
        return replace(self, **changes)

    def __getstate__(self) -> dict:
        """A pickled grid (a Result's, sent to another process) holds its own meta entries, not
        jaco's caches: those hold device arrays and planners, which need not pickle."""
        return {**self.__dict__, "meta": self._own_meta()}

    def _own_meta(self) -> dict:
        return {k: v for k, v in self.meta.items() if not k.startswith("_")}

    # -- world coordinates (ROS maps) ----------------------------------------------------------
    def _frame(self):
        if self.resolution is None:
            raise ProblemError(f"grid {self.name!r} has no resolution/origin: world coordinates need a ROS map")
        ox, oy, yaw = self.origin if self.origin is not None else (0.0, 0.0, 0.0)
        return float(self.resolution), float(ox), float(oy), float(yaw)

    def cell_to_world(self, cells: ArrayLike) -> np.ndarray:
        """World ``(x, y)`` in metres of cell centres; ``cells`` is ``(row, col)`` or ``(K, 2)``.

        Row 0 is the top of the image, i.e. the largest y, as map_server reads the image.
        """
        res, ox, oy, yaw = self._frame()
        try:
            rc = np.asarray(cells, dtype=float)
        except (TypeError, ValueError):
            rc = np.empty(0)
        if rc.ndim < 1 or rc.shape[-1] != 2 or not np.isfinite(rc).all():
            raise ProblemError(f"cells are (row, col) pairs of finite numbers, got {cells!r}")
        r, c = rc[..., 0], rc[..., 1]
        cs, sn = np.cos(yaw), np.sin(yaw)
        with np.errstate(over="ignore", invalid="ignore"):
            lx = (c + 0.5) * res
            ly = (self.height - 1 - r + 0.5) * res
            xy = np.stack([ox + cs * lx - sn * ly, oy + sn * lx + cs * ly], axis=-1)
        if not np.isfinite(xy).all():  # cells so far off that their metres overflow a float
            raise ProblemError(f"cells {cells!r} are too far from map {self.name!r} for world coordinates")
        return xy

    def world_to_cell(self, xy: ArrayLike) -> np.ndarray:
        """The ``(row, col)`` cell containing world point(s) ``(x, y)``; may be out of bounds."""
        res, ox, oy, yaw = self._frame()
        try:
            p = np.asarray(xy, dtype=float)
        except (TypeError, ValueError):
            raise ProblemError(f"a world point is (x, y) in metres, got {xy!r}") from None
        if p.ndim < 1 or p.shape[-1] != 2 or not np.isfinite(p).all():
            raise ProblemError(f"a world point is (x, y) in metres, two finite numbers, got {xy!r}")
        dx, dy = p[..., 0] - ox, p[..., 1] - oy
        cs, sn = np.cos(yaw), np.sin(yaw)
        with np.errstate(over="ignore", invalid="ignore"):
            lx, ly = cs * dx + sn * dy, -sn * dx + cs * dy
            # far-off points stay far off (out of bounds) without overflowing the integer cast
            limit = 4.0 * (self.height + self.width) + 4
            col = np.floor(np.clip(np.nan_to_num(lx / res, nan=-limit), -limit, limit)).astype(int)
            row = self.height - 1 - np.floor(np.clip(np.nan_to_num(ly / res, nan=-limit), -limit, limit)).astype(int)
        return np.stack([row, col], axis=-1)

    def __repr__(self) -> str:
        return f"Grid({self.name!r}, {self.height}x{self.width}, {self.n_free} free)"
