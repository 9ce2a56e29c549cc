"""Ctrl-C (SIGINT) and SIGTERM: a sweep, a search or a solve stops at once (a compiled run ends its
iteration loop at the next iteration), exits 130 / 143 with one line, leaves every existing output as it was and no
temporary file, and keeps what was finished (stored chunks, stored trials).

The commands run as real processes; the signal is sent at a known moment: while the program is
being set up and compiled (after the command's first line), or while it runs (once a chunk or a
trial is stored). An uninterrupted run of each would take minutes, so a stop within seconds is the
interrupt's doing, not the run ending by itself."""

import _thread
import os
import signal
import sqlite3
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

import jaco

pytestmark = pytest.mark.skipif(sys.platform == "win32", reason="POSIX signals")


@pytest.fixture(autouse=True, scope="module")
def sigint_reaches_python():
    """A test run started as a background job (``cmd &`` in a script) inherits SIGINT ignored, and
    so would every process these tests start: Python then installs no KeyboardInterrupt handler and
    an interrupt does nothing. Ctrl-C reaches a foreground program, so these tests run as one: this
    process takes Python's own handler, and its children start with SIGINT at its default."""
    ignored = signal.getsignal(signal.SIGINT) is signal.SIG_IGN
    if not ignored or threading.current_thread() is not threading.main_thread():
        yield
        return
    signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, signal.SIG_IGN)


CLI = [sys.executable, "-m", "jaco.cli"]
LONG_SWEEP = ["sweep", "demo", "--variant", "acs", "--param", "beta=1:10:200", "--seeds", "50", "--ants", "20",
              "--iters", "2000", "--chunk", "100"]  # 10,000 runs in chunks of 100: minutes in all


def _start(args, cwd):
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    return subprocess.Popen(CLI + args, cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)


def _rows(db, table) -> int:
    try:
        with sqlite3.connect(db, timeout=0.2) as con:
            return con.execute(f"SELECT COUNT(*) FROM {table}").fetchone()[0]
    except sqlite3.Error:
        return 0


def _stop(proc, sig):
    t0 = time.time()
    proc.send_signal(sig)
    out, err = proc.communicate(timeout=60)
    return time.time() - t0, out, err


def _wait_for(condition, proc, limit=180):
    """Seconds until ``condition()`` holds (the process still running)."""
    t0 = time.time()
    while time.time() - t0 < limit and proc.poll() is None and not condition():
        time.sleep(0.05)
    assert proc.poll() is None and condition(), "the command ended, or the moment never came"
    return time.time() - t0


@pytest.mark.slow
@pytest.mark.parametrize("sig, code, word", [(signal.SIGINT, 130, "interrupted"), (signal.SIGTERM, 143, "terminated")])
def test_a_sweep_stops_while_compiling_and_while_running(tmp_path, sig, code, word):
    out = tmp_path / "out.csv"
    out.write_text("old table\n")
    store = tmp_path / "s.db"
    # while compiling: right after the command's first line
    proc = _start(LONG_SWEEP + ["--csv", str(out), "--store", str(store)], tmp_path)
    assert proc.stdout.readline().startswith("sweep acs on demo")
    _, _, err = _stop(proc, sig)
    assert proc.returncode == code
    assert err.strip().splitlines()[-1] == (
        f"jaco: {word}: no chunk had finished, nothing new stored in {store}; the same command resumes"
    )
    # while running: in the second chunk, once the first is stored
    proc = _start(LONG_SWEEP + ["--csv", str(out), "--store", str(store)], tmp_path)
    assert proc.stdout.readline().startswith("sweep acs on demo")
    first = _wait_for(lambda: _rows(store, "chunks") >= 1, proc)  # compiling + one chunk
    time.sleep(0.2)
    waited, _, err = _stop(proc, sig)
    runs = 100 * _rows(store, "chunks")  # chunks of 100 runs, one query
    assert proc.returncode == code and runs >= 100
    assert err.strip().splitlines()[-1] == f"jaco: {word}: {runs} runs stored in {store}; the same command resumes"
    assert waited < max(2.0, first / 3), f"took {waited:.1f} s to stop; a chunk takes about {first:.1f} s"
    assert out.read_text() == "old table\n"  # the existing output is as it was
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.csv", "s.db"]  # no temporary file
    assert _rows(store, "chunks") >= 1  # the finished chunk is kept


@pytest.mark.slow
def test_a_search_stops_and_keeps_its_finished_trials(tmp_path):
    db = tmp_path / "study.db"
    args = ["search", "demo", "--variant", "acs", "--param", "beta=1:10:log", "--trials", "400", "--batch", "4",
            "--seeds", "25", "--ants", "20", "--iters", "2000", "--sampler", "random", "--storage", str(db)]
    proc = _start(args, tmp_path)
    first = _wait_for(lambda: _rows(db, "trials") >= 5, proc)  # the second batch has been asked
    time.sleep(0.2)
    waited, _, err = _stop(proc, signal.SIGTERM)
    assert waited < max(2.0, first / 3)
    study = jaco.load_study(str(db))
    states = [t.state.name for t in study.study.trials]
    assert states.count("COMPLETE") >= 4 and set(states) <= {"COMPLETE", "RUNNING"}  # RUNNING: resumed next time
    assert proc.returncode == 143 and err.strip().splitlines()[-1] == (
        f"jaco: terminated: {states.count('COMPLETE')} trials stored in {db}; the same command resumes"
    )


@pytest.mark.slow
def test_a_long_solve_stops(tmp_path):
    args = ["solve", "Berlin_1_256.map", "--start", "14,254", "--goal", "247,110", "--variant", "iaca",
            "--iters", "5000", "--ants", "100"]
    proc = _start(args, tmp_path)
    time.sleep(8)  # past the compile, well inside a run of minutes
    waited, out, err = _stop(proc, signal.SIGINT)
    assert proc.returncode == 130 and err.strip().splitlines()[-1] == "jaco: interrupted"
    assert waited < 10 and out == ""


def test_ctrl_c_in_python_ends_the_chunk_and_the_next_call_runs_normally():
    grid = jaco.maps.named("demo")
    s, g = grid.meta["start"], grid.meta["goal"]
    kw = dict(params={"beta": [1.0, 2.0, 3.0, 4.0]}, seeds=200, n_ants=20, n_iters=400, progress=False)
    plan = {k: v for k, v in kw.items() if k != "progress"}
    assert jaco.plan_sweep(grid, s, g, "acs", chunk=800, **plan)["chunks"] == 1  # compiled: the interrupt lands in the run
    timer = threading.Timer(1.0, _thread.interrupt_main)
    t0 = time.time()
    timer.start()
    with pytest.raises(KeyboardInterrupt):
        jaco.sweep(grid, s, g, "acs", chunk=800, **kw)
    assert time.time() - t0 < 15
    assert not jaco.engine.native.stop_is_set()  # the interrupted chunk has ended: the next call runs normally


# A script that interrupts its own long solve once the run's program is compiled and running, then
# measures the CPU the process uses afterwards and makes one more call. The iteration loop of a run
# asks whether to stop (the kernel's flag, or the host every few iterations without it).
_AFTER_COMPILE = """
import os, resource, signal, sys, threading, time
import jax, jaco

def cpu():
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime

running = threading.Event()  # the run's program is compiled: it runs from now on
jax.monitoring.register_event_duration_secs_listener(
    lambda event, secs, fun_name=None, **kw: fun_name == "jit(run)" and "backend_compile" in event and running.set())

def interrupt():
    running.wait()
    time.sleep(2)
    os.kill(os.getpid(), signal.{sig})

threading.Thread(target=interrupt, daemon=True).start()
"""

LONG_SOLVE = _AFTER_COMPILE + """
g = jaco.maps.named("demo")
try:
    jaco.solve(g, (17, 2), (2, 27), "mmas", n_ants=2, n_iters=5_000_000, progress=sys.argv[1] == "bar")
    print("finished")
except KeyboardInterrupt:
    c0 = cpu()
    time.sleep(5)
    print("cpu after", cpu() - c0)
    print("next", jaco.solve(g, (17, 2), (2, 27), "mmas", n_ants=8, n_iters=10, progress=False).success)
"""


@pytest.mark.parametrize("walk, bar", [("auto", "bar"), ("jax", "none")])
def test_ctrl_c_in_python_ends_the_compiled_run_and_the_next_call_runs(walk, bar, tmp_path):
    """The reproducer of an interrupted ``jaco.solve`` in a script or notebook: the run (minutes long)
    ends when the interrupt arrives, with or without a bar, with the kernel's stop flag or the
    host's; the process then uses no CPU for it, and the next call runs."""
    env = dict(os.environ, JACO_WALK=walk, PYTHONUNBUFFERED="1")
    proc = subprocess.run([sys.executable, "-c", LONG_SOLVE.format(sig="SIGINT"), bar], cwd=tmp_path, env=env,
                          capture_output=True, text=True, timeout=600)
    lines = dict(line.rsplit(" ", 1) for line in proc.stdout.splitlines())
    assert proc.returncode == 0 and "finished" not in proc.stdout, proc.stderr[-2000:]
    assert float(lines["cpu after"]) < 0.5 and lines["next"] == "True", proc.stdout


def test_cli_main_called_from_python_returns_after_sigterm(tmp_path):
    """``jaco.cli.main()`` called in-process (as a test harness does): SIGTERM ends the command with
    143 and the compiled run with it; nothing goes on afterwards."""
    script = _AFTER_COMPILE.format(sig="SIGTERM") + """
from jaco.cli import main
t0 = time.time()
code = main(["solve", "demo", "--variant", "mmas", "--ants", "2", "--iters", "5000000"])
c0 = cpu()
time.sleep(5)
print("code", code)
print("cpu after", cpu() - c0)
"""
    proc = subprocess.run([sys.executable, "-c", script], cwd=tmp_path, env=dict(os.environ, PYTHONUNBUFFERED="1"),
                          capture_output=True, text=True, timeout=600)
    lines = dict(line.rsplit(" ", 1) for line in proc.stdout.splitlines() if line.startswith(("code", "cpu")))
    assert lines["code"] == "143" and "jaco: terminated" in proc.stderr, proc.stdout + proc.stderr[-2000:]
    assert float(lines["cpu after"]) < 0.5


def _cpu_seconds(pid: int) -> float:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")  # utime + stime


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="reads a process's CPU time from /proc")
def test_a_notebook_kernel_interrupted_mid_solve_stops_and_is_used_again(tmp_path):
    """"Interrupt kernel" in Jupyter during a long solve: the cell ends with KeyboardInterrupt, the
    kernel uses no CPU afterwards and runs the next cell (no restart)."""
    from jupyter_client.manager import start_new_kernel

    km, kc = start_new_kernel(kernel_name="python3", cwd=str(tmp_path))
    try:
        setup = """
import pathlib, jax, jaco
jax.monitoring.register_event_duration_secs_listener(  # marks the moment the run's program is compiled
    lambda event, secs, fun_name=None, **kw: fun_name == "jit(run)" and "backend_compile" in event
    and pathlib.Path("running").touch())
g = jaco.maps.named("demo")
"""
        assert kc.execute_interactive(setup, timeout=300)["content"]["status"] == "ok"
        msg_id = kc.execute('jaco.solve(g, (17, 2), (2, 27), "mmas", n_ants=2, n_iters=5_000_000)')
        t0 = time.time()
        while not (tmp_path / "running").exists() and time.time() - t0 < 300:
            time.sleep(0.1)
        time.sleep(2)  # well inside a run of minutes
        km.interrupt_kernel()
        reply = kc.get_shell_msg(timeout=60)
        assert reply["parent_header"]["msg_id"] == msg_id
        assert reply["content"]["status"] == "error" and reply["content"]["ename"] == "KeyboardInterrupt"
        pid = km.provisioner.process.pid
        c0 = _cpu_seconds(pid)
        time.sleep(5)
        assert _cpu_seconds(pid) - c0 < 0.5
        out: list = []
        hook = lambda m: out.append(m["content"].get("text", "")) if m["msg_type"] == "stream" else None  # noqa: E731
        code = 'print(jaco.solve(g, (17, 2), (2, 27), "mmas", n_ants=8, n_iters=10, progress=False).success)'
        assert kc.execute_interactive(code, timeout=300, output_hook=hook)["content"]["status"] == "ok"
        assert "".join(out).split() == ["True"]
    finally:
        kc.stop_channels()
        km.shutdown_kernel(now=True)


def test_an_interrupted_write_leaves_the_old_file_and_no_temporary(tmp_path, monkeypatch):
    from jaco.outputs import write_text

    path = tmp_path / "table.csv"
    path.write_text("old\n")
    real = os.replace

    def interrupted(*a, **k):
        raise KeyboardInterrupt

    monkeypatch.setattr(os, "replace", interrupted)
    with pytest.raises(KeyboardInterrupt):
        write_text(path, "new\n" * 1000)
    monkeypatch.setattr(os, "replace", real)
    assert path.read_text() == "old\n" and [p.name for p in tmp_path.iterdir()] == ["table.csv"]


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_a_stop_signal_whose_exception_python_ignored_is_delivered_again(sig):
    """A signal handled inside a garbage-collector callback (JAX registers one) raises where Python
    ignores exceptions: the command would go on. The CLI sends it again until it stops the command."""
    import gc

    from jaco.cli import Terminated, stop_signals

    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    hook = sys.unraisablehook
    fired = []

    def collecting(phase, info):
        if phase == "start" and not fired:
            fired.append(phase)
            os.kill(os.getpid(), sig)  # its handler runs here and its exception is ignored

    expected = KeyboardInterrupt if sig == signal.SIGINT else Terminated
    try:
        with pytest.raises(expected), stop_signals():
            gc.callbacks.append(collecting)
            try:
                gc.collect()
            finally:
                gc.callbacks.remove(collecting)
            assert fired, "the callback ran and the command is still running"
            t0 = time.time()
            while time.time() - t0 < 10:  # without the second delivery this ends and nothing is raised
                time.sleep(0.01)
    finally:
        signal.signal(signal.SIGINT, previous)
    assert sys.unraisablehook is hook and signal.getsignal(signal.SIGTERM) is not jaco.cli._terminate


def test_without_a_cpu_backend_runs_skip_the_host_callback_and_say_so(monkeypatch):
    """``JAX_PLATFORMS=cuda`` alone leaves jax without the CPU backend that host callbacks need:
    the JAX walk's stop check must then trace to a constant (not a callback that fails at run
    time) and warn once that interrupts land between calls."""
    import jax
    import jax.numpy as jnp

    from jaco.engine import native

    def jaxpr_of():  # a new function each time: jax caches a function's trace
        return str(jax.make_jaxpr(lambda t: native._host_stopped(t))(jnp.int32(0)))

    monkeypatch.delitem(native._state, "host_callbacks", raising=False)
    assert "pure_callback" in jaxpr_of()  # this machine has its CPU backend

    real = jax.devices

    def devices(backend=None):
        if backend == "cpu":
            raise RuntimeError("Unknown backend cpu")
        return real(backend)

    monkeypatch.setattr(jax, "devices", devices)
    monkeypatch.delitem(native._state, "host_callbacks")
    with pytest.warns(UserWarning, match="no CPU backend"):
        text = jaxpr_of()
    assert "pure_callback" not in text and "cond" not in text
    assert not bool(jax.jit(lambda t: native._host_stopped(t))(jnp.int32(0)))
    monkeypatch.delitem(native._state, "host_callbacks")  # the next test asks again


def test_quick_solves_run_on_the_main_thread_and_an_interrupt_still_stops_them(monkeypatch):
    """A solve whose program's last call was quick runs on the calling thread (no hand-over to the
    worker), with the same results as through the worker; a real SIGINT during a loop of such
    solves raises KeyboardInterrupt at once and leaves no stop request behind."""
    from jaco import progress

    grid = jaco.maps.random_map(12, 0.2, seed=1)
    solve = lambda seed: jaco.solve(grid, (0, 0), (11, 11), "as", seed=seed, n_ants=10, n_iters=10, progress=False)  # noqa: E731
    handed = []
    real_submit = progress._WORKER.submit
    monkeypatch.setattr(progress._WORKER, "submit", lambda *a, **k: handed.append(1) or real_submit(*a, **k))
    monkeypatch.setattr(progress, "_TOOK", {})  # no call of any program noted yet
    first = solve(0)  # through the worker (and the compile, unless another test compiled the program)
    assert handed == [1]
    solve(0)  # the program's last call now took the run alone: quick
    assert any(t < progress.QUICK for t in progress._TOOK.values())
    handed.clear()
    again = [solve(s) for s in (0, 1, 2)]
    assert not handed  # quick now: on this thread
    np.testing.assert_array_equal(again[0].path, first.path)
    np.testing.assert_array_equal(again[0].history["best"], first.history["best"])
    monkeypatch.setattr(progress, "QUICK", 0.0)  # every call through the worker: the same results
    for s, r in zip((0, 1, 2), again):
        w = solve(s)
        np.testing.assert_array_equal(w.path, r.path)
        for k in r.history:
            np.testing.assert_array_equal(w.history[k], r.history[k])
    assert handed
    monkeypatch.undo()

    timer = threading.Timer(0.5, os.kill, (os.getpid(), signal.SIGINT))
    t0 = time.time()
    timer.start()
    with pytest.raises(KeyboardInterrupt):
        while time.time() - t0 < 60:
            solve(3)
    assert time.time() - t0 < 5 and not jaco.engine.native.stop_is_set()
    assert solve(4).success
