"""Parameter schedules: branch-free functions ``(params, t, n_iters) -> params``.

A planner's ``schedule`` is called once per iteration with the engine's iteration counter ``t``
(0-based, traced) and the static iteration budget ``n_iters``; it returns the :class:`Params`
that iteration uses. Every schedule here is written with ``jnp.where``/``jnp.maximum`` and never
branches in Python on a value, so its own parameters (slopes, break points, floors) are traced
leaves and can be swept with ``jax.vmap`` like any other hyperparameter.

The sources count iterations from 1, so every schedule below uses ``i = t + 1``.

>>> import jax.numpy as jnp
>>> from jaco.engine.params import Params
>>> defaults = Params(**{p.name: p.default for p in IDACA_PARAMS})
>>> p = alpha_beta(defaults, jnp.int32(9), 100)           # iteration i = 10
>>> round(float(p.alpha), 4), round(float(p.beta), 4)
(0.3, 2.85)
>>> p = alpha_beta(defaults, jnp.int32(99), 100)          # i = 100 > break_iter = 83
>>> float(p.alpha), float(p.beta)
(2.5, 2.0)
"""

from __future__ import annotations

from typing import Any, Callable

import jax.numpy as jnp

from .params import Param, Params, declare

#: IDACA's schedule parameters (thesis eqs. 3-8..3-10).
IDACA_PARAMS = declare(
    Param("alpha_slope", 0.03, 0, 10, "IDACA eq. 3-8: α(i) = alpha_slope·i up to break_iter"),
    Param("alpha_end", 2.5, 0, 20, "IDACA eq. 3-8: α after break_iter"),
    Param("beta_start", 3.0, 0, 20, "IDACA eq. 3-9: β(0)"),
    Param("beta_slope", 0.015, 0, 10, "IDACA eq. 3-9: β(i) = beta_start − beta_slope·i up to break_iter"),
    Param("beta_end", 2.0, 0, 20, "IDACA eq. 3-9: β after break_iter"),
    Param("break_iter", 83.0, 0, 1e6, "IDACA eqs. 3-8, 3-9: iteration where α and β switch to their plateaus"),
    Param("rho_min", 0.3, 0, 1, "IDACA eq. 3-10: floor of the decaying evaporation rate", lo_open=True),
    Param("rho_decay", 2.0, 1, 1000, "IDACA eq. 3-10: ρ(t+1) = ρ(t)·a^(−t/Nc), a = rho_decay > 1"),
)


def _iteration(t):
    """The sources' iteration number ``i = t + 1`` as a float."""
    return jnp.asarray(t).astype(jnp.float32) + 1.0


def alpha_beta(params: Params, t: Any, n_iters: int) -> Params:
    """Linear α, β ramps up to a break iteration, then plateaus (thesis eqs. 3-8, 3-9).

    For ``0 < i ≤ break_iter``: ``α = alpha_slope·i`` and ``β = beta_start − beta_slope·i``;
    for ``i > break_iter``: ``α = alpha_end`` and ``β = beta_end``. The thesis prints
    α = 3i/100, β = 3 − 1.5i/100, then 2.5 and 2 (the defaults of :data:`IDACA_PARAMS`, with the break
    at i = 83 where α reaches its plateau). β is floored at 0 so a long ramp never turns negative.
    """
    i = _iteration(t)
    early = i <= params.break_iter
    alpha = jnp.where(early, params.alpha_slope * i, params.alpha_end)  # Eq. (3-8)
    beta = jnp.where(early, jnp.maximum(params.beta_start - params.beta_slope * i, 0.0), params.beta_end)  # Eq. (3-9)
    return params.replace(alpha=alpha, beta=beta)


def rho_decay(params: Params, t: Any, n_iters: int) -> Params:
    """Decaying evaporation rate with a floor (thesis eq. 3-10).

    ``ρ(i+1) = ρ(i)·a^(−i/Nc)`` while ``ρ(i) > ρmin``, then ``ρmin``, with ``ρ(1) = params.rho``
    (ρ0), ``a = rho_decay`` and ``Nc = n_iters``. In closed form
    ``ρ(i) = max(ρmin, ρ0·a^(−i(i−1)/(2·Nc)))``: the product of the factors ``a^(−k/Nc)`` for
    k = 1..i−1. (Read literally, the recursion may step once below ρmin before it is reset; the
    closed form clamps at once.)
    """
    i = _iteration(t)
    exponent = -(i * (i - 1.0)) / (2.0 * n_iters)
    rho = jnp.maximum(params.rho_min, params.rho * jnp.power(params.rho_decay, exponent))  # Eq. (3-10)
    return params.replace(rho=rho)


def compose(*schedules: Callable) -> Callable:
    """Apply schedules one after another (each sees the previous one's output)."""

    def schedule(params: Params, t, n_iters) -> Params:
        for s in schedules:
            params = s(params, t, n_iters)
        return params

    return schedule


#: IDACA's schedule: eqs. 3-8 and 3-9 (α, β) then eq. 3-10 (ρ).
idaca = compose(alpha_beta, rho_decay)
