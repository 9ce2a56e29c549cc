#!/usr/bin/env python
"""Sweeps at scale: 10,000 configurations on a 32x32 map under a memory budget, and jaco's memory
estimate against XLA's own memory analysis of the compiled sweep.

    python experiments/bench_sweep.py                 # full run, updates BENCHMARKS.md
    python experiments/bench_sweep.py --smoke --json out.json   # tiny sizes, writes nothing else

Scale: a Latin hypercube of 10,000 configurations (alpha in [0.5, 4], beta in [1, 8], rho in
[0.02, 0.5] log-uniform) × 1 seed on ``random_map(32, 0.2, seed=0)``, start (0, 0), goal (31, 31),
through one ``jaco.sweep`` call with the default 2 GiB budget (smoke: 64 MiB). Each case runs in a
fresh process, so its peak resident memory (``ru_maxrss``) is its own; the growth is the peak minus
the resident memory just before the sweep (after importing jax and building the design).

Estimate: for every registered variant, ``jaco.research.sweeps.plan_sweep`` compiles a 64-configuration
chunk (50 ants, 100 iterations, 32x32) and reports the bytes per configuration from XLA's memory
analysis beside ``bytes_per_run``'s first guess and the earlier one-colony formula.

Nothing here asserts a time; ``tests/test_sweeps.py`` runs ``--smoke`` and checks the memory.
"""

from __future__ import annotations

import argparse
import datetime as _dt
import json
import os
import platform
import resource
import shlex
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(HERE))
from report import write_section, write_text  # noqa: E402 (the experiments' shared helpers)

SECTION = "bench_sweep"
RANGES = {"alpha": (0.5, 4.0), "beta": (1.0, 8.0), "rho": (0.02, 0.5)}
FULL = dict(configs=10_000, n_ants=20, n_iters=20, budget=2 << 30, variants=["mmas", "daca"], estimate=True)
SMOKE = dict(configs=10_000, n_ants=8, n_iters=5, budget=64 << 20, variants=["as"], estimate=False)


def rss_mib() -> float:
    """Resident memory now (Linux /proc; the peak is ru_maxrss)."""
    with open("/proc/self/statm") as f:
        pages = int(f.read().split()[1])
    return pages * os.sysconf("SC_PAGE_SIZE") / 2**20


def peak_rss_mib() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0  # Linux: KiB


def worker(variant: str, configs: int, n_ants: int, n_iters: int, budget: int) -> dict:
    """One scale case, in this (fresh) process."""
    import jaco

    grid = jaco.maps.random_map(32, 0.2, seed=0)
    design = jaco.research.designs.latin_hypercube(0, configs, RANGES, log=["rho"])
    before = rss_mib()
    t0 = time.perf_counter()
    table = jaco.sweep(grid, (0, 0), (31, 31), variant, design, seeds=1, n_ants=n_ants, n_iters=n_iters,
                       memory_budget=budget)
    wall = time.perf_counter() - t0
    peak = peak_rss_mib()
    summary = jaco.summarize(table).sort_values(["gap_mean", "length_mean"], kind="stable")
    best = summary.iloc[0]
    return dict(
        variant=variant, rows=len(table), n_ants=n_ants, n_iters=n_iters, wall_s=wall,
        rss_before_mib=before, rss_peak_mib=peak, rss_growth_mib=peak - before,
        success_rate=float(table.success.mean()), optimal=float(table.optimal.iloc[0]),
        best={k: float(best[k]) for k in ("alpha", "beta", "rho", "length_mean", "gap_mean")},
        median_gap=float(table.gap[table.success].median()) if table.success.any() else None, plan=table.attrs["sweep"],
    )


def estimates(variants) -> list[dict]:
    import jaco
    from jaco.engine.walk import pad_steps

    grid = jaco.maps.random_map(32, 0.2, seed=0)
    rows = []
    for name in variants:
        plan = jaco.research.sweeps.plan_sweep(grid, (0, 0), (31, 31), name, seeds=64, n_ants=50, n_iters=100, devices=1)
        s = pad_steps(jaco.engine.checks.default_steplimit(grid))
        old = 2 * (50 * grid.n_cells + 5 * 4 * s * 50 + 4 * 4 * 8 * grid.n_cells + 16 * 100)
        rows.append(dict(variant=name, old=old, estimate=plan["bytes_per_config_estimate"],
                         measured=plan["bytes_per_config_measured"], chunk_bytes=plan["bytes_per_chunk"]))
        print(f"estimate {name}: {rows[-1]}", flush=True)
    return rows


def machine() -> dict:
    import jax
    import jaxlib

    def git(*a):
        try:
            return subprocess.run(["git", *a], cwd=ROOT, capture_output=True, text=True, timeout=10).stdout.strip()
        except (OSError, subprocess.SubprocessError):
            return "?"

    return dict(cpus=os.cpu_count(), python=platform.python_version(), jax=jax.__version__, jaxlib=jaxlib.__version__,
                platform=platform.platform(), commit=git("rev-parse", "--short", "HEAD"),
                load=os.getloadavg()[0], memory_gib=os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") / 2**30)


def mib(b) -> str:
    return f"{b / 2**20:,.1f}"


def report(R: dict, command: str) -> str:
    m = R["machine"]
    lines = [
        "## Sweeps at scale (`experiments/bench_sweep.py`)",
        "",
        f"Command: `{command}` (run {R['date']}, {R['total_s']:.0f} s in all; jaco at commit {m['commit']}). "
        f"Machine: {m['cpus']} CPUs, {m['memory_gib']:.0f} GiB; {m['platform']}; Python {m['python']}, jax {m['jax']} / "
        f"jaxlib {m['jaxlib']}; 1 XLA device. Load average at start {R['load_start']:.2f}, at end {m['load']:.2f} (the machine is shared).",
        "",
        "A Latin hypercube of 10,000 configurations (α ∈ [0.5, 4], β ∈ [1, 8], ρ ∈ [0.02, 0.5] log-uniform) × 1 seed "
        "on `random_map(32, 0.2, seed=0)` (819 free cells), start (0, 0), goal (31, 31), default step limit, one "
        "`jaco.sweep` call per row below, each in a fresh process. Peak RSS is the process's `ru_maxrss`; growth is "
        "the peak minus the resident memory just before the call (jax imported, design built). Bytes per chunk: "
        "XLA's memory analysis of the compiled chunk (arguments + outputs + temporaries).",
        "",
        "| variant | ants × iterations | runs | budget MiB | chunks × runs | compiles | MiB per chunk (compiled) | "
        "peak RSS MiB | growth MiB | wall s | success | median gap (successful runs) | best (α, β, ρ): mean gap |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for c in R["scale"]:
        p, b = c["plan"], c["best"]
        lines.append(
            f"| {c['variant']} | {c['n_ants']} × {c['n_iters']} | {c['rows']:,} | {mib(p['memory_budget'])} | "
            f"{p['chunks']} × {p['chunk']:,} | {p['compiles']} | {mib(p['bytes_per_chunk'])} | {c['rss_peak_mib']:,.0f} | "
            f"{c['rss_growth_mib']:,.0f} | {c['wall_s']:.1f} | {c['success_rate']:.2f} | {'–' if c['median_gap'] is None else format(100 * c['median_gap'], '.1f') + ' %'} | "
            f"({b['alpha']:.2f}, {b['beta']:.2f}, {b['rho']:.3f}): {100 * b['gap_mean']:.1f} % |"
        )
    within = all(c["rss_peak_mib"] < 8 * 1024 for c in R["scale"])
    lines += ["", f"Every case finished within 8 GiB of resident memory: {'yes' if within else 'NO'}.", ""]
    if R.get("estimate"):
        lines += [
            "### Memory per configuration: estimate against XLA",
            "",
            "Bytes one configuration adds to a compiled chunk (64 configurations, 50 ants × 100 iterations, the same "
            "32x32 map): XLA's memory analysis per configuration (chunk bytes / 64, so the fixed part is spread over "
            "the chunk), `jaco.research.sweeps.bytes_per_run`'s first guess (the sweep's starting point; the analysis decides), "
            "and the one-colony formula used before (2 × tabu + step buffers + pheromone + history).",
            "",
            "| variant | XLA KiB/config | estimate KiB | estimate / XLA | old formula KiB | old / XLA |",
            "|---|---|---|---|---|---|",
        ]
        for e in R["estimate"]:
            lines.append(
                f"| {e['variant']} | {e['measured'] / 1024:,.0f} | {e['estimate'] / 1024:,.0f} | "
                f"{e['estimate'] / e['measured']:.2f} | {e['old'] / 1024:,.0f} | {e['old'] / e['measured']:.2f} |"
            )
        low = [e["variant"] for e in R["estimate"] if e["estimate"] < e["measured"]]
        lines += [
            "",
            "The guess is fitted to the shared engine with one and two colonies. Variants whose guess is below "
            f"XLA's ({', '.join(low) if low else 'none'}) keep more per iteration than the shared engine's buffers; for them the first "
            "compiled chunk may exceed the budget, and the sweep then compiles a smaller one (one extra compile) "
            "before running anything: the budget holds either way.",
            "",
        ]
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--smoke", action="store_true", help="tiny sizes (8 ants × 5 iterations, 64 MiB budget)")
    ap.add_argument("--out", default=None, help="markdown file to update (default BENCHMARKS.md; none with --smoke)")
    ap.add_argument("--json", default=None, help="also write every figure as JSON to this file")
    ap.add_argument("--worker", nargs=5, metavar=("VARIANT", "CONFIGS", "ANTS", "ITERS", "BUDGET"), help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    os.environ.setdefault("JAX_PLATFORMS", "cpu")
    if args.worker:
        v, n, a, it, b = args.worker
        print(json.dumps(worker(v, int(n), int(a), int(it), int(b))))
        return 0
    cfg = SMOKE if args.smoke else FULL
    out = None if args.smoke and args.out is None else Path(args.out or ROOT / "BENCHMARKS.md")
    t0 = time.perf_counter()
    R = dict(config=cfg, scale=[], load_start=os.getloadavg()[0])
    for variant in cfg["variants"]:
        cmd = [sys.executable, __file__, "--worker", variant, str(cfg["configs"]), str(cfg["n_ants"]),
               str(cfg["n_iters"]), str(cfg["budget"])]
        r = subprocess.run(cmd, capture_output=True, text=True)
        if r.returncode:
            sys.stderr.write(r.stderr)
            raise SystemExit(f"the {variant} case failed")
        R["scale"].append(json.loads(r.stdout.strip().splitlines()[-1]))
        print(f"scale {variant}: {R['scale'][-1]}", flush=True)
    if cfg["estimate"]:
        import jaco

        R["estimate"] = estimates(sorted(jaco.PLANNERS))
    R["machine"] = machine()
    R["total_s"] = time.perf_counter() - t0
    R["date"] = _dt.datetime.now().strftime("%Y-%m-%d %H:%M")
    shown = sys.argv[1:] if argv is None else list(argv)
    text = report(R, " ".join(["python experiments/bench_sweep.py"] + [shlex.quote(a) for a in shown]))
    print(text)
    if out is not None:
        write_section(out, SECTION, text)
        print(f"wrote {out}")
    if args.json:
        write_text(args.json, json.dumps(R, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
