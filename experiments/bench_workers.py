#!/usr/bin/env python
"""Several workers on one study: trials per second of ``jaco search --workers N`` for N = 1 and 2,
and the storage's own time per batch (what a worker asks and tells, without evaluating) for
SQLite, a journal file and PostgreSQL.

    python experiments/bench_workers.py                # prints the section
    python experiments/bench_workers.py --smoke        # small sizes, seconds
    python experiments/bench_workers.py --out FILE.md  # also writes the section into FILE.md

*Workers*: ``jaco search`` on the bundled ``random-32-32-10`` map (scenario 34), ACS's β and ρ by
TPE, on a fresh SQLite file, timed from the command's start to its end (imports and compiles
included, in every worker: they compile the same programs side by side), N worker processes
splitting the machine's cores. *Storage per batch*: a batch of B trials asked (Optuna's ask with a
random sampler), given jaco's attributes, told, plus the takeover scan a worker makes before every
batch, with jaco's own storage set-up for each kind; PostgreSQL is a local server
(``tests/postgres.py``: skipped, saying why, where none can start).
"""

from __future__ import annotations

import argparse
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from report import fixed, table, write_section  # noqa: E402 (the experiments' shared helpers)

SECTION = "bench_workers"


def workers_rate(n: int, trials: int, batch: int, sizes: dict, folder: Path) -> tuple[float, float]:
    """(wall seconds, finished trials per second) of ``jaco search --workers n`` on a fresh file."""
    db = folder / f"w{n}.db"
    cmd = [
        sys.executable, "-m", "jaco.cli", "search", "random-32-32-10.map", "--scen", "random-32-32-10-even-10.scen",
        "--index", "34", "--planner", "acs", "--param", "beta=1:20:log", "--param", "rho=0.01:0.5",
        "--trials", str(trials), "--batch", str(batch), "--seeds", "2", "--ants", str(sizes["n_ants"]),
        "--iters", str(sizes["n_iters"]), "--storage", str(db), "--workers", str(n),
    ]  # fmt: skip
    t0 = time.perf_counter()
    subprocess.run(cmd, cwd=folder, check=True, stdout=subprocess.DEVNULL)
    wall = time.perf_counter() - t0
    import jaco

    done = sum(t.state.name == "COMPLETE" for t in jaco.load_study(str(db)).study.trials)
    return wall, done / wall


def storage_per_batch(storage, batch: int, batches: int) -> float:
    """Median seconds per batch of the storage alone (ask, attributes, tell, takeover scan)."""
    import optuna

    from jaco.research.search_storage import claim_lock, opened, quiet, storage_target
    from jaco.research.search_workers import Workers

    obj, path, _ = storage_target(storage)
    times = []
    with quiet(), opened(obj, path) as store:
        study = optuna.create_study(storage=store, sampler=optuna.samplers.RandomSampler(seed=0), study_name="b")
        workers = Workers(study, store, claim_lock(store, path), 30.0, 90.0)
        for _ in range(batches):
            t0 = time.perf_counter()
            workers.running(study.get_trials(deepcopy=False, states=(optuna.trial.TrialState.RUNNING,)))
            trials = [study.ask() for _ in range(batch)]
            for t in trials:
                t.suggest_float("beta", 1.0, 20.0, log=True)
                t.suggest_float("rho", 0.01, 0.5)
                t.set_user_attr("jaco_trial", {"planner": "acs", "params": dict(t.params), "owner": workers.id})
            for t in trials:
                t.set_user_attr("jaco_runs", {"100": {"success": [[True, True]], "length": [[40.0, 41.0]]}})
                study.tell(t, 0.1)
            times.append(time.perf_counter() - t0)
    return sorted(times)[len(times) // 2]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--smoke", action="store_true", help="16 trials of 5 ants x 5 iterations; 3 storage batches")
    ap.add_argument(
        "--out", type=Path, default=None, help="markdown file to update (default BENCHMARKS.md; nothing with --smoke)"
    )
    args = ap.parse_args(argv)
    sizes = dict(n_ants=5, n_iters=5) if args.smoke else dict(n_ants=50, n_iters=100)
    trials, batch = (16, 4) if args.smoke else (256, 32)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        base = None
        for n in (1, 2):
            wall, rate = workers_rate(n, trials, batch, sizes, folder)
            base = base or rate
            rows.append([f"{n} worker{'s' * (n > 1)}", trials, fixed(wall, 2), fixed(rate, 2), f"{rate / base:.2f}×"])
            print(f"{n} workers: {trials} trials in {wall:.2f} s, {rate:.2f} trials/s", flush=True)
        store_rows = []
        kinds = [("SQLite", str(folder / "b.db")), ("journal file", str(folder / "b.journal"))]
        for label, storage in kinds + _postgres():
            if storage is None:
                store_rows.append([label, batch, "–", "no server here"])
                continue
            s = storage_per_batch(storage, batch, 3 if args.smoke else 10)
            store_rows.append([label, batch, fixed(1e3 * s, 1), fixed(1e3 * s / batch, 2)])
            print(f"{label}: {1e3 * s:.1f} ms per batch of {batch}", flush=True)
    cmd = "python experiments/bench_workers.py" + (" --smoke" if args.smoke else "")
    body = (
        "## Several workers on one study (`experiments/bench_workers.py`)\n\n"
        f"Command: `{cmd}` ({platform.processor() or platform.machine()}, {os.cpu_count()} cores). "
        f"`jaco search --workers N` on random-32-32-10 (scenario 34), ACS's β and ρ by TPE, {trials} trials in "
        f"batches of {batch}, 2 seeds, {sizes['n_ants']} ants × {sizes['n_iters']} iterations, a fresh SQLite file; "
        "wall time of the whole command (imports and every worker's compiles included).\n\n"
        + table(["workers", "trials", "wall s", "trials/s", "vs 1 worker"], rows)
        + "\n\nThe storage alone per batch (ask, jaco's attributes, tell, the takeover scan; no evaluation):\n\n"
        + table(["storage", "batch", "ms per batch", "ms per trial"], store_rows)
        + "\n"
    )
    print(body)
    out = args.out if args.out is not None or args.smoke else HERE.parent / "BENCHMARKS.md"
    if out is not None:
        write_section(out, SECTION, body)
    return 0


def _postgres() -> list:
    """[("PostgreSQL", url or None)], a server kept running until the process ends."""
    sys.path.insert(0, str(HERE.parent / "tests"))
    try:
        import postgres
    except ImportError:
        return [("PostgreSQL", None)]
    if postgres.missing():
        return [("PostgreSQL", None)]
    ctx = postgres.postgres_server()
    url = ctx.__enter__()
    import atexit

    atexit.register(ctx.__exit__, None, None, None)
    return [("PostgreSQL", url)]


if __name__ == "__main__":
    sys.exit(main())
