"""The roulette weights of every move: τ^α times the planner's factor, scaled per cell.

:func:`scaled_weights` defines them in JAX. On CPU with the native walk, a kernel
(``jaco/engine/weights.cc``) computes the same weights bit for bit: XLA computes float32 log and
exp with its own polynomials, and the kernel repeats them operation for operation, including the
multiply-adds that XLA fuses on CPUs with FMA. :func:`move_weights` uses the kernel only where it
equals XLA's code on this machine. :func:`kernel_mode` checks that once per process.
"""

from __future__ import annotations

import functools
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from . import native

_TINY = float(jnp.finfo(jnp.float32).tiny)
_state: dict = {}


def tau_of_moves(tau: jax.Array, nbr: jax.Array, *, cells: bool) -> jax.Array:
    """``tau`` (``(8N,)`` on moves, ``(N,)`` on cells) as the pheromone of every move ``(N, 8)``."""
    if cells:
        return tau[jnp.where(nbr >= 0, nbr, 0)]
    return tau.reshape(nbr.shape)


def scaled(log_w: jax.Array, valid: jax.Array) -> jax.Array:
    """``exp(log_w)`` scaled so that each cell's largest allowed weight is 1: exactly 0 where the
    map forbids the move, in [1e-30, 1] elsewhere. The roulette and the argmax only compare the
    weights of one cell, so the scaling changes no choice; it keeps large exponents away from
    float32's limits (a weight that would underflow, or a factor of 0, becomes 1e-30: taken only
    when nothing else is allowed)."""
    log_w = jnp.where(valid, jnp.nan_to_num(log_w, nan=-jnp.inf), -jnp.inf)
    top = jnp.max(log_w, axis=1, keepdims=True)
    top = jnp.where(jnp.isfinite(top), top, 0.0)  # rows with no allowed move, or only zero factors
    return jnp.where(valid, jnp.clip(jnp.exp(log_w - top), 1e-30, 1.0), 0.0)


def scaled_weights(tau: jax.Array, nbr: jax.Array, alpha: Any, factor: jax.Array, *, cells: bool) -> jax.Array:
    """The weights ``(N, 8)`` from the pheromone ``tau`` (as the trail holds it), the map's
    neighbours ``nbr (N, 8)`` (-1: forbidden), α and the log of the factor ``(N, 8)``:
    :func:`scaled` of α·log τ + factor, τ = 0 counted as the smallest normal float."""
    log_w = alpha * jnp.log(jnp.maximum(tau_of_moves(tau, nbr, cells=cells), _TINY)) + factor
    return scaled(log_w, nbr >= 0)


def move_weights(tau: jax.Array, nbr: jax.Array, alpha: Any, factor: jax.Array, *, cells: bool) -> jax.Array:
    """:func:`scaled_weights`, by the kernel where :func:`jaco.engine.native.dispatch` takes
    kernels and :func:`kernel_mode` found the kernel equal to XLA."""
    args = (tau, nbr, jnp.asarray(alpha, jnp.float32), factor)
    definition = functools.partial(scaled_weights, cells=cells)
    mode = kernel_mode() if native.active_walk() == "native" else None
    if mode is None:
        return definition(*args)
    return native.dispatch(
        functools.partial(native_move_weights, cells=cells, fused=mode == "fused"), definition, *args
    )


def native_move_weights(
    tau: jax.Array, nbr: jax.Array, alpha: Any, factor: jax.Array, *, cells: bool, fused: bool
) -> jax.Array:
    """The kernel's :func:`scaled_weights` (same arguments and result). ``fused``: each multiply
    that feeds an add is fused with it, as XLA's code does on CPUs with FMA (:func:`kernel_mode`)."""
    out = jax.ShapeDtypeStruct(jnp.shape(nbr), jnp.float32)
    # expand_dims: what the colonies share (the neighbours, a factor) is read in place, not copied per colony
    call = native.ffi_call("jaco_move_weights", out, vmap_method="expand_dims")
    return call(
        jnp.asarray(tau, jnp.float32).reshape(-1),
        jnp.asarray(nbr, jnp.int32),
        jnp.asarray(alpha, jnp.float32),
        jnp.asarray(factor, jnp.float32),
        cells=bool(cells),
        fused=bool(fused),
    )


def native_log_exp(x: jax.Array, *, fused: bool) -> tuple[jax.Array, jax.Array]:
    """The kernel's log of ``max(x, tiny)`` and exp of ``x`` (for x in [-inf, 0], where the weights
    take it). Tests compare them with ``jnp.log`` and ``jnp.exp``."""
    x = jnp.asarray(x, jnp.float32)
    out = (jax.ShapeDtypeStruct(x.shape, jnp.float32),) * 2
    return native.ffi_call("jaco_log_exp", out)(x, fused=bool(fused))


def kernel_mode() -> str | None:
    """How the kernel's weights equal XLA's on this machine. ``"fused"``: XLA fuses each
    multiply-add, as on CPUs with FMA. ``"unfused"``: it does not. None: neither form equals XLA
    (another XLA or another CPU), so XLA computes the weights. Found once per process by
    computing a probe's weights both ways (:func:`probe`)."""
    if "mode" not in _state:
        _state["mode"] = None
        if native.available():
            try:
                # the kernel's platform, whatever the default device; this process's own (under
                # jax.distributed, jax.devices lists every process's)
                cpu = jax.local_devices(backend="cpu")[0]
            except RuntimeError:  # no CPU backend (JAX_PLATFORMS=cuda): no kernel call can run
                return None
            # asked while tracing a run: the probe runs now, outside it
            with jax.default_device(cpu), jax.ensure_compile_time_eval():
                _state["mode"] = find_mode()
    return _state["mode"]


def find_mode() -> str | None:
    """The form of the kernel (``"fused"``, ``"unfused"``) whose weights equal XLA's on
    :func:`probe` in both pheromone layouts, or None."""
    tau_cells, tau_moves, nbr, alphas, factor = probe()
    forms = {"xla": scaled_weights} | {
        mode: functools.partial(native_move_weights, fused=mode == "fused") for mode in ("fused", "unfused")
    }

    def all_weights(tau_cells, tau_moves, nbr, alphas, factor):  # one program: one compile
        return {
            (name, cells): jax.vmap(functools.partial(fn, cells=cells), in_axes=(None, None, 0, None))(
                tau_cells if cells else tau_moves, nbr, alphas, factor
            )
            for name, fn in forms.items()
            for cells in (False, True)
        }

    out = {
        k: np.asarray(v).view(np.uint32)
        for k, v in jax.jit(all_weights)(tau_cells, tau_moves, nbr, alphas, factor).items()
    }
    equal = [
        mode for mode in ("fused", "unfused") if all(np.array_equal(out[mode, c], out["xla", c]) for c in (False, True))
    ]
    return equal[0] if equal else None


def probe() -> tuple[np.ndarray, ...]:
    """Inputs on which the kernel's weights must equal XLA's: ``(tau on cells, tau on moves, nbr,
    alphas, factor)``. The pheromone covers every binade of float32 and 0, denormals, inf, NaN and
    negatives. The factors run from -inf to large. Some moves are forbidden, some cells allow no
    move, and some cells have every weight NaN or infinite. α runs from 0 to 20."""
    rng = np.random.default_rng(0)
    n = 4096
    tau = rng.integers(0, 0x7F800000, 8 * n, dtype=np.uint32).view(np.float32).copy()  # finite floats, evenly by bits
    special = np.array([0.0, -0.0, 1e-45, 1e-40, _TINY, np.inf, np.nan, -1.0, 1.0, 2.0, 0.5, 3.4e38], np.float32)
    tau[rng.integers(0, 8 * n, 400)] = rng.choice(special, 400)
    factor = (rng.standard_normal(8 * n) * rng.choice([0.01, 1.0, 30.0, 1e30], 8 * n)).astype(np.float32)
    factor[rng.integers(0, 8 * n, 200)] = rng.choice(np.array([-np.inf, np.nan, 0.0, -0.0, 1e-42], np.float32), 200)
    nbr = rng.integers(0, n, 8 * n).astype(np.int32)
    nbr[rng.random(8 * n) < 0.2] = -1
    nbr[: 8 * 16] = -1  # cells with no allowed move
    tau[8 * 16 : 8 * 20] = np.nan  # cells whose every weight is NaN, +inf or -inf before nan_to_num
    tau[8 * 20 : 8 * 24] = np.inf
    factor[8 * 24 : 8 * 28] = -np.inf
    nbr[8 * 28 : 8 * 32] = 8 * 16 + np.arange(32) % 8  # on cells: every move into a cell of NaN pheromone
    alphas = np.array([0.0, 1.0, 0.37, 3.0, 20.0], np.float32)
    return tau[:n].copy(), tau, nbr.reshape(n, 8), alphas, factor.reshape(n, 8)
