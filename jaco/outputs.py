"""Writing files: output paths checked before a run, and every output written whole or not at all.

:func:`check_output` is called before anything runs, so that a path that cannot be written is an
:class:`~jaco.errors.OutputError` instead of a failure after the work is done. Every writer of jaco
(records, paths, figures, animations, sweep tables, text maps, the experiments' reports) writes
through :func:`write_text`, :func:`write_bytes` or :func:`atomic_paths`, which treat a path by what
it names (:func:`target` tells which):

* **a regular file, or a name that does not exist yet**: written to a temporary file in the same
  folder, flushed to disk and renamed onto the name only when complete. A failed or interrupted
  write leaves an existing file as it was and no partial file behind. Missing folders are created.
* **a symbolic link** (relative, absolute, a chain of links): followed; its final target is written
  atomically in the target's own folder, so the link stays a link. A dangling link creates its
  target when the target's folder exists (as the shell's ``>`` does) and is an error otherwise:
  jaco never creates the folders a stale link points into. A link to a directory, or a loop of
  links, is an error.
* ``-``: standard output (``sys.stdout``; the command line then prints its summary on stderr).
* **a character device** (``/dev/null``, ``/dev/full``, a terminal), **a FIFO**, or **a file
  descriptor of this process** (``/dev/stdout``, ``/dev/fd/N``, ``/proc/self/fd/N``): opened and
  written in place, without a temporary file or a rename; a descriptor is written through a copy of
  the one already open, so ``>> log`` still appends. Nothing is ever created, renamed or removed in
  ``/dev`` (``/dev/shm`` aside), ``/proc`` or ``/sys``: a new name there is an error, an existing
  regular file there is overwritten in place.

Any failure while writing (a full disk or device, a closed pipe, an I/O error) is an OutputError
naming the output and the system's reason. Several processes writing one path at once end with one
complete file from one of them: each writes its own temporary file and renames it, and
:func:`atomic_paths` renames the files of one output (a sweep record's table and sidecar) under a
lock on their folders, so no process leaves its table beside another's sidecar.
"""

from __future__ import annotations

import contextlib
import os
import re
import shutil
import stat
import sys
import tempfile
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any

from .errors import OutputError

try:
    import fcntl
except ImportError:  # pragma: no cover - Windows: renames are still atomic, pairs are not locked
    fcntl = None  # type: ignore[assignment]

#: The name that means standard output.
STDOUT = "-"
_LINK_HOPS = 40  # as the kernel's limit on symbolic links in one lookup (ELOOP)
_SYSTEM = ("/dev", "/proc", "/sys")  # folders of the system's nodes: never create, rename, remove
_stdout_streams: list = []  # set by standard_output()

#: A path argument: a str or an ``os.PathLike`` (also ``-``, a stream or a descriptor where the function says so).
PathArg = str | os.PathLike


def as_path(path: PathArg, what: str, error: type[Exception] = OutputError) -> Path:
    """``path`` (a str or ``os.PathLike``) as a :class:`~pathlib.Path`, or ``error`` saying a file
    path was expected (inputs pass their own error class)."""
    if isinstance(path, bool) or not isinstance(path, (str, os.PathLike)):
        raise error(f"{what}: expected a file path (str or os.PathLike), got {type(path).__name__}")
    text = os.fspath(path)
    if isinstance(text, bytes) or not text.strip() or "\0" in text:
        raise error(f"{what}: expected a file path, got {path!r}")
    if text != STDOUT and Path(text) == Path(STDOUT):  # "./-": a file named "-", not standard output
        return Path(os.path.abspath(text))
    return Path(text)


@dataclass(frozen=True)
class Target:
    """Where a write of an output path goes (:func:`target`).

    ``kind``: ``"file"`` (a regular file or a new name, written atomically at ``path``, every
    symbolic link followed), ``"stream"`` (a device, FIFO or a system folder's file, opened at
    ``path`` and written in place), ``"fd"`` (this process's descriptor ``fd``) or ``"stdout"``."""

    kind: str
    path: Path
    fd: int | None = None


def _system(folder: str) -> bool:
    inside = lambda root: folder == root or folder.startswith(root + "/")  # noqa: E731
    return any(inside(root) for root in _SYSTEM) and not inside("/dev/shm")


def _own_fd_folder(folder: str) -> bool:
    """Whether ``folder`` (resolved) is this process's ``/proc/PID/fd`` (``/dev/fd``, ``/proc/self/fd``)."""
    return re.fullmatch(rf"/proc/{os.getpid()}(/task/\d+)?/fd", folder) is not None


def _fail(what: str, path, why: str) -> OutputError:
    shown = "'-' (standard output)" if str(path) == STDOUT else repr(str(path))
    return OutputError(f"{what} {shown}: {why}")


def target(path: PathArg, what: str = "output") -> Target:
    """What writing ``path`` means (see the module docstring), checked: raises
    :class:`OutputError` for a directory, a loop of links, a dangling link into a missing folder,
    a new name in ``/dev``, ``/proc`` or ``/sys``, or a folder that cannot be written. Opens nothing."""
    given = as_path(path, what)
    if str(given) == STDOUT:
        return Target("stdout", given)
    parent = given.parent
    if not parent.is_dir():  # missing folders are created when the file is written
        up = parent
        while not os.path.lexists(up) and up != up.parent:
            up = up.parent
        if up.is_symlink() and not up.exists():
            raise _fail(what, given, f"folder {str(up)!r} is a dangling symbolic link")
        if not up.is_dir():
            raise _fail(what, given, f"{str(up)!r} is not a folder")
        _check_folder(what, repr(str(given)), os.path.realpath(up))
        return Target("file", given)
    folder, name, linked = os.path.realpath(parent), given.name, False
    for _ in range(_LINK_HOPS):
        full = os.path.join(folder, name)
        if _own_fd_folder(folder) and name.isdigit():
            return Target("fd", Path(full), int(name))
        if _system(folder) and folder.startswith("/proc/"):
            break  # /proc's links are not paths ("pipe:[123]"): opening the name itself follows them
        try:
            link = os.readlink(full)
        except OSError:  # not a link, or missing
            break
        new = os.path.join(folder, link)  # an absolute link replaces the folder
        folder, name, linked = os.path.realpath(os.path.dirname(new)), os.path.basename(new), True
    else:
        raise _fail(what, given, f"too many levels of symbolic links (a loop?) after {_LINK_HOPS} links")
    shown = f"{str(given)!r} -> {full!r}" if linked else repr(str(given))
    try:
        mode = os.stat(full).st_mode
    except FileNotFoundError:
        mode = None
    except NotADirectoryError:
        raise OutputError(f"{what} {shown}: {folder!r} is not a folder") from None
    except OSError as e:
        raise OutputError(f"{what} {shown}: {e.strerror}") from None
    if mode is not None and stat.S_ISDIR(mode):
        raise OutputError(f"{what} {shown} is a directory, not a file")
    if mode is None or stat.S_ISREG(mode):
        if linked and not os.path.isdir(folder):
            raise OutputError(f"{what} {shown}: a dangling symbolic link whose target's folder does not exist")
        if mode is None or not _system(folder):
            _check_folder(what, shown, folder)
            return Target("file", Path(full))
    return Target("stream", Path(full))


def _check_folder(what: str, shown: str, folder: str) -> None:
    """The folder a file is written in (renamed into, created in) is writable and not the system's."""
    if _system(folder):
        raise OutputError(
            f"{what} {shown}: jaco never creates, renames or removes anything in {folder!r} "
            "(only an existing device, FIFO or file there is written, in place)"
        )
    if not os.access(folder, os.W_OK | os.X_OK):
        raise OutputError(f"{what} {shown}: folder {folder!r} is not writable")


def is_stdout(path: Any) -> bool:
    """Whether writing ``path`` goes to this process's standard output (``-``, ``/dev/stdout``,
    a descriptor or node that is the one open as descriptor 1). Never raises."""
    try:
        t = target(path)
        if t.kind == "stdout":
            return True
        if t.kind in ("fd", "stream"):
            return os.path.samestat(os.fstat(t.fd) if t.kind == "fd" else os.stat(t.path), os.fstat(1))  # type: ignore[arg-type]
    except (OutputError, OSError):
        pass
    return False


def is_stream(path: Any) -> bool:
    """Whether ``path`` is written in place (standard output, a device, a FIFO, a descriptor): a
    name with no suffix to say a format there is normal. Never raises."""
    try:
        return target(path).kind != "file"
    except OutputError:
        return False


def _same_target(a, b) -> bool:
    """Whether two outputs write to the same place; discarding twice (``/dev/null``) is fine."""
    try:
        ta, tb = target(a), target(b)
    except OutputError:
        return os.path.abspath(a) == os.path.abspath(b)
    if "stdout" in (ta.kind, tb.kind):
        return ta.kind == tb.kind or is_stdout(b if ta.kind == "stdout" else a)
    try:
        sa, sb = (os.fstat(t.fd) if t.kind == "fd" else os.stat(t.path) for t in (ta, tb))  # type: ignore[arg-type]
    except OSError:
        return os.path.abspath(ta.path) == os.path.abspath(tb.path)
    return os.path.samestat(sa, sb) and not stat.S_ISCHR(sa.st_mode)


def check_output(
    path: PathArg,
    what: str,
    *,
    suffixes: Sequence[str] | None = None,
    inputs: Iterable[Any] = (),
    format: str | None = None,
    how: str = "format=",
) -> Path:
    """``path`` as a :class:`~pathlib.Path` once it is known to be writable (:func:`target`): a
    suffix in ``suffixes`` (when given; lower-case, with the dot) unless ``format`` names one (and
    the suffix, if it is one of ``suffixes``, agrees), and
    not one of ``inputs`` (files the run reads). A path written in place (``-``, a device, a FIFO)
    has no suffix: where ``suffixes`` offers several formats it needs ``format`` (``how`` says how
    to give it). Raises :class:`OutputError`."""
    path = as_path(path, what)
    t = target(path, what)
    if suffixes is not None:
        if format is not None:
            if "." + str(format).lower() not in suffixes:
                raise OutputError(
                    f"{what}: unsupported format {format!r}; use one of {', '.join(s[1:] for s in sorted(suffixes))}"
                )
            if path.suffix.lower() in suffixes and path.suffix.lower() != "." + str(format).lower():
                raise OutputError(
                    f"{what} {str(path)!r} names the format {path.suffix!r}, but the format given "
                    f"is {format!r}: one file, one format"
                )
        elif path.suffix.lower() not in suffixes and not (t.kind != "file" and not path.suffix and len(suffixes) == 1):
            if not path.suffix and t.kind != "file":
                raise OutputError(
                    f"{what} {str(path)!r} has no suffix to name the format: give it with {how} "
                    f"(one of {', '.join(s[1:] for s in sorted(suffixes))})"
                )
            raise OutputError(
                f"{what} {str(path)!r}: unsupported suffix {path.suffix or '(none)'!r}; "
                f"use one of {', '.join(sorted(suffixes))}"
            )
    for source in inputs:
        if source is not None and t.kind != "stdout" and _same_target(path, Path(source)):
            raise OutputError(f"{what} {str(path)!r} is an input of this run ({source}): it would be overwritten")
    return path


def check_distinct(named: dict) -> None:
    """Several outputs of one run must be different files (``{what: path or None}``)."""
    seen: dict = {}
    for what, path in named.items():
        if path is None:
            continue
        for other, p in seen.items():
            if _same_target(path, p):
                where = "standard output" if is_stdout(path) else f"the same file {str(path)!r}"
                raise OutputError(f"{what} and {other} name {where}")
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
def standard_output(stream: IO | None) -> Iterator[Any]:
    """Within the block, ``-`` writes to ``stream`` (default: ``sys.stdout`` at the time of the
    write). The command line keeps its data here while its summary goes to stderr."""
    _stdout_streams.append(stream)
    try:
        yield stream
    finally:
        _stdout_streams.pop()


def _write_in_place(t: Target, data: bytes) -> None:
    """Write ``data`` to standard output, a descriptor, a device or a FIFO: no temporary file."""
    if t.kind == "stdout":
        stream = _stdout_streams[-1] if _stdout_streams else sys.stdout
        stream.flush()
        buffer = getattr(stream, "buffer", None)
        if buffer is not None:
            buffer.write(data)
            buffer.flush()
            return
        try:
            text = data.decode("utf-8")
        except UnicodeDecodeError:
            raise OutputError(
                "standard output takes text only here (it has no binary buffer): write this output to a file"
            ) from None
        stream.write(text)
        stream.flush()
        return
    for stream in (sys.stdout, sys.stderr):  # what Python printed comes first on a shared descriptor
        with contextlib.suppress(Exception):
            stream.flush()
    flags = os.O_WRONLY | os.O_NOCTTY | os.O_TRUNC | getattr(os, "O_CLOEXEC", 0)
    fd = os.dup(t.fd) if t.kind == "fd" else os.open(t.path, flags)  # type: ignore[arg-type]  # never O_CREAT
    try:
        view = memoryview(data)
        while view:
            view = view[os.write(fd, view) :]
    finally:
        os.close(fd)


def _folder_lock(folders):
    """An exclusive lock on each folder (``flock`` on the folder itself: no lock file is left)."""
    stack = contextlib.ExitStack()
    if fcntl is None:
        return stack
    for folder in sorted(set(map(str, folders))):  # one order in every process: no deadlock
        fd = os.open(folder, os.O_RDONLY)
        stack.callback(os.close, fd)
        fcntl.flock(fd, fcntl.LOCK_EX)
    return stack


def _remove_if_there(path: str) -> None:
    if os.path.lexists(path):
        os.unlink(path)


def _reason(e: OSError) -> str:
    return e.strerror or str(e)


@contextlib.contextmanager
def atomic_paths(paths: Iterable[PathArg], what: str = "output") -> Iterator[list[Path]]:
    """Temporary paths for ``paths`` (same suffixes, for writers that choose the format by it),
    yielded as a list; when the block ends without an exception they replace their targets in the
    order given (renamed under a lock on their folders; a target written in place gets the
    temporary file's bytes), else they are removed. Raises :class:`OutputError` when a file
    cannot be written."""
    targets = [(Path(p), target(p, what)) for p in paths]
    temps: list = []
    with contextlib.ExitStack() as cleanup:
        try:
            for given, t in targets:
                if t.kind == "file":
                    given.parent.mkdir(parents=True, exist_ok=True)
                    t = target(given, what)  # the folders exist now: links are followed to the end
                    fd, tmp = tempfile.mkstemp(
                        dir=t.path.parent, prefix=f".{t.path.stem}.", suffix=f".tmp{t.path.suffix}"
                    )
                    os.close(fd)
                    cleanup.callback(_remove_if_there, tmp)
                    os.chmod(tmp, _mode(t.path))
                else:  # rendered into a private folder, then written in place
                    folder = tempfile.mkdtemp(prefix="jaco-")
                    cleanup.callback(shutil.rmtree, folder, True)
                    tmp = os.path.join(folder, "output" + given.suffix)
                temps.append((given, t, Path(tmp)))
            yield [tmp for _, _, tmp in temps]
            with _folder_lock(t.path.parent for _, t, _ in temps if t.kind == "file"):
                for _, t, tmp in temps:
                    if t.kind == "file":
                        os.replace(tmp, t.path)
                    else:
                        _write_in_place(t, tmp.read_bytes())
        except OSError as e:
            named = [g for g, _, tmp in temps if str(tmp) == e.filename] or [targets[0][0]]
            raise _fail(what, named[0], f"cannot write: {_reason(e)}") from e


@contextlib.contextmanager
def atomic_path(path: PathArg, what: str = "output") -> Iterator[Path]:
    """:func:`atomic_paths` of one path: yields its temporary path."""
    with atomic_paths([path], what) as (tmp,):
        yield tmp


def write_bytes(path: PathArg, data: bytes, what: str = "output") -> Path:
    """Write ``data`` to ``path`` (see the module docstring: atomically to a file, in place to a
    device, FIFO, descriptor or ``-``); returns the path as given. Raises :class:`OutputError`."""
    path = as_path(path, what)
    t = target(path, what)
    if t.kind == "file":
        with atomic_path(path, what) as tmp:
            with open(tmp, "wb") as f:
                f.write(data)
                f.flush()
                os.fsync(f.fileno())
        return path
    try:
        _write_in_place(t, data)
    except OSError as e:
        raise _fail(what, path, f"cannot write: {_reason(e)}") from e
    return path


def write_text(path: PathArg, text: str, what: str = "output") -> Path:
    """Write ``text`` (UTF-8, ``\\n`` line ends as given) to ``path`` as :func:`write_bytes` does."""
    return write_bytes(path, text.encode("utf-8"), what)
