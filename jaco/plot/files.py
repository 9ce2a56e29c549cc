"""Writing figures and animations: the formats matplotlib writes, output paths checked first,
files written atomically (:mod:`jaco.outputs`)."""

from __future__ import annotations

import io
import tempfile
from collections.abc import Iterable
from pathlib import Path
from typing import TYPE_CHECKING, Any

from matplotlib.figure import Figure

from ..outputs import PathArg, check_output, write_bytes

if TYPE_CHECKING:
    from matplotlib.animation import Animation


def save_gif(animation: Animation, path: PathArg, fps: int = 8) -> Path:
    """Write an animation as an animated GIF with matplotlib's Pillow writer; returns the path."""
    from matplotlib.animation import PillowWriter

    path = check_output(path, "animation", suffixes=(".gif",))
    with tempfile.TemporaryDirectory(prefix="jaco-") as folder:  # Pillow's writer takes a file name only
        drawn = Path(folder) / "animation.gif"
        animation.save(drawn, writer=PillowWriter(fps=fps))
        return write_bytes(path, drawn.read_bytes(), "animation")


def figure_suffixes() -> tuple[str, ...]:
    """The file suffixes matplotlib writes figures in (``.png``, ``.svg``, ``.pdf``, ...)."""
    from matplotlib.backend_bases import FigureCanvasBase

    return tuple(sorted("." + s for s in FigureCanvasBase.get_supported_filetypes()))


def check_figure_path(
    path: PathArg, what: str = "figure", inputs: Iterable[Any] = (), format: str | None = None, how: str = "format="
) -> Path:
    """:func:`jaco.outputs.check_output` for a figure: a suffix matplotlib can write, or ``format``
    (``"png"``, ``"svg"`` ...) naming one."""
    return check_output(path, what, suffixes=figure_suffixes(), inputs=inputs, format=format, how=how)


def save(fig: Figure, path: PathArg, format: str | None = None) -> Path:
    """Write ``fig`` in the format its suffix names (``.png`` at dpi 120, ``.svg``, ``.pdf``, ...;
    tight bounding box), or in ``format`` when given (needed for ``-``, a device or a FIFO, whose
    names have no suffix); atomically to a file, creating parent folders (see
    :mod:`jaco.outputs`); returns the path."""
    path = check_figure_path(path, format=format)
    data = io.BytesIO()  # drawn in memory first: a drawing error never touches the output
    fig.savefig(data, dpi=120, bbox_inches="tight", format=(format or path.suffix[1:]).lower())
    return write_bytes(path, data.getvalue(), "figure")
