"""A sweep's set-up: its configurations checked against the planner, its sizes, seeds and memory
budget checked, then its chunks planned and the chunk program compiled (:class:`SweepSetup`)."""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import numpy as np
from jax.sharding import Mesh

from ..engine.checks import check_seeds, resolve_params
from ..engine.memory import CONFIG_BYTES, check_memory
from ..engine.params import check_order, check_values
from ..engine.shape import RunShape
from ..errors import JacoError, ParamError
from ..planners.registry import get_planner
from .chunks import AXIS, Runner, mesh_devices
from .designs import as_design
from .queries import prepare_queries


# -- configurations -------------------------------------------------------------------------
def config_table(planner, params) -> tuple[dict, list[str]]:
    """Per-configuration values (float64, one array per Params field) and the swept names."""
    where = f"planner {planner.name!r}"
    if isinstance(params, dict):
        check_values(params, planner.params, where)  # the planner's own names in the message
        n = math.prod(np.size(v) for v in params.values())
        check_memory(
            n * CONFIG_BYTES,
            f"a grid of {n} configurations",
            "use fewer values per axis, or a random or Latin hypercube design",
        )
    design = as_design(params)
    unknown = [k for k in design.names if k not in planner.params]
    if unknown:
        raise ParamError(f"unknown parameter {unknown[0]!r} for {where}; valid: {', '.join(sorted(planner.params))}")
    base = resolve_params(planner, {}, where=where)
    n = len(design)
    table = {k: np.broadcast_to(design[k] if k in design else base[k], (n,)).astype(np.float64) for k in base}
    check_order(table, planner.params, per_row=True)  # on every row (τmin < τmax, Q1 < Q2 < Q3, ρ2 < ρ1)
    return table, list(design.names)


def check_budget(memory_budget: Any) -> int:
    if isinstance(memory_budget, bool) or not isinstance(memory_budget, (int, np.integer)) or memory_budget < 1:
        raise JacoError(f"memory_budget must be a positive number of bytes, got {memory_budget!r}")
    return int(memory_budget)


class SweepSetup(NamedTuple):
    planner: object
    queries: list
    problems: list
    values: dict
    config: np.ndarray
    seeds: np.ndarray
    runner: Runner
    info: dict


def set_up_sweep(
    grid,
    start,
    goal,
    planner,
    params,
    seeds,
    n_ants,
    n_iters,
    steplimit,
    connectivity,
    memory_budget,
    devices,
    on_compile=None,
    chunk=None,
):
    """Validate everything (before compiling), then plan the chunks and compile the program."""
    planner = get_planner(planner)
    qs, steplimit = prepare_queries(
        grid,
        start,
        goal,
        n_ants=n_ants,
        n_iters=n_iters,
        steplimit=steplimit,
        connectivity=connectivity,
        planner=planner,
    )
    seed_list = check_seeds(seeds)
    budget = check_budget(memory_budget)
    if chunk is not None and (isinstance(chunk, bool) or not isinstance(chunk, (int, np.integer)) or chunk < 1):
        raise JacoError(f"chunk must be a positive number of runs (configurations x seeds), got {chunk!r}")
    values, _ = config_table(planner, params)
    n_cfg = len(next(iter(values.values())))
    n_rows = n_cfg * len(seed_list) * len(qs.queries)
    check_memory(
        n_rows * 8 * (2 * len(values) + 16),
        f"a table of {n_rows} runs",
        "use fewer configurations, seeds or queries (or several sweeps)",
    )
    mesh = Mesh(np.array(mesh_devices(devices)), (AXIS,))
    config = np.repeat(np.arange(n_cfg), len(seed_list))  # configuration-major, seeds inner
    seed_arr = np.tile(seed_list, n_cfg)
    rows = len(config) if chunk is None else min(len(config), int(chunk))
    shape = RunShape(n_ants, n_iters, steplimit, connectivity)
    runner = Runner(planner, qs, shape=shape, mesh=mesh, rows=rows, budget=budget, on_compile=on_compile)
    info = dict(
        runs=len(config) * len(qs.problems),
        configurations=n_cfg,
        seeds=len(seed_list),
        queries=len(qs.problems),
        steplimit=int(steplimit),
        **runner.info,
    )
    if chunk is not None:  # chunks: over every row, not only the capped first one
        info["chunks"] = math.ceil(len(config) / runner.width)
    return SweepSetup(planner, qs.queries, qs.problems, values, config, seed_arr, runner, info)
