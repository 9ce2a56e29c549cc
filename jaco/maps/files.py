"""Map files: the bundled data (:data:`DATA_DIR`, :data:`BUNDLED`, :func:`bundled`) and what every
reader shares (a clear error for a missing file, text decoding)."""

from __future__ import annotations

from pathlib import Path

from ..errors import MapFormatError

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

#: The suffixes :func:`jaco.maps.load` reads.
SUPPORTED_SUFFIXES = (".map", ".yaml", ".yml", ".txt", ".npy", ".png", ".pgm", ".ppm", ".bmp")


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


def require_file(path: Path, what: str, referenced_by: str | None = None) -> None:
    """A :class:`MapFormatError` naming ``path`` (and the file that refers to it) unless it is a
    file; when a bundled copy of that name exists, the message says so."""
    if not path.is_file():
        why = "is a directory, not a file" if path.is_dir() else "not found"
        extra = f" (referenced by {referenced_by})" if referenced_by else ""
        hint = ""
        if not referenced_by and path.name in BUNDLED:
            hint = f"; a bundled copy exists: load_bundled({path.name!r})"
        raise MapFormatError(f"{what} {str(path)!r} {why}{extra}{hint}")


def read_text(path: Path) -> str:
    """The file as UTF-8 text, or a :class:`MapFormatError` naming the first byte that is not."""
    try:
        return path.read_bytes().decode("utf-8")
    except UnicodeDecodeError as e:
        raise MapFormatError(f"{path.name} is not a text file (byte {e.start} is not UTF-8)") from None
