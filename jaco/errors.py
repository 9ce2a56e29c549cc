"""Errors a user can cause. All derive from ``ValueError`` and are raised before anything compiles."""


class JacoError(ValueError):
    """Base class of every user-facing jaco error."""


class MapFormatError(JacoError):
    """A map or scenario file is malformed (bad header, unknown symbol, wrong size, missing image...)."""


class ProblemError(JacoError):
    """A planning problem is invalid: start/goal out of bounds or blocked, unreachable goal, empty map."""


class ParamError(JacoError):
    """A hyperparameter is unknown, NaN or out of its range."""
