#!/usr/bin/env python
"""IACA's backtracking walk alone, revisions side by side in one program: what a kernel change did.

    python experiments/bench_iaca_kernel.py --revs 9f72225 HEAD     # updates BENCHMARKS.md
    python experiments/bench_iaca_kernel.py --revs HEAD . --smoke --out DIR/x.md

A whole IACA solve on the machines here changes speed by up to 1.5x from one minute to the next,
so two solves minutes apart cannot show a 10 % change in the walk. This script compiles
``jaco/planners/iaca_lanes.cc`` of each revision (``.`` is the working tree) with AVX2 where
jaco's kernel runs its AVX2 lanes here (else the baseline), links them into one program
(``iaca_kernel_driver.cc``) and walks one colony with each in turn, walk after walk: every revision sees the slow and the fast moments alike. The walk is IACA's defaults (50
ants, q0 0.9, β 8) on the longest query of a bundled map, from the initial pheromone, one key per
walk; the program checks that every revision leaves the same pheromone, stacks and steps. The
revisions must share the kernel's interface (``iaca_lanes.h``) with the working tree: since 9f72225
the walk also returns each stack's moves, so earlier revisions no longer build with this driver. It
needs a C++ compiler (``$CXX``, else ``c++``).
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from report import kernel_isa, publish, revision_labels, revision_sources, table  # noqa: E402 (the experiments' shared helpers)

SECTION = "bench_iaca_kernel"
FULL = dict(map="Berlin_1_256.map", walks=15)
SMOKE = dict(map="arena.map", walks=2)
SOURCES = ["jaco/planners/iaca_lanes.cc", "jaco/planners/iaca_lanes.h", "jaco/engine/walk_lanes.h",
           "jaco/engine/walk_shared.h"]
AVX2 = ["-mavx2", "-mbmi", "-mbmi2", "-mpopcnt"]  # setup.py's flags for the AVX2 lanes


def write_inputs(name: str, out: Path) -> dict:
    """The walk's inputs for the longest query of bundled map ``name``, as the kernel reads them."""
    import jax.numpy as jnp

    import jaco
    from jaco.engine.bitexact import TABLES
    from jaco.engine.checks import default_steplimit
    from jaco.engine.pheromone import Trail
    from jaco.engine.problem import make_problem, to_device
    from jaco.planners.iaca import IACA, detour, iaca_init

    grid = jaco.maps.load(jaco.maps.bundled(name))
    scen = max(jaco.maps.load_scenarios(jaco.maps.bundled(name + ".scen")), key=lambda s: s.optimal)
    problem = to_device(make_problem(grid, scen.start, scen.goal))
    p = IACA.default_params()
    trail = iaca_init().init(Trail(jnp.zeros(grid.n_cells), 0.0, jnp.inf), problem, p)
    steplimit = default_steplimit(grid, IACA)
    n_ants = 50
    np.array([grid.n_cells, n_ants, steplimit, int(problem.start), int(problem.goal), 1], np.int64).tofile(
        out / "sizes.bin")
    np.asarray(trail.tau, np.float32).tofile(out / "tau.bin")
    np.asarray(detour(problem), np.float32).tofile(out / "rows.bin")
    scalars = [p.q0, p.alpha, p.beta, float(trail.lo), float(trail.hi), p.rho_local, p.q]
    np.array(scalars, np.float32).tofile(out / "scalars.bin")
    np.asarray(problem.offsets, np.int32).tofile(out / "offsets.bin")
    np.asarray(TABLES, np.int32).tofile(out / "tables.bin")
    return dict(map=name, start=scen.start, goal=scen.goal, cells=grid.n_cells, ants=n_ants, steplimit=steplimit)


def build(revs: list[str], tmp: Path) -> tuple[Path, str]:
    """The driver with one variant per revision (v0, v1, ...); the instruction set it uses."""
    cxx = os.environ.get("CXX", "c++")
    isa = kernel_isa()
    flags = ["-std=c++17", "-O3", "-ffp-contract=off"] + (AVX2 + ["-DJACO_HAVE_AVX2"] if isa == "avx2" else [])
    objects = []
    for i, rev in enumerate(revs):
        src = revision_sources(rev, SOURCES, tmp / f"v{i}")
        # The kernel's entry points are declared only for jaco's own sets: declare this one's.
        (src / "declare.h").write_text(f'#include "iaca_lanes.h"\nextern const BacktrackKernel backtrack_v{i};\n')
        obj = tmp / f"v{i}.o"
        subprocess.run([cxx, *flags, f"-DJACO_ISA=v{i}", "-include", str(src / "declare.h"), f"-I{src}", "-c",
                        str(src / "iaca_lanes.cc"), "-o", str(obj)], check=True)
        objects.append(str(obj))
    driver = tmp / "driver"
    variants = " ".join(f"X(v{i})" for i in range(len(revs)))
    subprocess.run([cxx, "-std=c++17", "-O2", f"-DVARIANTS={variants}", f"-I{tmp / 'v0'}",
                    str(HERE / "iaca_kernel_driver.cc"), *objects, "-o", str(driver)], check=True)
    return driver, isa


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--revs", nargs="+", default=["HEAD", "."], help="git revisions, '.' for the working tree")
    ap.add_argument("--smoke", action="store_true", help="a small map, two walks each")
    ap.add_argument("--out", default=None, help="markdown file to update (default BENCHMARKS.md; nothing with --smoke)")
    args = ap.parse_args(argv)
    cfg = SMOKE if args.smoke else FULL
    labels = revision_labels(args.revs)
    tmp = Path(tempfile.mkdtemp(prefix="jaco-iaca-kernel-"))
    try:
        query = write_inputs(cfg["map"], tmp)
        driver, isa = build(args.revs, tmp)
        proc = subprocess.run([str(driver), str(tmp), str(cfg["walks"])], capture_output=True, text=True, check=True)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    results = [line.split()[1:] for line in proc.stdout.splitlines() if line.startswith("RESULT ")]
    if len({r[4] for r in results}) != 1:
        raise SystemExit("the revisions' walks differ (pheromone, stacks or steps): not the same kernel results\n"
                         + proc.stdout)
    rows = []
    for label, (_, median, best, steps, _) in zip(labels, results):
        median, best, steps = float(median), float(best), int(steps)
        rows.append([label if label != "." else "working tree", median * 1e3, best * 1e3, steps, median / steps * 1e9])
    base = float(results[0][1])
    for row, r in zip(rows, results):
        row.append(base / float(r[1]))
    header = ["revision", "walk ms (median)", "walk ms (best)", "forward and back steps", "ns a step (median)",
              f"× {rows[0][0]}"]
    command = "python experiments/bench_iaca_kernel.py --revs " + " ".join(args.revs) + (" --smoke" if args.smoke else "")
    text = "\n".join([
        "## IACA's backtracking walk alone (`experiments/bench_iaca_kernel.py`)",
        "",
        f"Command: `{command}`. One colony's walk, {query['ants']} ants with IACA's defaults, on the longest query "
        f"of `{query['map']}` ({query['cells']:,} cells, {query['start']} → {query['goal']}, step limit "
        f"{query['steplimit']:,}), from the initial pheromone; each revision's kernel ({isa} lanes) in one program, "
        f"walk after walk, {cfg['walks']} walks each (one key each, the same for every revision). Every revision "
        "left the same pheromone, stacks and steps.",
        "",
        table(header, rows),
    ])
    publish(text, SECTION, args.out, args.smoke)
    return 0


if __name__ == "__main__":
    sys.exit(main())
