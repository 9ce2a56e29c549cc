#!/usr/bin/env python
"""The dying-ant lane walk alone, revisions side by side in one program: what a kernel change did.

    python experiments/bench_walk_kernel.py --revs 98f3010 HEAD     # updates BENCHMARKS.md
    python experiments/bench_walk_kernel.py --revs HEAD . --smoke --out DIR/x.md
    python experiments/bench_walk_kernel.py --revs HEAD . --side 128 --group 1 --out DIR/x.md  # one solve's colony on a large map

The machines here switch between a fast and a slow state from one minute to the next (the same
sweep 1.5x apart), so two runs minutes apart cannot show a 5 % change in the walk. This script
compiles ``jaco/engine/walk_lanes.cc`` of each revision (``.`` is the working tree) with the
instruction set jaco's kernel runs here, links them into one program (``walk_kernel_driver.cc``)
and walks the benchmark's colonies with each revision in turn, round after round, each round
starting with the next revision. It reports each revision's CPU time and the median of its
per-round ratio to the first revision's; the program checks that every revision takes the same
steps.

The workload is the throughput benchmark's sweep in mid-run: ant-cycle AS on the 30×30 map with
25 % obstacles, 64 colonies of 50 ants (β ∈ {1, 2, 4, 8} cycled), step limit 240, on the pheromone
of a 60-iteration solve with that β (the walks of a converging colony, about 80 steps an ant). Code
placement alone moves the ratio by a few per cent (the same source twice: 0.97–0.99): swap the
revisions' order to see it. It needs a C++ compiler (``$CXX``, else ``c++``).
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

SECTION = "bench_walk_kernel"
FULL = dict(side=30, colonies=64, n_ants=50, train_iters=60, rounds=300)
SMOKE = dict(side=12, colonies=4, n_ants=10, train_iters=3, rounds=3)
SOURCES = ["jaco/engine/walk_lanes.cc", "jaco/engine/walk_lanes.h", "jaco/engine/walk_shared.h"]
# setup.py's flags for each set's lanes (JACO_LANES: the ants a vector holds)
ISA_FLAGS = {"avx512": ["-mavx512f", "-mavx512bw", "-mavx512vl", "-mavx512dq", "-mavx2", "-mfma", "-mbmi", "-mbmi2",
                        "-mpopcnt", "-mprefer-vector-width=512", "-DJACO_LANES=16"],
             "avx2": ["-mavx2", "-mfma", "-mbmi", "-mbmi2", "-mpopcnt", "-DJACO_LANES=8"],
             "baseline": ["-DJACO_LANES=4"]}


def write_inputs(cfg: dict, out: Path) -> dict:
    """The colonies' move weights, keys and map, as the driver reads them."""
    import jax
    import jax.numpy as jnp

    import jaco
    import jaco.engine.checks as jc
    from jaco.engine.colony import move_weights
    from jaco.engine.pheromone import Trail
    from jaco.engine.problem import make_problem, to_device
    from jaco.engine.walk import key_words

    side, B = cfg["side"], cfg["colonies"]
    grid = jaco.maps.random_map(side, 0.25, seed=0)
    start, goal = (0, 0), (side - 1, side - 1)
    problem = to_device(make_problem(grid, start, goal))
    steplimit = jc.default_steplimit(grid)
    variant = jaco.PLANNERS["as"]
    betas = [1.0, 2.0, 4.0, 8.0]
    taus = [jaco.solve(grid, start, goal, planner="as", seed=i, n_ants=cfg["n_ants"], n_iters=cfg["train_iters"],
                       beta=b, keep_pheromone=True, progress=False).pheromone for i, b in enumerate(betas)]
    params = jax.vmap(lambda b: variant.default_params().replace(beta=b))(jnp.asarray(np.resize(betas, B), jnp.float32))
    empty = Trail(jnp.zeros(8 * grid.n_cells), jnp.float32(0), jnp.float32(jnp.inf))
    trail = jax.vmap(lambda p: variant.rule.init(empty, problem, p))(params)
    trail = trail._replace(tau=jnp.asarray(np.stack([taus[i % 4] for i in range(B)]), jnp.float32))
    weights = jax.jit(jax.vmap(lambda tr, p: move_weights(variant, tr, problem, p, 0, 100)))(trail, params)
    words = jax.vmap(key_words)(jax.random.split(jax.random.key(0), B))
    np.array([B, grid.n_cells, cfg["n_ants"], steplimit, int(problem.start), int(problem.goal)], np.int64).tofile(
        out / "sizes.bin")
    np.asarray(problem.offsets, np.int32).tofile(out / "offsets.bin")
    np.asarray(words, np.uint32).tofile(out / "words.bin")
    np.asarray(weights, np.float32).tofile(out / "weights.bin")
    return dict(side=side, colonies=B, ants=cfg["n_ants"], steplimit=steplimit)


def build(revs: list[str], tmp: Path) -> tuple[Path, str]:
    """The driver with one variant per revision (v0, v1, ...); the instruction set it uses."""
    cxx = os.environ.get("CXX", "c++")
    isa = kernel_isa(tuple(ISA_FLAGS))
    flags = ["-std=c++17", "-O3", "-ffp-contract=off", *ISA_FLAGS[isa]]
    objects = []
    for i, rev in enumerate(revs):
        src = revision_sources(rev, SOURCES, tmp / f"v{i}")
        for name, extra in (("walk_lanes.cc", []), (str(HERE / "walk_kernel_driver.cc"), ["-DJACO_ADAPTER"])):
            obj = tmp / f"v{i}-{Path(name).stem}.o"
            subprocess.run([cxx, *flags, *extra, f"-DJACO_ISA=v{i}", f"-I{src}", "-c", str(src / name), "-o", str(obj)],
                           check=True)
            objects.append(str(obj))
    driver = tmp / "driver"
    variants = " ".join(f"X(v{i})" for i in range(len(revs)))
    subprocess.run([cxx, "-std=c++17", "-O2", f"-DVARIANTS={variants}", str(HERE / "walk_kernel_driver.cc"), *objects,
                    "-o", str(driver)], check=True)
    return driver, isa


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--revs", nargs="+", default=["HEAD", "."], help="git revisions, '.' for the working tree")
    ap.add_argument("--smoke", action="store_true", help="a small map, three rounds")
    ap.add_argument("--rounds", type=int, default=None, help="rounds (default 300; 3 with --smoke)")
    ap.add_argument("--group", type=int, default=8,
                    help="colonies a group, for revisions whose walk takes groups (walk.cc's size for this sweep)")
    ap.add_argument("--side", type=int, default=None,
                    help="the random map's side (default 30, the benchmark's; larger maps have longer step limits)")
    ap.add_argument("--out", default=None, help="markdown file to update (default BENCHMARKS.md; nothing with --smoke)")
    args = ap.parse_args(argv)
    cfg = dict(SMOKE if args.smoke else FULL)
    if args.side is not None:
        if args.side < 2:
            raise SystemExit(f"--side must be at least 2, got {args.side}")
        cfg["side"] = args.side
    rounds = args.rounds or cfg["rounds"]
    labels = revision_labels(args.revs)
    tmp = Path(tempfile.mkdtemp(prefix="jaco-walk-kernel-"))
    try:
        work = write_inputs(cfg, tmp)
        driver, isa = build(args.revs, tmp)
        pin = ["taskset", "-c", "0"] if shutil.which("taskset") else []  # one core: the CPU time is the walk's
        proc = subprocess.run([*pin, str(driver), str(tmp), str(rounds), str(args.group)], capture_output=True, text=True)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    if proc.returncode != 0:
        raise SystemExit("the revisions' walks differ, or the driver failed:\n" + proc.stdout + proc.stderr)
    results = [line.split()[1:] for line in proc.stdout.splitlines() if line.startswith("RESULT ")]
    rows = []
    for label, (_, median, best, steps, ratio, q25, q75) in zip(labels, results):
        steps = int(steps)
        rows.append([label if label != "." else "working tree", float(median) * 1e3, float(best) * 1e3,
                     float(median) / steps * 1e9, float(best) / steps * 1e9, f"{float(ratio):.3f} ({float(q25):.3f}–{float(q75):.3f})"])
    steps = int(results[0][3])
    header = ["revision", "walk ms CPU (median)", "walk ms CPU (best)", "ns a step (median)", "ns a step (best)",
              f"per-round time ÷ {rows[0][0]}'s: median (quartiles)"]
    options = [f"--{k} {v}" for k, v in (("side", args.side), ("group", args.group if args.group != 8 else None),
                                         ("rounds", args.rounds)) if v is not None]
    command = " ".join(["python experiments/bench_walk_kernel.py --revs", *args.revs, *options] +
                       (["--smoke"] if args.smoke else []))
    text = "\n".join([
        "## The dying-ant lane walk alone (`experiments/bench_walk_kernel.py`)",
        "",
        f"Command: `{command}`. The walks of {work['colonies']} AS colonies, {work['ants']} ants each, on the "
        f"{work['side']}×{work['side']} {'benchmark' if work['side'] == FULL['side'] else 'random'} map, 25 % obstacles "
        f"(step limit {work['steplimit']}), from the pheromone of a "
        f"{cfg['train_iters']}-iteration solve: {steps:,} steps a round. Each revision's walk ({isa} lanes) in one "
        f"program on one pinned core, {rounds} rounds, each round starting with the next revision. Every revision "
        "took the same steps.",
        "",
        table(header, rows),
    ])
    publish(text, SECTION, args.out, args.smoke)
    return 0


if __name__ == "__main__":
    sys.exit(main())
