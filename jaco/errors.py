"""Errors a user can cause. All derive from ``ValueError`` and are raised before anything compiles.

The command line prints a :class:`JacoError` as one line and exits with code 2."""


class JacoError(ValueError):
    """Base class of every user-facing jaco error. Its message is one line: a message that quotes
    a multi-line text (a YAML parser's error, say) has its line breaks joined by spaces."""

    def __init__(self, *args):
        if len(args) == 1 and isinstance(args[0], str) and ("\n" in args[0] or "\r" in args[0]):
            args = (" ".join(args[0].split()),)
        super().__init__(*args)


class MapFormatError(JacoError):
    """A map or scenario file is malformed (bad header, unknown symbol, wrong size, missing image...)."""


class ProblemError(JacoError):
    """A planning problem is invalid: start/goal out of bounds or blocked, unreachable goal, empty map."""


class ParamError(JacoError):
    """A hyperparameter is unknown, NaN or out of its range."""


class ResourceError(JacoError):
    """A call too large for this machine: its memory estimate exceeds the budget (or a size
    overflows the 32-bit indices of the compiled program)."""


class OutputError(JacoError):
    """An output path that cannot be written: its folder is missing a parent or not writable, it
    is a directory, it names one of the run's inputs, or its suffix is not a format jaco writes."""
