"""Several processes filling one sweep store: each claims chunks, beats while it runs them, takes
over the chunks of a worker that stopped beating, and returns the one-process table bit for bit."""

import json
import math
import os
import signal
import sqlite3
import subprocess
import sys
import textwrap
import time

import numpy as np
import pandas as pd
import pytest

import jaco
from jaco.research import chunks, sweeps
from jaco.research import store as jstore

GRID = jaco.maps.named("demo")
ENDS = (jaco.maps.DEMO_START, jaco.maps.DEMO_GOAL)
AXES = {"beta": [1.0, 2.0, 4.0, 8.0], "rho": [0.1, 0.3]}  # 8 configurations x 3 seeds: 12 chunks of 2
RESULTS = ["success", "length", "cost", "best_iteration", "optimal", "gap", "coverage"]

WORKER = textwrap.dedent("""
    # One worker: python worker.py STORE OUT HOST GRACE BEAT N_ITERS GO
    import json, os, sys, time
    import jaco
    from jaco.research import store

    path, out, host, grace, beat, n_iters, go = sys.argv[1:8]
    store.HOST = host  # each worker looks like a host of its own: only the heartbeat tells it is alive
    grid, kw = jaco.maps.named("demo"), dict(seeds=3, n_ants=6, n_iters=int(n_iters), chunk=2)
    axes = {axes!r}
    jaco.plan_sweep(grid, jaco.maps.DEMO_START, jaco.maps.DEMO_GOAL, "acs", axes, **kw)  # compiles
    open(go + "." + host, "w").close()
    while not os.path.exists(go):  # every worker starts at once
        time.sleep(0.01)
    table = jaco.sweep(grid, jaco.maps.DEMO_START, jaco.maps.DEMO_GOAL, "acs", axes, store=path, progress=False,
                       grace_period=float(grace), heartbeat_interval=float(beat), **kw)
    table.to_pickle(out)
    info = {{k: v for k, v in table.attrs["sweep"].items() if isinstance(v, (int, str))}}
    json.dump(dict(info, finished=time.time()), open(out + ".json", "w"))
""").format(axes=AXES)


KW = dict(seeds=3, n_ants=6, progress=False)


def _plain(n_iters, chunk=None):
    return jaco.sweep(GRID, *ENDS, "acs", AXES, **KW, n_iters=n_iters, chunk=chunk)


def _start(tmp_path, hosts, grace=3.0, beat=0.5, n_iters=10):
    """Worker processes (one per host name) on ``tmp_path/sweep.db``, released together once all
    have compiled."""
    script = tmp_path / "worker.py"
    script.write_text(WORKER)
    args = [str(tmp_path / "sweep.db"), "", "", str(grace), str(beat), str(n_iters), str(tmp_path / "go")]
    procs = {}
    for host in hosts:
        args[1:3] = [str(tmp_path / f"{host}.pkl"), host]
        procs[host] = subprocess.Popen([sys.executable, str(script), *args], cwd=tmp_path)
    return procs


def _go(tmp_path, procs, timeout=300.0):
    deadline = time.time() + timeout
    while not all((tmp_path / f"go.{h}").exists() for h in procs):
        assert time.time() < deadline and all(p.poll() is None for p in procs.values()), "a worker never got ready"
        time.sleep(0.02)
    (tmp_path / "go").touch()


def _finish(tmp_path, procs) -> dict:
    for host, proc in procs.items():
        assert proc.wait(timeout=300) == 0, f"worker {host} failed"
    return {
        h: (pd.read_pickle(tmp_path / f"{h}.pkl"), json.loads((tmp_path / f"{h}.pkl.json").read_text())) for h in procs
    }


def _chunks(path, timeout=5.0):
    with sqlite3.connect(path, timeout=timeout) as con:
        rows = con.execute("SELECT rows, worker, attempt FROM chunks").fetchall()
    return [(np.frombuffer(r, "<i8"), w, a) for r, w, a in rows]


def _same(table, plain):
    assert all(np.array_equal(table[c].to_numpy(), plain[c].to_numpy()) for c in RESULTS)
    assert table.equals(plain)


def _stored_once(path, n_rows=24):
    """Every row of the sweep is stored exactly once; returns the chunks."""
    chunks = _chunks(path)
    rows = np.sort(np.concatenate([r for r, _, _ in chunks]))
    assert np.array_equal(rows, np.arange(n_rows)), "a row stored twice, or missing"
    return chunks


def _check_workers(tables, chunks, n_rows=24):
    """Each worker's units_run is the number of chunks the store names it for, and the rest of its
    table came from the others."""
    for _, info in tables.values():
        mine = [r for r, w, _ in chunks if w == info["worker"]]
        assert info["units_run"] == len(mine)
        assert info["resumed_runs"] == n_rows - sum(len(r) for r in mine)
    assert sum(info["units_run"] for _, info in tables.values()) == len(chunks)


def test_a_worker_process_and_this_one_fill_one_store_each_returns_the_one_process_table(tmp_path):
    procs = _start(tmp_path, ["host-b"])
    plain = _plain(10, chunk=2)  # compiles this process's worker program while the other compiles its own
    _go(tmp_path, procs)
    mine = jaco.sweep(
        GRID,
        *ENDS,
        "acs",
        AXES,
        **KW,
        n_iters=10,
        chunk=2,
        store=tmp_path / "sweep.db",
        grace_period=3.0,
        heartbeat_interval=0.5,
    )
    tables = dict(_finish(tmp_path, procs), here=(mine, mine.attrs["sweep"]))
    for table, _ in tables.values():
        _same(table, plain)
    chunks = _stored_once(tmp_path / "sweep.db")
    assert len(chunks) == 12 and {a for _, _, a in chunks} == {1}  # no chunk computed twice, none taken over
    assert {w.split("/")[0] for _, w, _ in chunks} <= {"host-b", jstore.HOST}
    _check_workers(tables, chunks)


# -- the claim protocol, in one process ---------------------------------------------------------
def _outputs(rows):
    n = len(rows)
    return [
        np.full((1, n), 1.5, np.float32),
        np.full((1, n), 2.5, np.float32),
        np.ones((1, n), np.int32),
        np.ones((1, n), np.int32),
    ]


def test_claims_are_exclusive_expire_without_heartbeat_and_are_taken_over_once(tmp_path):
    path = tmp_path / "s.db"
    a, b = jstore.SweepStore(path, grace_period=60.0), jstore.SweepStore(path, grace_period=0.3)
    try:
        first, second = a.claim("k", 6, 2), b.claim("k", 6, 2)
        assert (first.lo, first.hi, second.lo, second.hi) == (0, 2, 2, 4)
        third = a.claim("k", 6, 2)  # a worker claims one more unit before it commits: (4, 6)
        waiting = b.claim("k", 6, 2)
        assert isinstance(waiting, jstore.Waiting) and waiting.workers == (a.worker,) and waiting.done == 0
        assert a.commit("k", first, _outputs(first.rows)) and b.commit("k", second, _outputs(second.rows))
        time.sleep(0.4)  # a never beats: its claim on 4:6 expires for b (grace 0.3 s), not for a (60 s)
        taken = b.claim("k", 6, 2)
        assert (taken.lo, taken.hi, taken.attempt, taken.done) == (4, 6, 2, 4)
        assert isinstance(a.claim("k", 6, 2), jstore.Waiting)  # b's claim is live for a
        assert not a.commit("k", third, _outputs(third.rows))  # taken over: a's results are dropped
        assert b.commit("k", taken, _outputs(taken.rows))
        assert a.claim("k", 6, 2) is None and b.claim("k", 6, 2) is None  # every row stored
    finally:
        a.close()
        b.close()
    chunks = _stored_once(path, 6)
    assert [(w == b.worker, att) for _, w, att in chunks] == [(False, 1), (True, 1), (True, 2)]


def test_a_long_chunk_still_beats_and_a_closed_or_dead_worker_frees_its_claims(tmp_path):
    path = tmp_path / "s.db"
    a, b = jstore.SweepStore(path), jstore.SweepStore(path, grace_period=1.0)
    try:
        with a.heartbeat(0.1):
            claim = a.claim("k", 4, 2)
            time.sleep(1.5)  # a chunk longer than b's grace period: the thread beats, so the claim stays live
            assert b.claim("k", 4, 2).lo == 2
            assert isinstance(b.claim("k", 4, 2), jstore.Waiting)
        a.close()  # releases its claim on 0:2 at once
        assert b.claim("k", 4, 2)[:2] == (0, 2) and claim.attempt == 1
        dead = subprocess.Popen([sys.executable, "-c", "pass"])
        dead.wait()
        with sqlite3.connect(path) as con:  # a claim of a process of this host that no longer runs
            con.execute(
                "UPDATE claims SET worker = ?, heartbeat = ? WHERE lo = 0", (f"{jstore.HOST}/{dead.pid}/x", time.time())
            )
        c = jstore.SweepStore(path)
        assert c.claim("k", 4, 2)[:2] == (0, 2)  # taken at once, no grace period to wait
        c.close()
    finally:
        a.close()
        b.close()


def test_an_old_store_without_worker_columns_is_upgraded(tmp_path):
    path = tmp_path / "old.db"
    with sqlite3.connect(path) as con:
        con.executescript(
            "CREATE TABLE jaco_sweep_store (schema_version INTEGER NOT NULL); INSERT INTO jaco_sweep_store VALUES (1);"
            "CREATE TABLE sweeps (fingerprint TEXT PRIMARY KEY, planner TEXT, call TEXT);"
            "CREATE TABLE chunks (fingerprint TEXT NOT NULL, rows BLOB NOT NULL, cost BLOB, length BLOB, "
            "best_iteration BLOB, covered BLOB);"
        )
        con.execute(
            "INSERT INTO chunks VALUES ('k', ?, ?, ?, ?, ?)",
            (np.arange(2, dtype="<i8").tobytes(), *(o.tobytes() for o in _outputs([0, 1]))),
        )
    with jstore.SweepStore(path) as s:
        outs = [
            np.zeros((1, 4), np.float32),
            np.zeros((1, 4), np.float32),
            np.zeros((1, 4), np.int32),
            np.zeros((1, 4), np.int32),
        ]
        assert s.load("k", outs).tolist() == [True, True, False, False] and outs[0][0, 1] == 1.5
        assert s.claim("k", 4, 2)[:2] == (2, 4)  # the stored unit is not claimed again
    with sqlite3.connect(path) as con:
        assert con.execute("SELECT schema_version FROM jaco_sweep_store").fetchone()[0] == jstore.SCHEMA_VERSION


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(grace_period=-1), "grace_period must be a positive finite number of seconds, got -1"),
        (dict(grace_period=0), "grace_period must be a positive finite number"),
        (dict(grace_period=math.nan), "grace_period must be a positive finite number"),
        (dict(grace_period="60"), "grace_period must be a positive finite number"),
        (dict(grace_period=True), "grace_period must be a positive finite number"),
        (dict(heartbeat_interval=-2.0), "heartbeat_interval must be a positive finite number"),
        (
            dict(grace_period=10, heartbeat_interval=6),
            r"heartbeat_interval \(6 s\) must be at most half of grace_period \(10 s\)",
        ),
        (dict(grace_period=30, store=None), "apply to a shared store: pass store=FILE too"),
    ],
)
def test_bad_sharing_arguments_are_one_line_before_anything_compiles(tmp_path, monkeypatch, kwargs, match):
    def boom(*a, **k):
        raise AssertionError("compiled before the error")

    monkeypatch.setattr(chunks, "_plan", boom)
    kwargs = dict(dict(store=tmp_path / "s.db"), **kwargs)
    with pytest.raises(jaco.JacoError, match=match) as e:
        jaco.sweep(GRID, *ENDS, "acs", AXES, seeds=2, n_ants=6, n_iters=5, progress=False, **kwargs)
    assert "\n" not in str(e.value)
    assert not (tmp_path / "s.db").exists()


# -- several processes, killed ------------------------------------------------------------------
@pytest.mark.slow
def test_three_workers_share_the_chunks_and_none_runs_one_twice(tmp_path):
    procs = _start(tmp_path, ["host-a", "host-b", "host-c"], n_iters=40)
    plain = _plain(40)
    _go(tmp_path, procs)
    tables = _finish(tmp_path, procs)
    for table, _ in tables.values():
        _same(table, plain)
    chunks = _stored_once(tmp_path / "sweep.db")
    assert len(chunks) == 12 and {a for _, _, a in chunks} == {1}
    assert len({w for _, w, _ in chunks}) >= 2  # started together, they share the work
    _check_workers(tables, chunks)


def _claims(path, timeout=5.0):
    with sqlite3.connect(path, timeout=timeout) as con:
        return con.execute("SELECT lo, hi, worker FROM claims").fetchall()


def _kill_holding(proc, path, host, timeout=120.0):
    """SIGKILL ``proc`` while it holds a claim, once a chunk is stored; returns the claimed rows.

    The worker is stopped (SIGSTOP) before the store is read, so the claim read is the one it
    holds when it dies: read while it runs, it could store that chunk before the kill lands."""
    deadline = time.time() + timeout
    while time.time() < deadline and proc.poll() is None:
        os.kill(proc.pid, signal.SIGSTOP)
        try:
            held = [(lo, hi) for lo, hi, w in _claims(path, timeout=0.1) if w.startswith(host + "/")]
            stored = _chunks(path, timeout=0.1)
        except sqlite3.Error:  # stopped inside a write: let it finish
            held = stored = []
        if held and stored:
            os.kill(proc.pid, signal.SIGKILL)
            proc.wait()
            return held[0], time.time()
        os.kill(proc.pid, signal.SIGCONT)
        time.sleep(0.005)
    raise AssertionError(f"worker {host} ended before it could be killed while holding a claim")


@pytest.mark.slow
def test_a_killed_workers_chunk_is_taken_over_after_the_grace_period_exactly_once(tmp_path):
    grace = 3.0
    procs = _start(tmp_path, ["host-a", "host-b"], grace=grace, beat=0.5, n_iters=400)
    plain = _plain(400)
    _go(tmp_path, procs)
    (lo, hi), killed = _kill_holding(procs.pop("host-a"), tmp_path / "sweep.db", "host-a")
    tables = _finish(tmp_path, procs)
    table, info = tables["host-b"]
    _same(table, plain)
    chunks = _stored_once(tmp_path / "sweep.db")
    retaken = [(w, a) for r, w, a in chunks if r[0] == lo]
    assert retaken == [(info["worker"], 2)] and info["units_taken_over"] == 1  # once, by the survivor
    assert info["finished"] - killed >= grace - 0.5  # a's last beat was at most one interval before
    assert not _claims(tmp_path / "sweep.db")


@pytest.mark.slow
def test_a_sweep_whose_workers_all_died_resumes_and_finishes(tmp_path):
    procs = _start(tmp_path, ["host-a", "host-b"], grace=60.0, beat=0.5, n_iters=400)
    plain = _plain(400)
    _go(tmp_path, procs)
    for host, proc in procs.items():
        _kill_holding(proc, tmp_path / "sweep.db", host)
    stale = _claims(tmp_path / "sweep.db")
    assert stale and len(_chunks(tmp_path / "sweep.db")) < 12
    # the claims of the dead "hosts" expire after this worker's grace period, then it takes them
    table = jaco.sweep(
        GRID,
        *ENDS,
        "acs",
        AXES,
        **KW,
        n_iters=400,
        chunk=2,
        store=tmp_path / "sweep.db",
        grace_period=1.0,
        heartbeat_interval=0.2,
    )
    _same(table, plain)
    chunks = _stored_once(tmp_path / "sweep.db")
    assert table.attrs["sweep"]["units_taken_over"] == len(stale)
    assert sum(a == 2 for _, w, a in chunks if w == table.attrs["sweep"]["worker"]) == len(stale)
    assert not _claims(tmp_path / "sweep.db")


def test_the_cli_takes_a_grace_period_only_with_a_store(tmp_path, capsys, monkeypatch):
    from jaco.cli import main

    def boom(*a, **k):
        raise AssertionError("compiled before the error")

    monkeypatch.setattr(chunks, "_plan", boom)
    assert main(["sweep", "demo", "--grace-period", "5"]) == 2
    assert (
        capsys.readouterr()
        .err.strip()
        .splitlines()[-1]
        .endswith("--grace-period is for a shared store: give --store FILE.db too")
    )
    assert main(["sweep", "demo", "--store", str(tmp_path / "s.db"), "--grace-period", "-1"]) == 2
    assert "--grace-period: expected a positive finite number of seconds, got '-1'" in capsys.readouterr().err
    seen = {}
    monkeypatch.setattr(sweeps, "sweep", lambda *a, **k: seen.update(k) or (_ for _ in ()).throw(KeyboardInterrupt))
    main(["sweep", "demo", "--store", str(tmp_path / "s.db"), "--grace-period", "90", "--seeds", "1"])
    assert seen["grace_period"] == 90.0 and seen["store"] == str(tmp_path / "s.db")
