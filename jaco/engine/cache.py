"""The compile cache: every compiled program (runs, sweep chunks, waypoint legs, tuning loops) is
built once per key and kept, so repeated calls of one shape never recompile.

Keys hold the planner itself (a :class:`~jaco.engine.planner.Planner` is hashable: its functions
by identity, its defaults as a frozen map), the static shape of the run
(:class:`~jaco.engine.shape.RunShape`) and whatever else the program depends on. The active walk
(:func:`jaco.engine.native.active_walk`) is part of every key: a program traced for one walk never
serves the other.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Hashable
from typing import Any

from . import native

_COMPILED: dict = {}
_KEPT_LOCK = threading.Lock()


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


def kept(store: dict, key: Hashable, build: Callable[[], Any], limit: int) -> Any:
    """``build()`` for ``key``, kept in ``store`` (a dict) among the ``limit`` keys used last: a
    hit moves its key to the newest, a new key drops the oldest. A ``build`` that raises keeps
    nothing. Safe from several threads (two may build one key; both get a value)."""
    with _KEPT_LOCK:
        hit = store.pop(key, None)
    if hit is None:
        hit = build()
    keep(store, key, hit, limit)
    return hit


def keep(store: dict, key: Hashable, value: Any, limit: int) -> None:
    """``store[key] = value`` as :func:`kept` keeps it: the newest of the ``limit`` keys used last."""
    with _KEPT_LOCK:
        store.pop(key, None)
        while len(store) >= limit:
            store.pop(next(iter(store)))  # the key used longest ago
        store[key] = value
