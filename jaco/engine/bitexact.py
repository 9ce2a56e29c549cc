"""Float arithmetic that JAX and the native kernels (``jaco/engine/walk.cc``, ``jaco/planners/iaca.cc``) round identically.

XLA:CPU and libm round ``pow``, ``exp`` and ``log`` differently in the last bit, and XLA fuses
a multiply and an add into one FMA where C++ rounds twice. A walk that raises the pheromone to a
power *while it walks* (IACA's local update changes τ after every step) must therefore compute
with operations both sides round identically: :func:`rounded` keeps a product from being fused
into the next add, and :func:`power` is built from integer operations, exact conversions and one
float multiply: ``x^a = 2^(a·log2 x)`` with

* ``log2 x`` = exponent + a 1024-entry table of ``log2(1 + m)`` (fixed point, 2^-24) linearly
  interpolated in integers on the 13 low mantissa bits,
* ``2^y`` = ``2^floor(y)`` × a 1024-entry table of ``2^f`` (fixed point, 2^-23) interpolated on
  14 bits of the fraction,

relative error below 1e-5 (float32 rounding of ``a·log2 x`` dominates); ``x ≤ 0`` gives 0, underflow 0, overflow inf.
The tables are made here, once, in float64 numpy, and handed to the kernel as arguments, so both
sides use the same integers.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

BITS = 10  # table index bits
_I = np.arange(2**BITS + 1, dtype=np.float64) / 2**BITS
LOG_TABLE = np.round(np.log2(1.0 + _I) * 2**24).astype(np.int32)  # log2(1 + i/1024), 2^-24 units
EXP_TABLE = np.round(np.exp2(_I) * 2**23).astype(np.int32)  # 2^(i/1024), 2^-23 units
TABLES = np.concatenate([LOG_TABLE, EXP_TABLE])  # what the kernel receives


def rounded(x: jax.Array) -> jax.Array:
    """``x`` rounded to float32 on its own: XLA:CPU fuses a product into a following add (one
    rounding, an FMA) where the C++ kernel rounds twice; this select stops the fusion and is the
    identity (NaN stays NaN)."""
    return jnp.where(x == x, x, jnp.float32(jnp.nan))


def _bits_to_float(b):
    return jax.lax.bitcast_convert_type(b.astype(jnp.int32), jnp.float32)


def log2(x: jax.Array | float) -> jax.Array:
    """log2 of positive normal float32 ``x`` (float32)."""
    b = jax.lax.bitcast_convert_type(jnp.asarray(x, jnp.float32), jnp.int32)
    e = (b >> 23) - 127
    m = b & 0x7FFFFF
    i = m >> (23 - BITS)
    f = m & ((1 << (23 - BITS)) - 1)
    lo, hi = jnp.asarray(LOG_TABLE)[i], jnp.asarray(LOG_TABLE)[i + 1]
    frac = lo + (((hi - lo) * f) >> (23 - BITS))
    # frac·2^-24 is exact, so one rounding (the add) whether or not XLA fuses it into an FMA.
    return e.astype(jnp.float32) + frac.astype(jnp.float32) * jnp.float32(2.0**-24)


def exp2(y: jax.Array | float) -> jax.Array:
    """2^y for float32 ``y`` (0 below 2^-126, inf from 2^128)."""
    y = jnp.asarray(y, jnp.float32)
    n = jnp.floor(y)
    r = y - n  # exact: n is an integer and |y| is far below 2^24
    big = jnp.int32(1 << 24)
    fx = jnp.minimum((r * jnp.float32(2.0**24)).astype(jnp.int32), big - 1)
    j = fx >> (24 - BITS)
    g = fx & ((1 << (24 - BITS)) - 1)
    lo, hi = jnp.asarray(EXP_TABLE)[j], jnp.asarray(EXP_TABLE)[j + 1]
    mant = lo + (((hi - lo) * g) >> (24 - BITS))  # in [2^23, 2^24)
    ni = jnp.clip(n, -126, 127).astype(jnp.int32)
    scale = _bits_to_float((ni + 127) << 23)
    value = mant.astype(jnp.float32) * jnp.float32(2.0**-23) * scale  # products by powers of 2: exact
    return jnp.where(n < -126, 0.0, jnp.where(n > 127, jnp.inf, value)).astype(jnp.float32)


def power(x: jax.Array | float, a: jax.Array | float) -> jax.Array:
    """``x^a`` for float32 ``x`` and ``a`` (0 where ``x ≤ 0``)."""
    x = jnp.asarray(x, jnp.float32)
    pos = x > 0
    y = jnp.asarray(a, jnp.float32) * log2(jnp.where(pos, x, 1.0))
    return jnp.where(pos, exp2(y), 0.0)
