"""The memory estimate of a call, checked against a budget before anything compiles.

:func:`bytes_per_run` guesses what one run adds to a batch; :func:`memory_budget` is what one call
may plan to use (``JACO_MEMORY_BUDGET`` or half the physical memory); :func:`check_memory` and
:func:`check_run_memory` turn an estimate over the budget into a :class:`~jaco.errors.ResourceError`
that names both. :func:`jaco.sweep` only starts from the guess: the compiled program's own memory
analysis decides its chunks.
"""

from __future__ import annotations

import math
import os

from ..errors import JacoError, ResourceError
from . import native


def bytes_per_run(n_cells: int, n_ants: int, n_iters: int, steplimit: int, path_len: int | None = None) -> int:
    """First guess of the peak bytes one run (one configuration, one query) adds to a batch.

    Fitted to XLA's memory analysis of compiled sweeps (one and two colonies, both walks): about
    8 bytes per ant and step slot with the native walk (moves, cells, targets, step lengths), 14
    with the JAX walk, which also keeps every ant's tabu bitmap (``A·N`` bytes) in XLA's memory;
    the pheromone, weights and heuristic tables ``(N, 8)``, about 100 bytes per cell; the
    history. ``path_len`` is the length of the construct step's candidate buffer: when it is
    longer than one walk (two colonies spliced by crossover), the crossover tables cost about 52
    bytes per ant and candidate slot. A 10 % margin on top. :func:`jaco.sweep` only starts from
    this guess: the compiled program's own memory analysis decides.
    """
    s = steplimit
    path_len = s if path_len is None else path_len
    jax_walk = native.active_walk() == "jax"
    per_slot = 52 if path_len > s else (14 if jax_walk else 8)
    per = (n_ants * n_cells if jax_walk else 0) + per_slot * path_len * n_ants + 100 * n_cells + 32 * n_iters
    return int(1.1 * per)


#: Host bytes one configuration of a sweep costs before it runs: every parameter as float64 in the
#: configuration table, its copies while the design is built, and its row of the result table.
CONFIG_BYTES = 16 * (45 + 8)  # a bound: 45 parameters, every parameter of jaco's own components together


def _parse_bytes(text: str) -> int:
    units = {"": 1, "K": 1 << 10, "M": 1 << 20, "G": 1 << 30, "T": 1 << 40}
    t = text.strip().upper().removesuffix("IB").removesuffix("B")
    unit = t[-1:] if t[-1:] in units else ""
    try:
        value = float(t[: len(t) - len(unit)]) * units[unit]
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value >= 1):
        raise JacoError(f"JACO_MEMORY_BUDGET must be a number of bytes (e.g. 8G, 512M, 1000000), got {text!r}")
    return int(value)


def memory_budget() -> int:
    """Bytes one call may plan to use: ``JACO_MEMORY_BUDGET`` (bytes, or with a K, M, G or T
    suffix) when set, else half of the physical memory (8 GiB where that cannot be read)."""
    text = os.environ.get("JACO_MEMORY_BUDGET")
    if text:
        return _parse_bytes(text)
    try:
        return int(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")) // 2
    except (AttributeError, ValueError, OSError):  # pragma: no cover - not a POSIX system
        return 8 << 30


def _size(n: float) -> str:
    for unit in ("B", "KiB", "MiB", "GiB", "TiB"):
        if n < 1024 or unit == "TiB":
            return f"{n:.3g} {unit}" if unit != "B" else f"{int(n)} B"
        n /= 1024
    return f"{n:.3g} PiB"  # pragma: no cover


def check_memory(need: int, what: str, hint: str) -> None:
    """A :class:`ResourceError` naming the estimate and the budget when ``need`` bytes exceed
    :func:`memory_budget`."""
    budget = memory_budget()
    if need > budget:
        raise ResourceError(
            f"{what} needs about {_size(need)} of memory, more than the budget of {_size(budget)} "
            f"(half the physical memory, or JACO_MEMORY_BUDGET): {hint}"
        )


def check_run_memory(
    n_cells: int,
    n_ants: int,
    n_iters: int,
    steplimit: int,
    *,
    runs: int = 1,
    keep_pheromone: bool | str = False,
    what: str = "this call",
) -> None:
    """The memory estimate of ``runs`` runs held at once (:func:`bytes_per_run`, plus the
    pheromone of every iteration with ``keep_pheromone="history"``) against the budget."""
    need = runs * bytes_per_run(n_cells, n_ants, n_iters, steplimit)
    if keep_pheromone == "history":
        need += runs * n_iters * 8 * n_cells * 4
    check_memory(
        need,
        f"{what} ({runs} run(s) of {n_ants} ants x {n_iters} iterations, step limit {steplimit}, {n_cells} cells)",
        "use fewer ants, iterations or runs, or a smaller step limit",
    )
