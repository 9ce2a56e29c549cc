#!/usr/bin/env python
"""Rebuild Dong & Zhao 2021's table 1 (ACO, PF-ACO, APF-ACO: best length, mean iterations, mean
time and coverage over 100 runs) and compare IAACO (Miao et al. 2021) and chaos ACO (the chaos-ACO
paper from Xi'an Technological University) with AS, ACS and MMAS on length, turns, heading change,
safety and time. References and equations: docs/algorithms.md.

    python experiments/paper_tables.py                      # full run -> docs/results.md (its section) + figures
    python experiments/paper_tables.py --smoke --out DIR    # tiny sizes, for the tests

Maps: the look-alikes ``jaco.maps.named("simple-20")`` and ``named("complex-30")`` of Dong & Zhao
2021's figures 4 and 6 (the sources print no map; start and goal in ``grid.meta``). Miao et al. 2021
and the chaos-ACO paper do not describe their maps either (our copy of Miao et al. 2021 is a summary;
the chaos-ACO paper's figures and table 1 are not in its text), so their comparison runs on the same
two maps.

For every map and planner, the R independent runs (seeds 0..R-1) are ONE compiled batch: the
program ``jaco.sweep`` is built on (``jaco.engine.run.compiled_run(batched=True)``: runs vmapped, each run
equal to ``jaco.solve`` with its seed). It is called directly, not through ``jaco.sweep``, because
the sweep's table has no paths or histories, and turns, heading change and safety need every run's
path: going through both would compile every planner twice. The batch is compiled ahead of time
(``lower().compile()``), so the time per run (batch seconds / R) excludes compilation.

"ACO" of Dong & Zhao 2021 is its section 4.1: the random-proportional rule (6) with η =
1/(distance of the candidate to the goal) (the paper speaks of the heuristic's "greedy pull toward the goal") and the
global update (7, 8) on the iteration-best path, with the paper's tuned α = 2, β = 6, ρ = 0.7,
Q = 1. The APF rows are ``jaco.apf.plan`` alone (deterministic: one run). Lengths in cell units.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

import jaco
from jaco.engine import pheromone as ph
from jaco.engine.cost import path_length
from jaco.engine.planner import make_planner
from jaco.metrics import SAFETY_RADIUS, path_metrics, validate_path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from report import fixed as fmt  # noqa: E402 (the experiments' shared helpers)
from report import output_dir, write_section

MAPS = ["simple-20", "complex-30"]
BASE = ("alpha", "beta", "rho", "q", "tau0")  # the classic family's parameters
SQRT2 = math.sqrt(2.0)

#: Dong & Zhao 2021's "basic ACO" (its 4.1, eqs. 6–8) with the paper's tuned parameters (its 5).
ACO_003 = make_planner(
    "aco-003",
    "Dong & Zhao 2021, 4.1, eqs. 6, 7, 8; docs/algorithms.md §6",
    "The basic ACO of Dong & Zhao 2021: random-proportional rule (6), η = 1/(distance of the candidate to "
    "the goal), global update (7, 8) on the iteration-best path only, τ ← (1−ρ)τ + Q/L_ib.",
    BASE,
    dict(alpha=2.0, beta=6.0, rho=0.7, q=1.0, tau0=0.1),
    ph.chain(ph.init_constant(), ph.evaporate(), ph.deposit_iteration_best()),
)

#: Dong & Zhao 2021, table 1 (30×30 complex map, 100 runs each; MATLAB R2014a on an i5-5200U) and the text of
#: its 5.1 (20×20 simple map: best lengths; iterations = those of the best run to reach its optimum,
#: read from fig. 5). Lengths in metres with cell side Ra = 1, i.e. cell units.
PUBLISHED_003 = {
    "complex-30": {
        "ACO": dict(best=49.692, iters=30, time=12.2616, coverage=57.1),
        "PF-ACO": dict(best=47.936, iters=21, time=7.9159, coverage=71.23),
        "APF-ACO": dict(best=45.102, iters=11, time=3.3261, coverage=75.69),
    },
    "simple-20": {
        "ACO": dict(best=29.213),
        "PF-ACO": dict(best=28.627, iters=8),
        "APF-ACO": dict(best=28.627, iters=3),
    },
}
#: Straight start–goal distance in the paper's own coordinates: its start and goal are lattice
#: corners, (0, 0)→(20, 20) and (0, 30)→(30, 0); ours are the corner cells' centres, one cell nearer
#: along each axis (19·√2 and 29·√2).
PAPER_SG = {"simple-20": 20 * SQRT2, "complex-30": 30 * SQRT2}


def table1_planners() -> dict:
    """Dong & Zhao 2021's table 1 rows: label -> (Planner, parameter values). PF-ACO and APF-ACO run with
    the paper's printed α = 2, β = 6, ρ = 0.7, Q = 1 (``jaco.planners.apf_guided.PAPER_PARAMS``), not jaco's
    defaults (β = 20, ρ = 0.3, chosen for dense maps: docs/planners.md)."""
    from jaco.planners.apf_guided import PAPER_PARAMS

    out = {"ACO": (ACO_003, {})}
    for label, name in (("PF-ACO", "pf-aco"), ("APF-ACO", "apf-aco")):
        if name in jaco.PLANNERS:
            out[label] = (jaco.PLANNERS[name], PAPER_PARAMS)
    return out


COMPARE = (("AS", "as"), ("ACS", "acs"), ("MMAS", "mmas"), ("IAACO", "iaaco"), ("chaos ACO", "chaos-aco"))


def compare_planners(labels=None) -> dict:
    """The comparison of Miao et al. 2021 and the chaos-ACO paper: the classic baselines and the
    two papers' planners (``labels``: a subset of :data:`COMPARE`'s labels; default all)."""
    out = {}
    for label, name in COMPARE:
        if (labels is None or label in labels) and name in jaco.PLANNERS:
            out[label] = jaco.PLANNERS[name]
    return out


def has_apf() -> bool:
    """Whether the standalone potential-field planner ``jaco.apf.plan`` exists."""
    try:
        from jaco import apf
    except ImportError:
        return False
    return hasattr(apf, "plan")


def _batch(grid, variant, seeds, n_ants, n_iters, steplimit, values=None):
    """Compile, then run and time, R runs of ``variant`` on ``grid`` as ONE batched program
    (``jaco.engine.run.compiled_run(batched=True)``: seeds vmapped, the program ``jaco.sweep`` runs);
    returns the raw outputs (numpy, leading axis = run), the parameters and the seconds of the run
    alone (compiled ahead of time with ``lower().compile()``, so compilation is outside the timing)."""
    import jax

    from jaco.engine.checks import params_from, resolve_params
    from jaco.engine.problem import make_problem, stack
    from jaco.engine.run import compiled_run
    from jaco.engine.shape import RunShape

    start, goal = grid.meta["start"], grid.meta["goal"]
    base = resolve_params(variant, dict(values or {}), where=variant.name)
    n = len(seeds)
    params = params_from({k: np.full(n, v, np.float64) for k, v in base.items()}, (n,))
    keys = jax.vmap(jax.random.key)(np.asarray(seeds, np.uint32))
    problems = stack([make_problem(grid, start, goal)])
    run = compiled_run(variant, RunShape(n_ants, n_iters, steplimit), batched=True)
    exe = run.lower(keys, problems, params).compile()
    t0 = time.perf_counter()
    out = jax.block_until_ready(exe(keys, problems, params))
    seconds = time.perf_counter() - t0
    return jax.tree.map(lambda a: np.asarray(a)[0], jax.device_get(out)), base, seconds


def run_cell(grid, variant, runs, n_ants, n_iters, steplimit, values=None, rs=SAFETY_RADIUS):
    """R runs (seeds 0..R-1) of one planner on one map (parameter ``values`` over its defaults):
    the table's figures, per-run path figures (means over the successful runs) and the shortest
    run as a :class:`jaco.Result`."""
    import jax

    from jaco.engine.result import path_cells, to_result
    from jaco.engine.shape import RunShape

    start, goal = grid.meta["start"], grid.meta["goal"]
    seeds = list(range(runs))
    raw, base, seconds = _batch(grid, variant, seeds, n_ants, n_iters, steplimit, values)
    optimal = float(make_optimal(grid))
    ok = np.isfinite(raw.best_cost)
    lengths = np.where(ok, raw.best_length.astype(np.float64) * grid.cell_size, np.inf)
    per_run = []
    for i in np.flatnonzero(ok):
        path = path_cells(grid, start, raw.best_cells[i])
        problems = validate_path(grid, path, start, goal)
        assert not problems, (grid.name, variant.name, i, problems)
        per_run.append(path_metrics(grid, path, optimal=optimal, rs=rs))
    best_i = int(np.argmin(lengths))
    best = to_result(
        jax.tree.map(lambda a: a[best_i], raw), grid=grid, planner=variant, start=start, goal=goal,
        optimal=optimal / grid.cell_size, seed=seeds[best_i], params=base,
        shape=RunShape(n_ants, n_iters, steplimit),
    )
    iters = raw.best_iteration[ok].astype(float) + 1

    def mean(key):
        return float(np.mean([m[key] for m in per_run])) if per_run else math.inf

    return dict(
        best=float(lengths.min()),
        mean=float(lengths[ok].mean()) if ok.any() else math.inf,
        optimal=optimal,
        success=float(ok.mean()),
        iters=float(iters.mean()) if ok.any() else math.inf,
        coverage=float(np.mean(raw.covered)) / grid.n_free,
        time=seconds / runs,
        turns=mean("turns"),
        heading=mean("heading_change"),
        safety=mean("safety"),
        clearance=mean("mean_clearance"),
        best_metrics=path_metrics(grid, best.path, optimal=optimal, rs=rs) if best.success else None,
        result=best,
        runs=runs,
        cost_is_length=variant.cost is path_length,
    )


def make_optimal(grid) -> float:
    """Exact optimal length (Dijkstra, the ants' move model) from the map's start to its goal."""
    from jaco.exact import distance_field

    return float(distance_field(grid, grid.meta["goal"])[tuple(grid.meta["start"])]) * grid.cell_size


def apf_cell(grid, kind="improved", rs=SAFETY_RADIUS):
    """The APF planner alone (``jaco.apf.plan``, deterministic): one run, timed (numpy; the time
    includes the query's validation and the exact optimum that ``plan`` computes)."""
    from jaco import apf

    start, goal = grid.meta["start"], grid.meta["goal"]
    apf.plan(grid, start, goal, kind=kind)  # warm-up (the classic kind jits its potential table)
    t0 = time.perf_counter()
    r = apf.plan(grid, start, goal, kind=kind)
    seconds = time.perf_counter() - t0
    m = path_metrics(grid, r.path, optimal=r.optimal, rs=rs) if r.success else None
    return dict(
        best=r.length, mean=r.length, optimal=r.optimal, success=float(r.success), iters=math.nan,
        coverage=r.coverage, time=seconds, turns=m["turns"] if m else math.inf,
        heading=m["heading_change"] if m else math.inf, safety=m["safety"] if m else math.inf,
        clearance=m["mean_clearance"] if m else math.inf, best_metrics=m, result=r, runs=1, cost_is_length=True,
    )


def multi_cost(c, weights) -> float:
    """Miao et al. 2021's J = kL·L + kS·S + kE·E of the best path (same S and E for every planner)."""
    m = c["best_metrics"]
    if not m:
        return math.inf
    return weights[0] * m["length"] + weights[1] * m["safety"] + weights[2] * m["heading_change"]


def pct(x, digits=1):
    """Percent; a float32 length a hair below the float64 optimum prints 0.0, not -0.0."""
    return fmt(None if x is None else 100 * (0.0 if abs(x) < 1e-6 else x), digits)


def table1_lines(rows: dict) -> list:
    lines = [
        "| map | planner | runs | best | mean | optimum | gap % | success | mean iterations | s/run | coverage % | best / L_SG |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for name, cells in rows.items():
        sg = straight(jaco.maps.named(name))
        for label, c in cells.items():
            gap = (c["best"] - c["optimal"]) / c["optimal"] if math.isfinite(c["best"]) else None
            lines.append(
                f"| {name} | {label} | {c['runs']} | {fmt(c['best'])} | {fmt(c['mean'])} | {fmt(c['optimal'])} | {pct(gap)} | "
                f"{fmt(c['success'])} | {fmt(c['iters'], 1) if math.isfinite(c['iters']) else '–'} | {fmt(c['time'], 3)} | "
                f"{pct(c['coverage'])} | {fmt(c['best'] / sg, 3)} |"
            )
    return lines


def published_lines(rows: dict) -> list:
    lines = [
        "| map | planner | paper best | paper best / L_SG | ours best | ours best / L_SG | paper iterations | ours iterations | paper s/run | ours s/run | paper coverage % | ours coverage % |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for name, pub in PUBLISHED_003.items():
        if name not in rows:
            continue
        sg = straight(jaco.maps.named(name))
        for label, p in pub.items():
            c = rows[name].get(label)
            if c is None:
                lines.append(f"| {name} | {label} | {p['best']} | {fmt(p['best'] / PAPER_SG[name], 3)} | (not built) | | | | | | | |")
                continue
            lines.append(
                f"| {name} | {label} | {p['best']} | {fmt(p['best'] / PAPER_SG[name], 3)} | {fmt(c['best'])} | {fmt(c['best'] / sg, 3)} | "
                f"{p.get('iters', '–')} | {fmt(c['iters'], 1)} | {p.get('time', '–')} | {fmt(c['time'], 3)} | "
                f"{p.get('coverage', '–')} | {pct(c['coverage'])} |"
            )
    return lines


def compare_lines(rows: dict, weights) -> list:
    lines = [
        "| map | planner | best | mean | gap % (best) | success | turns | heading change (rad) | safety S | mean clearance | J of best | mean iterations | s/run |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for name, cells in rows.items():
        for label, c in cells.items():
            gap = (c["best"] - c["optimal"]) / c["optimal"] if math.isfinite(c["best"]) else None
            lines.append(
                f"| {name} | {label} | {fmt(c['best'])} | {fmt(c['mean'])} | {pct(gap)} | {fmt(c['success'])} | "
                f"{fmt(c['turns'], 1)} | {fmt(c['heading'])} | {fmt(c['safety'])} | {fmt(c['clearance'])} | "
                f"{fmt(multi_cost(c, weights))} | {fmt(c['iters'], 1)} | {fmt(c['time'], 3)} |"
            )
    return lines


def straight(grid) -> float:
    (r0, c0), (r1, c1) = grid.meta["start"], grid.meta["goal"]
    return math.hypot(r1 - r0, c1 - c0) * grid.cell_size


def claims_003(rows: dict) -> list:
    """Dong & Zhao 2021's claims, checked on our runs."""
    out = []
    for name, cells in rows.items():
        if not {"ACO", "PF-ACO", "APF-ACO"} <= set(cells):
            continue
        a, p, f = cells["ACO"], cells["PF-ACO"], cells["APF-ACO"]
        checks = [
            ("best length APF-ACO ≤ PF-ACO ≤ ACO", f["best"] <= p["best"] + 1e-6 <= a["best"] + 2e-6),
            ("mean iterations APF-ACO < PF-ACO < ACO", f["iters"] < p["iters"] < a["iters"]),
            ("time per run APF-ACO < PF-ACO < ACO", f["time"] < p["time"] < a["time"]),
            ("coverage APF-ACO > PF-ACO > ACO", f["coverage"] > p["coverage"] > a["coverage"]),
        ]
        out.append(f"- {name}: " + "; ".join(f"{what}: **{'holds' if ok else 'does not hold'}**" for what, ok in checks) + ".")
    return out


def apf_lines(rows: dict) -> list:
    """What the potential-field planners do alone, and how far the colonies guided by them get."""
    out = []
    for name, cells in rows.items():
        if "APF alone" not in cells:
            continue
        a, opt = cells["APF alone"], cells["APF alone"]["optimal"]
        text = f"- {name}: the improved APF alone "
        text += (f"reaches the goal with length {fmt(a['best'])} (gap {pct((a['best'] - opt) / opt)} %)"
                 if math.isfinite(a["best"]) else "does not reach the goal")
        c = cells.get("classic APF alone")
        if c is not None:
            text += "; the classic APF alone " + (f"reaches it with {fmt(c['best'])}" if math.isfinite(c["best"])
                                                  else "stops in a local minimum (PF-ACO falls back to the Euclidean distance there)")
        if "APF-ACO" in cells:
            f = cells["APF-ACO"]
            text += f"; APF-ACO's best of {f['runs']} runs is {fmt(f['best'])}, its mean {fmt(f['mean'])}"
        out.append(text + ".")
    return out


def claims_compare(rows: dict) -> list:
    """The chaos-ACO paper: shorter paths, fewer turns, less search time than the traditional ACO (AS);
    Miao et al. 2021: IAACO's paths shorter and safer than those of the classic planners."""
    out = []
    for name, cells in rows.items():
        if "AS" in cells and "chaos ACO" in cells:
            a, c = cells["AS"], cells["chaos ACO"]
            checks = [
                ("shorter mean length", c["mean"] < a["mean"], f"{fmt(c['mean'])} vs {fmt(a['mean'])}"),
                ("fewer mean turns", c["turns"] < a["turns"], f"{fmt(c['turns'], 1)} vs {fmt(a['turns'], 1)}"),
                ("less time per run", c["time"] < a["time"], f"{fmt(c['time'], 3)} vs {fmt(a['time'], 3)} s"),
            ]
            out.append(
                f"- {name}, chaos ACO against AS (the chaos-ACO paper's claims): "
                + "; ".join(f"{what} **{'holds' if ok else 'does not hold'}** ({nums})" for what, ok, nums in checks) + "."
            )
        if "IAACO" in cells:
            i = cells["IAACO"]
            others = {k: v for k, v in cells.items() if k in ("AS", "ACS", "MMAS")}
            if others:
                shorter = [k for k, v in others.items() if i["mean"] < v["mean"]]
                safer = [k for k, v in others.items() if i["safety"] < v["safety"]]
                smoother = [k for k, v in others.items() if i["heading"] < v["heading"]]
                faster = [k for k, v in others.items() if i["time"] < v["time"]]
                out.append(
                    f"- {name}, IAACO (Miao et al. 2021) against {', '.join(others)}: shorter mean length than "
                    f"{', '.join(shorter) or 'none'}; lower mean safety cost S than {', '.join(safer) or 'none'}; "
                    f"less mean heading change than {', '.join(smoother) or 'none'}; faster than {', '.join(faster) or 'none'}."
                )
    return out


def figures(name, grid, cells, figdir: Path, prefix: str) -> None:
    start, goal = grid.meta["start"], grid.meta["goal"]
    paths = {f"{k} ({fmt(c['best'])})": c["result"].path for k, c in cells.items() if c["result"].success}
    fig = jaco.plot.plot_paths(grid, paths, start=start, goal=goal, title=f"{name}: best path of each planner")
    jaco.plot.save(fig, figdir / f"{prefix}_paths_{name}.png")
    curves = [(k, c) for k, c in cells.items() if c["runs"] > 1]
    if curves:
        hist = [{"best": c["result"].history["best"], "mean": c["result"].history["mean"]} for _, c in curves]
        labels = [k if c["cost_is_length"] else f"{k} (its cost J, not the length)" for k, c in curves]
        fig = jaco.plot.plot_convergence(hist, label=labels, optimal=cells[curves[0][0]]["optimal"],
                                         title=f"{name}: best run of each planner")
        jaco.plot.save(fig, figdir / f"{prefix}_convergence_{name}.png")


def run_table1(maps, runs, n_ants, n_iters, steplimit, with_apf=True, verbose=True) -> dict:
    """Dong & Zhao 2021's table 1 on ``maps``: label -> figures, per map."""
    rows = {}
    for name in maps:
        grid = jaco.maps.named(name)
        limit = steplimit or jaco.engine.checks.default_steplimit(grid)
        cells = {label: run_cell(grid, v, runs, n_ants, n_iters, limit, values)
                 for label, (v, values) in table1_planners().items()}
        if with_apf and has_apf():
            cells["APF alone"] = apf_cell(grid, "improved")
            cells["classic APF alone"] = apf_cell(grid, "classic")
        rows[name] = cells
        if verbose:
            print(f"{name:12s} optimum {fmt(cells['ACO']['optimal'])}  " + "  ".join(f"{k} {fmt(c['best'])}" for k, c in cells.items()), flush=True)
    return rows


def run_compare(maps, runs, n_ants, n_iters, steplimit, labels=None, verbose=True) -> dict:
    """The comparison of Miao et al. 2021 and the chaos-ACO paper on ``maps``: label -> figures, per map."""
    rows = {}
    for name in maps:
        grid = jaco.maps.named(name)
        limit = steplimit or jaco.engine.checks.default_steplimit(grid)
        rows[name] = {label: run_cell(grid, v, runs, n_ants, n_iters, limit) for label, v in compare_planners(labels).items()}
        if verbose:
            print(f"{name:12s} " + "  ".join(f"{k} {fmt(c['best'])}/{fmt(c['turns'], 1)}t" for k, c in rows[name].items()), flush=True)
    return rows


NOTES = """How to read the comparison honestly:

- **Maps are look-alikes.** Dong & Zhao 2021 print no map, only figures; `simple-20` and `complex-30` are
  rebuilt with fixed seeds (`jaco.maps.named`: scattered rectangles, connected by construction). The
  same name is a different map, so lengths cannot match cell for cell; the exact optimum of *our* map
  is given beside every length.
- **Cell vs corner coordinates.** The paper's start and goal are lattice corners ((0, 0)→(20, 20),
  (0, 30)→(30, 0)), ours the centres of the corner cells, one cell nearer along each axis: every
  paper length carries about √2 more. The column "best / L_SG" divides by the straight start–goal
  distance of each convention (20√2, 30√2 for the paper; 19√2, 29√2 for ours), which makes the two
  comparable up to the map difference.
- **ACO** is the paper's basic ACO (4.1: rule (6), iteration-best global update (7, 8), η =
  1/distance to the goal) with the paper's α = 2, β = 6, ρ = 0.7, Q = 1 — the same values as PF-ACO
  and APF-ACO. The paper prints no ant count and no iteration budget; ours are given in the command.
- **Iterations** are the mean over the successful runs of the iteration at which each run found its
  best path (1-based). On `simple-20` the paper's 8 and 3 are the iterations of its best run to reach
  its optimum (fig. 5), not means.
- **Time.** The paper's seconds are MATLAB R2014a per run on an i5-5200U; ours are seconds per run
  after compilation on a shared 2-core CPU (one compiled batch of R runs / R). Only ratios
  between planners can be compared; the APF rows time `jaco.apf.plan` (numpy, including its input
  validation and the exact optimum it reports).
- **Coverage** is the paper's definition — free cells visited by any ant during the whole run / free
  cells, mean over the runs — but it grows with the budget of ants × iterations, which the paper does
  not print. Ours, {cov_lo:.0f}–{cov_hi:.0f} % for the three colonies, cannot be set beside the paper's
  57–76 % as a like-for-like figure. The APF rows' coverage is the share of cells on their one path.
- **Miao et al. 2021 and the chaos-ACO paper print no numbers we can compare with**: the copy of
  Miao et al. 2021 we worked from is a summary with its parameters only, and the chaos-ACO paper's
  table 1 ("simulation data") lost its numbers in the text. Their comparison is therefore ours alone, on the same two maps, with each planner's registered
  defaults (IAACO: m = 50, Nmax = 100 of the paper) and the same S (`jaco.metrics.safety_cost`, radius
  {rs:g}), E (total heading change) and J = {kl:g}·L + {ks:g}·S + {ke:g}·E (Miao et al. 2021's weights) for
  every planner. "turns", "heading change", "safety S", "mean clearance" (cells from the nearest
  obstacle centre, the map's edge counting as obstacle) are means over the successful runs' paths;
  "J of best" is J of the shortest run's path. IAACO minimises J, not the length: its convergence
  curve is in J.
"""


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--smoke", action="store_true", help="tiny sizes, for the tests")
    ap.add_argument("--runs", type=int, default=100, help="independent runs R per map and planner (Dong & Zhao 2021: 100)")
    ap.add_argument("--compare-runs", type=int, default=100, help="runs per map and planner of the comparison of Miao et al. 2021 and the chaos-ACO paper")
    ap.add_argument("--ants", type=int, default=50)
    ap.add_argument("--iters", type=int, default=100)
    ap.add_argument("--steplimit", type=int, default=None, help="default: 4·(H+W), at most the free cells")
    ap.add_argument("--out", type=Path, default=None,
                    help="folder for the markdown and figures (default docs/; with --smoke a temporary folder)")
    args = ap.parse_args(argv)
    args.out = output_dir(args.out, args.smoke)
    maps, labels = list(MAPS), None
    if args.smoke:  # one map, and the comparison against AS only: few compilations
        maps, args.runs, args.compare_runs, args.ants, args.iters = ["simple-20"], 2, 2, 8, 4
        labels = ("AS", "IAACO", "chaos ACO")
    args.out.mkdir(parents=True, exist_ok=True)
    figdir = args.out / "figures"
    figdir.mkdir(exist_ok=True)
    t_all = time.perf_counter()
    rows1 = run_table1(maps, args.runs, args.ants, args.iters, args.steplimit)
    rows2 = run_compare(maps, args.compare_runs, args.ants, args.iters, args.steplimit, labels)
    for name in maps:
        grid = jaco.maps.named(name)
        figures(name, grid, rows1[name], figdir, "paper003")
        figures(name, grid, rows2[name], figdir, "paper_compare")
    total = time.perf_counter() - t_all

    iaaco = jaco.PLANNERS.get("iaaco")
    d = dict(iaaco.defaults) if iaaco is not None else {}
    weights = (d.get("k_len", 0.7), d.get("k_safe", 0.1), d.get("k_energy", 0.2))
    covs = [c["coverage"] for cells in rows1.values() for c in cells.values() if c["runs"] > 1]
    missing = [n for n in ("pf-aco", "apf-aco", "iaaco", "chaos-aco") if n not in jaco.PLANNERS]
    if not has_apf():
        missing.append("jaco.apf.plan")
    cmd = (f"python experiments/paper_tables.py{' --smoke' if args.smoke else ''} --runs {args.runs} --compare-runs {args.compare_runs} "
           f"--ants {args.ants} --iters {args.iters}" + (f" --steplimit {args.steplimit}" if args.steplimit else ""))
    lines = [
        "## Papers (Dong & Zhao 2021, Miao et al. 2021, the chaos-ACO paper): APF-ACO's table 1, IAACO and chaos ACO",
        "",
        f"Command: `{cmd}` ({total:.0f} s in all). Lengths in cell units. Step limit 4·(H+W) unless given. "
        "Figures: `docs/figures/paper003_*` and `docs/figures/paper_compare_*` (best path of each planner; "
        "convergence of each planner's best run).",
        "",
        NOTES.format(rs=SAFETY_RADIUS, kl=weights[0], ks=weights[1], ke=weights[2], cov_lo=100 * min(covs), cov_hi=100 * max(covs)),
    ]
    if missing:
        lines += [f"Not built when this ran (rows left out): {', '.join(missing)}.", ""]
    lines += [f"### Dong & Zhao 2021, table 1 layout (R = {args.runs} runs per planner and map)", ""]
    lines += table1_lines(rows1)
    lines += ["", "Beside the published numbers (Dong & Zhao 2021's table 1 and its 5.1):", ""]
    lines += published_lines(rows1)
    c1 = claims_003(rows1)
    if c1:
        lines += ["", "Dong & Zhao 2021's orderings, on our runs:", ""] + c1
    c1 = apf_lines(rows1)
    if c1:
        lines += ["", "The potential field alone:", ""] + c1
    lines += ["", f"### Miao et al. 2021 and the chaos-ACO paper: IAACO and chaos ACO against AS, ACS, MMAS (R = {args.compare_runs} runs)", ""]
    lines += compare_lines(rows2, weights)
    c2 = claims_compare(rows2)
    if c2:
        lines += ["", "The papers' claims, on our runs:", ""] + c2
    out = args.out / ("results_paper_smoke.md" if args.smoke else "results.md")
    write_section(out, "paper_tables", "\n".join(lines) + "\n")
    print(f"wrote {out} and figures in {figdir}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
