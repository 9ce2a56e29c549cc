#!/usr/bin/env python
"""jaco against an earlier jaco, on one core, in alternating processes: what a change did per core.

    python experiments/bench_before_after.py --before 3e04a59      # updates BENCHMARKS.md
    python experiments/bench_before_after.py --before HEAD~1 --smoke --out DIR/x.md

The machines here are shared: the same program runs up to 1.5x faster or slower from one minute to
the next, so two benchmark runs made minutes apart cannot say what a change did. This script
builds the earlier revision's package (a git worktree and its native kernel, in a temporary
folder), then measures both in turn, ``rounds`` times, each time in a fresh process pinned to one
core (CPU time is then the per-core cost, with no idle pool thread counted), with the numba loop
of ``native_reference.py`` in the same process as the yardstick; it reports the best of each.

Figures, each as in ``bench_throughput.py`` (same map, 50 ants x 100 iterations): the
64-configuration AS sweep's real ant-steps per second against the numba loop's; one ``jaco.solve``
against the numba loop's run of the same problem; IACA on the longest Berlin_1_256 query. The
two revisions must give the same tables (the script checks the sweep's costs). ``--smoke`` runs the
same figures on a small workload (12x12 map, 8 configurations, 10 ants x 10 iterations, no IACA):
a check that the script works, not a measurement.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(HERE))
from report import publish, table  # noqa: E402 (the experiments' shared helpers)

SECTION = "bench_before_after"
#: The workload (``side``: the random map's side, 25 % obstacles; ``values``: each of alpha, beta and
#: rho takes the first ``values`` of its axis) and the repetitions.
FULL = dict(rounds=2, sweep_reps=3, solve_calls=24, solve_seeds=8, city=True, side=30, values=4, n_ants=50, n_iters=100)
SMOKE = dict(rounds=1, sweep_reps=1, solve_calls=4, solve_seeds=2, city=False, side=12, values=2, n_ants=10, n_iters=10)

# Run in a child process pinned to one core, with the package to measure first on sys.path.
CHILD = r"""
import itertools, json, os, statistics, sys, time
import numpy as np
os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})
if sys.argv[2]:
    sys.path.insert(0, sys.argv[2])
import native_reference as nr
import jaco
import jaco.engine.checks as jc
cfg = json.loads(sys.argv[1])
side, n_ants, n_iters = cfg["side"], cfg["n_ants"], cfg["n_iters"]
grid = jaco.maps.random_map(side, 0.25, seed=0)
start, goal = (0, 0), (side - 1, side - 1)
axes = {k: v[:cfg["values"]] for k, v in
        {"alpha": [0.5, 1.0, 2.0, 4.0], "beta": [1.0, 2.0, 4.0, 8.0], "rho": [0.1, 0.3, 0.5, 0.7]}.items()}
steplimit = jc.default_steplimit(grid)
nbr, eta, s, g = nr.problem_arrays(grid, start, goal)
cols = np.array(list(itertools.product(axes["alpha"], axes["beta"], axes["rho"])))

def timed(fn, n):
    best, out = float("inf"), None
    for _ in range(n):
        c0 = time.process_time(); out = fn(); best = min(best, time.process_time() - c0)
    return best, out

sweep = lambda: jaco.sweep(grid, start, goal, "as", axes, seeds=1, n_ants=n_ants, n_iters=n_iters, steplimit=steplimit)
native = lambda: nr.sweep_native(cols, nbr, eta, s, g, q=1.0, tau0=0.1, n_ants=n_ants, n_iters=n_iters, steplimit=steplimit,
                                  seed=0)
table = sweep(); native()
jaco_s, _ = timed(sweep, cfg["sweep_reps"])
native_s, (lengths, steps) = timed(native, cfg["sweep_reps"])
# both call seeds 0 .. solve_seeds - 1 in turn (their random numbers differ; one seed's can give one
# side a quarter more steps than the other's)
seed_of = lambda i: i % cfg["solve_seeds"]
solve = lambda seed: jaco.solve(grid, start, goal, "as", seed=seed, n_ants=n_ants, n_iters=n_iters)
solve(0)
p = jc.resolve_params(jaco.PLANNERS["as"], {}, where="as")
one = [float(p[k]) for k in ("alpha", "beta", "rho", "q", "tau0")]
lat, nat = [], []  # one call of each in turn, the same seed: a pair sees one state of the machine
for i in range(cfg["solve_calls"]):
    nat.append(timed(lambda: nr.as_colony(nbr, eta, s, g, *one, n_ants, n_iters, steplimit, seed_of(i)), 1)[0])
    lat.append(timed(lambda: solve(seed_of(i)), 1)[0])
out = dict(jaco_s=jaco_s, native_s=native_s, native_steps=int(np.sum(steps)), costs=table["cost"].tolist(),
           solve_ms=1e3 * statistics.median(lat), native_run_ms=1e3 * statistics.median(nat),
           solve_speedup=statistics.median(n / j for n, j in zip(nat, lat)))
if cfg["city"]:
    berlin = jaco.maps.load(jaco.maps.bundled("Berlin_1_256.map"))
    scen = max(jaco.maps.load_scenarios(jaco.maps.bundled("Berlin_1_256.map.scen")), key=lambda q: q.optimal)
    city = lambda: jaco.solve(berlin, scen.start, scen.goal, "iaca", seed=0, n_ants=50, n_iters=100)
    city()
    out["city_s"] = min(timed(city, 1)[0] for _ in range(2))
print("RESULT " + json.dumps(out))
"""


def build_revision(rev: str, where: Path) -> Path:
    """A worktree of ``rev`` with its native kernel built in place; the folder to put on sys.path."""
    tree = where / "before"
    subprocess.run(["git", "worktree", "add", "--detach", "-q", str(tree), rev], cwd=ROOT, check=True)
    # The user's kernel cache: a revision whose kernel sources match one built before is copied, not compiled.
    subprocess.run([sys.executable, "setup.py", "-q", "build_ext", "--inplace"], cwd=tree, check=True,
                   capture_output=True)
    return tree


def measure(path: Path | None, cfg: dict) -> dict:
    """The figures of the package at ``path`` (None: the jaco this Python imports), in a child process."""
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(p) for p in (path, HERE) if p]))
    proc = subprocess.run([sys.executable, "-c", CHILD, json.dumps(cfg), str(path or "")], env=env,
                          capture_output=True, text=True, timeout=3600)
    line = next((x for x in proc.stdout.splitlines() if x.startswith("RESULT ")), None)
    if line is None:
        raise SystemExit(f"the measurement of {path} failed:\n{proc.stderr[-3000:]}")
    return json.loads(line[len("RESULT "):])


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--before", required=True, help="the earlier revision (a git commit)")
    ap.add_argument("--smoke", action="store_true", help="one round, few repetitions, a small workload, no IACA")
    ap.add_argument("--rounds", type=int, default=None, help="alternating rounds (default 2; 1 with --smoke)")
    ap.add_argument("--out", default=None, help="markdown file to update (default BENCHMARKS.md; nothing with --smoke)")
    args = ap.parse_args(argv)
    cfg = dict(SMOKE if args.smoke else FULL)
    if args.rounds is not None:
        if args.rounds < 1:
            ap.error("--rounds must be at least 1")
        cfg["rounds"] = args.rounds
    rev = subprocess.run(["git", "rev-parse", "--short", args.before], cwd=ROOT, capture_output=True, text=True,
                         check=True).stdout.strip()
    now = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True, text=True).stdout.strip()
    tmp = Path(tempfile.mkdtemp(prefix="jaco-before-"))
    try:
        before = build_revision(rev, tmp)
        runs = {"before": [], "after": []}
        # Alternating, so that both see the machine's slow and fast minutes, and each round in the
        # other order than the round before (the same code twice measured ±9 % apart, one process to
        # the next): neither revision always runs first.
        for r in range(cfg["rounds"]):
            for side in ("before", "after") if r % 2 == 0 else ("after", "before"):
                runs[side].append(measure(before if side == "before" else None, cfg))
    finally:
        subprocess.run(["git", "worktree", "remove", "--force", str(tmp / "before")], cwd=ROOT, capture_output=True)
        shutil.rmtree(tmp, ignore_errors=True)
    if runs["before"][0]["costs"] != runs["after"][0]["costs"]:
        raise SystemExit("the two revisions' sweeps give different costs: not the same runs")

    def best(side, key):
        return min(r[key] for r in runs[side])

    from jaco.engine import native

    rows, fig = [], {}
    for side, label in (("before", f"before ({rev})"), ("after", f"after ({now})")):
        f = {k: best(side, k) for k in ("jaco_s", "native_s", "solve_ms", "native_run_ms") + (("city_s",) if cfg["city"] else ())}
        f["solve_speedup"] = max(r["solve_speedup"] for r in runs[side])  # the best round's, as the times
        fig[side] = f
        rows.append([label, f["jaco_s"], f["native_s"], f["native_s"] / f["jaco_s"], f["solve_ms"], f["native_run_ms"],
                     f["solve_speedup"]] + ([f["city_s"]] if cfg["city"] else []))
    header = ["jaco", "sweep CPU s (1 core)", "numba loop CPU s", "sweep × numba per core", "solve ms (median)",
              "numba run ms (median)", "solve × numba run (median of pairs)"] + (["IACA Berlin_1_256 s"] if cfg["city"] else [])
    command = (f"python experiments/bench_before_after.py --before {args.before}" + (" --smoke" if args.smoke else "")
               + (f" --rounds {args.rounds}" if args.rounds is not None else ""))
    speed = fig["before"]["jaco_s"] / fig["after"]["jaco_s"]
    text = "\n".join([
        "## Before and after, per core (`experiments/bench_before_after.py`)",
        "",
        f"Command: `{command}`: revision {rev} against {now}, {cfg['rounds']} alternating rounds (each in the other "
        "order than the one before), each a fresh process "
        "pinned to one core, best of each; the numba loop measured in the same process as the yardstick "
        f"(the machine's speed changes from minute to minute); the solve and the numba loop's run are called in "
        f"turn, seeds 0–{cfg['solve_seeds'] - 1}, and their speed-up is the median over those pairs of calls. "
        "Native lane kernels now: "
        + ", ".join(f"{k} ({v})" for k, v in native.isas().items()) + ".",
        "",
        table(header, rows),
        "",
        f"The same sweep costs {cpu_words(speed)} on one core after than before; the two give the same costs, "
        "run for run."
        + (f" (--smoke: a {cfg['side']}x{cfg['side']} map, {cfg['values'] ** 3} configurations, {cfg['n_ants']} ants × "
           f"{cfg['n_iters']} iterations: a check that the script runs, not a measurement.)" if args.smoke else ""),
    ])
    publish(text, SECTION, args.out, args.smoke)
    return 0


def cpu_words(speed: float) -> str:
    """``speed`` (CPU before / CPU after) in words that name the right direction."""
    if speed >= 1:
        return f"{speed:.2f}× less CPU"
    return f"{1 / speed:.2f}× more CPU"


if __name__ == "__main__":
    sys.exit(main())
