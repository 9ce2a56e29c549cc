"""Writing files: output paths checked before a run, and every file written atomically.

:func:`check_output` is called before anything runs, so that a path that cannot be written is an
:class:`~jaco.errors.OutputError` instead of a failure after the work is done. :func:`atomic_path`
and :func:`write_text` write to a temporary file beside the target and rename it into place only
when it is complete: a failed or interrupted write leaves an existing file as it was and no partial
file behind. Missing parent folders are created when the file is written.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from pathlib import Path

from .errors import OutputError


def as_path(path, what: str, error=OutputError) -> Path:
    """``path`` (a str or ``os.PathLike``) as a :class:`~pathlib.Path`, or ``error`` saying a file
    path was expected (inputs pass their own error class)."""
    if isinstance(path, bool) or not isinstance(path, (str, os.PathLike)):
        raise error(f"{what}: expected a file path (str or os.PathLike), got {type(path).__name__}")
    text = os.fspath(path)
    if isinstance(text, bytes) or not text.strip() or "\0" in text:
        raise error(f"{what}: expected a file path, got {path!r}")
    return Path(text)


def _same_file(a: Path, b: Path) -> bool:
    try:
        if a.exists() and b.exists():
            return os.path.samefile(a, b)
    except OSError:
        pass
    return os.path.abspath(a) == os.path.abspath(b)


def check_output(path, what: str, *, suffixes=None, inputs=()) -> Path:
    """``path`` as a :class:`~pathlib.Path` once it is known to be writable: not a directory, a
    suffix in ``suffixes`` (when given; lower-case, with the dot), not one of ``inputs`` (files the
    run reads), and its nearest existing folder writable. Raises :class:`OutputError`."""
    path = as_path(path, what)
    if path.is_dir():
        raise OutputError(f"{what} {str(path)!r} is a directory, not a file")
    if suffixes is not None and path.suffix.lower() not in suffixes:
        raise OutputError(
            f"{what} {str(path)!r}: unsupported suffix {path.suffix or '(none)'!r}; use one of {', '.join(sorted(suffixes))}"
        )
    for source in inputs:
        if source is not None and _same_file(path, Path(source)):
            raise OutputError(f"{what} {str(path)!r} is an input of this run ({source}): it would be overwritten")
    folder = path.parent
    while not folder.exists() and folder != folder.parent:
        folder = folder.parent
    if not folder.is_dir():
        raise OutputError(f"{what} {str(path)!r}: {str(folder)!r} is not a folder")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise OutputError(f"{what} {str(path)!r}: folder {str(folder)!r} is not writable")
    return path


def check_distinct(named: dict) -> None:
    """Several outputs of one run must be different files (``{what: path or None}``)."""
    seen: dict = {}
    for what, path in named.items():
        if path is None:
            continue
        for other, p in seen.items():
            if _same_file(Path(path), Path(p)):
                raise OutputError(f"{what} and {other} name the same file {str(path)!r}")
        seen[what] = path


def _mode(path: Path) -> int:
    """The permissions the file would get from a plain ``open``: the old file's, else the umask's."""
    try:
        return path.stat().st_mode & 0o777
    except OSError:
        umask = os.umask(0)
        os.umask(umask)
        return 0o666 & ~umask


@contextlib.contextmanager
def atomic_path(path):
    """A temporary path beside ``path`` (same suffix, for writers that choose the format by it),
    renamed onto ``path`` when the block ends without an exception and removed otherwise."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.stem}.", suffix=f".tmp{path.suffix}")
    os.close(fd)
    try:
        os.chmod(tmp, _mode(path))
        yield Path(tmp)
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


def write_text(path, text: str) -> Path:
    """Write ``text`` (UTF-8, ``\\n`` line ends as given) to ``path`` atomically; returns the path."""
    path = Path(path)
    with atomic_path(path) as tmp:
        with open(tmp, "w", encoding="utf-8", newline="") as f:
            f.write(text)
            f.flush()
            os.fsync(f.fileno())
    return path
