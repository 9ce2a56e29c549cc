"""Command line interface: ``jaco demo | solve | sweep | search | rerun | planners | maps | info``.

Run ``jaco --help`` or ``jaco COMMAND --help`` for the options. Every user mistake (bad argument,
unknown map / planner / parameter, missing file, blocked or unreachable start/goal, out-of-range
parameter, an output that cannot be written, a call too large for the memory budget) ends as one
line ``jaco: error: ...`` on stderr and exit code 2, never a traceback. Anything else that escapes
is a bug in jaco: one line ``jaco: internal error: ...`` and exit code 3 (``jaco --debug COMMAND``
prints the traceback instead). ``jaco solve`` and ``jaco demo`` exit with 4 when no ant reached
the goal, after a hint of what usually helps (:func:`jaco.engine.result.failure_hint`).

Heavy modules (jax, matplotlib, pandas) are imported inside the command functions, so building the
parser and printing help cost nothing beyond importing the :mod:`jaco` package itself.
"""

from __future__ import annotations

import sys
import time

_IMPORTED = [time.perf_counter()]  # before jax and the rest are imported: the reported time counts start-up

from ..errors import one_line  # noqa: E402
from .args import UsageError  # noqa: E402
from .parser import build_parser, join_negative_xy  # noqa: E402
from .signals import INTERRUPTED, TERMINATED, Terminated, _terminate, stop_signals  # noqa: E402,F401

__all__ = ["main", "entry", "build_parser"]

#: Exit codes: 2 a user error (a :class:`~jaco.errors.JacoError` or a bad argument), 3 a bug,
#: 128 + the signal when interrupted (INTERRUPTED, TERMINATED: :mod:`jaco.cli.signals`).
USER_ERROR, INTERNAL_ERROR = 2, 3
BROKEN_PIPE = 141  # 128 + SIGPIPE: what a shell reports for a writer whose reader left


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``jaco`` console script; returns the exit code."""
    from ..errors import JacoError

    with stop_signals():
        return _main(argv, JacoError)


def _main(argv, JacoError) -> int:
    argv = join_negative_xy(argv)
    debug = "--debug" in argv[: argv.index("--") if "--" in argv else None]
    args = None
    try:
        parser = build_parser()
        try:
            args = parser.parse_args(argv)
        except SystemExit as e:  # --help / --version
            return e.code if isinstance(e.code, int) else 0
        args.started = _IMPORTED.pop() if _IMPORTED else time.perf_counter()  # later calls: from main
        if args.walk is not None:
            from ..engine import native

            native.set_walk(args.walk)
        return args.func(args)
    except (UsageError, JacoError) as e:
        print(f"jaco: error: {one_line(e)}", file=sys.stderr)
        return USER_ERROR
    except BrokenPipeError:  # the reader left (`jaco planners | head -3`): stop quietly, as cat does
        from .output_flags import quiet_stdout

        quiet_stdout()
        return BROKEN_PIPE
    except OSError as e:
        text = f"{e.filename}: {e.strerror}" if e.strerror and e.filename else str(e)
        print(f"jaco: error: {one_line(text)}", file=sys.stderr)
        return USER_ERROR
    except KeyboardInterrupt:
        print(_stopped("interrupted", args), file=sys.stderr)
        return INTERRUPTED
    except Terminated:
        print(_stopped("terminated", args), file=sys.stderr)
        return TERMINATED
    except Exception as e:  # a bug: one line and exit code 3, the traceback only with --debug
        if debug:
            import traceback

            traceback.print_exc()
        else:
            print(
                f"jaco: internal error: {type(e).__name__}: {one_line(e)[:500]} (this is a bug in jaco: "
                "please report it with the command line; 'jaco --debug ...' prints the traceback)",
                file=sys.stderr,
            )
        return INTERNAL_ERROR


def _stopped(word: str, args) -> str:
    """The last line of a stopped command: ``jaco: interrupted`` (or ``terminated``), and for a
    command that keeps finished work (``args.kept``, set by sweep and search) what it kept and how
    to resume: ``jaco: interrupted: 600 runs stored in long.db; the same command resumes``."""
    kept = getattr(args, "kept", None)
    try:
        said = kept() if kept is not None else ""
    except BaseException:  # noqa: BLE001 - a second signal, or a store that cannot be read now: the plain line
        said = ""
    return f"jaco: {word}: {said}" if said else f"jaco: {word}"


def entry() -> None:
    """The console script: :func:`main`, then exit. After an interrupt the process ends at once
    (``os._exit``): an XLA compile cannot be stopped and would otherwise keep it alive until it
    finished (a compiled run ends at its next iteration). Output was flushed and files closed first."""
    import os

    code = main()
    if code in (INTERRUPTED, TERMINATED):
        for stream in (sys.stdout, sys.stderr):
            try:
                stream.flush()
            except (OSError, ValueError):
                pass
        os._exit(code)
    sys.exit(code)
