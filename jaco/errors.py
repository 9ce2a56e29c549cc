"""Errors a user can cause. All derive from ``ValueError`` and are raised before anything compiles.

The command line prints a :class:`JacoError` as one line and exits with code 2. A misspelt name
(a keyword of ``jaco.solve``/``sweep``/``tune``, a parameter) is answered with the closest names
the call takes (:func:`did_you_mean`, :func:`check_keywords`)."""

from __future__ import annotations

import difflib
import functools
import inspect
import warnings
from collections.abc import Callable, Iterable
from typing import Any, TypeVar, cast


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


F = TypeVar("F", bound=Callable[..., Any])


def one_line(text: object) -> str:
    """``text`` (a message, an exception) on one line: its whitespace runs as single spaces."""
    return " ".join(str(text).split())


def did_you_mean(name: str, candidates: Iterable[str]) -> str:
    """``" (did you mean 'n_ants'?)"`` for the names in ``candidates`` closest to a misspelt
    ``name`` (difflib's ratio ≥ 0.6, at most three), or ``""`` when none is close."""
    close = difflib.get_close_matches(str(name), [str(c) for c in candidates], n=3, cutoff=0.6)
    return f" (did you mean {' or '.join(repr(c) for c in close)}?)" if close else ""


#: Keywords renamed when planners got one name (jaco 0.1 called them variants): the old keyword is
#: still taken, because users' code and stored records type it.
KEYWORD_ALIASES = {"variant": "planner"}


def resolve_aliases(kwargs: dict) -> dict:
    """``kwargs`` with each former keyword (:data:`KEYWORD_ALIASES`) under its new name, with a
    DeprecationWarning that names the new one."""
    for old, new in KEYWORD_ALIASES.items():
        if old in kwargs:
            if new in kwargs:
                raise JacoError(f"{old}= and {new}= are the same argument ({old} is its former name): give one")
            warnings.warn(f"{old}= is the former name of {new}=; write {new}=", DeprecationWarning, stacklevel=3)
            kwargs[new] = kwargs.pop(old)
    return kwargs


def accepts_aliases(fn: F) -> F:
    """Decorate a public function so that a former keyword (:data:`KEYWORD_ALIASES`:
    ``variant=``) is taken as its new name (``planner=``)."""

    @functools.wraps(fn)
    def call(*args, **kwargs):
        return fn(*args, **resolve_aliases(kwargs))

    return cast(F, call)


def check_keywords(fn: F) -> F:
    """Decorate a public function so that an unknown keyword argument is a :class:`JacoError`
    naming the closest keywords it takes (``n_ant`` -> ``n_ants``) and listing them all, instead
    of Python's TypeError; a former keyword (``variant=``) is taken as its new name. The signature
    is kept (``inspect.signature`` sees ``fn``'s)."""
    params = inspect.signature(fn).parameters.values()
    names = [p.name for p in params if p.kind in (p.POSITIONAL_OR_KEYWORD, p.KEYWORD_ONLY)]

    @functools.wraps(fn)
    def checked(*args, **kwargs):
        if "planner" in names:
            kwargs = resolve_aliases(kwargs)
        for key in kwargs:
            if key not in names:
                raise JacoError(
                    f"unknown keyword {key!r} for jaco.{fn.__name__}{did_you_mean(key, names)}; "
                    f"its keywords: {', '.join(names)}"
                )
        return fn(*args, **kwargs)

    return cast(F, checked)
