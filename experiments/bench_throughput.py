#!/usr/bin/env python
"""Throughput of jaco against a native loop, with both walks: sweep throughput, solve latency,
compile time, IACA on a 256x256 city map, memory and scaling.

    python experiments/bench_throughput.py              # full run, updates BENCHMARKS.md
    python experiments/bench_throughput.py --smoke      # tiny sizes, writes nothing unless --out

Workload (the project's speed target): a 64-configuration ant-cycle AS sweep (alpha x beta x rho,
4 values each, one seed) on a 30x30 random map with 25 % obstacles, start (0, 0), goal (29, 29),
50 ants, 100 iterations, jaco's default step limit. The same sweep runs in the same process as a
plain numba loop on one core (``experiments/native_reference.py``, the ``bench`` extra), and the
script prints jaco's throughput as a multiple of it.

jaco runs it twice: with the native walk (the C++ kernel through ``jax.ffi``, the default on CPU
when it was built; the configurations are split over the intra-op threads, i.e. both cores) and
with the JAX walk (``jaco.set_walk("jax")``, the walk on GPU/TPU and without a compiler). Both walks
take the same moves, so they report the same table, which the script checks.

Counting: ant-steps are *real* steps (steps ants actually took), from ``RunOutput.steps`` for
jaco (read from the same cached compiled function ``jaco.sweep`` uses, with the same keys, and
checked to give the same table) and from the loop itself for the native reference. The two
engines draw different random numbers, so their step counts differ a little; steps/s compares
them fairly, configs/s is the user-facing figure.

Devices: ``--devices N`` sets ``XLA_FLAGS=--xla_force_host_platform_device_count=N`` before jax
is imported (N CPU "devices" of XLA's host platform); ``jaco.sweep(..., devices=N)`` shards the
configuration axis over them with ``jax.shard_map`` (each device walks its own slice), checked
bit for bit against the 1-device table.

Timings are the best of ``reps`` repetitions, with the engines interleaved, because the machine
may be shared; the load average is recorded. Nothing here asserts a time.
"""

from __future__ import annotations

import argparse
import contextlib
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
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(HERE))
from report import table, write_section, write_text  # noqa: E402 (the experiments' shared helpers)

SECTION = "bench_throughput"

FULL = dict(
    side=30, p=0.25, map_seed=0, n_ants=50, n_iters=100,
    axes={"alpha": [0.5, 1.0, 2.0, 4.0], "beta": [1.0, 2.0, 4.0, 8.0], "rho": [0.1, 0.3, 0.5, 0.7]},
    reps=5, latency_calls=24, solve_rounds=3, solve_seeds=8, block_rounds=12, city="Berlin_1_256.map", city_reps=3,
    sides=[16, 32, 64, 128, 256, 384, 512], ants=[10, 50, 200, 800], batches=[1, 8, 64, 256],
    scale_iters=20, scale_reps=3,
)
SMOKE = dict(
    side=12, p=0.25, map_seed=0, n_ants=10, n_iters=5,
    axes={"alpha": [1.0, 2.0], "beta": [2.0, 4.0], "rho": [0.3, 0.5]},
    reps=1, latency_calls=4, solve_rounds=1, solve_seeds=2, block_rounds=2, city=None, city_reps=1,
    sides=[8, 12], ants=[10], batches=[4],  # one row per table where a row needs no compile of its own
    scale_iters=3, scale_reps=1,
)
TARGETS = {"per_core": 3.0, "per_core_milestone": 2.0, "solve_speedup": 2.5, "compile_s": 5.0, "city_s": 1.5}
WALK_NAMES = {"native": "native walk", "jax": "JAX walk"}


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
    os.environ.setdefault("JAX_PLATFORMS", "cpu")  # JAX_PLATFORMS=cuda measures the JAX walk on a GPU


def section(backend: str) -> str:
    """BENCHMARKS.md's section for a run: the CPU one, or one per accelerator backend."""
    return SECTION if backend == "cpu" else f"{SECTION}_{backend}"


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

    from jaco.engine import native

    model, mhz = platform.processor() or "?", None
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name") and model in ("?", platform.processor()):
                model = line.split(":", 1)[1].strip()
            if line.startswith("cpu MHz") and mhz is None:
                mhz = float(line.split(":", 1)[1])
    except (OSError, ValueError):
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
        "ghz": mhz / 1e3 if mhz else None,  # the clock the kernel reports (cycles per step use it)
        "isas": native.isas(),
        "python": platform.python_version(),
        "jax": jax.__version__,
        "jaxlib": jaxlib.__version__,
        "numba": numba.__version__,
        "xla_devices": len(jax.devices()),
        "backend": jax.default_backend(),
        "device_kind": jax.devices()[0].device_kind,
        "platform": platform.platform(),
    }


def native_isa():
    """The instruction set of the native lane kernels in use (None without the kernel)."""
    from jaco.engine import native

    return native.isa() if native.available() else None


def walks() -> list:
    """The walks to measure: the native one where it was built, and the JAX one."""
    from jaco.engine import native

    return (["native"] if native.available() else []) + ["jax"]


@contextlib.contextmanager
def walking(walk):
    import jaco

    jaco.set_walk(walk)
    try:
        yield
    finally:
        jaco.set_walk(None)


# ------------------------------------------------------------------------------------------------
# the benchmark
# ------------------------------------------------------------------------------------------------
def run_benchmark(args) -> dict:
    cfg = SMOKE if args.smoke else FULL
    import jax
    import numpy as np

    import jaco
    import jaco.engine.checks as jc
    import jaco.engine.run as jr
    from jaco.engine.problem import stack
    from jaco.engine.shape import RunShape

    import native_reference as nr

    t_start = time.perf_counter()
    R: dict = {"config": {k: v for k, v in cfg.items()}, "machine": machine(), "load_start": os.getloadavg(),
               "walks": walks()}
    variant = jaco.PLANNERS["as"]
    n_dev = min(args.devices, len(jax.devices()))

    side, n_ants, n_iters = cfg["side"], cfg["n_ants"], cfg["n_iters"]
    grid = jaco.maps.random_map(side, cfg["p"], seed=cfg["map_seed"])
    start, goal = (0, 0), (side - 1, side - 1)
    steplimit = jc.default_steplimit(grid)
    axes = cfg["axes"]
    names = list(axes)
    combos = np.array(list(itertools.product(*(axes[k] for k in names))), np.float64)
    n_cfg = len(combos)
    base = jc.resolve_params(variant, {}, where="as")
    q, tau0 = float(base["q"]), float(base["tau0"])
    R["workload"] = dict(map=grid.name, side=side, n_free=int(grid.n_free), n_configs=n_cfg, n_ants=n_ants,
                         n_iters=n_iters, steplimit=steplimit, axes=axes, q=q, tau0=tau0)

    # -- native reference -----------------------------------------------------------------------
    nbr, eta, s_idx, g_idx = nr.problem_arrays(grid, start, goal)
    native_cols = np.stack([combos[:, names.index(k)] for k in ("alpha", "beta", "rho")], axis=1)

    def native_loop():
        return nr.sweep_native(native_cols, nbr, eta, s_idx, g_idx, q=q, tau0=tau0, n_ants=n_ants,
                               n_iters=n_iters, steplimit=steplimit, seed=0)

    t0 = time.perf_counter()
    nr.sweep_native(native_cols[:1], nbr, eta, s_idx, g_idx, n_ants=1, n_iters=1, steplimit=steplimit)
    nr.as_colony(nbr, eta, s_idx, g_idx, 1.0, 1.0, 0.5, 1.0, 0.1, 1, 1, steplimit, 0)
    R["native_compile_s"] = time.perf_counter() - t0

    # -- jaco, each walk: one device and N devices, through jaco.sweep -------------------------
    def sweep(devices):
        return jaco.sweep(grid, start, goal, "as", axes, seeds=1, n_ants=n_ants, n_iters=n_iters, steplimit=steplimit,
                          devices=devices)

    def on(walk, fn):
        def call():
            with walking(walk):
                return fn()
        return call

    def on_isa(isa, fn):
        def call():
            from jaco.engine import native

            native.set_isa(isa)
            try:
                return fn()
            finally:
                native.set_isa(None)
        return call

    tab = {k: np.full(n_cfg, v) for k, v in base.items()}
    for i, k in enumerate(names):
        tab[k] = combos[:, i]
    keys = jax.vmap(jax.random.key)(np.zeros(n_cfg, np.uint32))
    problems = stack([jaco.make_problem(grid, start, goal)])
    engines = {"native": native_loop}
    tables, first, equal = {}, {}, {}
    for walk in R["walks"]:
        first[walk], _, tables[walk] = timed(on(walk, lambda: sweep(1)))
        engines[f"{walk}_1"] = on(walk, lambda: sweep(1))
        if walk == "native" and native_isa() not in (None, "baseline"):  # the portable lanes, for comparison
            engines["native-baseline_1"] = on_isa("baseline", on(walk, lambda: sweep(1)))
            equal["native walk, baseline lanes"] = bool(engines["native-baseline_1"]().equals(tables[walk]))
        if n_dev > 1:
            sharded = timed(on(walk, lambda: sweep(n_dev)))[2]
            equal[f"{walk}, {n_dev} devices"] = bool(sharded.equals(tables[walk]))
            engines[f"{walk}_{n_dev}"] = on(walk, lambda: sweep(n_dev))
        with walking(walk):  # the real step count, from the compiled program jaco.sweep used
            run_b = jr.compiled_run(variant, RunShape(n_ants, n_iters, steplimit), batched=True)
            out = jax.device_get(run_b(keys, problems, jc.params_from(tab, (n_cfg,))))
        if not np.array_equal(np.asarray(out.best_cost)[0], tables[walk]["cost"].to_numpy(np.float32)):
            raise SystemExit(f"the batched compiled run does not reproduce jaco.sweep's table ({walk} walk)")
        R.setdefault("jaco_steps", int(np.sum(np.asarray(out.steps, np.int64))))
    if len(tables) == 2:
        equal["native walk, JAX walk"] = bool(tables["native"].equals(tables["jax"]))
    R["equal"] = equal
    ref_table = tables[R["walks"][0]]
    jaco_steps = R["jaco_steps"]

    # -- timed repetitions, engines interleaved -------------------------------------------------
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

    def label(k):
        if k == "native":
            return "native (numba loop, 1 core)"
        if k == "native-baseline_1":
            return "jaco, native walk, baseline lanes (`JACO_NATIVE_ISA=baseline`), 1 device"
        walk, dev = k.split("_")
        how = "`jaco.sweep`" if dev == "1" else f"`jaco.sweep(devices={dev})`, sharded"
        return f"jaco, {WALK_NAMES[walk]}, {dev} device{'s' if dev != '1' else ''} ({how})"

    rows, figures = [], {}
    nat_rate = native_steps / best["native"][0]
    nat_core = native_steps / best["native"][1]
    ghz = R["machine"]["ghz"] or math.nan
    for k, (w, c) in best.items():
        steps = native_steps if k == "native" else jaco_steps
        rate = steps / w
        figures[k] = dict(label=label(k), wall_s=w, cpu_s=c, configs_per_s=n_cfg / w, steps=steps, steps_per_s=rate,
                          steps_per_cpu_s=steps / c, vs_native=rate / nat_rate, vs_native_per_core=steps / c / nat_core,
                          cycles_per_step=c * ghz * 1e9 / steps, all_wall_s=[t[0] for t in times[k]])
        rows.append([label(k), w, c, n_cfg / w, steps, rate, rate / nat_rate, steps / c, steps / c / nat_core,
                     1e9 * c / steps, c * ghz * 1e9 / steps])
    R["throughput"] = figures
    R["throughput_table"] = table(
        ["engine", "wall s (best)", "CPU s", "configs/s", "real ant-steps", "ant-steps/s", "× native (steps/s)",
         "ant-steps per CPU s", "× native per core", "CPU ns per step", "cycles per step"], rows
    )
    R["ratio"] = {}
    for walk in R["walks"]:
        k = max((k for k in figures if k.startswith(walk + "_")), key=lambda k: figures[k]["steps_per_s"])
        core = max((k for k in figures if k.startswith(walk + "_")), key=lambda k: figures[k]["steps_per_cpu_s"])
        R["ratio"][walk] = dict(engine=figures[k]["label"], steps=figures[k]["vs_native"],
                                configs=figures[k]["configs_per_s"] / figures["native"]["configs_per_s"],
                                per_core=figures[core]["vs_native_per_core"], per_core_engine=figures[core]["label"])
    R["sweep_first_call_s"] = first
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
    R["rss_after_sweep_mib"] = peak_rss_mib()
    print(R["throughput_table"], flush=True)

    # -- one solve: latency after compile, compile time -----------------------------------------
    problem = jaco.make_problem(grid, start, goal)
    p1 = jc.params_from(base)
    one = [float(base[k]) for k in ("alpha", "beta", "rho", "q", "tau0")]
    # Both series call seeds 0 .. solve_seeds - 1 in turn: the two take different random numbers, and
    # one seed's can make one side's ants walk a quarter more steps than the other's (seed 0 here:
    # jaco 273,073 real steps, the numba loop 340,162), so a single seed would weigh the two unevenly.
    seeds = list(range(cfg["solve_seeds"]))

    def native_solve(seed):
        return nr.as_colony(nbr, eta, s_idx, g_idx, *one, n_ants, n_iters, steplimit, seed)

    R["solve"] = {}
    R["solve_seeds"] = len(seeds)
    for walk in R["walks"]:
        with walking(walk):
            def solve(seed=0, progress=False):  # progress None would depend on whether stderr is a terminal
                return jaco.solve(grid, start, goal, "as", seed=seed, n_ants=n_ants, n_iters=n_iters, progress=progress)

            w_first, _, _ = timed(solve)
            timed(lambda: solve(0, True))
            # In rounds: the numba loop's run, the solve, the solve with a progress bar (the program a
            # terminal or notebook runs; the bar itself opens only after two seconds, so none is
            # drawn here) and the compiled run alone (no validation, problem or Result), one call of
            # each in turn with the same seed. The machines here switch between a fast and a slow
            # state from one moment to the next (the numba run: 8 or 14 ms; rounds of one run 1.9 and
            # 2.7 apart in their ratio), so the speed-up is the median over the pairs of calls made
            # one after the other (the same seed, the same state), and each series also keeps its
            # best round's median, as the sweeps keep their best.
            run_1 = jr.compiled_run(variant, RunShape(n_ants, n_iters, steplimit), batched=False)
            # the run's arguments already on the device, as a solve keeps them (a numpy argument is
            # copied at every call, about 35 µs an array)
            on_device, p1_device = jax.device_put(problem), jax.device_put(p1)
            keys = {seed: jax.random.key(seed) for seed in seeds}
            lat, lat_bar, native_run, raw, pairs = [], [], [], [], []
            for _ in range(cfg["solve_rounds"]):
                calls: dict = {"native": [], "solve": [], "bar": [], "raw": []}
                for i in range(cfg["latency_calls"]):
                    seed = seeds[i % len(seeds)]
                    calls["native"].append(timed(lambda seed=seed: native_solve(seed))[0])
                    calls["solve"].append(timed(lambda seed=seed: solve(seed))[0])
                    calls["bar"].append(timed(lambda seed=seed: solve(seed, True))[0])
                    calls["raw"].append(timed(lambda key=keys[seed], run_1=run_1, p=on_device, v=p1_device: run_1(key, p, v))[0])
                native_run.append(calls["native"])
                lat.append(calls["solve"])
                lat_bar.append(calls["bar"])
                raw.append(calls["raw"])
                pairs += [n / j for n, j in zip(calls["native"], calls["solve"])]
            # In blocks as well: each side's calls one after another (seeds 0 .. solve_seeds - 1), as
            # `timeit` runs them, the two blocks of a round in the other order than the round before.
            # A solve called right after other work (the numba run above, or a pause) takes 0.5-1 ms
            # more than one called right after a solve, pinned to one core too: its caches are cold
            # (docs/native.md). The paired figure pays that on every call; the blocks show the speed
            # of a loop of solves (a search, a sweep of single runs).
            blocks = []
            for r in range(cfg["block_rounds"]):
                sides = [("native", native_solve), ("solve", solve)][:: 1 if r % 2 == 0 else -1]
                med = {name: statistics.median(timed(lambda f=f, seed=seed: f(seed))[0] for seed in seeds) for name, f in sides}
                blocks.append(med["native"] / med["solve"])
            rounds_ms = {"solve": [1e3 * statistics.median(r) for r in lat],
                         "solve_bar": [1e3 * statistics.median(r) for r in lat_bar],
                         "native": [1e3 * statistics.median(r) for r in native_run]}
            lat = min(lat, key=statistics.median)
            lat_bar = min(lat_bar, key=statistics.median)
            raw = min(raw, key=statistics.median)
            if walk == R["walks"][0]:  # the work behind the two series: real ant-steps a run, the mean over the seeds
                R["solve_steps"] = {
                    "jaco": statistics.mean(int(run_1(keys[sd], on_device, p1_device).steps) for sd in seeds),
                    "native": statistics.mean(int(native_solve(sd)[2]) for sd in seeds),
                }
            t0 = time.perf_counter()
            lowered = jax.jit(jr.make_run(variant, n_ants=n_ants, n_iters=n_iters, steplimit=steplimit)).lower(
                jax.random.key(0), problem, p1)
            t_lower = time.perf_counter() - t0
            t0 = time.perf_counter()
            lowered.compile()
            t_compile = time.perf_counter() - t0
        med = statistics.median(lat)
        R["solve"][walk] = dict(first_call_s=w_first, median_ms=1e3 * med, min_ms=1e3 * min(lat), max_ms=1e3 * max(lat),
                                bar_median_ms=1e3 * statistics.median(lat_bar), rounds_ms=rounds_ms,
                                native_run_ms=min(rounds_ms["native"]), speedup=statistics.median(pairs), pairs=len(pairs),
                                speedup_quartiles=statistics.quantiles(pairs, n=4)[::2] if len(pairs) > 1 else pairs * 2,
                                speedup_blocks=statistics.median(blocks), blocks=len(blocks),
                                speedup_blocks_range=[min(blocks), max(blocks)],
                                compiled_run_median_ms=1e3 * statistics.median(raw), trace_s=t_lower,
                                xla_compile_s=t_compile, compile_s=w_first - med, calls=len(lat))
    sv = R["solve"]
    R["solve_table"] = table(
        ["figure"] + [WALK_NAMES[w] for w in R["walks"]],
        [
            ["first `solve` call (trace + compile + run), s"] + [sv[w]["first_call_s"] for w in R["walks"]],
            ["compile time (first call − median call), s"] + [sv[w]["compile_s"] for w in R["walks"]],
            ["  of which tracing + lowering, s"] + [sv[w]["trace_s"] for w in R["walks"]],
            ["  of which XLA compile, s"] + [sv[w]["xla_compile_s"] for w in R["walks"]],
            [f"`solve` latency after compile, median of {cfg['latency_calls']} calls, seeds 0–{len(seeds) - 1} in turn (best of {cfg['solve_rounds']} rounds), ms"] + [sv[w]["median_ms"] for w in R["walks"]],
            ["`solve` latency, min / max, ms"] + [f"{sv[w]['min_ms']:.1f} / {sv[w]['max_ms']:.1f}" for w in R["walks"]],
            ["`solve` latency with a progress bar (`progress=True`, as in a terminal or notebook), median, ms"]
            + [sv[w]["bar_median_ms"] for w in R["walks"]],
            ["compiled run alone (no validation, problem or result), median (best round), ms"]
            + [sv[w]["compiled_run_median_ms"] for w in R["walks"]],
            ["the numba loop's run of the same problem and parameters, median (best round), ms"]
            + [sv[w]["native_run_ms"] for w in R["walks"]],
            ["real ant-steps a run, mean over the seeds: jaco / the numba loop"]
            + [f"{R['solve_steps']['jaco']:,.0f} / {R['solve_steps']['native']:,.0f}" for w in R["walks"]],
            ["`solve` speed-up over the numba loop's run: median of the pairs of calls (quartiles)"]
            + [f"{sv[w]['speedup']:.2f} ({sv[w]['speedup_quartiles'][0]:.2f}–{sv[w]['speedup_quartiles'][1]:.2f})"
               for w in R["walks"]],
            [f"the same in blocks: {len(seeds)} calls of each side one after another, median over {cfg['block_rounds']} rounds (lowest–highest)"]
            + [f"{sv[w]['speedup_blocks']:.2f} ({sv[w]['speedup_blocks_range'][0]:.2f}–{sv[w]['speedup_blocks_range'][1]:.2f})"
               for w in R["walks"]],
            ["the pairs' speed-up from each round's medians (the machine's state moves it)"]
            + [" / ".join(f"{n / j:.2f}" for n, j in zip(sv[w]["rounds_ms"]["native"], sv[w]["rounds_ms"]["solve"]))
               for w in R["walks"]],
        ],
    )
    print(R["solve_table"], flush=True)

    # -- IACA on a real 256x256 map ---------------------------------------------------------------
    if cfg["city"]:
        R["city"] = city(cfg, jaco)

    # -- scaling ----------------------------------------------------------------------------------
    if not args.no_scaling:
        R["scaling"] = scaling(cfg, jax, np, jaco, jr, nr, variant, base, stack, R["walks"])
    R["rss_peak_mib"] = peak_rss_mib()
    R["load_end"] = os.getloadavg()
    R["total_s"] = time.perf_counter() - t_start
    return R


def city(cfg, jaco) -> dict:
    """IACA (backtracking ants) on the longest scenario of a bundled 256x256 city map, 50 ants x
    100 iterations, seed 0: the first call (with the compile) and the best later call."""
    grid = jaco.maps.load(jaco.maps.bundled(cfg["city"]))
    scen = max(jaco.maps.load_scenarios(jaco.maps.bundled(cfg["city"] + ".scen")), key=lambda s: s.optimal)
    out = dict(map=cfg["city"], start=scen.start, goal=scen.goal, optimal=scen.optimal)
    for walk in walks():
        with walking(walk):
            def solve():
                return jaco.solve(grid, scen.start, scen.goal, "iaca", seed=0, n_ants=50, n_iters=100)

            w_first, _, r = timed(solve)
            reps = cfg["city_reps"] if walk == "native" else 0  # the JAX walk takes minutes here: once
            w = min([timed(solve)[0] for _ in range(reps)], default=w_first)
        out[walk] = dict(first_s=w_first, best_s=w, length=r.length, success=r.success)
        print(f"  city {walk}: first {w_first:.2f} s, best {w:.2f} s, length {r.length:.1f}", flush=True)
    return out


def compile_s(first, steady):
    """First call minus a steady call; "cached" when the shape was compiled earlier in the run."""
    d = first - steady
    return d if d > 0.05 else "cached"


def scaling(cfg, jax, np, jaco, jr, nr, variant, base, stack, walk_list) -> dict:
    import jaco.engine.checks as jc
    from jaco.engine.shape import RunShape

    it, reps = cfg["scale_iters"], cfg["scale_reps"]
    q, tau0 = float(base["q"]), float(base["tau0"])
    p1 = jc.params_from(base)
    alpha, beta, rho = (float(base[k]) for k in ("alpha", "beta", "rho"))
    out = {}

    def one(grid, n_ants):
        side = grid.height
        start, goal = (0, 0), (side - 1, side - 1)
        steplimit = jc.default_steplimit(grid)
        problem = jaco.make_problem(grid, start, goal)
        cols, steps = [steplimit], None
        for walk in walk_list:
            with walking(walk):
                def solve():
                    return jaco.solve(grid, start, goal, "as", n_ants=n_ants, n_iters=it)

                w_first = timed(solve)[0]
                w, _, _ = best_of(solve, reps)
                run_1 = jr.compiled_run(variant, RunShape(n_ants, it, steplimit), batched=False)
                steps = int(run_1(jax.random.key(0), problem, p1).steps)
            cols += [compile_s(w_first, w), 1e3 * w / it]
            cols.append(steps / w)
        nbr, eta, s, g = nr.problem_arrays(grid, start, goal)
        nw, _, (_, _, nsteps) = best_of(
            lambda: nr.as_colony(nbr, eta, s, g, alpha, beta, rho, q, tau0, n_ants, it, steplimit, 0), reps)
        walk_rates = cols[3::3]
        return cols + [steps / it, 1e3 * nw / it, nsteps / nw] + [r / (nsteps / nw) for r in walk_rates]

    head = [h for w in walk_list for h in (f"{WALK_NAMES[w]}: compile s", f"{WALK_NAMES[w]}: ms/iteration",
                                           f"{WALK_NAMES[w]}: steps/s")]
    head += ["real steps/iteration", "native ms/iteration", "native steps/s"]
    head += [f"{WALK_NAMES[w]}: × native" for w in walk_list]
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
    steplimit = jc.default_steplimit(grid)
    n_ants = cfg["n_ants"]
    nbr, eta, s, g = nr.problem_arrays(grid, start, goal)
    problems = stack([jaco.make_problem(grid, start, goal)])
    rows = []
    for b in cfg["batches"]:
        cols = [b]
        steps = None
        for walk in walk_list:
            with walking(walk):
                def sweep(b=b):
                    return jaco.sweep(grid, start, goal, "as", {}, seeds=b, n_ants=n_ants, n_iters=it, steplimit=steplimit)

                w_first = timed(sweep)[0]
                w, _, _ = best_of(sweep, reps)
                run_b = jr.compiled_run(variant, RunShape(n_ants, it, steplimit), batched=True)
                keys = jax.vmap(jax.random.key)(np.arange(b, dtype=np.uint32))
                steps = int(np.sum(np.asarray(run_b(keys, problems, jc.params_from(base, (b,))).steps, np.int64)))
            cols += [compile_s(w_first, w), w, steps / w]

        def native(b=b):
            total = 0
            for seed in range(b):
                total += nr.as_colony(nbr, eta, s, g, alpha, beta, rho, q, tau0, n_ants, it, steplimit, seed)[2]
            return total

        nw, _, nsteps = best_of(native, reps)
        rates = cols[3::3]
        r = cols + [nw, nsteps / nw] + [x / (nsteps / nw) for x in rates]
        rows.append(r)
        print(f"  batch {b}: {r}", flush=True)
    bhead = [h for w in walk_list for h in (f"{WALK_NAMES[w]}: compile s", f"{WALK_NAMES[w]}: s/sweep",
                                            f"{WALK_NAMES[w]}: steps/s")]
    out["batch"] = table(["runs (1 config × B seeds)"] + bhead + ["native s (B runs)", "native steps/s"]
                         + [f"{WALK_NAMES[w]}: × native" for w in walk_list], rows)
    out["batch_rows"] = rows
    out["iters"] = it
    return out


# ------------------------------------------------------------------------------------------------
# report
# ------------------------------------------------------------------------------------------------
def verdict(ok: bool) -> str:
    return "**met**" if ok else "**not met**"


def report(R: dict, command: str) -> str:
    m, w, sv = R["machine"], R["workload"], R["solve"]
    qa = R["quality"]
    on_cpu = m.get("backend", "cpu") == "cpu"
    where = "" if on_cpu else f" on {m['device_kind']}"
    lines = [
        f"## Throughput{where}: jaco against a native AS loop (`experiments/bench_throughput.py`)",
        "",
        f"Command: `{command}` (run {R['date']}, {R['total_s']:.0f} s in all; jaco at commit {m['commit']}).",
        "",
    ]
    if not on_cpu:
        lines += [
            f"Device: jax runs on `{m['backend']}`, one {m['device_kind']} ({m['xla_devices']} device(s)); the "
            "native kernel is a CPU kernel, so jaco takes the JAX walk. The numba loop runs on this machine's CPU. "
            "CPU s and the per-core columns count the host process (it mostly waits for the GPU), and cycles per "
            "step use the CPU clock: on a GPU read wall s, configs/s and ant-steps/s.",
            "",
        ]
    lines += [
        f"Machine: {m['nproc']} CPUs ({m['affinity']} usable), {m['cpu']}; {m['platform']}; Python {m['python']}, "
        f"jax {m['jax']} / jaxlib {m['jaxlib']}, numba {m['numba']}; {m['xla_devices']} XLA host device(s); "
        f"clock {m['ghz'] or float('nan'):.2f} GHz as the kernel reports it (cycles per step use it); native lane kernels: "
        + (", ".join(f"{k} ({v})" for k, v in m["isas"].items()) if m.get("isas") else "none (not built here)") + ". "
        f"Load average at start {R['load_start'][0]:.2f}, at end {R['load_end'][0]:.2f} "
        "(other processes share the machine; timings are the best of the repetitions).",
        "",
        f"Workload: ant-cycle AS (`as`), {w['n_configs']} configurations = "
        + " × ".join(f"{k} ∈ {{{', '.join(f'{v:g}' for v in vals)}}}" for k, vals in w["axes"].items())
        + f" (q = {w['q']:g}, τ0 = {w['tau0']:g}), one seed each, on `{w['map']}` ({w['side']}x{w['side']}, "
        f"{w['n_free']} free cells), start (0, 0), goal ({w['side'] - 1}, {w['side'] - 1}), {w['n_ants']} ants, "
        f"{w['n_iters']} iterations, step limit {w['steplimit']}. The native reference is the same algorithm as "
        "plain numba loops on one core (`experiments/native_reference.py`). Real ant-steps are steps ants "
        "actually took (`RunOutput.steps` for jaco). The native walk is jaco's default on CPU; the JAX walk "
        "(`jaco.set_walk(\"jax\")`) is the walk on GPU/TPU and where no C++ compiler built the kernel.",
        "",
        "### Sweep throughput",
        "",
        R["throughput_table"],
        "",
    ]
    for walk, r in R["ratio"].items():
        if not on_cpu:  # the host's CPU time says nothing of the GPU's work
            lines.append(f"**{WALK_NAMES[walk]}: {r['steps']:.2f}× the native loop's real ant-steps per second** "
                         f"(wall time; {r['configs']:.2f}× in configs/s), {r['engine']}.")
            continue
        lines.append(f"**{WALK_NAMES[walk]}: {r['per_core']:.2f}× the native loop per core** (real ant-steps per CPU "
                     f"second, {r['per_core_engine']}); {r['steps']:.2f}× in wall-time real ant-steps/s "
                     f"({r['configs']:.2f}× in configs/s), best row: {r['engine']}.")
    lines += [
        "",
        "First `jaco.sweep` call (trace + compile + run): "
        + ", ".join(f"{WALK_NAMES[k]} {v:.1f} s" for k, v in R["sweep_first_call_s"].items())
        + f"; numba compile of the reference: {R['native_compile_s']:.1f} s. Wall s is the best of the repetitions "
        "(all: see `--json`), CPU s the process CPU time of that repetition (above the wall time where more than "
        "one core worked); ant-steps per CPU s is the per-core rate, which other processes on the machine disturb "
        "least. It counts a thread of XLA's pool while it spins waiting for work, too; "
        "`experiments/bench_before_after.py` measures on one pinned core.",
        "",
        "The same tables bit for bit: " + "; ".join(f"{k}: {'yes' if v else '**NO**'}" for k, v in R["equal"].items())
        + ".",
        "",
        f"Same work, different random numbers: jaco {qa['jaco_steps_per_ant_iter']:.1f} and native "
        f"{qa['native_steps_per_ant_iter']:.1f} real steps per ant and iteration; success (share of configurations "
        f"that found a path) {qa['jaco_success']:.2f} / {qa['native_success']:.2f}; median best length "
        f"{qa['jaco_median_length']:.1f} / {qa['native_median_length']:.1f} (optimum {qa['optimal']:.1f}).",
        "",
        "### One solve",
        "",
        f"`jaco.solve(grid, (0, 0), ({w['side'] - 1}, {w['side'] - 1}), \"as\", n_ants={w['n_ants']}, "
        f"n_iters={w['n_iters']}, progress=False)` on the same map, 1 device (with `progress=True` in the row "
        "that says so: the program that keeps a bar moving, as a terminal or a notebook runs by default). "
        f"Each series calls seeds 0–{R['solve_seeds'] - 1} in turn, the numba loop too: the two draw different "
        "random numbers, and one seed's can make one side's ants walk a quarter more steps than the other's.",
        "",
        R["solve_table"],
        "",
    ]
    if "city" in R:
        c = R["city"]
        lines += [
            "### IACA on a 256x256 city map",
            "",
            f"`jaco.solve(grid, {c['start']}, {c['goal']}, \"iaca\", seed=0, n_ants=50, n_iters=100)` on the bundled "
            f"MovingAI `{c['map']}` (the longest scenario, optimum {c['optimal']:.1f}): backtracking ants, local "
            "pheromone update during the walk.",
            "",
            table(["walk", "first call (with compile), s", "later call, s", "length"],
                  [[WALK_NAMES[k], c[k]["first_s"], c[k]["best_s"], c[k]["length"]] for k in R["walks"] if k in c]),
            "",
        ]
    lines += [
        f"Peak memory (max RSS of the process): {R['rss_after_sweep_mib']:.0f} MiB after the sweeps, "
        f"{R['rss_peak_mib']:.0f} MiB at the end of the benchmark.",
        "",
    ]
    if "scaling" in R:
        sc = R["scaling"]
        lines += [
            "### Scaling",
            "",
            f"`jaco.solve` (1 device) with each walk and the native loop, {sc['iters']} iterations, AS defaults, "
            "random maps p = 0.25, start (0, 0), goal in the opposite corner, default step limit 4·(H + W) (at most "
            "the free cells). Compile s = first call − best call.",
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
    if not on_cpu:
        walk = R["walks"][0]
        lines += [
            f"Reading: on the {m['device_kind']} a batch pays and a single run does not. The sweep of "
            f"{w['n_configs']} configurations takes {R['throughput'][walk + '_1']['wall_s']:.3g} s, "
            f"{R['ratio'][walk]['steps']:.2f}× the numba loop's ant-steps per second on one CPU core, and the "
            "batch table grows to hundreds of runs at about the same time per call; one `solve` is bound by "
            "the latency of the walk's loop (each step of the lock-step walk is a few device kernels, whatever "
            "the batch holds), so it is slower than the loop on a CPU core.",
            "",
            "The speed targets are CPU figures (the section measured on a CPU); per core and cycles per step "
            "describe no GPU work.",
            f"Peak memory: {R['rss_peak_mib']:.0f} MiB of host memory.",
            "",
        ]
        return "\n".join(lines)
    main_walk = R["walks"][0]
    ratio = R["ratio"][main_walk]["steps"]
    per_core = R["ratio"][main_walk]["per_core"]
    s0 = sv[main_walk]
    lines += [
        f"### Targets ({WALK_NAMES[main_walk]})",
        "",
        f"- per core (real ant-steps per CPU second, the sweep): ≥ {TARGETS['per_core']:.0f}× the numba loop "
        f"(milestone {TARGETS['per_core_milestone']:.0f}×): {per_core:.2f}× ({R['ratio'][main_walk]['per_core_engine']}) "
        f"— {verdict(per_core >= TARGETS['per_core'])}; milestone {verdict(per_core >= TARGETS['per_core_milestone'])}.",
        f"- one `solve` ≥ {TARGETS['solve_speedup']:.1f}× faster than the numba loop's run: "
        f"{s0['speedup']:.2f}×, the median of {s0['pairs']} pairs of calls "
        f"(best rounds: {s0['median_ms']:.1f} ms against {s0['native_run_ms']:.1f} ms) — "
        f"{verdict(s0['speedup'] >= TARGETS['solve_speedup'])}. In blocks of consecutive calls (a loop of "
        f"solves, as `timeit` times it): {s0['speedup_blocks']:.2f}×; the target is judged on the pairs.",
        f"- wall time, all cores: {ratio:.2f}× the numba loop's real ant-steps/s (no target).",
        f"- compile ≤ {TARGETS['compile_s']:.0f} s: {s0['compile_s']:.2f} s — {verdict(s0['compile_s'] <= TARGETS['compile_s'])}.",
    ]
    if "city" in R and main_walk in R["city"]:
        t = R["city"][main_walk]["best_s"]
        lines.append(f"- IACA on `{R['city']['map']}` ≤ {TARGETS['city_s']:.1f} s: {t:.2f} s — {verdict(t <= TARGETS['city_s'])}.")
    lines += [f"- peak memory: {R['rss_peak_mib']:.0f} MiB (no target).", ""]
    return "\n".join(lines)


def main(argv=None):
    args = parse_args(argv)
    set_device_count(args.devices)
    R = run_benchmark(args)
    R["date"] = _dt.datetime.now().strftime("%Y-%m-%d %H:%M")
    argv_shown = sys.argv[1:] if argv is None else list(argv)
    for flag in ("--out", "--json"):  # where the figures went is no part of how they were made
        while flag in argv_shown[:-1]:
            i = argv_shown.index(flag)
            del argv_shown[i : i + 2]
    backend = R["machine"]["backend"]
    env = [] if backend == "cpu" else [f"JAX_PLATFORMS={os.environ.get('JAX_PLATFORMS', backend)}"]
    command = " ".join(env + ["python experiments/bench_throughput.py"] + [shlex.quote(a) for a in argv_shown])
    text = report(R, command)
    print()
    print(text)
    if args.out:
        write_section(Path(args.out), section(backend), text)
        print(f"wrote {args.out}")
    if args.json:
        write_text(args.json, json.dumps(R, indent=1, default=lambda o: o.tolist() if hasattr(o, "tolist") else str(o)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
