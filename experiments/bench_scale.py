#!/usr/bin/env python
"""Every registered planner on the largest bundled maps: one ``jaco.solve`` per planner, timed.

    python experiments/bench_scale.py                 # updates BENCHMARKS.md
    python experiments/bench_scale.py --smoke --out DIR

The MovingAI map bloodvenomfalls (512×512, its scenario file's longest query) and the ROS
map_server map ``map.yaml`` (384×384, the two free cells farthest apart in the component of the
middle free cell) at 50 ants × 100 iterations, seed 0: the first call (tables, tracing, XLA
compile and the run) and a second call (the run alone), success and gap. Nothing here asserts a
time; the point is that no planner does work that grows with cells² (the potential-field tables
of ``apf-aco``/``pf-aco`` are distance transforms and outline scans, ``jaco.potential``).
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from report import fixed, publish, table  # noqa: E402 (the experiments' shared helpers)

SECTION = "bench_scale"


def queries(jaco, smoke: bool):
    """(label, grid, start, goal) of the maps to time."""
    if smoke:
        g = jaco.maps.load(jaco.maps.bundled("room-32-32-4.map"))
        s = max(jaco.maps.load_scenarios(jaco.maps.bundled("room-32-32-4-even-10.scen")), key=lambda x: x.optimal)
        return [("room-32-32-4 (longest scenario)", g, s.start, s.goal)]
    g = jaco.maps.load(jaco.maps.bundled("bloodvenomfalls.map"))
    s = max(jaco.maps.load_scenarios(jaco.maps.bundled("bloodvenomfalls.map.scen")), key=lambda x: x.optimal)
    out = [("bloodvenomfalls 512×512 (longest scenario)", g, s.start, s.goal)]
    ros = jaco.maps.load(jaco.maps.bundled("map.yaml"))
    free = np.argwhere(ros.free)
    start = tuple(int(v) for v in free[len(free) // 2])
    reach = np.argwhere(jaco.exact.reachable(ros, start))
    goal = tuple(int(v) for v in reach[((reach - np.array(start)) ** 2).sum(1).argmax()])
    return out + [("ROS map.yaml 384×384", ros, start, goal)]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--smoke", action="store_true", help="one 32×32 map, two planners, 5 ants × 3 iterations")
    ap.add_argument("--skip-largest", nargs="*", default=[], metavar="PLANNER",
                    help="planners left out on the 512×512 map (listed as left out in the table)")
    ap.add_argument("--out", type=Path, default=None, help="markdown file to write (default BENCHMARKS.md; --smoke: none)")
    args = ap.parse_args(argv)
    import jaco

    ants, iters = (5, 3) if args.smoke else (50, 100)
    names = ["mmas", "iaca"] if args.smoke else list(jaco.PLANNERS)
    t_all = time.perf_counter()
    rows = []
    for label, grid, start, goal in queries(jaco, args.smoke):
        for name in names:
            if name in args.skip_largest and label.startswith("bloodvenomfalls"):
                rows.append([label, name, "left out", "–", "–", "–"])
                continue
            times = []
            for _ in range(2):
                t0 = time.perf_counter()
                r = jaco.solve(grid, start, goal, name, seed=0, n_ants=ants, n_iters=iters, progress=False)
                times.append(time.perf_counter() - t0)
            rows.append([label, name, fixed(times[0], 1), fixed(times[1], 2), "yes" if r.success else "no",
                         fixed(100 * r.gap, 1) if r.success else "–"])
            print(" | ".join(rows[-1]), flush=True)
    head = ["map, query", "planner", "first call s", "second call s", "success", "gap %"]
    try:
        commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=HERE, capture_output=True, text=True).stdout.strip()
    except OSError:
        commit = "?"
    shown = sys.argv[1:] if argv is None else list(argv)
    text = "\n".join([
        "## Every planner on the largest maps (`experiments/bench_scale.py`)", "",
        f"Command: `{' '.join(['python experiments/bench_scale.py', *shown])}` (run {time.strftime('%Y-%m-%d %H:%M')}, "
        f"{time.perf_counter() - t_all:.0f} s in all; jaco at commit {commit}; {os.cpu_count()} CPUs, "
        f"load average {os.getloadavg()[0]:.2f} at the end). `jaco.solve(..., seed=0, n_ants={ants}, n_iters={iters})`, "
        "one device, native walk; the first call includes the tables, tracing and XLA compile.", "",
        table(head, rows), "",
    ] + ([f"Left out on the 512×512 map (`--skip-largest`): {', '.join(args.skip_largest)}.", ""] if args.skip_largest else []))
    publish(text, SECTION, args.out, args.smoke)
    return 0


if __name__ == "__main__":
    sys.exit(main())
