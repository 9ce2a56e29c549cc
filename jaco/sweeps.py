"""Hyperparameter sweeps (``jaco.sweep``): the product configurations × seeds × queries as ONE jitted call.

The run is ``jit(vmap(vmap(run)))``: the inner vmap goes over configurations × seeds (one
flat axis), the outer over queries (start/goal pairs, or maps of one shape). Every row of the
table equals :func:`jaco.solve` with the same parameters and seed. The batch is cut into
equal chunks only when it would not fit in ``memory_budget`` bytes (the last chunk is padded,
so every chunk reuses the one compiled function).
"""

from __future__ import annotations

import itertools
import math

import jax
import numpy as np
import pandas as pd

from .construct import pad_steps
from .errors import JacoError
from .grid import Grid
from .problem import make_problem, stack
from .run import check_sizes, compiled_run, default_steplimit, gap, params_from, resolve_params
from .variants import get_variant


def _queries(grid, start, goal):
    """Normalise (grid | [grids], pair | [pairs], pair | [pairs]) to a list of triples."""

    def is_pair(x):
        return np.ndim(x) == 1 and len(x) == 2

    grids = [grid] if isinstance(grid, Grid) else list(grid)
    starts = [start] if is_pair(start) else list(start)
    goals = [goal] if is_pair(goal) else list(goal)
    n = max(len(grids), len(starts), len(goals))
    for name, xs in (("grids", grids), ("starts", starts), ("goals", goals)):
        if len(xs) not in (1, n):
            raise JacoError(f"{name}: got {len(xs)}, expected 1 or {n} (one per query)")
    pick = lambda xs, i: xs[0] if len(xs) == 1 else xs[i]  # noqa: E731
    return [(pick(grids, i), tuple(pick(starts, i)), tuple(pick(goals, i))) for i in range(n)]


def bytes_per_run(n_cells: int, n_ants: int, n_iters: int, steplimit: int) -> int:
    """Rough peak bytes of one run inside a batch: the tabu bitmaps, the step buffers and
    uniforms, the pheromone and weights, the history; doubled for XLA's temporaries."""
    s = pad_steps(steplimit)
    per = n_ants * n_cells + 5 * 4 * s * n_ants + 4 * 4 * 8 * n_cells + 16 * n_iters
    return 2 * per


def sweep(
    grid,
    start,
    goal,
    variant="mmas",
    params: dict | None = None,
    seeds=4,
    *,
    n_ants: int = 50,
    n_iters: int = 100,
    steplimit: int | None = None,
    connectivity: int = 8,
    memory_budget: int = 2 << 30,
    progress: bool = False,
) -> pd.DataFrame:
    """Run every combination of ``params`` (name -> list of values) × ``seeds`` × queries.

    ``seeds`` is a count (``range(seeds)``) or a list of integer seeds. ``grid`` may be a list of
    grids of one shape and ``start``/``goal`` lists of pairs (one per query, or one for all).
    Returns one row per query × configuration × seed with the parameter values, the seed, and
    ``success, length, cost, best_iteration, optimal, gap, coverage``.
    """
    variant = get_variant(variant)
    queries = _queries(grid, start, goal)
    shapes = {g.shape for g, _, _ in queries}
    if len(shapes) != 1:
        raise JacoError(f"all maps of a sweep must have one shape, got {sorted(shapes)}")
    steplimit = default_steplimit(queries[0][0]) if steplimit is None else steplimit
    check_sizes(n_ants, n_iters, steplimit)
    seeds = list(range(seeds)) if isinstance(seeds, (int, np.integer)) else [int(s) for s in seeds]
    if not seeds:
        raise JacoError("seeds: need at least one seed")
    axes = {k: np.atleast_1d(np.asarray(v, dtype=np.float64)) for k, v in (params or {}).items()}
    resolve_params(variant, axes, where=f"variant {variant.name!r}")  # names, NaN, ranges
    problems = [make_problem(g, s, t, connectivity=connectivity) for g, s, t in queries]

    names = list(axes)
    combos = list(itertools.product(*(axes[k] for k in names))) or [()]
    rows = [(dict(zip(names, c)), seed) for c in combos for seed in seeds]
    base = resolve_params(variant, {}, where=variant.name)
    table = {k: np.array([{**base, **r}[k] for r, _ in rows], np.float64) for k in base}
    seed_arr = np.array([s for _, s in rows], np.uint32)

    n_rows, n_q = len(rows), len(problems)
    per = bytes_per_run(problems[0].n_cells, n_ants, n_iters, steplimit) * n_q
    chunk = int(max(1, min(n_rows, memory_budget // max(per, 1))))
    n_chunks = math.ceil(n_rows / chunk)
    run = compiled_run(variant, n_ants, n_iters, steplimit, False, batched=True)
    batch = stack(problems)
    make_keys = jax.vmap(jax.random.key)

    outs = []
    bar = range(n_chunks)
    if progress and n_chunks > 1:
        from tqdm.auto import tqdm

        bar = tqdm(bar, desc=f"sweep {variant.name}", unit="chunk")
    for c in bar:
        idx = np.minimum(np.arange(c * chunk, (c + 1) * chunk), n_rows - 1)  # pad the last chunk
        out = run(make_keys(seed_arr[idx]), batch, params_from({k: v[idx] for k, v in table.items()}, (chunk,)))
        out = jax.device_get((out.best_cost, out.best_length, out.best_iteration, out.covered))
        outs.append([np.asarray(a)[:, : min(chunk, n_rows - c * chunk)] for a in out])
    cost, length, best_iter, coverage = (np.concatenate(parts, axis=1) for parts in zip(*outs))

    records = []
    for q, (g, s, t) in enumerate(queries):
        optimal = float(problems[q].optimal) * g.cell_size
        for i, (_, seed) in enumerate(rows):
            success = bool(np.isfinite(cost[q, i]))
            L = float(length[q, i]) * g.cell_size if success else math.inf
            rec = {"map": g.name, "start": s, "goal": t} if n_q > 1 else {}
            rec.update({k: float(table[k][i]) for k in variant.params})
            rec.update(
                seed=seed,
                success=success,
                length=L,
                cost=float(cost[q, i]),
                best_iteration=int(best_iter[q, i]),
                optimal=optimal,
                gap=gap(L, optimal),
                coverage=int(coverage[q, i]) / g.n_free,
            )
            records.append(rec)
    return pd.DataFrame.from_records(records)


def summarize(table: pd.DataFrame, by=None) -> pd.DataFrame:
    """Per-configuration summary over seeds: mean, std and min length, success rate, mean gap."""
    ignore = {"seed", "success", "length", "cost", "best_iteration", "optimal", "gap", "coverage"}
    by = [c for c in table.columns if c not in ignore] if by is None else list(by)
    finite = table.assign(length=table["length"].where(np.isfinite(table["length"])))
    return finite.groupby(by, sort=False).agg(
        length_mean=("length", "mean"),
        length_std=("length", "std"),
        length_min=("length", "min"),
        success_rate=("success", "mean"),
        gap_mean=("gap", lambda g: float(np.mean(g)) if np.isfinite(g).all() else math.inf),
        runs=("seed", "count"),
    ).reset_index()
