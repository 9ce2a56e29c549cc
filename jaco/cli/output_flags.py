"""A command's output flags (``--json``, ``--csv``, ``--plot`` ...): every one checked before
anything runs, standard output kept for the data when one of them writes there, and a failed
write after the run said to be one."""

from __future__ import annotations

import contextlib
import functools
import os
import sys
from pathlib import Path


def _map_inputs(args, grid) -> list:
    """The files a command reads (the map, a ROS map's image, the scenario): no output may name one."""
    out = []
    for spec in (getattr(args, "map", None), getattr(args, "scen", None)):
        if spec is not None and Path(spec).is_file():
            out.append(Path(spec))
    image = grid.meta.get("image") if grid is not None else None
    if isinstance(image, str) and out:
        out.append(out[0].parent / image)
    return out


def check_outputs(args, grid=None, figures=(), files=()) -> None:
    """Every output flag checked before anything runs (:func:`jaco.outputs.check_output`)."""
    from ..outputs import check_distinct, check_output
    from ..plot import check_figure_path

    inputs = _map_inputs(args, grid)
    named = {}
    for flag, suffixes in files:
        value = getattr(args, flag.lstrip("-").replace("-", "_"))
        if value is not None:
            named[flag] = check_output(value, flag, suffixes=suffixes, inputs=inputs)
    for flag in figures:
        value = getattr(args, flag.lstrip("-").replace("-", "_"))
        if value is not None:
            how = "--plot-format" if flag == "--plot" else "jaco solve demo --plot - --plot-format png"
            named[flag] = check_figure_path(
                value, flag, inputs=inputs, format=getattr(args, "plot_format", None), how=how
            )
    if args.command == "sweep" and "--record" in named:  # the sweep record's JSON sidecar
        named["--record sidecar"] = check_output(
            named["--record"].with_suffix(".json"), "--record sidecar", inputs=inputs
        )
    check_distinct(named)


def handles_outputs(*flags):
    """A command's output handling (its output flags named): when one writes to standard output
    (``-``, ``/dev/stdout``) the human summary goes to stderr, so stdout holds only the data; an
    output that fails to be written after the run says that the run itself finished."""

    def wrap(cmd):
        @functools.wraps(cmd)
        def run(args):
            from ..errors import OutputError
            from ..outputs import is_stdout, standard_output

            with contextlib.ExitStack() as stack:
                if any(is_stdout(v) for v in (getattr(args, f.lstrip("-").replace("-", "_")) for f in flags) if v):
                    stack.enter_context(standard_output(sys.stdout))
                    stack.enter_context(contextlib.redirect_stdout(sys.stderr))
                try:
                    return cmd(args)
                except OutputError as e:
                    if isinstance(e.__cause__, BrokenPipeError) and sys.stdout is sys.__stdout__:
                        quiet_stdout()
                    if not getattr(args, "finished", False):
                        raise
                    raise OutputError(
                        f"{e}; the run itself finished (its summary above is complete), "
                        "but this output and any after it were not written"
                    ) from e

        return run

    return wrap


def quiet_stdout() -> None:
    """After standard output's reader went away: send what Python still holds for it to
    /dev/null, so that exiting does not print a second error about the closed pipe."""
    with contextlib.suppress(OSError, ValueError):
        null = os.open(os.devnull, os.O_WRONLY)
        os.dup2(null, sys.stdout.fileno())
        os.close(null)
