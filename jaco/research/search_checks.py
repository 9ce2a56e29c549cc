"""A search's options checked, each mistake one line before anything compiles: the objectives
(:data:`OBJECTIVES`), their penalties, the fidelity schedule (:class:`Halving`), counts and
seconds; :class:`SearchError`, the error of every search that cannot run or resume."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np

from ..errors import JacoError

OBJECTIVES: dict[str, Literal["minimize", "maximize"]] = {
    "gap": "minimize",
    "length": "minimize",
    "turns": "minimize",
    "success": "maximize",
    "budget": "minimize",
}
PENALIZED = ("gap", "length", "turns")


class SearchError(JacoError):
    """A search that cannot run or resume (one line, before anything compiles)."""


def positive_int(name, v, limit: int | None = 2**31 - 1, *, even: str = "", error: type = SearchError) -> int:
    """``v`` as an int, checked: an integer (not a bool) in ``[1, limit]`` (no bound with None);
    with ``even`` (the reason, in the message) an even one ≥ 2. The research package's one check of a
    count: ``error`` is the caller's error class."""
    ok = not isinstance(v, bool) and isinstance(v, (int, np.integer)) and 1 <= v and (limit is None or v <= limit)
    if not ok or (even and v % 2):
        need = f"an even integer ≥ 2 ({even})" if even else "a positive integer"
        raise error(f"{name} must be {need}, got {v!r}")
    return int(v)


def positive_seconds(name, v, error: type = SearchError) -> float:
    """``v`` as a float, checked: a finite number (not a bool or a string) > 0; the research
    package's one check of a duration, ``error`` the caller's error class."""
    if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)) or not 0 < v < math.inf:
        raise error(f"{name} must be a positive finite number of seconds, got {v!r}")
    return float(v)


@dataclass(frozen=True)
class Halving:
    """Successive halving over the iteration budget (see :mod:`jaco.research.search`): rungs at
    ``n_iters / eta**k`` iterations down to ``min_iters`` (default ``n_iters / eta**2``, at least
    1); each rung keeps the best ``1/eta`` of the trials (at least one). ``hyperband``: the
    brackets cycle through the rungs they start at (Hyperband's brackets, each with ``batch``
    trials), the first starting at the smallest budget."""

    min_iters: int | None = None
    eta: int = 3
    hyperband: bool = False

    def rungs(self, n_iters: int) -> list[int]:
        if isinstance(self.eta, bool) or not isinstance(self.eta, (int, np.integer)) or self.eta < 2:
            raise SearchError(f"Halving: eta must be an integer >= 2, got {self.eta!r}")
        low = self.min_iters if self.min_iters is not None else max(1, n_iters // self.eta**2)
        if isinstance(low, bool) or not isinstance(low, (int, np.integer)) or not 1 <= low <= n_iters:
            raise SearchError(f"Halving: min_iters must be an integer in [1, n_iters = {n_iters}], got {low!r}")
        rungs = [int(n_iters)]
        while rungs[0] // self.eta >= low:
            rungs.insert(0, rungs[0] // self.eta)
        return rungs

    def brackets(self, n_iters: int) -> list[list[int]]:
        """The rungs of each bracket, cycled through in order."""
        rungs = self.rungs(n_iters)
        return [rungs[s:] for s in range(len(rungs) if self.hyperband else 1)]

    def describe(self) -> dict:
        return {"min_iters": self.min_iters, "eta": int(self.eta), "hyperband": bool(self.hyperband)}


def check_fidelity(fidelity) -> Halving | None:
    if fidelity is None or isinstance(fidelity, Halving):
        return fidelity
    if fidelity in ("halving", "hyperband"):
        return Halving(hyperband=fidelity == "hyperband")
    raise SearchError(
        f"fidelity must be None, 'halving', 'hyperband' or a jaco.research.search.Halving, got {fidelity!r}"
    )


def check_objectives(objective) -> tuple[str, ...]:
    names = (
        (objective,) if isinstance(objective, str) else tuple(objective) if isinstance(objective, (list, tuple)) else ()
    )
    if not names or not all(isinstance(n, str) for n in names):
        raise SearchError(f"objective must be a name or a list of names ({', '.join(OBJECTIVES)}), got {objective!r}")
    for n in names:
        if n not in OBJECTIVES:
            raise SearchError(f"unknown objective {n!r}; valid: {', '.join(OBJECTIVES)}")
    if len(set(names)) != len(names):
        raise SearchError(f"objective: {names} names one twice")
    return names


def check_penalties(penalty, objectives) -> dict:
    """User penalties by objective (None: the default bound, per query)."""
    out: dict[str, float | None] = {n: None for n in objectives if n in PENALIZED}
    if penalty is None:
        return out
    given = penalty if isinstance(penalty, dict) else {n: penalty for n in out}
    for n, v in given.items():
        if n not in out:
            raise SearchError(f"penalty for {n!r}: only {', '.join(out) or 'no objective'} of this search take one")
        try:
            x = float(v)
        except (TypeError, ValueError):
            raise SearchError(f"penalty for {n!r} must be a number, got {v!r}") from None
        if not (math.isfinite(x) and x >= 0):
            raise SearchError(f"penalty for {n!r} must be a finite number >= 0, got {v!r}")
        out[n] = x
    return out
