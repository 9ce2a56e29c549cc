#!/usr/bin/env python
"""What local search and the default step limit cost, and which paths to search.

    python experiments/bench_local_search.py                 # updates BENCHMARKS.md
    python experiments/bench_local_search.py --smoke --out FILE

Four measurements, 50 ants × 100 iterations, native walk, one device:

1. **Which paths to search** (the choice of ``jaco.engine.local_search.BEST``): backtracking +
   the chaos heuristic + IACA's rule (the suite's best composition) without local search, with
   the octile shortcut of each iteration's best path, of its best 5, and of every ant's, on the
   suite's four queries of Berlin_1_256, bloodvenomfalls and lak303d (``movingai_suite.scenarios``)
   × 2 seeds: median gap, success, time per query (one batched ``jaco.sweep`` per map and choice,
   compile included).
2. **A solve with and without it on Berlin_1_256**: ``jaco.solve`` of the same planner with and
   without ``local_search="shortcut"`` on the same four queries and seeds, the two alternating,
   after a first call that compiles; median seconds of each per query, and the ratio of their
   sums over the queries.
3. **The default step limit on bloodvenomfalls** (512×512): `iaca` and the planner with local
   search at the old default 4·(H + W) and at the new one for backtracking ants (there 8·(H + W)):
   seconds per solve (median over the four queries and a seed each) and the compiled program's
   memory (XLA's memory analysis: arguments, outputs and temporaries of one solve).
4. **Every map's longest scenarios at the new default**: `iaca` on the ``--longest`` longest
   scenarios of every bundled MovingAI scenario file, seed 0: how many it solves.

Nothing here asserts a time.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from movingai_suite import scenarios  # noqa: E402 (the suite's choice of queries)

from report import fixed, publish, table  # noqa: E402 (the experiments' shared helpers)

SECTION = "bench_local_search"
CHAOS = dict(construct="backtrack", heuristic="chaos", rule="iaca")


def _grid(jaco, name):
    return jaco.maps.load(jaco.maps.bundled(name))


def which_paths(jaco, maps, n_scen, seeds, ants, iters):
    """Rows of measurement 1."""
    from jaco.engine import local_search as ls

    base = jaco.compose(**CHAOS)
    choices = [("none", base)] + [
        (label, base._replace(name=f"{base.name} best={best}",
                              local_search=ls.shortcut_search(window=ls.WINDOW, passes=ls.PASSES, best=best)))
        for label, best in (("best 1", 1), ("best 5", 5), ("every ant", None))
    ]
    rows = []
    for m in maps:
        grid = _grid(jaco, m)
        scen = scenarios(jaco, m, n_scen)
        for label, v in choices:
            t0 = time.perf_counter()
            tab = jaco.sweep(grid, [s.start for s in scen], [s.goal for s in scen], v, seeds=seeds, n_ants=ants,
                             n_iters=iters, progress=False)
            per_query = (time.perf_counter() - t0) / len(tab)
            rows.append([m.removesuffix(".map"), label, fixed(100 * float(np.median(tab.gap)), 1),
                         f"{100 * tab.success.mean():.0f}%", fixed(per_query, 2)])
            print(" | ".join(rows[-1]), flush=True)
    return rows


def solve_ratio(jaco, name, n_scen, seeds, ants, iters, reps):
    """Measurement 2: (rows, the queries' median seconds summed without, and with)."""
    grid = _grid(jaco, name)
    scen = scenarios(jaco, name, n_scen)
    plain, searching = jaco.compose(**CHAOS), jaco.compose(**CHAOS, local_search="shortcut")
    total = {plain.name: 0.0, searching.name: 0.0}
    rows = []
    for q, s in enumerate(scen):
        for v in (plain, searching):  # compile (once per shape and planner)
            jaco.solve(grid, s.start, s.goal, v, seed=0, n_ants=ants, n_iters=iters, progress=False)
        mine = {plain.name: [], searching.name: []}
        gaps = {}
        for rep in range(reps):
            for seed in range(seeds):
                for v in ((plain, searching) if (rep + seed) % 2 == 0 else (searching, plain)):
                    t0 = time.perf_counter()
                    r = jaco.solve(grid, s.start, s.goal, v, seed=seed, n_ants=ants, n_iters=iters, progress=False)
                    mine[v.name].append(time.perf_counter() - t0)
                    gaps.setdefault(v.name, []).append(r.gap)
        a, b = statistics.median(mine[plain.name]), statistics.median(mine[searching.name])
        total[plain.name] += a
        total[searching.name] += b
        rows.append([str(q + 1), fixed(s.optimal, 1), fixed(a, 2), fixed(b, 2), fixed(b / a, 2),
                     fixed(100 * float(np.median(gaps[plain.name])), 1), fixed(100 * float(np.median(gaps[searching.name])), 1)])
        print(" | ".join(rows[-1]), flush=True)
    return rows, total[plain.name], total[searching.name]


def step_limit_cost(jaco, name, n_scen, ants, iters):
    """Rows of measurement 3."""
    from jaco.engine import checks as jc
    from jaco.engine import run as jr
    from jaco.engine.problem import make_problem
    from jaco.engine.shape import RunShape

    grid = _grid(jaco, name)
    scen = scenarios(jaco, name, n_scen)
    old, new = jc.legacy_steplimit(grid), jc.default_steplimit(grid, jaco.PLANNERS["iaca"])
    rows = []
    for planner in ("iaca", jaco.compose(**CHAOS, local_search="shortcut")):
        v = jaco.planners.registry.get_planner(planner)
        for limit in (old, new):
            times, gaps = [], []
            for q, s in enumerate(scen):
                if q == 0:  # compile
                    jaco.solve(grid, s.start, s.goal, v, seed=0, n_ants=ants, n_iters=iters, steplimit=limit, progress=False)
                t0 = time.perf_counter()
                r = jaco.solve(grid, s.start, s.goal, v, seed=1, n_ants=ants, n_iters=iters, steplimit=limit, progress=False)
                times.append(time.perf_counter() - t0)
                gaps.append(r.gap)
            run = jr.compiled_run(v, RunShape(ants, iters, limit), batched=False)
            problem = make_problem(grid, scen[0].start, scen[0].goal)
            values = jc.resolve_params(v, {}, where="bench")
            mem = run.lower(jaco.engine.run.jax.random.key(0), problem, jc.params_from(values)).compile().memory_analysis()
            total = sum(getattr(mem, k, 0) for k in ("argument_size_in_bytes", "output_size_in_bytes", "temp_size_in_bytes"))
            label = "old default, 4·(H + W)" if limit == old else "new default for backtracking ants"
            rows.append([jaco.planners.registry.get_planner(planner).name if planner == "iaca" else "backtrack+chaos+iaca+shortcut",
                         f"{limit} — {label}", fixed(statistics.median(times), 2), fixed(max(times), 2),
                         f"{total / 2**20:.0f}", fixed(100 * float(np.median(gaps)), 1)])
            print(" | ".join(rows[-1]), flush=True)
    return rows


def longest(jaco, k, ants, iters, maps=None):
    """Rows of measurement 4."""
    rows = []
    names = maps or sorted(n for n in jaco.maps.BUNDLED if n.endswith(".map"))
    for m in names:
        grid = _grid(jaco, m)
        scen_name = next(n for n in jaco.maps.BUNDLED if n.endswith(".scen") and
                         (n == m + ".scen" or n.startswith(m.removesuffix(".map") + "-even")))
        scen = sorted(jaco.maps.load_scenarios(jaco.maps.bundled(scen_name)), key=lambda s: s.optimal)[-k:]
        t0 = time.perf_counter()
        tab = jaco.sweep(grid, [s.start for s in scen], [s.goal for s in scen], "iaca", seeds=[0], n_ants=ants,
                         n_iters=iters, progress=False)
        limit = jaco.engine.checks.default_steplimit(grid, jaco.PLANNERS["iaca"])
        rows.append([m.removesuffix(".map"), f"{grid.height}x{grid.width}", str(limit), fixed(scen[0].optimal, 1),
                     fixed(scen[-1].optimal, 1), f"{int(tab.success.sum())} of {len(tab)}",
                     fixed(100 * float(np.median(tab.gap)), 1), fixed(time.perf_counter() - t0, 0)])
        print(" | ".join(rows[-1]), flush=True)
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--smoke", action="store_true", help="small maps, 6 ants × 4 iterations, to check that it runs")
    ap.add_argument("--out", type=Path, default=None, help="markdown file to write (default BENCHMARKS.md; --smoke: none)")
    ap.add_argument("--reps", type=int, default=3, help="repetitions of each timed solve (measurement 2)")
    ap.add_argument("--longest", type=int, default=5, help="longest scenarios per map (measurement 4; 0: leave it out)")
    args = ap.parse_args(argv)
    import jaco

    t_all = time.perf_counter()
    if args.smoke:
        ants, iters, n_scen, seeds = 6, 4, 2, 1
        big, berlin, maps, longest_maps = "room-32-32-4.map", "room-32-32-4.map", ["room-32-32-4.map"], ["room-32-32-4.map"]
    else:
        ants, iters, n_scen, seeds = 50, 100, 4, 2
        big, berlin, maps, longest_maps = "bloodvenomfalls.map", "Berlin_1_256.map", [
            "Berlin_1_256.map", "bloodvenomfalls.map", "lak303d.map"], None
    load0 = os.getloadavg()[0]
    part1 = which_paths(jaco, maps, n_scen, seeds, ants, iters)
    part2, t_plain, t_search = solve_ratio(jaco, berlin, n_scen, seeds, ants, iters, 1 if args.smoke else args.reps)
    part3 = step_limit_cost(jaco, big, n_scen, ants, iters)
    part4 = longest(jaco, args.longest, ants, iters, longest_maps) if args.longest else []
    try:
        commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=HERE, capture_output=True, text=True).stdout.strip()
    except OSError:
        commit = "?"
    shown = sys.argv[1:] if argv is None else list(argv)
    b = berlin.removesuffix(".map")
    text = "\n".join([
        "## Local search and the default step limit (`experiments/bench_local_search.py`)", "",
        f"Command: `{' '.join(['python experiments/bench_local_search.py', *shown])}` (run {time.strftime('%Y-%m-%d %H:%M')}, "
        f"{time.perf_counter() - t_all:.0f} s in all; jaco at commit {commit}; {os.cpu_count()} CPUs shared with other "
        f"processes, load average {load0:.2f} at the start and {os.getloadavg()[0]:.2f} at the end). {ants} ants × "
        f"{iters} iterations, native walk, one device. The planner is `compose(construct=backtrack, heuristic=chaos, "
        "rule=iaca)` (backtrack+chaos+iaca) with and without `local_search=\"shortcut\"`; queries: the MovingAI suite's "
        f"{n_scen} per map.", "",
        "### Which paths to search", "",
        f"The octile shortcut of each iteration's best path, best 5 or every ant's ({seeds} seeds × {n_scen} queries "
        "per map; seconds per query of one batched sweep, compile included).", "",
        table(["map", "searched", "median gap %", "success", "s/query"], part1), "",
        f"### A solve with and without local search on {b}", "",
        f"`jaco.solve` after a first call that compiled; median over {seeds} seeds × {args.reps if not args.smoke else 1} "
        "repetitions, the two planners alternating.", "",
        table(["query", "optimum", "without s", "with s", "ratio", "gap without %", "gap with %"], part2), "",
        f"**The {len(part2)} queries, each at its median: {t_plain:.2f} s without, {t_search:.2f} s with local search: "
        f"{t_search / t_plain:.2f}×.**", "",
        f"### The default step limit on {big.removesuffix('.map')}", "",
        "Seconds per `jaco.solve` (seed 1, after a call that compiled; median and slowest over the queries), the "
        "compiled program's memory (arguments + outputs + temporaries, XLA's memory analysis) and the median gap.", "",
        table(["planner", "step limit", "median s", "slowest s", "program MiB", "median gap %"], part3), "",
    ] + ([
        "### Every map's longest scenarios at the new default", "",
        f"`iaca`, seed 0, the {args.longest} longest scenarios of each scenario file, one sweep per map (s: its time, "
        "compile included).", "",
        table(["map", "size", "step limit", "shortest of them", "longest", "solved", "median gap %", "s"], part4), "",
    ] if part4 else []))
    publish(text, SECTION, args.out, args.smoke)
    return 0


if __name__ == "__main__":
    sys.exit(main())
