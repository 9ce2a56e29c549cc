#!/usr/bin/env python
"""Throughput of jaco against a native loop, solve latency, compile time, memory and scaling.

    python experiments/bench_throughput.py              # full run, updates BENCHMARKS.md
    python experiments/bench_throughput.py --smoke      # tiny sizes, writes nothing unless --out

Workload (the project's speed target, DESIGN.md "Speed"): a 64-configuration ant-cycle AS sweep
(alpha x beta x rho, 4 values each, one seed) on a 30x30 random map with 25 % obstacles, start
(0, 0), goal (29, 29), 50 ants, 100 iterations, jaco's default step limit. The same sweep runs
in the same process as a plain numba loop on one core (``experiments/native_reference.py``, the
``bench`` extra), and the script prints jaco's throughput as a multiple of it.

Counting: ant-steps are *real* steps (steps ants actually took), from ``RunOutput.steps`` for
jaco (read from the same cached compiled function ``jaco.sweep`` uses, with the same keys, and
checked to give the same table) and from the loop itself for the native reference. The two
engines draw different random numbers, so their step counts differ a little; steps/s compares
them fairly, configs/s is the user-facing figure.

Devices: ``--devices N`` sets ``XLA_FLAGS=--xla_force_host_platform_device_count=N`` before jax
is imported (N CPU "devices" of XLA's host platform), and the configuration axis is spread over
them in two ways, both measured and both checked bit-for-bit against the 1-device table:

* threads: the configurations are split along one parameter axis into N equal parts, and each
  part runs through ``jaco.sweep`` in its own Python thread under ``jax.default_device(d)``
  (JAX releases the GIL while XLA runs, so the parts run on different cores, independently);
* sharding: ``jaco.sweep(..., devices=N)``, the configuration axis sharded over the N devices
  with ``jax.shard_map`` (one program; each device walks its own slice, no communication).

Timings are the best of ``reps`` repetitions, with the engines interleaved, because the machine
may be shared; the load average is recorded. Nothing here asserts a time.
"""

from __future__ import annotations

import argparse
import datetime as _dt
import itertools
import json
import math
import os
import platform
import re
import resource
import shlex
import statistics
import sys
import threading
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
SECTION = "bench_throughput"

FULL = dict(
    side=30, p=0.25, map_seed=0, n_ants=50, n_iters=100,
    axes={"alpha": [0.5, 1.0, 2.0, 4.0], "beta": [1.0, 2.0, 4.0, 8.0], "rho": [0.1, 0.3, 0.5, 0.7]},
    reps=5, latency_calls=20,
    sides=[16, 32, 64, 128, 256], ants=[10, 50, 200, 800], batches=[1, 8, 64, 256],
    scale_iters=20, scale_reps=3,
)
SMOKE = dict(
    side=12, p=0.25, map_seed=0, n_ants=10, n_iters=5,
    axes={"alpha": [1.0, 2.0], "beta": [2.0, 4.0], "rho": [0.3, 0.5]},
    reps=1, latency_calls=3,
    sides=[8, 12], ants=[5, 10], batches=[1, 4],
    scale_iters=3, scale_reps=1,
)
TARGETS = {"ratio": 1.0, "latency_ms": 20.0, "compile_s": 5.0}


def parse_args(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--smoke", action="store_true", help="tiny sizes (seconds), to check that it runs")
    ap.add_argument("--out", default=None,
                    help="markdown file to write/update (default: BENCHMARKS.md at the repo root; "
                         "with --smoke nothing is written unless --out is given)")
    ap.add_argument("--json", default=None, help="also write every figure as JSON to this file")
    ap.add_argument("--devices", type=int, default=2, help="XLA host devices to spread the configurations over")
    ap.add_argument("--no-scaling", action="store_true", help="skip the scaling tables")
    args = ap.parse_args(argv)
    if args.devices < 1:
        ap.error("--devices must be >= 1")
    if args.out is None and not args.smoke:
        args.out = str(ROOT / "BENCHMARKS.md")
    return args


def set_device_count(n: int):
    """Ask XLA for ``n`` host devices; must happen before jax is imported."""
    if "jax" in sys.modules:
        print("warning: jax was imported before the device count was set; --devices may not apply", file=sys.stderr)
    flags = re.sub(r"--xla_force_host_platform_device_count=\d+", "", os.environ.get("XLA_FLAGS", ""))
    os.environ["XLA_FLAGS"] = f"{flags} --xla_force_host_platform_device_count={n}".strip()
    os.environ.setdefault("JAX_PLATFORMS", "cpu")


# ------------------------------------------------------------------------------------------------
# small helpers
# ------------------------------------------------------------------------------------------------
def timed(fn):
    """``(wall s, process CPU s, result)`` of ``fn()``; the result is blocked on when it is a jax value."""
    import jax

    c0, t0 = time.process_time(), time.perf_counter()
    out = jax.block_until_ready(fn())
    return time.perf_counter() - t0, time.process_time() - c0, out


def best_of(fn, reps):
    """Best wall time (and its CPU time) of ``reps`` calls, plus the last result."""
    runs = [timed(fn) for _ in range(reps)]
    wall, cpu, _ = min(runs, key=lambda r: r[0])
    return wall, cpu, runs[-1][2]


def peak_rss_mib() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0  # Linux: KiB


def machine() -> dict:
    import jax
    import jaxlib
    import numba

    model = platform.processor() or "?"
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    import subprocess

    def git(*a):
        try:
            return subprocess.run(["git", *a], cwd=ROOT, capture_output=True, text=True, timeout=10).stdout.strip()
        except (OSError, subprocess.SubprocessError):
            return ""

    commit = git("rev-parse", "--short", "HEAD") or "?"
    dirty = bool(git("status", "--porcelain", "--", "jaco"))
    return {
        "commit": commit + (" + uncommitted changes in jaco/" if dirty else ""),
        "nproc": os.cpu_count(),
        "affinity": len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else None,
        "cpu": model,
        "python": platform.python_version(),
        "jax": jax.__version__,
        "jaxlib": jaxlib.__version__,
        "numba": numba.__version__,
        "xla_devices": len(jax.devices()),
        "platform": platform.platform(),
    }


def fmt(x, digits=3):
    if isinstance(x, str):
        return x
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "–"
    if isinstance(x, int):
        return f"{x:,}"
    ax = abs(x)
    if ax >= 1e6:
        return f"{x:.3g}" if ax < 1e9 else f"{x:.3e}"
    if ax >= 100:
        return f"{x:,.0f}"
    return f"{x:.{digits}g}"


def table(header, rows) -> str:
    out = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    out += ["| " + " | ".join(fmt(v) for v in r) + " |" for r in rows]
    return "\n".join(out)


def split_axes(axes: dict, n: int):
    """Split the product of ``axes`` into ``n`` equal products along the first axis whose length
    ``n`` divides (configuration order is kept: the parts concatenate to the full product)."""
    for name, values in axes.items():
        if len(values) % n == 0:
            k = len(values) // n
            return [{**axes, name: values[i * k : (i + 1) * k]} for i in range(n)]
    raise SystemExit(f"--devices {n} divides none of the axis lengths {[len(v) for v in axes.values()]}")


# ------------------------------------------------------------------------------------------------
# the benchmark
# ------------------------------------------------------------------------------------------------
def run_benchmark(args) -> dict:
    cfg = SMOKE if args.smoke else FULL
    import jax
    import jax.numpy as jnp
    import numpy as np

    import jaco
    import jaco.engine.run as jr
    from jaco.engine.problem import stack

    sys.path.insert(0, str(HERE))
    import native_reference as nr

    if "steps" not in jr.RunOutput._fields:
        raise SystemExit("this benchmark needs jaco.engine.run.RunOutput.steps (real ant-steps of a run)")

    t_start = time.perf_counter()
    R: dict = {"config": {k: v for k, v in cfg.items()}, "machine": machine(), "load_start": os.getloadavg()}
    variant = jaco.VARIANTS["as"]
    devices = jax.devices()
    n_dev = min(args.devices, len(devices))

    side, n_ants, n_iters = cfg["side"], cfg["n_ants"], cfg["n_iters"]
    grid = jaco.maps.random_map(side, cfg["p"], seed=cfg["map_seed"])
    start, goal = (0, 0), (side - 1, side - 1)
    steplimit = jr.default_steplimit(grid)
    axes = cfg["axes"]
    names = list(axes)
    combos = np.array(list(itertools.product(*(axes[k] for k in names))), np.float64)
    n_cfg = len(combos)
    base = jr.resolve_params(variant, {}, where="as")
    q, tau0 = float(base["q"]), float(base["tau0"])
    R["workload"] = dict(map=grid.name, side=side, n_free=int(grid.n_free), n_configs=n_cfg, n_ants=n_ants,
                         n_iters=n_iters, steplimit=steplimit, axes=axes, q=q, tau0=tau0)

    # -- native reference -----------------------------------------------------------------------
    nbr, eta, s_idx, g_idx = nr.problem_arrays(grid, start, goal)
    native_cols = np.stack([combos[:, names.index(k)] for k in ("alpha", "beta", "rho")], axis=1)

    def native():
        return nr.sweep_native(native_cols, nbr, eta, s_idx, g_idx, q=q, tau0=tau0, n_ants=n_ants,
                               n_iters=n_iters, steplimit=steplimit, seed=0)

    t0 = time.perf_counter()
    nr.sweep_native(native_cols[:1], nbr, eta, s_idx, g_idx, n_ants=1, n_iters=1, steplimit=steplimit)
    nr.as_colony(nbr, eta, s_idx, g_idx, 1.0, 1.0, 0.5, 1.0, 0.1, 1, 1, steplimit, 0)
    R["native_compile_s"] = time.perf_counter() - t0

    # -- jaco: one device, through jaco.sweep ---------------------------------------------------
    def sweep(ax, devices=1):
        # devices=1: one XLA device; the threads below pass None, i.e. the thread's default device
        return jaco.sweep(grid, start, goal, "as", ax, seeds=1, n_ants=n_ants, n_iters=n_iters, steplimit=steplimit,
                          devices=devices)

    first = timed(lambda: sweep(axes))
    ref_table = first[2]

    # the same batch through the same cached compiled function, for the real step count
    run_b = jr.compiled_run(variant, n_ants, n_iters, steplimit, False, batched=True)
    tab = {k: np.full(n_cfg, v) for k, v in base.items()}
    for i, k in enumerate(names):
        tab[k] = combos[:, i]
    keys = jax.vmap(jax.random.key)(np.zeros(n_cfg, np.uint32))
    prm = jr.params_from(tab, (n_cfg,))
    problems = stack([jaco.make_problem(grid, start, goal)])
    out = jax.device_get(run_b(keys, problems, prm))
    if not np.array_equal(np.asarray(out.best_cost)[0], ref_table["cost"].to_numpy(np.float32)):
        raise SystemExit("the batched compiled run does not reproduce jaco.sweep's table")
    jaco_steps = int(np.sum(np.asarray(out.steps, np.int64)))

    # -- jaco: N devices ------------------------------------------------------------------------
    parts = split_axes(axes, n_dev) if n_dev > 1 else None
    results = [None] * n_dev

    def threads():
        def work(i):
            with jax.default_device(devices[i]):
                results[i] = sweep(parts[i], devices=None)

        ts = [threading.Thread(target=work, args=(i,)) for i in range(n_dev)]
        for t in ts:
            t.start()
        for t in ts:
            t.join()
        import pandas as pd

        return pd.concat(results, ignore_index=True)

    if n_dev > 1:
        def sharded():  # jaco.sweep's own sharding: shard_map, each device walks its slice
            return sweep(axes, devices=n_dev)

        first_threads = timed(threads)
        first_sharded = timed(sharded)
        cols = ["cost", "length", "best_iteration", "coverage"]
        want = ref_table.sort_values(names, kind="stable").reset_index(drop=True)

        def same(table):
            got = table.sort_values(names, kind="stable").reset_index(drop=True)
            return len(got) == len(want) and all(np.array_equal(got[c].to_numpy(), want[c].to_numpy()) for c in cols + names)

        same_threads, same_sharded = same(first_threads[2]), same(first_sharded[2])
        R["multi_device_equal"] = {"threads": bool(same_threads), "sharding": bool(same_sharded)}

    # -- timed repetitions, engines interleaved -------------------------------------------------
    engines = {"native": native, "jaco_1": lambda: sweep(axes)}
    if n_dev > 1:
        engines.update({"jaco_threads": threads, "jaco_sharded": sharded})
    times = {k: [] for k in engines}
    native_out = None
    for _ in range(cfg["reps"]):
        for k, fn in engines.items():
            w, c, o = timed(fn)
            times[k].append((w, c))
            if k == "native":
                native_out = o
    native_lengths, native_steps = native_out
    native_steps = int(np.sum(native_steps))
    best = {k: min(v) for k, v in times.items()}

    rows = []
    nat_rate = native_steps / best["native"][0]
    labels = {
        "native": "native (numba loop, 1 core)",
        "jaco_1": "jaco, 1 device (`jaco.sweep`)",
        "jaco_threads": f"jaco, {n_dev} devices: threads (`jaco.sweep` per part)",
        "jaco_sharded": f"jaco, {n_dev} devices: sharded config axis (`jaco.sweep(devices={n_dev})`)",
    }
    figures = {}
    for k, (w, c) in best.items():
        steps = native_steps if k == "native" else jaco_steps
        rate = steps / w
        figures[k] = dict(wall_s=w, cpu_s=c, configs_per_s=n_cfg / w, steps=steps, steps_per_s=rate,
                          steps_per_cpu_s=steps / c, vs_native=rate / nat_rate, all_wall_s=[t[0] for t in times[k]])
        rows.append([labels[k], w, c, n_cfg / w, steps, rate, steps / c, rate / nat_rate])
    R["throughput"] = figures
    best_jaco = max((k for k in figures if k != "native"), key=lambda k: figures[k]["steps_per_s"])
    R["ratio"] = figures[best_jaco]["vs_native"]
    R["ratio_configs"] = figures[best_jaco]["configs_per_s"] / figures["native"]["configs_per_s"]
    R["best_jaco"] = labels[best_jaco]
    R["sweep_first_call_s"] = first[0]
    R["throughput_table"] = table(
        ["engine", "wall s (best)", "CPU s", "configs/s", "real ant-steps", "ant-steps/s", "ant-steps per CPU s",
         "× native (steps/s)"], rows
    )
    succ_j = float(np.mean(np.isfinite(ref_table["cost"].to_numpy())))
    succ_n = float(np.mean(np.isfinite(native_lengths)))
    R["quality"] = dict(
        jaco_success=succ_j, native_success=succ_n,
        jaco_median_length=float(np.median(ref_table["length"][np.isfinite(ref_table["length"])])) if succ_j else math.inf,
        native_median_length=float(np.median(native_lengths[np.isfinite(native_lengths)])) if succ_n else math.inf,
        jaco_steps_per_ant_iter=jaco_steps / (n_cfg * n_ants * n_iters),
        native_steps_per_ant_iter=native_steps / (n_cfg * n_ants * n_iters),
        optimal=float(problems.optimal[0]),
    )
    # -- where part of the time goes: uniforms drawn for every step slot, used or not ------------
    from jaco.engine.walk import pad_steps

    s_pad = pad_steps(steplimit)

    @jax.jit
    def draw(keys):
        def one(k):
            body = lambda c, kt: (c + jnp.sum(jax.random.uniform(kt, (s_pad, n_ants), jnp.float32)), None)  # noqa: E731
            return jax.lax.scan(body, jnp.float32(0), jax.random.split(k, n_iters))[0]

        return jax.vmap(one)(keys)

    draw(keys).block_until_ready()
    w_draw = best_of(lambda: draw(keys), cfg["reps"])[0]
    R["rng"] = dict(drawn=n_cfg * n_iters * s_pad * n_ants, used=jaco_steps, seconds=w_draw,
                    share_of_sweep=w_draw / figures["jaco_1"]["wall_s"])
    R["rss_after_sweep_mib"] = peak_rss_mib()
    print(R["throughput_table"], flush=True)
    print(f"ratio jaco/native (real ant-steps/s, {R['best_jaco']}): {R['ratio']:.3f}x", flush=True)

    # -- one solve: latency after compile, compile time -----------------------------------------
    def solve():
        return jaco.solve(grid, start, goal, "as", n_ants=n_ants, n_iters=n_iters)

    w_first, _, _ = timed(solve)
    lat = [timed(solve)[0] for _ in range(cfg["latency_calls"])]
    run_1 = jr.compiled_run(variant, n_ants, n_iters, steplimit, False, batched=False)
    problem = jaco.make_problem(grid, start, goal)
    p1 = jr.params_from(base)
    raw = [timed(lambda: run_1(jax.random.key(0), problem, p1))[0] for _ in range(cfg["latency_calls"])]
    t0 = time.perf_counter()
    lowered = jax.jit(jr.make_run(variant, n_ants=n_ants, n_iters=n_iters, steplimit=steplimit)).lower(
        jax.random.key(0), problem, p1)
    t_lower = time.perf_counter() - t0
    t0 = time.perf_counter()
    lowered.compile()
    t_compile = time.perf_counter() - t0
    med = statistics.median(lat)
    R["solve"] = dict(first_call_s=w_first, median_ms=1e3 * med, min_ms=1e3 * min(lat), max_ms=1e3 * max(lat),
                      compiled_run_median_ms=1e3 * statistics.median(raw), trace_s=t_lower, xla_compile_s=t_compile,
                      compile_s=w_first - med, calls=len(lat))
    R["solve_table"] = table(
        ["figure", "value"],
        [
            ["first `solve` call (trace + compile + run), s", w_first],
            ["compile time (first call − median call), s", w_first - med],
            ["  of which tracing + lowering, s", t_lower],
            ["  of which XLA compile, s", t_compile],
            [f"`solve` latency after compile, median of {len(lat)}, ms", 1e3 * med],
            ["`solve` latency, min / max, ms", f"{1e3 * min(lat):.1f} / {1e3 * max(lat):.1f}"],
            ["compiled run alone (no problem building / result), median, ms", 1e3 * statistics.median(raw)],
        ],
    )
    print(R["solve_table"], flush=True)

    # -- scaling ----------------------------------------------------------------------------------
    if not args.no_scaling:
        R["scaling"] = scaling(cfg, jax, np, jaco, jr, nr, variant, base, stack)
    R["rss_peak_mib"] = peak_rss_mib()
    R["load_end"] = os.getloadavg()
    R["total_s"] = time.perf_counter() - t_start
    return R


def compile_s(first, steady):
    """First call minus a steady call; "cached" when the shape was compiled earlier in the run."""
    d = first - steady
    return d if d > 0.05 else "cached"


def scaling(cfg, jax, np, jaco, jr, nr, variant, base, stack) -> dict:
    it, reps = cfg["scale_iters"], cfg["scale_reps"]
    q, tau0 = float(base["q"]), float(base["tau0"])
    p1 = jr.params_from(base)
    alpha, beta, rho = (float(base[k]) for k in ("alpha", "beta", "rho"))
    out = {}

    def one(grid, n_ants):
        side = grid.height
        start, goal = (0, 0), (side - 1, side - 1)
        steplimit = jr.default_steplimit(grid)

        def solve():
            return jaco.solve(grid, start, goal, "as", n_ants=n_ants, n_iters=it)

        w_first = timed(solve)[0]
        w, _, _ = best_of(solve, reps)
        run_1 = jr.compiled_run(variant, n_ants, it, steplimit, False, batched=False)
        steps = int(run_1(jax.random.key(0), jaco.make_problem(grid, start, goal), p1).steps)
        nbr, eta, s, g = nr.problem_arrays(grid, start, goal)
        nw, _, (_, _, nsteps) = best_of(
            lambda: nr.as_colony(nbr, eta, s, g, alpha, beta, rho, q, tau0, n_ants, it, steplimit, 0), reps)
        return [steplimit, compile_s(w_first, w), 1e3 * w, 1e3 * w / it, steps / it, steps / w,
                1e3 * nw / it, nsteps / nw, (steps / w) / (nsteps / nw)]

    head = ["compile s", "ms/solve", "ms/iteration", "real steps/iteration", "jaco steps/s",
            "native ms/iteration", "native steps/s", "× native (steps/s)"]
    rows = []
    for side in cfg["sides"]:
        grid = jaco.maps.random_map(side, 0.25, seed=cfg["map_seed"])
        r = one(grid, cfg["n_ants"])
        rows.append([f"{side}x{side}", int(grid.n_free)] + r)
        print(f"  side {side}: {r}", flush=True)
    out["side"] = table(["map", "free cells", "steplimit"] + head, rows)
    out["side_rows"] = rows

    grid = jaco.maps.random_map(cfg["side"], 0.25, seed=cfg["map_seed"])
    rows = []
    for n_ants in cfg["ants"]:
        r = one(grid, n_ants)
        rows.append([n_ants] + r)
        print(f"  ants {n_ants}: {r}", flush=True)
    out["ants"] = table(["ants", "steplimit"] + head, rows)
    out["ants_rows"] = rows

    # batch: one configuration (AS defaults), B seeds, one jaco.sweep call on one device
    start, goal = (0, 0), (cfg["side"] - 1, cfg["side"] - 1)
    steplimit = jr.default_steplimit(grid)
    n_ants = cfg["n_ants"]
    nbr, eta, s, g = nr.problem_arrays(grid, start, goal)
    problems = stack([jaco.make_problem(grid, start, goal)])
    rows = []
    for b in cfg["batches"]:
        def sweep():
            return jaco.sweep(grid, start, goal, "as", {}, seeds=b, n_ants=n_ants, n_iters=it, steplimit=steplimit)

        w_first = timed(sweep)[0]
        w, _, _ = best_of(sweep, reps)
        run_b = jr.compiled_run(variant, n_ants, it, steplimit, False, batched=True)
        keys = jax.vmap(jax.random.key)(np.arange(b, dtype=np.uint32))
        steps = int(np.sum(np.asarray(run_b(keys, problems, jr.params_from(base, (b,))).steps, np.int64)))

        def native():
            total = 0
            for seed in range(b):
                total += nr.as_colony(nbr, eta, s, g, *(float(base[k]) for k in ("alpha", "beta", "rho")),
                                      float(base["q"]), float(base["tau0"]), n_ants, it, steplimit, seed)[2]
            return total

        nw, _, nsteps = best_of(native, reps)
        r = [b, compile_s(w_first, w), w, 1e3 * w / (b * it), b / w, steps / w, nw, nsteps / nw, (steps / w) / (nsteps / nw)]
        rows.append(r)
        print(f"  batch {b}: {r}", flush=True)
    out["batch"] = table(["runs (1 config × B seeds)", "compile s", "s/sweep", "ms per run-iteration", "runs/s",
                          "jaco steps/s", "native s (B runs)", "native steps/s", "× native (steps/s)"], rows)
    out["batch_rows"] = rows
    out["iters"] = it
    return out


# ------------------------------------------------------------------------------------------------
# report
# ------------------------------------------------------------------------------------------------
def verdict(ok: bool) -> str:
    return "**met**" if ok else "**not met**"


def report(R: dict, command: str) -> str:
    m, w, th, sv = R["machine"], R["workload"], R["throughput"], R["solve"]
    qa = R["quality"]
    lines = [
        "## Throughput: jaco against a native AS loop (`experiments/bench_throughput.py`)",
        "",
        f"Command: `{command}` (run {R['date']}, {R['total_s']:.0f} s in all; jaco at commit {m['commit']}).",
        "",
        f"Machine: {m['nproc']} CPUs ({m['affinity']} usable), {m['cpu']}; {m['platform']}; Python {m['python']}, "
        f"jax {m['jax']} / jaxlib {m['jaxlib']}, numba {m['numba']}; {m['xla_devices']} XLA host device(s). "
        f"Load average at start {R['load_start'][0]:.2f}, at end {R['load_end'][0]:.2f} "
        "(other processes share the machine; timings are the best of the repetitions).",
        "",
        f"Workload: ant-cycle AS (`as`), {w['n_configs']} configurations = "
        + " × ".join(f"{k} ∈ {{{', '.join(f'{v:g}' for v in vals)}}}" for k, vals in w["axes"].items())
        + f" (q = {w['q']:g}, τ0 = {w['tau0']:g}), one seed each, on `{w['map']}` ({w['side']}x{w['side']}, "
        f"{w['n_free']} free cells), start (0, 0), goal ({w['side'] - 1}, {w['side'] - 1}), {w['n_ants']} ants, "
        f"{w['n_iters']} iterations, step limit {w['steplimit']}. The native reference is the same algorithm as "
        "plain numba loops on one core (`experiments/native_reference.py`). Real ant-steps are steps ants "
        "actually took (`RunOutput.steps` for jaco).",
        "",
        "### Sweep throughput",
        "",
        R["throughput_table"],
        "",
        f"**Ratio jaco / native: {R['ratio']:.2f}×** in real ant-steps/s ({R['ratio_configs']:.2f}× in configs/s), "
        f"best jaco row: {R['best_jaco']}. First `jaco.sweep` call (trace + compile + run): "
        f"{R['sweep_first_call_s']:.1f} s; numba compile of the reference: {R['native_compile_s']:.1f} s. "
        "Wall s is the best of the repetitions (all: see `--json`), CPU s the process CPU time of that repetition "
        "(above the wall time where more than one core worked); ant-steps per CPU s is the per-core rate, which "
        "other processes on the machine disturb least.",
        "",
        f"Same work, different random numbers: jaco {qa['jaco_steps_per_ant_iter']:.1f} and native "
        f"{qa['native_steps_per_ant_iter']:.1f} real steps per ant and iteration; success (share of configurations "
        f"that found a path) {qa['jaco_success']:.2f} / {qa['native_success']:.2f}; median best length "
        f"{qa['jaco_median_length']:.1f} / {qa['native_median_length']:.1f} (optimum {qa['optimal']:.1f}).",
        "",
    ]
    rng = R["rng"]
    lines += [
        f"Random numbers: jaco draws one uniform per ant and step slot of every iteration, "
        f"{rng['drawn']:,} for this sweep, of which ants use {rng['used']:,} ({100 * rng['used'] / rng['drawn']:.0f} %); "
        f"drawing them alone takes {rng['seconds']:.2f} s, {100 * rng['share_of_sweep']:.0f} % of the 1-device sweep.",
        "",
    ]
    if "multi_device_equal" in R:
        eq = R["multi_device_equal"]
        lines += [
            "Multi-device results equal the 1-device results bit for bit: "
            f"threads {'yes' if eq['threads'] else 'NO'}, sharding {'yes' if eq['sharding'] else 'NO'}. "
            "Threads: the configurations are split along one parameter axis, one `jaco.sweep` per part, each in its "
            "own Python thread under `jax.default_device` (JAX releases the GIL). Sharding: `jaco.sweep(devices=N)`, "
            "the configuration axis sharded with `jax.shard_map` (each device walks its own slice).",
            "",
        ]
    lines += [
        "### One solve",
        "",
        f"`jaco.solve(grid, (0, 0), ({w['side'] - 1}, {w['side'] - 1}), \"as\", n_ants={w['n_ants']}, "
        f"n_iters={w['n_iters']})` on the same map, 1 device.",
        "",
        R["solve_table"],
        "",
        f"Peak memory (max RSS of the process): {R['rss_after_sweep_mib']:.0f} MiB after the sweeps, "
        f"{R['rss_peak_mib']:.0f} MiB at the end of the benchmark.",
        "",
    ]
    if "scaling" in R:
        sc = R["scaling"]
        lines += [
            "### Scaling",
            "",
            f"`jaco.solve` (1 device) and the native loop, {sc['iters']} iterations, AS defaults, random maps p = 0.25, "
            "start (0, 0), goal in the opposite corner, default step limit 4·(H + W) (at most the free cells). "
            "Compile s = first call − best call.",
            "",
            f"Grid side ({w['n_ants']} ants):",
            "",
            sc["side"],
            "",
            f"Ants ({w['side']}x{w['side']} map):",
            "",
            sc["ants"],
            "",
            f"Batch size: one `jaco.sweep` of B runs (AS defaults, seeds 0..B−1; 1 device) on the "
            f"{w['side']}x{w['side']} map, {w['n_ants']} ants; the native loop runs the B runs one after the other.",
            "",
            sc["batch"],
            "",
        ]
    ok_ratio = R["ratio"] >= TARGETS["ratio"]
    ok_lat = sv["median_ms"] <= TARGETS["latency_ms"]
    ok_cmp = sv["compile_s"] <= TARGETS["compile_s"]
    lines += [
        "### Targets",
        "",
        f"- jaco ≥ {TARGETS['ratio']:.1f}× the native reference (real ant-steps/s, jaco on all devices): "
        f"{R['ratio']:.2f}× — {verdict(ok_ratio)}.",
        f"- one `solve` after compile ≤ {TARGETS['latency_ms']:.0f} ms: median {sv['median_ms']:.1f} ms — {verdict(ok_lat)}.",
        f"- compile ≤ {TARGETS['compile_s']:.0f} s: {sv['compile_s']:.2f} s — {verdict(ok_cmp)}.",
        f"- peak memory: {R['rss_peak_mib']:.0f} MiB (no target).",
        "",
    ]
    return "\n".join(lines)


def write_section(path: Path, body: str):
    """Replace this script's section of ``path`` (between markers), or append it; create the file
    with a short introduction when it does not exist."""
    start, end = f"<!-- {SECTION}:start -->", f"<!-- {SECTION}:end -->"
    block = f"{start}\n{body.rstrip()}\n{end}\n"
    if path.exists():
        text = path.read_text()
        if start in text and end in text:
            text = text[: text.index(start)] + block + text[text.index(end) + len(end) + 1 :]
        else:
            text = text.rstrip() + "\n\n" + block
    else:
        text = (
            "# Benchmarks\n\n"
            "Figures measured by the scripts in `experiments/`. Each section is written by the script it names, "
            "with the command that produced it; run the command again to refresh the section. No test asserts a "
            "time: the tests only run the scripts at `--smoke` size.\n\n" + block
        )
    path.write_text(text)


def main(argv=None):
    args = parse_args(argv)
    set_device_count(args.devices)
    R = run_benchmark(args)
    R["date"] = _dt.datetime.now().strftime("%Y-%m-%d %H:%M")
    argv_shown = sys.argv[1:] if argv is None else list(argv)
    command = " ".join(["python experiments/bench_throughput.py"] + [shlex.quote(a) for a in argv_shown])
    text = report(R, command)
    print()
    print(text)
    if args.out:
        write_section(Path(args.out), text)
        print(f"wrote {args.out}")
    if args.json:
        Path(args.json).write_text(json.dumps(R, indent=1, default=lambda o: o.tolist() if hasattr(o, "tolist") else str(o)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
