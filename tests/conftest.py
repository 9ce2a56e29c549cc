import os

# Tests run on the CPU, single device unless a test starts its own process.
os.environ.setdefault("JAX_PLATFORMS", "cpu")

import jax  # noqa: E402

jax.config.update("jax_numpy_rank_promotion", "raise")

import pytest  # noqa: E402

#: Memory maps a test process may hold before the compiled programs are forgotten (Linux allows
#: 65,530 by default; every XLA:CPU executable holds some).
MAP_BUDGET = 25_000


def _memory_maps() -> int | None:
    try:
        with open("/proc/self/maps", "rb") as f:
            return sum(1 for _ in f)
    except OSError:  # not Linux: forget after every module
        return None


@pytest.fixture(autouse=True, scope="module")
def _forget_compiled_programs():
    """Hundreds of executables in one process exhaust the kernel's memory-map limit (XLA:CPU then
    crashes), so after a module the compiled programs are forgotten once the process holds more
    than MAP_BUDGET maps; below it the next modules reuse them (the same planner on the same map
    compiles once per process, not once per module)."""
    yield
    maps = _memory_maps()
    if maps is None or maps > MAP_BUDGET:
        import jaco.engine.cache

        jaco.engine.cache.clear_compiled()
        jax.clear_caches()


@pytest.fixture
def kill_after():
    """:func:`_kill_after`, for the tests that kill a process in the middle of its work."""
    return _kill_after


def _kill_after(proc, count, at_least: int, what: str, timeout: float = 120.0) -> None:
    """SIGKILL ``proc`` once ``count()`` (a query of the database it writes) reaches ``at_least``;
    fails if the process ends first. A database still locked or not yet created counts as not yet."""
    import signal
    import sqlite3
    import time

    deadline = time.time() + timeout
    while time.time() < deadline and proc.poll() is None:
        time.sleep(0.1)
        try:
            if count() >= at_least:
                break
        except sqlite3.Error:
            continue
    assert proc.poll() is None, f"the {what} ended before it could be killed"
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()


#: The longest test files first. A file runs whole in one process (``--dist loadfile``), so a long
#: one that starts last leaves the other processes idle at the end; started first, the short files
#: fill the gaps around it (longest processing time first).
LONGEST = ("test_native.py", "test_notebooks.py", "test_variants.py", "test_local_search.py",
           "test_experiments.py", "test_quality.py", "test_bench.py", "test_signals.py", "test_search.py",
           "test_sweeps.py")


def pytest_collection_modifyitems(items):
    rank = {name: i for i, name in enumerate(LONGEST)}
    items.sort(key=lambda item: rank.get(item.path.name, len(LONGEST)))  # stable: the rest keep their order
