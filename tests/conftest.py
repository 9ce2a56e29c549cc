import os

# Tests run on the CPU, single device unless a test starts its own process.
os.environ.setdefault("JAX_PLATFORMS", "cpu")

import jax  # noqa: E402

jax.config.update("jax_numpy_rank_promotion", "raise")

import pytest  # noqa: E402


@pytest.fixture(autouse=True, scope="module")
def _forget_compiled_programs():
    """Each test module starts without the previous modules' compiled programs: hundreds of
    executables in one process exhaust the kernel's memory-map limit (XLA:CPU then crashes)."""
    yield
    import jaco.engine.run

    jaco.engine.run.clear_compiled()
    jax.clear_caches()
