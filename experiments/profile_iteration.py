#!/usr/bin/env python
"""Where one colony iteration spends its time, part by part, with the native walk and with the JAX
walk, against the native numba loop.

    python experiments/profile_iteration.py            # full size, updates BENCHMARKS.md (its section)
    python experiments/profile_iteration.py --smoke    # tiny sizes, writes nothing unless --out

Workload: one iteration of the throughput benchmark's sweep (``bench_throughput.py``): ant-cycle AS,
``B`` configurations (β ∈ {1, 2, 4, 8} cycled, first-iteration pheromone) × 50 ants on the 30×30,
25 % map, step limit 240, all configurations vmapped as ``jaco.sweep`` runs them. Each part is
jitted and timed alone (process CPU time and wall time, best of ``reps``), once per walk:

* weights: τ^α η^β for every move (:func:`jaco.engine.colony.move_weights`: the native kernel with
  the native walk, XLA with the JAX walk; jitted alone, β·log η is computed every call);
* walk: the ants' walks alone — the C++ kernel (:func:`jaco.engine.native.walk`) or the JAX walk
  (:func:`jaco.engine.walk.jax_walk`), the same moves; called alone, the kernel's step buffer is a
  new one filled with "no step" every call (in a run it writes over the last iteration's);
* tours: step lengths, path lengths and the pheromone element of every step (the walk gives the
  latter as its edges: what remains is the lengths);
* pheromone update: evaporation and the ant-cycle deposit (the kernel's deposit with the native
  walk, XLA's scatter-add with the JAX walk);
* whole iteration: the mean over a 20-iteration run, everything in one compiled program.

The native loop (``native_reference.py``) gives the per-iteration bar. The script exits 1 when the
two walks' moves differ. Nothing here asserts a time.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

SECTION = "profile_iteration"
FULL = dict(configs=64, n_ants=50, reps=15, run_iters=20, native_iters=20)
SMOKE = dict(configs=4, n_ants=8, reps=1, run_iters=2, native_iters=2)
WALKS = ("native", "jax")


def timed_ms(fn, *args, reps):
    """Best process CPU time (ms) and best wall time (ms) of ``reps`` calls after one warm-up call."""
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
    import jaco.engine.checks as jc
    import jaco.engine.run as jr
    from jaco.engine import native
    from jaco.engine.colony import move_weights, step_targets
    from jaco.engine.pheromone import Trail, Walks
    from jaco.engine.problem import make_problem, to_device
    from jaco.engine.walk import _tours, jax_walk, key_words

    B, A, reps = cfg["configs"], cfg["n_ants"], cfg["reps"]
    grid = jaco.maps.random_map(30, 0.25, seed=0)
    start, goal = (0, 0), (29, 29)
    prob = to_device(make_problem(grid, start, goal))
    steplimit = jc.default_steplimit(grid)
    var = jaco.PLANNERS["as"]
    betas = jnp.asarray(np.resize([1.0, 2.0, 4.0, 8.0], B), jnp.float32)
    P = jax.vmap(lambda b: var.default_params().replace(beta=b))(betas)
    empty = Trail(jnp.zeros(8 * prob.nbr.shape[0]), jnp.float32(0), jnp.float32(jnp.inf))
    trail = jax.vmap(lambda p: var.rule.init(empty, prob, p))(P)
    keys = jax.random.split(jax.random.key(0), B)
    words = jax.vmap(key_words)(keys)
    n = prob.nbr.shape[0]

    walk_fns = {"native": native.walk, "jax": jax_walk}
    parts, moves, real = {}, {}, None
    for walk in WALKS:
        if walk == "native" and not native.available():
            continue
        jaco.set_walk(walk)
        try:
            weights = jax.jit(jax.vmap(lambda tr, p: move_weights(var, tr, prob, p, 0, 100)))
            W = weights(trail, P)
            walk_only = jax.jit(jax.vmap(lambda w, k, walk=walk: walk_fns[walk](
                w, k, prob.start, prob.goal, jnp.float32(0), prob.offsets, n_ants=A, steplimit=steplimit, exploit=False)))
            out = walk_only(W, words)
            moves[walk] = np.asarray(out[0])
            real = int(np.sum(np.asarray(out[2])))

            def tours_of(walks):
                t = _tours(*walks)
                return t, step_targets("moves", t.cells, t.moves, prob.start, n, t.edges)

            tours = jax.jit(jax.vmap(tours_of))
            t, targets = tours(out)
            cost = jnp.where(t.arrived, t.length, jnp.inf)

            def update(tr, targets, step_len, cost, p):
                walks = Walks(targets, step_len, cost, targets[:, 0], step_len[:, 0], cost[0])
                return var.rule.update(tr, walks, prob, p)

            update = jax.jit(jax.vmap(update))
            iters = cfg["run_iters"]
            run = jax.jit(jax.vmap(jr.make_run(var, n_ants=A, n_iters=iters, steplimit=steplimit), in_axes=(0, None, 0)))
            c, w = timed_ms(run, keys, prob, P, reps=max(1, reps // 3))
            walk_rows = {"walk": timed_ms(walk_only, W, words, reps=reps)}
            if walk == "native" and native.isa() != "baseline":  # the portable lanes beside the widest
                widest = native.isa()
                native.set_isa("baseline")
                try:
                    walk_rows["walk, baseline lanes (SSE2: 4 ants at once)"] = timed_ms(walk_only, W, words, reps=reps)
                    same_isa = np.array_equal(np.asarray(walk_only(W, words)[0]), moves[walk])
                finally:
                    native.set_isa(None)
                walk_rows = {f"walk ({widest} lanes)": walk_rows["walk"], **{k: v for k, v in walk_rows.items() if k != "walk"}}
                if not same_isa:
                    raise SystemExit("the baseline lanes took other moves than the widest")
            parts[walk] = {
                "weights (τ^α η^β of every move)": timed_ms(weights, trail, P, reps=reps),
                **walk_rows,
                "tours (lengths, pheromone elements of every step)": timed_ms(tours, out, reps=reps),
                "pheromone update (evaporation, deposit)": timed_ms(update, trail, targets, t.step_len, cost, P, reps=reps),
                f"whole iteration (mean over a {iters}-iteration run)": (c / iters, w / iters),
            }
        finally:
            jaco.set_walk(None)

    native_bar = None
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
        native_bar = dict(ms_per_iteration=1e3 * (time.process_time() - c0) / n_it, steps_per_iteration=steps / n_it)
    except ImportError:
        pass
    same = len(moves) < 2 or bool(np.array_equal(moves["native"], moves["jax"]))
    ghz = None
    try:
        ghz = next(float(line.split(":")[1]) / 1e3 for line in open("/proc/cpuinfo") if line.startswith("cpu MHz"))
    except (OSError, StopIteration, ValueError):
        pass
    return dict(cfg=cfg, B=B, A=A, steplimit=steplimit, parts=parts, real=real, same=same, native=native_bar,
                jax=jax.__version__, built=native.available(), ghz=ghz,
                isas=native.isas() if native.available() else {})


def report(R, command) -> str:
    from report import fmt, table

    walks = [w for w in WALKS if w in R["parts"]]
    names = list(dict.fromkeys(n for w in walks for n in R["parts"][w]))
    ghz = R.get("ghz") or float("nan")
    header = (["part"] + [f"{w} walk: {kind} ms" for w in walks for kind in ("CPU", "wall")]
              + [f"{w} walk: CPU ns per real step" for w in walks] + ["native walk: cycles per real step"])

    def cell(w, name, i):
        return R["parts"][w][name][i] if name in R["parts"][w] else "–"

    def per_step(w, name, scale=1e6):
        return scale * R["parts"][w][name][0] / max(R["real"], 1) if name in R["parts"][w] else "–"

    rows = [[name] + [cell(w, name, i) for w in walks for i in (0, 1)] + [per_step(w, name) for w in walks]
            + [per_step("native", name, 1e6 * ghz) if "native" in walks else "–"] for name in names]
    lines = [
        "## One iteration, part by part (`experiments/profile_iteration.py`)",
        "",
        f"Command: `{command}` (jax {R['jax']}). Process CPU time and wall time, best of the repetitions, "
        f"each part jitted alone; one iteration of the throughput sweep: {R['B']} configurations × {R['A']} ants, "
        f"vmapped, 30x30 map with 25 % obstacles, step limit {R['steplimit']}, first-iteration pheromone. "
        "CPU time above wall time means both cores worked.",
        "",
        table(header, rows),
        "",
        f"The walks take {fmt(R['real'])} real ant-steps. Cycles at the {ghz:.2f} GHz the kernel reports; native "
        "lane kernels: " + ", ".join(f"{k} ({v})" for k, v in R.get("isas", {}).items())
        + ". The two walks' moves are identical: " + ("yes" if R["same"] else "**NO**") + ".",
    ]
    if not R["built"]:
        lines += ["", "The native walk was not built on this machine: only the JAX walk is shown."]
    if R["native"]:
        nb = R["native"]
        lines += [
            "",
            f"Native loop (numba, one core), same workload: {nb['ms_per_iteration']:.2f} ms CPU per iteration for "
            f"all {R['B']} configurations ({fmt(nb['steps_per_iteration'])} real steps, "
            f"{1e6 * nb['ms_per_iteration'] / max(nb['steps_per_iteration'], 1):.0f} ns per step including τ^α η^β).",
        ]
    if "native" in walks:  # where each ns of the native iteration goes
        nat = R["parts"]["native"]
        whole = next(v for k, v in nat.items() if k.startswith("whole"))[0]
        walk_ms = next(v for k, v in nat.items() if k.startswith("walk"))[0]
        named = sum(v[0] for k, v in nat.items() if not k.startswith(("whole", "walk, baseline")))
        ns = 1e6 / max(R["real"], 1)
        if whole >= named:
            rest = (
                f"and {(whole - named) * ns:.0f} ({(whole - named) / whole:.0%}) the rest of the compiled iteration "
                "(best-so-far, history, keys, XLA's runtime between its kernels), measured as the whole iteration "
                "minus its parts"
            )
        else:  # the parts alone cost more than the iteration: there XLA fuses the tours into what reads them
            rest = (
                f"together {(named - whole) * ns:.0f} ns more than the whole iteration: jitted alone, the walk and the tours "
                "compute every step slot's cell and length, while in the compiled iteration XLA fuses them into "
                "what reads them (a sweep without paths reads the lengths only)"
            )
        lines += [
            "",
            f"Where the native iteration's {whole * ns:.0f} ns CPU per real step go: the walk {walk_ms * ns:.0f} "
            f"({walk_ms / whole:.0%}), the weights, tours and update {(named - walk_ms) * ns:.0f} "
            f"({(named - walk_ms) / whole:.0%}), {rest}. The walk's limit on this CPU: an ant-step is about 16 "
            "loads and 40 lane operations (the roulette over 8 moves), a few cycles per ant-step at 8 or 16 "
            "lanes; each lane's own stores, tabu bits and uniforms, and the steps of the lanes left walking "
            "alone at a colony's end, make up most of the rest; docs/native.md says where a step's time goes, "
            "what the lanes do and what did not pay.",
        ]
    lines += [
        "",
        "Reading: the native walk advances the ants of a colony in SIMD lanes (docs/native.md) and splits "
        "the configurations over both cores. The JAX walk runs every ant on its own lane in lock-step until "
        "the batch's last ant stops, and XLA:CPU runs each operation of a step as its own kernel: "
        "microseconds per loop step and tens of ns per lane-step, most lanes idle. With the native walk, the "
        "weights and the deposit are kernels too: the weights with XLA's own log and exp, 8 cells at a time "
        "in AVX2 lanes (8 pairs of cells in AVX-512's 16), over every move of every cell an ant can enter "
        "(the weights row also computes the "
        "factor β·log η, which a run computes once); the deposit adds the steps walked, not every step slot. "
        "The tours are elementwise XLA code over every step slot.",
    ]
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--smoke", action="store_true", help="tiny sizes")
    ap.add_argument("--out", default=None, help="markdown file to update (default BENCHMARKS.md; nothing with --smoke)")
    args = ap.parse_args(argv)
    from report import publish

    R = measure(SMOKE if args.smoke else FULL)
    command = "python experiments/profile_iteration.py" + (" --smoke" if args.smoke else "")
    text = report(R, command)
    publish(text, SECTION, args.out, args.smoke)
    return 0 if R["same"] else 1


if __name__ == "__main__":
    sys.exit(main())
