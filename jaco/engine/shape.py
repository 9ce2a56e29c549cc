"""The static shape of a run: :class:`RunShape`, the choices fixed when a program compiles.

One frozen, hashable value instead of the sizes threaded one by one through
:func:`jaco.engine.run.solve`, the waypoint legs, :func:`jaco.engine.result.to_result` and the
sweep's chunk programs; it is part of the compile cache's keys (:mod:`jaco.engine.cache`).
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class RunShape:
    """``n_ants`` ants per iteration, ``n_iters`` iterations, at most ``steplimit`` steps per
    walk; ``connectivity`` (4 or 8) of the move model; ``keep_pheromone``: False, True (the final
    pheromone) or ``"history"`` (after every iteration). Sizes are validated by
    :func:`jaco.engine.checks.check_shape` before anything compiles."""

    n_ants: int
    n_iters: int
    steplimit: int
    connectivity: int = 8
    keep_pheromone: bool | str = False

    @property
    def program(self) -> tuple:
        """What a compiled run depends on: every field but ``connectivity``, which only changes
        the problem's arrays (same shapes), so 4- and 8-connected runs share one program."""
        return (self.n_ants, self.n_iters, self.steplimit, self.keep_pheromone)

    @property
    def sizes(self) -> dict:
        """``n_ants``, ``n_iters`` and ``steplimit`` as keyword arguments (of :func:`make_run`)."""
        return dict(n_ants=self.n_ants, n_iters=self.n_iters, steplimit=self.steplimit)
