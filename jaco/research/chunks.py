"""The compiled chunk program of a sweep or search and its :class:`Runner`.

The program is ``vmap(vmap(run))`` over configurations × seeds (the *configuration axis*) and
queries, sharded over a 1-D mesh of devices; the chunk size is planned under a memory budget from
XLA's memory analysis of the compiled program (:func:`_plan`), and :class:`Runner` runs any rows
through it in chunks of one width (the last one padded), so one executable serves all.
"""

from __future__ import annotations

import math

import jax
import numpy as np
from jax.sharding import Mesh, NamedSharding, PartitionSpec

from .. import progress as _progress
from ..engine import native
from ..engine.cache import cached, is_cached
from ..engine.checks import params_from
from ..engine.memory import bytes_per_run
from ..engine.planner import Planner
from ..engine.problem import stack
from ..engine.run import batch_runs, make_run
from ..engine.shape import RunShape
from ..errors import JacoError
from .queries import Queries

AXIS = "config"


# -- memory ---------------------------------------------------------------------------------
def _footprint(compiled) -> int | None:
    """Per-device bytes of a compiled program: arguments + outputs + XLA temporaries."""
    try:
        m = compiled.memory_analysis()
    except (NotImplementedError, RuntimeError, AttributeError):  # backends without the analysis
        return None
    if m is None:
        return None
    return int(m.argument_size_in_bytes + m.output_size_in_bytes + m.temp_size_in_bytes - m.alias_size_in_bytes)


# -- devices and the compiled chunk program -------------------------------------------------
def mesh_devices(devices) -> list:
    """None: every device (all processes' after ``jax.distributed.initialize``), or the one set
    by ``jax.default_device``; an int n: the first n; or a list of devices."""
    if devices is None:
        chosen = jax.config.jax_default_device  # type: ignore[attr-defined]  # jax's Config makes its flags at runtime
        return [chosen] if isinstance(chosen, jax.Device) else list(jax.devices())
    if isinstance(devices, (int, np.integer)) and not isinstance(devices, bool):
        available = jax.devices()
        if not 1 <= devices <= len(available):
            raise JacoError(f"devices: asked for {devices}, there are {len(available)} ({available[0].platform})")
        return list(available[: int(devices)])
    devs = list(devices)
    if not devs or not all(isinstance(d, jax.Device) for d in devs):
        raise JacoError("devices must be None, a positive int or a non-empty list of jax devices")
    if len({d.id for d in devs}) != len(devs):
        raise JacoError("devices: a device is listed twice")
    return devs


_PER_CONFIG: dict = {}  # (walk, planner, shape, batch shapes) -> measured bytes per configuration and device


def _program(planner: Planner, shape: RunShape, mesh: Mesh, paths: bool = False):
    """The jitted chunk program (cached): ``(seeds, problems, params) -> (cost, length, best
    iteration, covered[, best cells])``, each ``(queries, configurations)``; ``paths`` adds the
    best ant's cells (for path metrics such as turns)."""
    key = ("sweep", planner, *shape.sizes.values(), tuple(d.id for d in mesh.devices.flat), paths)

    def build():
        # reports a few times a chunk (its bar); an interrupt ends the chunk at its next iteration
        batched = batch_runs(make_run(planner, **shape.sizes, report=True))

        def chunk(seeds, problems, params):
            out = batched(jax.vmap(jax.random.key)(seeds), problems, params)
            cells = (out.best_cells,) if paths else ()
            return (out.best_cost, out.best_length, out.best_iteration, out.covered) + cells

        # Each device runs its slice on its own (no collective inside), so a device's while-loops
        # stop when its own ants do; check_vma off: the run's loop carries start replicated.
        program = jax.shard_map(
            chunk,
            mesh=mesh,
            in_specs=(PartitionSpec(AXIS), PartitionSpec(), PartitionSpec(AXIS)),
            out_specs=PartitionSpec(None, AXIS),
            check_vma=False,
        )
        return jax.jit(program)

    return key, cached(key, build)


def _shapes(batch) -> tuple:
    return tuple((tuple(x.shape), str(x.dtype)) for x in jax.tree.leaves(batch))


def _executable(
    planner: Planner,
    shape: RunShape,
    mesh: Mesh,
    batch,
    n_params: int,
    chunk: int,
    on_compile=None,
    paths: bool = False,
):
    """The compiled chunk program for ``chunk`` configurations per device (cached), its bytes
    per device (:func:`_footprint`, None where the backend does not say), and whether it was
    compiled by this call (``on_compile()`` is called first when it is)."""
    pkey, program = _program(planner, shape, mesh, paths)
    key = (pkey, _shapes(batch), n_params, chunk)
    new = not is_cached(key)

    def build():
        if on_compile is not None:
            on_compile()
        width = chunk * mesh.size
        on_cfg, replicated = NamedSharding(mesh, PartitionSpec(AXIS)), NamedSharding(mesh, PartitionSpec())
        seeds = jax.ShapeDtypeStruct((width,), np.uint32, sharding=on_cfg)
        problems = jax.tree.map(lambda x: jax.ShapeDtypeStruct(x.shape, x.dtype, sharding=replicated), batch)
        params = params_from(planner.default_params().to_dict(), (width,))
        params = jax.tree.map(lambda x: jax.ShapeDtypeStruct(x.shape, np.float32, sharding=on_cfg), params)
        return _progress.run_interruptibly(lambda: program.lower(seeds, problems, params).compile())

    exe = cached(key, build)
    # XLA's memory analysis takes milliseconds a call: asked once per program, not once per sweep
    return exe, cached(("footprint", *key), lambda: _footprint(exe)), new


def _agree(value: int) -> int:
    """Process 0's value on every process (chunk decisions must match everywhere)."""
    if jax.process_count() == 1:
        return int(value)
    from jax.experimental import multihost_utils

    return int(multihost_utils.broadcast_one_to_all(np.int32(value)))


def fit_chunk(budget: int, fixed: int, per: float, rows_per_device: int) -> int:
    """Configurations per device and chunk: as many as fit, then balanced over the chunks."""
    c = int(max(1, min(rows_per_device, (budget - fixed) // max(per, 1.0))))
    n_chunks = math.ceil(rows_per_device / c)
    return math.ceil(rows_per_device / n_chunks)


def _plan(
    planner: Planner,
    shape: RunShape,
    mesh: Mesh,
    batch,
    n_params: int,
    n_rows: int,
    budget: int,
    on_compile=None,
    paths: bool = False,
):
    """Choose the chunk size under the budget from the compiled program's memory analysis: as
    many of ``n_rows`` runs per chunk as fit (``n_rows`` is also the cap: a caller that wants
    smaller chunks passes the chunk it wants).

    Returns ``(executable, configurations per device and chunk, info dict)``."""
    rows_per_device = math.ceil(n_rows / mesh.size)
    fixed = sum(int(np.asarray(x).nbytes) for x in jax.tree.leaves(batch))  # replicated problems
    mkey = (native.active_walk(), planner, *shape.sizes.values(), _shapes(batch), paths)
    path_len = path_buffer(planner, shape, jax.tree.map(lambda x: jax.ShapeDtypeStruct(x.shape[1:], x.dtype), batch))
    guess = bytes_per_run(batch.n_cells, shape.n_ants, shape.n_iters, shape.steplimit, path_len) * batch.nbr.shape[0]
    per = _PER_CONFIG.get(mkey, guess)
    chunk = _agree(fit_chunk(budget, fixed, per, rows_per_device))
    compiles, tried = 0, []
    while True:
        exe, used, new = _executable(planner, shape, mesh, batch, n_params, chunk, on_compile, paths)
        compiles += new
        tried.append(chunk)
        if used is None:
            break
        used = 1024 * _agree(math.ceil(used / 1024))  # KiB: fits an int32 broadcast
        measured = max(1.0, (used - fixed) / chunk)
        _PER_CONFIG[mkey] = measured
        if used <= budget or chunk == 1:
            break
        chunk = _agree(min(chunk - 1, fit_chunk(budget, fixed, 1.05 * measured, rows_per_device)))
    info = dict(
        devices=mesh.size,
        processes=jax.process_count(),
        chunk_per_device=chunk,
        chunk=chunk * mesh.size,
        chunks=math.ceil(rows_per_device / chunk),
        bytes_per_chunk=used,
        bytes_per_config_estimate=guess,
        bytes_per_config_measured=None if used is None else measured,
        memory_budget=budget,
        compiles=compiles,
        chunks_tried=tried,  # configurations per device of each compiled attempt
    )
    return exe, chunk, info


_PATH_LEN: dict = {}


def path_buffer(planner: Planner, shape: RunShape, problem) -> int:
    """Length of the best-path buffer of ``planner``'s run of ``shape`` on problems shaped as
    ``problem`` (one problem: arrays or shapes); traced once per planner and shapes."""
    key = (planner, *shape.sizes.values(), _shapes(problem))
    if key not in _PATH_LEN:
        run = make_run(planner, **shape.sizes)
        prm = jax.tree.map(lambda x: jax.ShapeDtypeStruct((), np.float32), planner.default_params())
        out = jax.eval_shape(run, jax.ShapeDtypeStruct((), jax.random.key(0).dtype), problem, prm)
        _PATH_LEN[key] = int(out.best_cells.shape[0])
    return _PATH_LEN[key]


def _put(x: np.ndarray, sharding):
    """A (possibly multi-process) global array from the full host array every process holds."""
    x = np.asarray(x)
    return jax.make_array_from_callback(x.shape, sharding, lambda index: x[index])


def _fetch(x) -> np.ndarray:
    if x.is_fully_addressable:
        return np.asarray(x)
    from jax.experimental import multihost_utils

    return np.asarray(multihost_utils.process_allgather(x, tiled=True))


class Runner:
    """One planner's compiled chunk program on fixed queries, sizes and devices: ``runner(values,
    seeds)`` runs one row per (configuration values, seed), in chunks of :attr:`width` rows (the
    last one padded), and returns ``(cost, length, best_iteration, covered[, best_cells])`` as
    numpy arrays ``(queries, rows)``. Every row equals :func:`jaco.solve` with its values and seed,
    whatever the chunk it ran in. Built by :func:`jaco.sweep` and :func:`jaco.search`."""

    def __init__(
        self,
        planner: Planner,
        queries: Queries,
        *,
        shape: RunShape,
        mesh: Mesh,
        rows: int,
        budget: int,
        on_compile=None,
        paths: bool = False,
    ):
        self.planner, self.queries, self.mesh, self.paths, self.shape = planner, queries, mesh, paths, shape
        batch = stack(queries.problems)
        n_params = len(planner.default_params().to_dict())
        self.exe, self.chunk, self.info = _plan(planner, shape, mesh, batch, n_params, rows, budget, on_compile, paths)
        self.width = self.chunk * mesh.size
        self._on_cfg = NamedSharding(mesh, PartitionSpec(AXIS))
        self._batch = jax.tree.map(lambda x: _put(x, NamedSharding(mesh, PartitionSpec())), batch)

    def __call__(self, values: dict, seeds: np.ndarray, on_chunk=None, on_iteration=None) -> tuple:
        """``values``: name -> float array (one per row; every parameter of the planner);
        ``seeds``: uint32 (rows,). ``on_chunk(lo, hi, outputs)`` after each chunk (``outputs`` as
        returned, for rows ``lo:hi``); ``on_iteration(lo, hi, done)`` while a chunk runs (``done``
        of its iterations finished)."""
        n = len(seeds)
        outs = None
        for lo in range(0, n, self.width):
            hi = min(lo + self.width, n)
            idx = np.minimum(np.arange(lo, lo + self.width), n - 1)  # pad the last chunk
            prm = params_from({k: np.asarray(v)[idx] for k, v in values.items()}, (self.width,))
            args = (
                _put(np.asarray(seeds, np.uint32)[idx], self._on_cfg),
                self._batch,
                jax.tree.map(lambda x: _put(x, self._on_cfg), prm),
            )
            update = (lambda done, lo=lo, hi=hi: on_iteration(lo, hi, done)) if on_iteration else (lambda done: None)
            with _progress.reporting(update):
                got = _progress.run_interruptibly(lambda args=args: [_fetch(x) for x in self.exe(*args)])
            got = [x[:, : hi - lo] for x in got]
            if outs is None:
                outs = [np.empty((x.shape[0], n) + x.shape[2:], x.dtype) for x in got]
            for dst, src in zip(outs, got):
                dst[:, lo:hi] = src
            if on_chunk is not None:
                on_chunk(lo, hi, got)
        assert outs is not None, "a sweep has at least one row (check_seeds)"
        return tuple(outs)
