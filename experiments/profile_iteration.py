#!/usr/bin/env python
"""Where one colony iteration spends its time, against the native loop: why jaco's sweep runs at a
fraction of a hand-written numba loop on XLA:CPU, and what a work-queue walk would change.

    python experiments/profile_iteration.py            # full size, updates BENCHMARKS.md (its section)
    python experiments/profile_iteration.py --smoke    # tiny sizes, writes nothing unless --out

Workload: one iteration of the throughput benchmark's sweep (``bench_throughput.py``): ant-cycle AS,
``B`` configurations (β ∈ {1, 2, 4, 8} cycled, first-iteration pheromone) × 50 ants on the 30×30,
25 % map, step limit 240, all configurations vmapped as ``jaco.sweep`` runs them. Each part of
the iteration is jitted and timed alone (process CPU time, best of ``reps``):

* uniforms: the iteration's ``(S_pad, ants)`` uniforms per configuration (threefry);
* weights: τ^α η^β for every move, once per iteration;
* walk: :func:`jaco.engine.walk.walk`, every ant in lock-step, chunks of 8 steps in a while-loop;
* construct: the whole construction step (uniforms + weights + walk + cells, lengths, targets);
* update: the pheromone rule (evaporation + ant-cycle deposit).

It also measures the two costs that bound a lock-step walk (every ant on its own lane until the
batch's last ant stops): the fixed cost of one loop step (the walk with a single ant) and the cost
per lane-step, and the share of lane-steps that are real ant steps (lane utilisation). jaco's
engine walks a batch of more than ``jaco.engine.walk.POOL`` ants on a pool of that many lanes, each
lane taking the next ant of any configuration when its ant stops; the last table times that walk
for several pool sizes (same moves as the lock-step walk, checked bit for bit). The native loop
(``native_reference.py``) gives the per-iteration bar. Nothing here asserts a time.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

SECTION = "profile_iteration"
FULL = dict(configs=64, n_ants=50, reps=7, lanes=[128, 256, 512, 1024], native_iters=20)
SMOKE = dict(configs=4, n_ants=8, reps=1, lanes=[8, 16], native_iters=2)


def cpu_ms(fn, *args, reps):
    """Best process CPU time (ms) and wall time (ms) of ``reps`` calls after one warm-up call."""
    import jax

    jax.block_until_ready(fn(*args))
    cpu, wall = [], []
    for _ in range(reps):
        c0, t0 = time.process_time(), time.perf_counter()
        jax.block_until_ready(fn(*args))
        cpu.append(time.process_time() - c0)
        wall.append(time.perf_counter() - t0)
    return 1e3 * min(cpu), 1e3 * min(wall)


def measure(cfg) -> dict:
    import jax
    import jax.numpy as jnp
    import numpy as np

    import jaco
    from jaco.engine.colony import move_weights, single_colony
    from jaco.engine.pheromone import Trail, Walks
    from jaco.engine.problem import make_problem, to_device
    from jaco.engine.walk import CHUNK, pad_steps, walk

    B, A, reps = cfg["configs"], cfg["n_ants"], cfg["reps"]
    grid = jaco.maps.random_map(30, 0.25, seed=0)
    start, goal = (0, 0), (29, 29)
    prob = to_device(make_problem(grid, start, goal))
    steplimit = jaco.engine.run.default_steplimit(grid)
    s_pad = pad_steps(steplimit)
    var = jaco.VARIANTS["as"]
    betas = jnp.asarray(np.resize([1.0, 2.0, 4.0, 8.0], B), jnp.float32)
    P = jax.vmap(lambda b: var.default_params().replace(beta=b))(betas)
    empty = Trail(jnp.zeros(8 * prob.nbr.shape[0]), jnp.float32(0), jnp.float32(jnp.inf))
    trail = jax.vmap(lambda p: var.rule.init(empty, prob, p))(P)
    keys = jax.random.split(jax.random.key(0), B)

    uniforms = jax.jit(jax.vmap(lambda k: jax.random.uniform(k, (s_pad, A))))
    weights = jax.jit(jax.vmap(lambda tr, p: move_weights(var, tr, prob, p, 0, 100)))
    W, U = weights(trail, P), uniforms(keys)
    from jaco.engine.walk import _lockstep_walk

    lockstep = jax.jit(jax.vmap(lambda w, u: _lockstep_walk(w, u, prob.start, prob.goal, 0.0, offsets=prob.offsets,
                                                             steplimit=steplimit, exploit=False)))

    def pooled():  # jaco's walk under vmap, traced anew so that it reads the current POOL
        return jax.jit(jax.vmap(lambda w, u: walk(prob, w, u, 0.0, steplimit=steplimit, exploit=False)))

    construct = jax.jit(jax.vmap(lambda tr, p, k: single_colony(var, prob, tr, p, 0, 100, k, n_ants=A, steplimit=steplimit)))
    _, col = construct(trail, P, keys)

    def update(tr, c, p):
        walks = Walks(c.targets, c.step_len, c.cost, c.targets[:, 0], c.step_len[:, 0], c.cost[0])
        return var.rule.update(tr, walks, prob, p)

    update = jax.jit(jax.vmap(update))
    parts = {
        "uniforms": cpu_ms(uniforms, keys, reps=reps),
        "weights": cpu_ms(weights, trail, P, reps=reps),
        "walk, lock-step (every ant its own lane)": cpu_ms(lockstep, W, U, reps=reps),
        f"walk, jaco (pool of {jaco.engine.walk.POOL} lanes beyond {jaco.engine.walk.POOL} ants)": cpu_ms(pooled(), W, U, reps=reps),
        "construct (all of the above + cells, lengths)": cpu_ms(construct, trail, P, keys, reps=reps),
        "pheromone update": cpu_ms(update, trail, col, P, reps=reps),
    }
    iters = 10
    run = jax.jit(jax.vmap(jaco.make_run(var, n_ants=A, n_iters=iters, steplimit=steplimit), in_axes=(0, None, 0)))
    c, w = cpu_ms(run, keys, prob, P, reps=max(1, reps // 3))
    parts["whole iteration (mean over a 10-iteration run)"] = (c / iters, w / iters)

    moves, _ = lockstep(W, U)
    n_steps = jnp.sum(moves >= 0, axis=1)
    real = int(jnp.sum(n_steps))
    loop_steps = int(-(-int(jnp.max(n_steps)) // CHUNK) * CHUNK)
    lanes = B * A

    # Fixed cost of a loop step: the same walk with one ant (its own steps, one lane).
    one = jax.jit(lambda w, u: walk(prob, w, u, 0.0, steplimit=steplimit, exploit=False))
    single_steps = int(-(-int(one(W[0], U[0][:, :1]).n_steps[0]) // CHUNK) * CHUNK)
    one_ms, _ = cpu_ms(one, W[0], U[0][:, :1], reps=reps)

    queue = []
    default_pool = jaco.engine.walk.POOL
    try:
        for L in cfg["lanes"]:
            jaco.engine.walk.POOL = L
            f = pooled()
            same = bool(jnp.array_equal(f(W, U).moves, moves))
            cpu, wall = cpu_ms(f, W, U, reps=reps)
            queue.append(dict(lanes=L, cpu_ms=cpu, wall_ms=wall, same=same))
    finally:
        jaco.engine.walk.POOL = default_pool

    native = None
    try:
        import native_reference as nr

        nbr, eta, s_i, g_i = nr.problem_arrays(grid, start, goal)
        n_it = cfg["native_iters"]

        def native_all():
            steps = 0
            for b in range(B):
                steps += nr.as_colony(nbr, eta, s_i, g_i, 1.0, float(betas[b]), 0.3, 1.0, 0.1, A, n_it, steplimit, b)[2]
            return steps

        native_all()  # compile
        c0 = time.process_time()
        steps = native_all()
        native = dict(ms_per_iteration=1e3 * (time.process_time() - c0) / n_it, steps_per_iteration=steps / n_it)
    except ImportError:
        pass
    return dict(cfg=cfg, B=B, A=A, steplimit=steplimit, parts=parts, real=real, loop_steps=loop_steps, lanes=lanes,
                one_ms=one_ms, single_steps=single_steps, queue=queue, native=native, jax=jax.__version__)


def report(R, command) -> str:
    from bench_throughput import fmt, table

    walk_cpu = R["parts"]["walk, lock-step (every ant its own lane)"][0]
    lane_ns = 1e6 * walk_cpu / (R["lanes"] * R["loop_steps"])
    step_us = 1e3 * R["one_ms"] / max(R["single_steps"], 1)
    lines = [
        "## One iteration, part by part (`experiments/profile_iteration.py`)",
        "",
        f"Command: `{command}` (jax {R['jax']}). Process CPU time, best of the repetitions; one iteration of the "
        f"throughput sweep: {R['B']} configurations × {R['A']} ants, vmapped, 30x30 map with 25 % obstacles, "
        f"step limit {R['steplimit']}, first-iteration pheromone.",
        "",
        table(["part", "CPU ms", "wall ms"], [(k, c, w) for k, (c, w) in R["parts"].items()]),
        "",
        f"Lock-step walk: {fmt(R['real'])} real ant-steps in {R['loop_steps']} loop steps × {R['lanes']} lanes: "
        f"lane utilisation {100 * R['real'] / (R['lanes'] * R['loop_steps']):.0f} %, "
        f"{lane_ns:.0f} ns CPU per lane-step, {1e6 * walk_cpu / max(R['real'], 1):.0f} ns per real step. "
        f"Fixed cost of one loop step (the same walk with a single ant): {step_us:.1f} µs.",
    ]
    if R["native"]:
        n = R["native"]
        lines += [
            "",
            f"Native loop (numba, one core), same workload: {n['ms_per_iteration']:.2f} ms CPU per iteration for all "
            f"{R['B']} configurations ({fmt(n['steps_per_iteration'])} real steps, "
            f"{1e6 * n['ms_per_iteration'] / max(n['steps_per_iteration'], 1):.0f} ns per step including τ^α η^β).",
        ]
    lines += [
        "",
        "jaco's pool walk by pool size (`jaco.engine.walk.POOL`; identical moves to the lock-step walk: "
        + ("yes" if all(q["same"] for q in R["queue"]) else "**NO**") + "):",
        "",
        table(["lanes", "CPU ms", "wall ms"], [(q["lanes"], q["cpu_ms"], q["wall_ms"]) for q in R["queue"]]),
        "",
        "Reading: XLA:CPU runs every operation of a loop step as its own kernel, so a step has a fixed cost of "
        "microseconds whatever the number of lanes, and a lane-step (a gather of 8 weights, 8 tabu "
        "lookups, a roulette on 8 numbers, a scatter) costs tens of ns where the numba loop spends ~15–30 ns "
        "on a whole real step. A pool of lanes that take the next ant keeps the lanes busy; fewer lanes "
        "raise the utilisation but multiply the loop steps, whose fixed cost then dominates.",
    ]
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--smoke", action="store_true", help="tiny sizes")
    ap.add_argument("--out", default=None, help="markdown file to update (default BENCHMARKS.md; nothing with --smoke)")
    args = ap.parse_args(argv)
    from bench_throughput import write_section

    R = measure(SMOKE if args.smoke else FULL)
    command = "python experiments/profile_iteration.py" + (" --smoke" if args.smoke else "")
    text = report(R, command)
    print(text)
    out = args.out or (None if args.smoke else str(HERE.parent / "BENCHMARKS.md"))
    if out:
        import bench_throughput

        bench_throughput.SECTION = SECTION
        write_section(Path(out), text)
        print(f"wrote {out}")
    return 0 if all(q["same"] for q in R["queue"]) else 1


if __name__ == "__main__":
    sys.exit(main())
