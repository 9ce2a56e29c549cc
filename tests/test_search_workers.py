"""Several worker processes on one study (jaco.search with one storage and study_name): they share
the trials, stop at ``trials`` finished (at most one batch more per other worker), leave nothing
RUNNING, never evaluate a trial twice, and take a killed worker's trials over exactly once."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
import time

import pytest

pytest.importorskip("optuna")

from postgres import postgres_url  # noqa: E402,F401  (a session fixture: a real server)

import jaco  # noqa: E402
from jaco.research.search_workers import BEAT  # noqa: E402

#: One worker: logs every trial it evaluated (after the evaluation) to evals-PID.jsonl; with
#: JACO_TEST_HANG it marks its first batch as asked and hangs there (to be killed mid-batch);
#: with JACO_TEST_HOST it claims another host name (no process check: only heartbeats tell).
WORKER = textwrap.dedent("""
    import json, os, socket, sys, time
    import jaco
    from jaco.research import search as S

    if os.environ.get("JACO_TEST_HOST"):
        socket.gethostname = lambda: os.environ["JACO_TEST_HOST"]
    storage, name, sampler, trials, batch, worker = sys.argv[1:7]
    real = S.Evaluator.__call__

    def logged(self, jobs):
        if os.environ.get("JACO_TEST_HANG"):
            with open(f"hung-{os.getpid()}.json", "w") as f:
                json.dump([j.trial.number for j in jobs], f)
            time.sleep(600)
        out = real(self, jobs)
        with open(f"evals-{os.getpid()}.jsonl", "a") as f:
            for j in jobs:
                f.write(json.dumps({"number": j.trial.number, "values": j.own}) + "\\n")
        return out

    S.Evaluator.__call__ = logged
    grid = jaco.maps.named("demo")
    jaco.search(grid, grid.meta["start"], grid.meta["goal"], {"beta": (1.0, 8.0), "rho": (0.05, 0.5)},
                planner="as", trials=int(trials), batch=int(batch), seeds=2, n_ants=4, n_iters=5,
                sampler=sampler, storage=storage, study_name=name, worker=int(worker),
                heartbeat_interval=0.5, grace_period=3.0, progress=False)
""")


def _start(tmp_path, storage, worker, *, name="s", sampler="tpe", trials=8, batch=2, env=None):
    script = tmp_path / "worker.py"
    script.write_text(WORKER)
    args = [sys.executable, str(script), storage, name, sampler, str(trials), str(batch), str(worker)]
    return subprocess.Popen(args, cwd=tmp_path, env={**os.environ, **(env or {})}, stderr=subprocess.PIPE, text=True)


def _wait(procs, timeout=300):
    for p in procs:
        _, err = p.communicate(timeout=timeout)
        assert p.returncode == 0, err[-2000:]


def _evaluations(tmp_path) -> list[dict]:
    return [json.loads(line) for f in sorted(tmp_path.glob("evals-*.jsonl")) for line in f.read_text().splitlines()]


def _check_shared(tmp_path, storage, *, trials, batch, workers, name="s"):
    """Exactly what the docs promise of a finished multi-worker study."""
    study = jaco.load_study(storage, name).study
    states = [t.state.name for t in study.trials]
    done = states.count("COMPLETE")
    assert trials <= done <= trials + batch * (workers - 1)  # at most one batch more per other worker
    assert "RUNNING" not in states
    evals = _evaluations(tmp_path)
    numbers = [e["number"] for e in evals]
    assert len(numbers) == len(set(numbers))  # no trial evaluated twice
    complete = {t.number: t for t in study.trials if t.state.name == "COMPLETE"}
    assert set(complete) <= set(numbers)  # every finished trial evaluated once, by some worker
    retried = {t.user_attrs["jaco_trial"].get("retry_of") for t in complete.values()}
    for n in set(numbers) - set(complete):  # a result dropped: its worker looked dead (a loaded machine)
        assert study.trials[n].state.name == "FAIL" and n in retried
    points = [tuple(sorted(t.params.items())) for t in complete.values()]
    assert len(set(points)) == len(points)  # and no two with one configuration (the same seeds)
    return study


def test_two_local_workers_share_one_sqlite_study(tmp_path):
    storage = str(tmp_path / "s.db")
    procs = [_start(tmp_path, storage, w) for w in range(2)]
    _wait(procs)
    study = _check_shared(tmp_path, storage, trials=8, batch=2, workers=2)
    owners = {t.user_attrs["jaco_trial"]["owner"] for t in study.trials}
    assert len(owners) >= 1 and all(o.count(":") >= 2 for o in owners)  # host:pid:token of a worker


@pytest.mark.slow
@pytest.mark.parametrize("sampler", ["tpe", "cmaes"])
@pytest.mark.parametrize("kind", ["sqlite", "journal", "postgres"])
def test_three_workers_on_each_storage(tmp_path, kind, sampler, request):
    storage = {
        "sqlite": f"sqlite:///{tmp_path / 's.db'}",
        "journal": str(tmp_path / "s.journal"),
        "postgres": None,
    }[kind]
    name = "s"
    if kind == "postgres":  # one server for the session: a study per test
        storage, name = request.getfixturevalue("postgres_url"), f"s_{sampler}"
    procs = [_start(tmp_path, storage, w, name=name, sampler=sampler, trials=12, batch=3) for w in range(3)]
    _wait(procs)
    _check_shared(tmp_path, storage, trials=12, batch=3, workers=3, name=name)


def _complete(db) -> int:
    import sqlite3

    try:
        with sqlite3.connect(db, timeout=0.1) as con:
            return con.execute("SELECT COUNT(*) FROM trials WHERE state = 'COMPLETE'").fetchone()[0]
    except sqlite3.Error:  # not created yet, or busy
        return 0


@pytest.mark.slow
@pytest.mark.parametrize("other_host", [False, True])
def test_a_killed_workers_trials_are_retried_exactly_once(tmp_path, other_host):
    """Worker 0 hangs in its first batch and is SIGKILLed there while worker 1, having finished
    the rest, waits. On this host the dead process is seen at once; from another host only its
    heartbeat stops, and its trials wait out the grace period (3 s here) after its last heartbeat
    before worker 1 retries them, each exactly once, as new trials with the same parameters."""
    db = tmp_path / "s.db"
    env = {"JACO_TEST_HANG": "1", **({"JACO_TEST_HOST": "elsewhere"} if other_host else {})}
    hung = _start(tmp_path, str(db), 0, env=env)
    other = _start(tmp_path, str(db), 1)
    deadline = time.time() + 240
    while not (list(tmp_path.glob("hung-*.json")) and _complete(db) >= 6):  # worker 1 now waits for worker 0
        for p in (hung, other):
            assert p.poll() is None, p.communicate()[1][-3000:]
        assert time.time() < deadline
        time.sleep(0.2)
    killed_at = time.time()
    os.kill(hung.pid, signal.SIGKILL)
    hung.wait()
    (mark,) = tmp_path.glob("hung-*.json")
    killed = json.loads(mark.read_text())
    _wait([other])
    study = _check_shared(tmp_path, str(db), trials=8, batch=2, workers=2)
    by_number = {t.number: t for t in study.trials}
    for n in killed:
        assert by_number[n].state.name == "FAIL"
        again = [t for t in study.trials if t.user_attrs["jaco_trial"].get("retry_of") == n]
        assert len(again) == 1 and again[0].state.name == "COMPLETE" and again[0].params == by_number[n].params
        retried_at = again[0].datetime_start.timestamp()
        if other_host:  # the grace period counts from the last heartbeat (on a loaded machine it can be late)
            beat = float(study.user_attrs[BEAT + by_number[n].user_attrs["jaco_trial"]["owner"]])
            assert 0 < beat <= killed_at and retried_at - beat >= 3.0 - 0.05
        else:
            assert retried_at - killed_at < 3.0


def _claim(trial) -> None:
    """What another worker's claim does to a trial it took for a dead worker's: RUNNING -> FAIL."""
    from optuna.trial import TrialState

    trial.study._storage.set_trial_state_values(trial._trial_id, TrialState.FAIL)


@pytest.mark.parametrize("fidelity", [None, "halving"])
def test_a_worker_whose_trials_are_claimed_drops_them_and_goes_on(tmp_path, monkeypatch, fidelity):
    """A live worker can look dead to the others: its heartbeats late past the grace period, or a
    trial it asks still without parameters after it (a stalled machine). Its trial is then failed
    by another worker's claim while it asks it or evaluates it. It drops that trial (asks another,
    or drops the result: the claimer evaluates it again) and goes on; it no longer stops with
    "Cannot tell a FAIL trial" (before the fix, the search raised at the first claim)."""
    from jaco.research import search as S
    from jaco.research.search_evaluation import Evaluator

    claimed: list[int] = []
    described, evaluate = S._Run._described, Evaluator.__call__

    def claimed_while_asked(self, trial, extra):
        if not claimed:  # the first trial asked
            _claim(trial)
            claimed.append(trial.number)
        return described(self, trial, extra)

    def claimed_while_evaluated(self, jobs):
        out = evaluate(self, jobs)
        if len(claimed) == 1:  # the first batch evaluated
            _claim(jobs[-1].trial)
            claimed.append(jobs[-1].trial.number)
        return out

    monkeypatch.setattr(S._Run, "_described", claimed_while_asked)
    monkeypatch.setattr(Evaluator, "__call__", claimed_while_evaluated)
    grid = jaco.maps.named("demo")
    study = jaco.search(grid, grid.meta["start"], grid.meta["goal"], {"beta": (1.0, 8.0), "rho": (0.05, 0.5)},
                        planner="as", trials=6, batch=3, seeds=2, n_ants=4, n_iters=6, sampler="random",
                        fidelity=fidelity, storage=str(tmp_path / "s.db"), progress=False)  # fmt: skip
    states = {t.number: t.state.name for t in study.study.trials}
    assert [states[n] for n in claimed] == ["FAIL", "FAIL"]
    assert sum(s in ("COMPLETE", "PRUNED") for s in states.values()) == 6 and "RUNNING" not in states.values()
    assert study.timings["lost"] == 2
    assert "jaco_runs" not in study.study.trials[claimed[1]].user_attrs  # its result dropped, not stored


def test_asking_slower_than_the_grace_period_every_time_is_a_clear_error(tmp_path, monkeypatch):
    from jaco.research import search as S

    described = S._Run._described

    def always_claimed(self, trial, extra):
        _claim(trial)
        return described(self, trial, extra)

    monkeypatch.setattr(S._Run, "_described", always_claimed)
    grid = jaco.maps.named("demo")
    with pytest.raises(S.SearchError, match=r"longer than grace_period \(3 s\) three times.*longer grace_period"):
        jaco.search(grid, grid.meta["start"], grid.meta["goal"], {"beta": (1.0, 8.0)}, planner="as", trials=4,
                    batch=2, n_ants=4, n_iters=5, storage=str(tmp_path / "s.db"), heartbeat_interval=1,
                    progress=False)  # fmt: skip


def _interrupted_search(db) -> tuple[float, list]:
    """A search on ``db`` that an interrupt stops (the test patches where): its seconds and the
    heartbeats its study keeps."""
    grid = jaco.maps.named("demo")
    t0 = time.monotonic()
    with pytest.raises(KeyboardInterrupt):
        jaco.search(grid, grid.meta["start"], grid.meta["goal"], {"beta": (1.0, 8.0)}, planner="as", trials=4,
                    batch=2, n_ants=4, n_iters=5, storage=str(db), heartbeat_interval=0.2, progress=False)  # fmt: skip
    seconds = time.monotonic() - t0
    beats = [v for k, v in jaco.load_study(str(db)).study.user_attrs.items() if k.startswith(BEAT)]
    return seconds, beats


def test_an_interrupt_inside_a_storage_transaction_releases_its_lock(tmp_path, monkeypatch):
    """Ctrl-C (or the parent's SIGINT to a worker) that lands inside one of Optuna's storage calls
    leaves the main thread's transaction open, holding SQLite's write lock. The search ends that
    session before it stops its heartbeat, so the worker's last heartbeat (0: it stopped) is
    written at once and the lock is free for the other workers. Before, stopping the heartbeat
    thread (blocked on that lock) waited out SQLite's 60 s busy timeout."""
    import sqlalchemy

    from jaco.research import search as S

    def interrupted_in_a_transaction(self, trials):
        session = self.workers.storage.scoped_session()
        session.execute(sqlalchemy.text("SELECT 1"))  # begins: BEGIN IMMEDIATE takes the write lock
        time.sleep(1.0)  # the heartbeat thread now waits for the lock, in its busy timeout (60 s)
        raise KeyboardInterrupt

    monkeypatch.setattr(S._Run, "_loop", interrupted_in_a_transaction)
    db = tmp_path / "s.db"
    seconds, beats = _interrupted_search(db)
    # not a speed check: with the lock still held, stopping the heartbeat waits out SQLite's 60 s busy timeout
    assert seconds < 45
    import sqlite3

    with sqlite3.connect(db, timeout=0.5) as con:  # the lock is free: a write does not wait
        con.execute("BEGIN IMMEDIATE")
        con.rollback()
    assert beats == [0.0]


@pytest.mark.parametrize(
    "where", ["a statement on a closed connection", "a connection out of the session", "the first heartbeat"]
)
def test_a_worker_interrupted_anywhere_says_it_stopped(tmp_path, monkeypatch, where):
    """The last heartbeat (0: stopped) is written wherever the interrupt lands. Inside SQLAlchemy's
    execution of a storage call, the interrupt can leave the call's connection out of the session's
    reach: closed by SQLAlchemy with its statement in progress (SQLite then keeps the connection's
    transaction and write lock until the statement is finalized), or checked out with its
    transaction open; only the interrupt's frames hold either, and the stop drops them. Before,
    the last heartbeat waited 60 s for that lock and failed (a CI run of the SIGTERM test below
    failed so). Right after the first heartbeat, before the search's loop: the stop runs all the same."""
    import sqlalchemy

    from jaco.research import search as S
    from jaco.research import search_workers as W

    if where != "the first heartbeat":

        def interrupted(self, trials):
            conn = self.workers.storage.engine.connect()  # not the session's, as the interrupt leaves it
            rows = conn.execute(sqlalchemy.text("WITH RECURSIVE n(i) AS (SELECT 1 UNION ALL SELECT i + 1 FROM n "
                                                "WHERE i < 1000) SELECT i FROM n"))  # fmt: skip
            assert rows.fetchone() is not None  # the statement is in progress; BEGIN IMMEDIATE holds the lock
            if where == "a statement on a closed connection":
                conn.invalidate()  # what SQLAlchemy does to a connection whose call an interrupt stopped
            raise KeyboardInterrupt

        monkeypatch.setattr(S._Run, "_loop", interrupted)
    else:
        first_beat = W.Workers._beat

        def beat_then_interrupt(self):
            first_beat(self, time.time())
            raise KeyboardInterrupt

        monkeypatch.setattr(W.Workers, "start", beat_then_interrupt)
    seconds, beats = _interrupted_search(tmp_path / "s.db")
    assert seconds < 45  # not a speed check: a held lock makes the last heartbeat wait 60 s
    assert beats == [0.0]


# -- jaco search --workers N ----------------------------------------------------------------------
CLI = ["search", "demo", "--planner", "as", "--param", "beta=1:8", "--param", "rho=0.05:0.5", "--trials", "8",
       "--batch", "2", "--seeds", "2", "--ants", "4", "--iters", "5"]  # fmt: skip


@pytest.mark.parametrize(
    "extra, match",
    [
        ([], "--workers N shares one study between processes: give --storage"),
        (["--storage", "s.db", "--sampler", "evosax:SNES"], "an evosax strategy runs one worker per study"),
    ],
)
def test_cli_workers_need_a_storage_before_anything_compiles(extra, match, capsys, monkeypatch, tmp_path):
    from jaco.cli import main
    from jaco.research import sweeps

    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(sweeps.Runner, "__init__", lambda *a, **k: pytest.fail("compiled"))
    assert main([*CLI, "--workers", "2", *extra]) == 2
    err = capsys.readouterr().err.strip()
    assert match in err and "\n" not in err


@pytest.mark.slow
def test_cli_workers_share_the_study_and_sigterm_stops_them_all(tmp_path):
    """Two workers finish the study; a second command (started with SIGINT ignored), stopped by
    SIGTERM, stops its workers too (exit 143), leaves nothing evaluated twice, and the same command
    again finishes the study."""
    db = tmp_path / "c.db"
    cmd = [sys.executable, "-m", "jaco.cli", *CLI, "--storage", str(db), "--workers", "2", "--grace-period", "2",
           "--heartbeat-interval", "0.5"]  # fmt: skip
    done = subprocess.run(cmd, cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    assert "2 workers" in done.stdout
    study = jaco.load_study(str(db)).study
    asked = [t for t in study.trials if "jaco_trial" in t.user_attrs]  # (not a trial lost while being asked)
    assert 8 <= sum(t.state.name == "COMPLETE" for t in study.trials) <= 10 and len(asked) <= 10, done.stderr[-3000:]
    big = [*cmd]
    big[big.index("--trials") + 1] = "400"
    # started with SIGINT ignored, as a shell's background job is: the workers must stop all the same
    ignoring = ["sh", "-c", 'trap "" INT; exec "$0" "$@"', *big]
    proc = subprocess.Popen(ignoring, cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.time() + 120
    while sum(t.state.name == "COMPLETE" for t in jaco.load_study(str(db)).study.trials) < 14:
        assert proc.poll() is None and time.time() < deadline
        time.sleep(0.5)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=180)
    assert proc.returncode == 143 and "terminated" in err, err[-3000:]
    beats = {k: v for k, v in jaco.load_study(str(db)).study.user_attrs.items() if k.startswith("jaco_worker:")}
    assert beats and all(v == 0 for v in beats.values()), err[-3000:]  # every worker stopped and said so
    again = [*cmd]
    again[again.index("--trials") + 1] = "30"
    done = subprocess.run(again, cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-3000:]
    trials = jaco.load_study(str(db)).study.trials
    assert "RUNNING" not in {t.state.name for t in trials}
    retried = [t.user_attrs["jaco_trial"].get("retry_of") for t in trials if "jaco_trial" in t.user_attrs]
    failed = [t.number for t in trials if t.state.name == "FAIL" and "jaco_trial" in t.user_attrs]
    assert sorted(r for r in retried if r is not None) == sorted(failed)  # each stopped trial retried once


@pytest.mark.parametrize("write", ["before", "after"])
def test_a_stop_between_a_claim_and_its_retry_still_leaves_the_retry(tmp_path, monkeypatch, write):
    """A worker claims a dead worker's trial (RUNNING -> FAIL) and creates its retry: two storage
    writes. Ctrl-C landing between them (``before`` the retry's write, or ``after`` it but before
    the call returned) used to leave a FAIL trial that nobody ever retried (later searches take over
    RUNNING trials only). The stopping worker now makes the retry on its way out, once: the stop
    still stops the search, and the next search finishes the study with each trial retried once."""
    from jaco.research.search_evaluation import Evaluator
    from jaco.research.search_workers import Workers

    grid = jaco.maps.named("demo")
    db = str(tmp_path / "s.db")

    def run(trials):
        return jaco.search(grid, grid.meta["start"], grid.meta["goal"], {"beta": (1.0, 8.0)}, planner="as",
                           trials=trials, batch=2, n_ants=4, n_iters=5, sampler="random", storage=db,
                           progress=False)  # fmt: skip

    with monkeypatch.context() as m:  # a worker stopped mid-batch: its two trials left RUNNING

        def stopped(self, jobs):
            raise KeyboardInterrupt

        m.setattr(Evaluator, "__call__", stopped)
        with pytest.raises(KeyboardInterrupt):
            run(4)
    replace = Workers.replace
    calls: list[int] = []

    def stopped_around_the_write(self, frozen):
        calls.append(frozen.number)
        if len(calls) == 1 and write == "before":
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(0.2)  # Python runs a signal's handler between two bytecodes: it has had its chance
        trial = replace(self, frozen)
        if len(calls) == 1 and write == "after":
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(0.2)
        return trial

    # Ctrl-C raises KeyboardInterrupt, as in a terminal (a shell's background job, such as a CI run,
    # starts with SIGINT ignored)
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        with monkeypatch.context() as m:
            m.setattr(Workers, "replace", stopped_around_the_write)
            with pytest.raises(KeyboardInterrupt):
                run(4)
    finally:
        signal.signal(signal.SIGINT, previous)
    # the first retry's write interrupted; made on the way out only where it had not been made
    assert calls == ([0, 0] if write == "before" else [0])
    trials = jaco.load_study(db).study.trials
    assert trials[0].state.name == "FAIL" and trials[1].state.name == "RUNNING"
    assert [t.user_attrs["jaco_trial"].get("retry_of") for t in trials[2:]] == [0]
    assert trials[2].state.name == "RUNNING"  # owned by the stopped worker: the next search takes it over
    trials = run(4).study.trials
    failed = [t.number for t in trials if t.state.name == "FAIL"]
    retried = [t.user_attrs["jaco_trial"].get("retry_of") for t in trials]
    assert sorted(r for r in retried if r is not None) == failed and {0, 1, 2} <= set(failed)
    assert sum(t.state.name == "COMPLETE" for t in trials) == 4 and "RUNNING" not in {t.state.name for t in trials}
