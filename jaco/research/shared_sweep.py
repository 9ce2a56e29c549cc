"""A sweep shared through a store (:mod:`jaco.research.store`): the sharing arguments checked, then
the worker's loop that claims units of rows, runs them, beats while they run and commits them,
until every row is stored; every worker returns the whole table."""

from __future__ import annotations

import jax
import pandas as pd

from ..errors import JacoError
from .search_checks import positive_seconds
from .sweep_table import tidy_table

#: Seconds without a heartbeat after which a worker's claim on a stored sweep's chunk expires.
GRACE_PERIOD = 60.0


def check_sharing(store, grace_period, heartbeat_interval) -> tuple[float, float]:
    """The store's ``(grace period, heartbeat interval)`` in seconds, checked before anything runs."""
    if store is not None and jax.process_count() > 1:
        raise JacoError(
            "store= with several jax.distributed processes: a shared store's workers are independent processes "
            "(start them without jax.distributed), or run the jax.distributed sweep without a store"
        )
    if store is None and (grace_period is not None or heartbeat_interval is not None):
        raise JacoError("grace_period and heartbeat_interval apply to a shared store: pass store=FILE too")
    grace = GRACE_PERIOD if grace_period is None else positive_seconds("grace_period", grace_period, JacoError)
    beat = (
        grace / 6
        if heartbeat_interval is None
        else positive_seconds("heartbeat_interval", heartbeat_interval, JacoError)
    )
    if beat * 2 > grace:
        raise JacoError(
            f"heartbeat_interval ({beat:g} s) must be at most half of grace_period ({grace:g} s), so that "
            "a live worker's claim never expires between two beats"
        )
    return grace, beat


def stored_sweep(bar, st, outs, path, unit, grace, beat) -> pd.DataFrame:
    """Claim, run and store units of ``unit`` rows (fixed: rows ``k·unit`` on, so every worker cuts
    the sweep alike) until every row of the sweep is stored, then read the whole table back."""
    from .store import SweepStore

    n_q, n_rows = outs[0].shape
    with SweepStore(path, grace) as held:
        sizes = st.runner.shape
        key = held.fingerprint(
            st.planner,
            st.queries,
            st.values,
            st.config,
            st.seeds,
            n_ants=sizes.n_ants,
            n_iters=sizes.n_iters,
            steplimit=sizes.steplimit,
            connectivity=sizes.connectivity,
        )
        held.load(key, outs)
        bar.start(n_rows * n_q, f"sweep {st.planner.name}: {n_rows * n_q} runs")
        with held.heartbeat(beat):
            ran, units, took_over = _claim_and_run(bar, st, held, key, n_rows, unit, min(beat / 2, 0.25))
        held.load(key, outs)
        worker = held.worker
    table = tidy_table(st.planner, st.queries, st.problems, st.values, st.config, st.seeds, *outs)
    table.attrs["sweep"] = dict(
        st.info,
        resumed_runs=int((n_rows - ran) * n_q),  # found stored, or run by other workers
        worker=worker,
        units_run=units,
        units_taken_over=took_over,
    )
    return table


def _claim_and_run(bar, st, held, key, n_rows, unit, poll) -> tuple[int, int, int]:
    """The worker's loop: returns the rows, units and taken-over units it ran."""
    import time

    from .store import Waiting

    n_q, ran, units, took_over, waited = len(st.queries), 0, 0, 0, False
    while True:
        got = held.claim(key, n_rows, unit)
        if got is None:
            return ran, units, took_over
        if isinstance(got, Waiting):  # every unit left is claimed by a live worker
            bar.update(got.done * n_q)
            bar.status(f"waiting for {got.held} chunks of {len(got.workers)} other workers")
            time.sleep(poll)
            waited = True
            continue
        if waited:
            bar.status("running")
        results = st.runner(
            {k: v[st.config[got.rows]] for k, v in st.values.items()},
            st.seeds[got.rows],
            on_iteration=_unit_bar(bar, st, n_q * got.done, n_q * len(got.rows)),
        )
        if held.commit(key, got, results):
            ran, units, took_over = ran + len(got.rows), units + 1, took_over + (got.attempt > 1)
        bar.update(n_q * (got.done + len(got.rows)))


def _unit_bar(bar, st, start: int, runs: int):
    """``on_iteration`` of a claimed unit: the bar at ``start`` plus its ``runs`` by iterations."""
    n_iters = st.runner.shape.n_iters
    return lambda lo, hi, done: bar.update(start + runs * min(int(done), n_iters) // n_iters)
