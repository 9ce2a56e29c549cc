"""The native move weights' log and exp against XLA's on every float32 input.

jaco's native kernel computes the roulette weights ``τ^α·f`` the way XLA:CPU computes
:func:`jaco.engine.weights.scaled_weights`: XLA's own float32 log and exp polynomials, operation for
operation (``jaco/engine/weights_lanes.cc``). This script compares the kernel's log of
``max(x, tiny)`` with ``jnp.log(jnp.maximum(x, tiny))`` for all 2^32 bit patterns x, and its exp
with ``jnp.exp`` for every x in [-inf, 0] (where the weights take it), with each instruction set
of the kernel this CPU runs, NaN counted equal to NaN. It prints the number of inputs that differ
(0 expected) and fails otherwise.

The kernel itself checks, once per process, that its weights equal XLA's on a probe of every
binade (:func:`jaco.engine.weights.kernel_mode`); this is the exhaustive check behind it, to run
again after a jaxlib upgrade:

    python experiments/check_xla_math.py            # all 2^32 inputs, a few minutes a set
    python experiments/check_xla_math.py --smoke    # 2^22 inputs spread over every binade
"""

from __future__ import annotations

import argparse
import sys
import time

import jax
import jax.numpy as jnp
import numpy as np

from jaco.engine import native, weights

CHUNK = 1 << 24
TINY = np.float32(np.finfo(np.float32).tiny)


def same(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Bit-equal, or both NaN."""
    return (a.view(np.uint32) == b.view(np.uint32)) | (np.isnan(a) & np.isnan(b))


def inputs(smoke: bool):
    """Chunks of float32 bit patterns: all 2^32, or for --smoke 2^22 spread evenly over them."""
    if smoke:
        rng = np.random.default_rng(0)
        yield np.concatenate([rng.integers(0, 2**32, 1 << 22, dtype=np.uint64).astype(np.uint32),
                              np.arange(0, 2**32, 1 << 16, dtype=np.uint64).astype(np.uint32)]).view(np.float32)
        return
    for c in range(2**32 // CHUNK):
        yield (np.arange(CHUNK, dtype=np.uint64) + c * CHUNK).astype(np.uint32).view(np.float32)


def check(isa: str, fused: bool, smoke: bool) -> tuple[int, int, int]:
    """(inputs checked, logs that differ, exps that differ) with instruction set ``isa``."""
    native.set_isa(isa)
    xla_log = jax.jit(lambda x: jnp.log(jnp.maximum(x, TINY)))
    xla_exp = jax.jit(jnp.exp)
    kernel = jax.jit(lambda x: weights.native_log_exp(x, fused=fused))
    n = bad_log = bad_exp = 0
    for x in inputs(smoke):
        lg, ex = (np.asarray(a) for a in kernel(x))
        bad_log += int((~same(lg, np.asarray(xla_log(x)))).sum())
        neg = (x <= 0) | np.isneginf(x)  # the exp's domain in the weights (NaN excluded)
        if neg.any():
            bad_exp += int((~same(ex[neg], np.asarray(xla_exp(x[neg])))).sum())
        n += x.size
    return n, bad_log, bad_exp


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--smoke", action="store_true", help="2^22 inputs instead of all 2^32")
    args = ap.parse_args(argv)
    if not native.available():
        print(f"no native kernel: {native.unavailable_reason()}")
        return 1
    mode = weights.kernel_mode()
    print(f"jax {jax.__version__}; the kernel's weights equal XLA's on this machine: {mode or 'no'}")
    fused = mode != "unfused"
    failed = mode is None
    runnable = [name for name, state in native.isas().items() if state in ("active", "runs")]
    try:
        for isa in runnable:
            t = time.perf_counter()
            n, bad_log, bad_exp = check(isa, fused, args.smoke)
            print(f"{isa:9s} {'fused' if fused else 'unfused'}: {n:,} inputs, log differs on {bad_log:,}, "
                  f"exp on {bad_exp:,} ({time.perf_counter() - t:.0f} s)")
            failed |= bool(bad_log or bad_exp)
    finally:
        native.set_isa(None)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
