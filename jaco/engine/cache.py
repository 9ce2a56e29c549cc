"""The compile cache: every compiled program (runs, sweep chunks, waypoint legs, tuning loops) is
built once per key and kept, so repeated calls of one shape never recompile.

Keys hold the planner itself (a :class:`~jaco.engine.planner.Planner` is hashable: its functions
by identity, its defaults as a frozen map), the static shape of the run
(:class:`~jaco.engine.shape.RunShape`) and whatever else the program depends on. The active walk
(:func:`jaco.engine.native.active_walk`) is part of every key: a program traced for one walk never
serves the other.
"""

from __future__ import annotations

from collections.abc import Callable, Hashable
from typing import Any

from . import native

_COMPILED: dict = {}


def _walk_key(key: tuple) -> tuple:
    return (native.active_walk(),) + key


def cached(key: tuple[Hashable, ...], build: Callable[[], Any]) -> Any:
    """``build()`` once per ``key`` (and active walk); the same object on every later call."""
    full = _walk_key(key)
    hit = _COMPILED.get(full)
    if hit is None:
        hit = _COMPILED[full] = build()
    return hit


def is_cached(key: tuple[Hashable, ...]) -> bool:
    """Whether :func:`cached` holds a program for ``key`` (under the active walk)."""
    return _walk_key(key) in _COMPILED


def clear_compiled() -> None:
    """Forget every cached program (e.g. to bound memory in a long session)."""
    _COMPILED.clear()
