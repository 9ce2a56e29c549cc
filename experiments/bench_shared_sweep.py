#!/usr/bin/env python
"""A sweep shared by worker processes through one store: wall time with 1 and 2 workers, and the
store's own cost per chunk (one claim plus one commit).

    python experiments/bench_shared_sweep.py            # prints the figures, updates BENCHMARKS.md (its section)
    python experiments/bench_shared_sweep.py --smoke    # tiny sizes, writes nothing unless --out

Workers are fresh processes (``python -c``, started in a temporary folder) that each compile the
chunk program, wait until all of them have compiled, then run ``jaco.sweep(..., store=...)`` on
the same store. Two times per worker count: ``end_to_end`` (launch to the last worker's exit:
imports, compiling and the sweep) and ``sweep`` (from the common start to the last worker's
table). Every worker's table is checked against the first one, bit for bit. The store's cost is
timed in this process on a store file of its own: ``claim`` + ``commit`` of a unit of ``chunk``
rows, repeated, with the rollback journal the store uses and with WAL for comparison.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from report import table, write_section  # noqa: E402 (the experiments' shared helpers)

FULL = dict(configs=16, seeds=4, n_ants=20, n_iters=200, chunk=4, commits=500)
SMOKE = dict(configs=4, seeds=2, n_ants=6, n_iters=10, chunk=2, commits=50)

WORKER = """
import json, os, sys, time
import numpy as np
import jaco
out, go, configs, seeds, n_ants, n_iters, chunk = sys.argv[1], sys.argv[2], *map(int, sys.argv[3:8])
grid = jaco.maps.named("demo")
axes = {"beta": list(np.linspace(1.0, 8.0, configs))}
kw = dict(n_ants=n_ants, n_iters=n_iters, chunk=chunk)
jaco.plan_sweep(grid, jaco.maps.DEMO_START, jaco.maps.DEMO_GOAL, "acs", axes, seeds, **kw)
open(out + ".ready", "w").close()
while not os.path.exists(go):
    time.sleep(0.005)
table = jaco.sweep(grid, jaco.maps.DEMO_START, jaco.maps.DEMO_GOAL, "acs", axes, seeds, store="sweep.db",
                   progress=False, **kw)
done = time.time()
table.to_pickle(out)
json.dump(dict(done=done, units=table.attrs["sweep"]["units_run"]), open(out + ".json", "w"))
"""


def run_workers(n: int, sizes: dict) -> dict:
    """``n`` worker processes on one new store: the two wall times, each worker's units, and
    whether every table is the same."""
    import pandas as pd

    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        args = [str(sizes[k]) for k in ("configs", "seeds", "n_ants", "n_iters", "chunk")]
        t0 = time.time()
        procs = [
            subprocess.Popen(
                [sys.executable, "-c", WORKER, str(folder / f"w{i}.pkl"), str(folder / "go"), *args], cwd=folder
            )
            for i in range(n)
        ]
        while not all((folder / f"w{i}.pkl.ready").exists() for i in range(n)):
            if any(p.poll() not in (None, 0) for p in procs):
                raise SystemExit("a worker failed")
            time.sleep(0.005)
        go = time.time()
        (folder / "go").touch()
        if any(p.wait() != 0 for p in procs):
            raise SystemExit("a worker failed")
        end = time.time()
        info = [json.loads((folder / f"w{i}.pkl.json").read_text()) for i in range(n)]
        tables = [pd.read_pickle(folder / f"w{i}.pkl") for i in range(n)]
        return dict(
            workers=n,
            end_to_end_s=round(end - t0, 3),
            sweep_s=round(max(i["done"] for i in info) - go, 3),
            units=[i["units"] for i in info],
            same_tables=all(t.equals(tables[0]) for t in tables),
        )


def store_cost(commits: int, chunk: int, journal: str) -> dict:
    """Mean milliseconds of one claim + commit (a unit of ``chunk`` rows, one query)."""
    import numpy as np

    from jaco.research import store as jstore

    jstore.JOURNAL_MODE = journal
    with tempfile.TemporaryDirectory() as tmp, jstore.SweepStore(Path(tmp) / "s.db") as s:
        outs = [np.zeros((1, chunk), np.float32)] * 2 + [np.zeros((1, chunk), np.int32)] * 2
        t0 = time.perf_counter()
        for _ in range(commits):
            got = s.claim("k", commits * chunk, chunk)
            assert s.commit("k", got, outs)
        ms = (time.perf_counter() - t0) / commits * 1e3
    jstore.JOURNAL_MODE = "delete"
    return dict(journal=journal, commits=commits, ms_per_claim_and_commit=round(ms, 3))


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--smoke", action="store_true", help="tiny sizes: checks that the script runs")
    parser.add_argument(
        "--out", type=Path, default=None, help="markdown file to update (default BENCHMARKS.md; nothing with --smoke)"
    )
    args = parser.parse_args(argv)
    sizes = SMOKE if args.smoke else FULL
    print(f"sizes: {sizes}", flush=True)
    result = dict(sizes=sizes, runs=[], store=[])
    for n in (1, 2):
        r = run_workers(n, sizes)
        print(f"{n} worker(s): {r}", flush=True)
        result["runs"].append(r)
    for journal in ("delete", "wal"):
        c = store_cost(sizes["commits"], sizes["chunk"], journal)
        print(f"store: {c}", flush=True)
        result["store"].append(c)
    print(json.dumps(result))
    out = args.out if args.out is not None or args.smoke else Path(__file__).resolve().parent.parent / "BENCHMARKS.md"
    if out is not None:
        write_section(out, "bench_shared_sweep", _markdown(result, args.smoke))


def _markdown(result: dict, smoke: bool) -> str:
    s = result["sizes"]
    cmd = "python experiments/bench_shared_sweep.py" + (" --smoke" if smoke else "")
    runs = [
        [
            r["workers"],
            f"{r['sweep_s']:.2f}",
            f"{r['end_to_end_s']:.2f}",
            " / ".join(map(str, r["units"])),
            str(r["same_tables"]),
        ]
        for r in result["runs"]
    ]
    store = [[c["journal"], c["commits"], f"{c['ms_per_claim_and_commit']:.1f}"] for c in result["store"]]
    return (
        "## A sweep shared by worker processes (`experiments/bench_shared_sweep.py`)\n\n"
        f"Command: `{cmd}`. `acs` on the demo map, {s['configs']} configurations × {s['seeds']} seeds, "
        f"{s['n_ants']} ants × {s['n_iters']} iterations, units of {s['chunk']} rows in one store; every worker's "
        "table equal to the first bit for bit. *sweep*: from a common start (every worker compiled) to the last "
        "table; *end to end*: launch to the last exit (imports and each worker's compile included).\n\n"
        + table(["workers", "sweep s", "end to end s", "units per worker", "tables equal"], runs)
        + "\n\nThe store's own cost per unit (one claim and one commit, in one process):\n\n"
        + table(["journal mode", "units", "ms per claim + commit"], store)
        + "\n"
    )


if __name__ == "__main__":
    main()
