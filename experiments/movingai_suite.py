#!/usr/bin/env python
"""Every planner on every bundled MovingAI map against the scenarios' exact optima.

    python experiments/movingai_suite.py                    # the full suite, updates docs/results.md
    python experiments/movingai_suite.py --smoke --out DIR  # tiny sizes, into DIR

For each bundled MovingAI map (``jaco.maps.BUNDLED``: the MovingAI grid and MAPF benchmarks, 16×16
to 512×512) the suite takes ``--scenarios`` scenarios spread over the scenario file's range of
optimal lengths (from a short one to the longest, i.e. over its buckets) and runs every planner —
the registered ones and a set of compositions of their components (``jaco.compose``) — on all of
them with ``--seeds`` seeds, each planner without and with local search (``--local-search``, by
default the octile shortcut: ``"<planner>+shortcut"``, ``compose(..., local_search="shortcut")``),
at the fixed budget (50 ants × 100 iterations) and, for each map's
best three at the fixed budget (or the planners named by ``--larger-planners``), at a larger one
(100 × 300). Each (map, planner, budget) is one batched ``jaco.sweep`` over the queries × seeds.
It records per run: success, length, the gap to the scenario's optimum; per batch: the time per
query. ``--update`` runs the suite in parts: the CSV keeps the other planners' rows, the best
three are ranked over the kept and the new rows together, and a kept planner pushed out of a
map's best three loses its larger-budget rows there, so the parts add up to one full run.

Outputs (into ``--out``, default ``docs/``): ``results.md``'s ``movingai_suite`` section (success
rate and gap median/quartiles per map and planner, then per planner by the scenario's rank in its
map's length range (the MovingAI buckets), time per query; then each planner with local search
against itself without, a paired Wilcoxon signed-rank test over the (map, query, seed) runs),
``figures/movingai_suite_gap.png`` (median gap against optimal length, one line per planner),
``figures/movingai_suite_local_search.png`` (every run's gap with local search against without)
and ``movingai_suite.csv`` (every run). Nothing here asserts a time or a gap.
"""

from __future__ import annotations

import argparse
import math
import sys
import textwrap
import time
from pathlib import Path

import numpy as np

from jaco.outputs import atomic_path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(HERE))
from report import fixed as decimals  # noqa: E402 (the experiments' shared helpers)
from report import output_dir, table, write_section, write_text  # noqa: E402

SECTION = "movingai_suite"

#: Compositions across the sources (beyond the registered planners' own): every construct with
#: another source's heuristic and rule. The suite's findings (docs/results.md) say which help.
COMPOSITIONS = (
    dict(construct="backtrack", heuristic="iaaco", rule="iaca"),
    dict(construct="backtrack", heuristic="distance", rule="iaca"),
    dict(construct="backtrack", heuristic="chaos", rule="iaca"),
    dict(construct="backtrack", heuristic="apf", rule="iaca"),
    dict(construct="backtrack", heuristic="iaca", rule="mmas"),
    dict(construct="backtrack", heuristic="iaca", rule="acs"),
    dict(construct="double", heuristic="iaaco", rule="acs"),
    dict(construct="dying", heuristic="iaaco", rule="mmas"),
)

#: The maps on which the "selected" planner is chosen (a sweep over the compositions and their β, γ);
#: it is then reported on every map, and counts as tuned only on these.
SELECT_MAPS = ("arena.map", "den312d.map", "room-32-32-4.map", "maze-32-32-2.map")
SELECT_AXES = {"beta": [4.0, 8.0, 16.0], "gamma": [4.0, 16.0]}

FULL = dict(scenarios=5, seeds=3, budget=(50, 100), larger=(100, 300), maps=None, select=SELECT_MAPS,
            select_scenarios=3, select_seeds=2)
SMOKE = dict(scenarios=2, seeds=1, budget=(6, 4), larger=(8, 6), maps=["empty-16-16.map", "room-32-32-4.map"],
             select=("empty-16-16.map",), select_scenarios=1, select_seeds=1)


def parse_args(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--smoke", action="store_true", help="tiny sizes: two small maps, two planners, to check that it runs")
    ap.add_argument("--out", type=Path, default=None,
                    help="folder for results.md, figures/ and the CSV (default docs/; with --smoke a temporary folder)")
    ap.add_argument("--maps", nargs="*", default=None, help="bundled map files (default: every MovingAI map)")
    ap.add_argument("--planners", nargs="*", default=None,
                    help="planners: registered names and composition names, with a local search as '<name>+shortcut' "
                    "(default: all registered + the compositions, each without and with --local-search; "
                    "none after the flag: only the selected one)")
    ap.add_argument("--local-search", default="shortcut", metavar="NAME",
                    help="the local search the default planners also run with (default shortcut; none: without)")
    ap.add_argument("--larger-planners", nargs="*", default=None,
                    help="planners also run at the larger budget (default: the best three at the fixed budget; "
                    "none after the flag: no larger budget)")
    ap.add_argument("--scenarios", type=int, default=None, help="scenarios per map")
    ap.add_argument("--seeds", type=int, default=None, help="seeds per scenario")
    ap.add_argument("--update", action="store_true",
                    help="keep the rows of the (map, planner) pairs not run now from the existing CSV in --out "
                    "(run the suite in parts)")
    ap.add_argument("--steplimit-scale", type=float, default=None, metavar="S",
                    help="run only the fixed budget, with S times 4·(H + W) as the step limit (at most the free cells), "
                    "reported as a budget of its own")
    ap.add_argument("--skip", nargs="*", default=(), help="registered planners to leave out")
    ap.add_argument("--no-select", action="store_true", help="leave out the planner selected on other maps")
    ap.add_argument("--select-maps", nargs="+", default=None, metavar="MAP",
                    help="choose the selected planner on these maps instead (default: arena, den312d, room-32-32-4, "
                    "maze-32-32-2); its label names them, and it sits beside the default selection in the table")
    ap.add_argument("--report", action="store_true",
                    help="run nothing: write results.md's section and the figure again from the CSV in --out")
    args = ap.parse_args(argv)
    import jaco

    # names checked before any run: one line, not a traceback after minutes of work
    maps = sorted(n for n in jaco.maps.BUNDLED if n.endswith(".map"))
    for m in (args.maps or []) + (args.select_maps or []):
        if m not in maps:
            ap.error(f"unknown MovingAI map {m!r}; bundled: {', '.join(maps)}")
    for n in (args.planners or []) + list(args.skip):
        try:
            jaco.planners.registry.get_planner(n)
        except jaco.JacoError as e:
            ap.error(str(e))
    searches = jaco.planners.compose.COMPONENTS["local_search"]
    if args.local_search not in searches:
        ap.error(f"unknown local search {args.local_search!r}; valid: {', '.join(searches)}")
    args.out = output_dir(args.out, args.smoke)
    return args


def scenarios(jaco, map_name: str, k: int):
    """``k`` scenarios of the map's own scenario file, spread over its optimal lengths: the
    shortest non-trivial, then evenly spaced ranks up to the longest."""
    scen_name = next(n for n in jaco.maps.BUNDLED if n.endswith(".scen") and
                     (n == map_name + ".scen" or n.startswith(map_name.removesuffix(".map") + "-even")))
    rows = sorted((s for s in jaco.maps.load_scenarios(jaco.maps.bundled(scen_name)) if s.optimal > 0),
                  key=lambda s: (s.optimal, s.bucket))
    picks = sorted({round(i) for i in np.linspace(0, len(rows) - 1, k)})
    return [rows[i] for i in picks]


def planners(jaco, names, local_search: str = "none"):
    """``(label, variant, fixed parameters)`` of every planner to run: ``names``, or every registered
    planner and composition, each also with ``local_search`` (unless ``"none"``)."""
    if names is not None:
        vs = [jaco.planners.registry.get_planner(n) for n in names]
    else:
        vs = list(jaco.PLANNERS.values()) + [jaco.compose(**kw) for kw in COMPOSITIONS]
        if local_search != "none":
            vs += [jaco.planners.registry.with_local_search(v, local_search) for v in vs]
    return [(short(v.name), v, {}) for v in vs]


def select_maps(cfg, args) -> tuple:
    return tuple(args.select_maps or cfg["select"])


def selected_prefix(cfg, args) -> str:
    """How the selected planner's label starts: ``selected:``, or ``selected on MAPS:`` when it was
    chosen on other maps than the default ones."""
    maps = select_maps(cfg, args)
    return "selected:" if maps == tuple(cfg["select"]) else f"selected on {', '.join(m.removesuffix('.map') for m in maps)}:"


def select(jaco, cfg, args):
    """The composition and β, γ (the latter where it has one) with the lowest median gap over
    the selection maps (``SELECT_MAPS`` or ``--select-maps``; failures count as infinite; ties
    broken by success, then mean gap), as ``(label, variant, params)``: one sweep per composition
    and map over ``SELECT_AXES``."""
    candidates = [jaco.compose(**kw) for kw in COMPOSITIONS] if not args.smoke else [jaco.compose(construct="backtrack", rule="iaca")]
    gaps: dict = {}
    for m in select_maps(cfg, args):
        grid = jaco.maps.load(jaco.maps.bundled(m))
        scen = scenarios(jaco, m, cfg["select_scenarios"])
        n_ants, n_iters = cfg["budget"]
        for v in candidates:
            axes = {k: vals for k, vals in SELECT_AXES.items() if k in v.params}
            tab = jaco.sweep(grid, [s.start for s in scen], [s.goal for s in scen], v, params=axes,
                             seeds=cfg["select_seeds"], n_ants=n_ants, n_iters=n_iters)
            for key, g in tab.groupby(list(axes)):
                key = key if isinstance(key, tuple) else (key,)
                gaps.setdefault((v.name, tuple(zip(axes, key))), []).extend(g.gap.tolist())
    # lowest median gap; ties (small maps are often solved optimally in most runs) go to the higher
    # success rate, then the lower mean gap of the successful runs
    (name, fixed), gap = min(gaps.items(), key=lambda kv: gap_rank(kv[1]))
    v = jaco.planners.registry.get_planner(name)
    label = selected_prefix(cfg, args) + " " + short(name) + " (" + ", ".join(f"{k}={x:g}" for k, x in fixed) + ")"
    print(f"{label}, median gap {100 * float(np.median(gap)):.1f} % on its maps", flush=True)
    return label, v, dict(fixed)


def short(name: str) -> str:
    """A composition's name without the components left at their defaults (for tables)."""
    if not name.startswith("compose("):
        return name
    parts = [p.strip() for p in name[len("compose("):-1].split(",")]
    keep = [p.split("=")[1] for p in parts if p not in ("transition=roulette", "schedule=constant", "cost=length")]
    return "+".join(keep)  # a local search comes last: "backtrack+chaos+iaca+q0+shortcut"


def run_suite(cfg, args, checkpoint=lambda rows: None, earlier=()):
    """The suite's rows; ``checkpoint(rows)`` after each map, so a long run keeps what it finished.
    ``earlier``: rows of an earlier run kept beside these (``--update``), ranked with them when the
    best three at the fixed budget are chosen for the larger one."""
    import jaco

    # smallest map first: a long run that is cut short still reports every smaller map
    map_names = args.maps or cfg["maps"] or sorted((n for n in jaco.maps.BUNDLED if n.endswith(".map")),
                                                   key=lambda n: jaco.maps.load(jaco.maps.bundled(n)).n_cells)
    names = args.planners if args.planners is not None else (["mmas", "iaca", "iaca+shortcut"] if args.smoke else None)
    plist = [p for p in planners(jaco, names, args.local_search) if p[0] not in args.skip]
    if not args.no_select:
        plist.append(select(jaco, cfg, args))
    k, n_seeds = args.scenarios or cfg["scenarios"], args.seeds or cfg["seeds"]
    labels = {p[0] for p in plist}
    prefix = selected_prefix(cfg, args)
    redone = lambda r: r["planner"] in labels or (r["planner"].startswith(prefix) and not args.no_select)  # noqa: E731
    others = [r for r in earlier if not redone(r)]
    rows = []
    for m in map_names:
        grid = jaco.maps.load(jaco.maps.bundled(m))
        scen = scenarios(jaco, m, k)
        starts, goals = [s.start for s in scen], [s.goal for s in scen]
        budgets = (("fixed", cfg["budget"]), ("larger", cfg["larger"]))
        steplimit = None  # the default: 4·(H + W), at most the free cells; twice that for backtracking ants
        if args.steplimit_scale:  # times the default of every planner before backtracking ants got twice it
            budgets = ((f"fixed, {args.steplimit_scale:g}× step limit", cfg["budget"]),)
            steplimit = int(min(grid.free.sum(), round(args.steplimit_scale * 4 * (grid.height + grid.width))))
        for budget, (ants, iters) in budgets:
            for label, v, fixed in plist:
                if budget == "larger" and label not in larger_set(args, others + rows, m, cfg):
                    continue
                t0 = time.perf_counter()
                tab = jaco.sweep(grid, starts, goals, v, params={k: [x] for k, x in fixed.items()}, seeds=n_seeds,
                                 n_ants=ants, n_iters=iters, steplimit=steplimit)
                seconds = time.perf_counter() - t0
                per_query = seconds / (len(scen) * n_seeds)
                for (_, r) in tab.iterrows():
                    cells = ((r["start_row"], r["start_col"]), (r["goal_row"], r["goal_col"])) if "start_row" in r else None
                    q = 0 if cells is None else next(i for i, s in enumerate(scen) if (tuple(s.start), tuple(s.goal)) == cells)
                    rows.append(dict(map=m.removesuffix(".map"), size=f"{grid.height}x{grid.width}", planner=label,
                                     budget=budget, ants=ants, iters=iters, query=q, bucket=scen[q].bucket,
                                     optimal=scen[q].optimal, seed=int(r["seed"]), success=bool(r["success"]),
                                     length=float(r["length"]), gap=float(r["gap"]), seconds_per_query=per_query))
                ok = np.mean([x["success"] for x in rows[-len(tab):]])
                print(f"{m:28s} {budget:6s} {label:45s} success {ok:4.0%}  {per_query:6.2f} s/query", flush=True)
        checkpoint(rows)
    return rows


def larger_set(args, rows, map_name, cfg) -> set:
    """Planners that also run at the larger budget on this map: ``--larger-planners``, or
    :func:`best_three` of ``rows``."""
    if args.larger_planners is not None:
        return set(args.larger_planners)
    return best_three(rows, map_name.removesuffix(".map"))


def best_three(rows, map_name: str) -> set:
    """The three planners with the best median gap at the fixed budget on this map (failures
    counting as infinite); ties (small maps are often solved optimally by many) to the higher
    success rate, the lower mean gap of the successful runs, then the name, so that the choice
    does not depend on the order of the rows."""
    by = {}
    for r in rows:
        if r["map"] == map_name and r["budget"] == "fixed":
            by.setdefault(r["planner"], []).append(r["gap"])

    return set(sorted(by, key=lambda p: (*gap_rank(by[p]), p))[:3])


def gap_rank(gaps) -> tuple:
    """Sort key of a planner's gaps (failures infinite): the median, then the higher success rate,
    then the lower mean gap of the successful runs."""
    g = np.asarray(gaps, float)
    ok = np.isfinite(g)
    return float(np.median(g)), -float(ok.mean()), float(g[ok].mean()) if ok.any() else np.inf


def by_size(part) -> list:
    """The maps of ``part``, smallest first (by cells, then name)."""
    sizes = part.drop_duplicates("map").set_index("map")["size"]
    return sorted(sizes.index, key=lambda m: (math.prod(int(x) for x in sizes[m].split("x")), m))


def ordered(labels, suffix: str = "+shortcut") -> list:
    """The planners in the order they first appear, each with local search right after itself."""
    labels = list(dict.fromkeys(labels))
    bases = list(dict.fromkeys(p.removesuffix(suffix) if p.removesuffix(suffix) in labels else p for p in labels))
    return [x for b in bases for x in (b, b + suffix) if x in labels]


def quartiles(g):
    g = np.asarray(g, float)
    if not np.isfinite(g).any():
        return "failed"
    # An infinite gap (a failed run) sorts last; a quartile that falls next to one is ∞.
    top = g[np.isfinite(g)].max()
    q1, q2, q3 = (np.inf if x > top else x for x in np.percentile(np.minimum(g, 2 * top + 1), [25, 50, 75]))
    f = lambda x: "∞" if not math.isfinite(x) else decimals(100 * x, 1)  # noqa: E731
    return f"{f(q2)} [{f(q1)}, {f(q3)}]"


def report(df, command: str, fig_rel: str) -> str:
    lines = [
        "## Every planner on the MovingAI maps (`experiments/movingai_suite.py`)",
        "",
        f"Command(s): `{command}`. Gap = (length − optimum)/optimum against the scenario file's optimum "
        "(jaco.exact reproduces every one); a failed run (no ant reached the goal) counts as an infinite gap. "
        "Cells: median gap in % [quartiles]; success = share of runs (scenarios × seeds) that found a path.",
        "",
    ]
    for budget in sorted(set(df.budget), key=lambda b: (b != "fixed", b == "larger", b)):
        part = df[df.budget == budget]
        ants, iters = int(part.ants.iloc[0]), int(part.iters.iloc[0])
        name, _, steps = budget.partition(", ")
        steps = f"; {steps} (at most the free cells)" if steps else ""
        lines += [f"### {name.capitalize()} budget: {ants} ants × {iters} iterations{steps}", ""]
        maps = by_size(part)
        plist = ordered(part.planner)
        head = ["planner"] + [f"{m} ({part[part['map'] == m]['size'].iloc[0]})" for m in maps]
        body = []
        for p in plist:
            row = [p]
            for m in maps:
                g = part[(part.planner == p) & (part["map"] == m)]
                row.append("–" if g.empty else f"{quartiles(g.gap)}; {100 * g.success.mean():.0f}%")
            body.append(row)
        lines += [table(head, body), ""]
        tq = part.groupby(["map", "planner"]).seconds_per_query.first().groupby("map").max()
        lines += ["Slowest planner's time per query (s, batched): " + ", ".join(f"{m} {tq[m]:.1f}" for m in maps), ""]
    lines += by_length(df[df.budget == "fixed"])
    lines += [f"![median gap against optimal length]({fig_rel})", ""]
    lines += with_and_without(df[df.budget == "fixed"], LOCAL_FIGURE)
    return "\n".join(lines)


def by_length(part) -> list:
    """Lines of a table: each planner at the fixed budget over all maps, by the scenario's rank
    among its map's scenarios (shortest … longest), with the MovingAI buckets those scenarios
    come from."""
    ranks = sorted(set(part["query"]))
    order = {p: i for i, p in enumerate(ordered(part.planner))}
    head = ["planner"]
    for q in ranks:
        b = part[part["query"] == q].bucket
        head.append(f"{'shortest' if q == ranks[0] else 'longest' if q == ranks[-1] else f'query {q + 1}'} "
                    f"(buckets {b.min()}–{b.max()})")
    body = [[p] + [f"{quartiles(g[g['query'] == q].gap)}; {100 * g[g['query'] == q].success.mean():.0f}%" for q in ranks]
            for p, g in sorted(part.groupby("planner", sort=False), key=lambda pg: order[pg[0]])]
    return ["#### Fixed budget, all maps, by scenario length", "",
            "Each map's scenarios ranked by optimal length (a map's scenarios come from its scenario file's "
            "buckets: bucket k holds optimal lengths in [4k, 4k + 4)); median gap in % [quartiles]; success.", "",
            table(head, body), ""]


LOCAL_FIGURE = "figures/movingai_suite_local_search.png"
#: A failed run's gap in the paired test: worse than any run that found a path.
FAILED = 1e6


def pairs(part, suffix: str = "+shortcut"):
    """``{planner with local search: DataFrame of (map, query, seed) -> gap without, gap with}`` for
    every planner of ``part`` (one budget) whose label ends in ``suffix`` and whose label without it
    is there too."""
    import pandas as pd

    out = {}
    labels = set(part.planner)
    for p in ordered(part.planner):
        base = p.removesuffix(suffix)
        if p.endswith(suffix) and base in labels:
            key = ["map", "query", "seed"]
            a = part[part.planner == base].set_index(key).gap.rename("without")
            b = part[part.planner == p].set_index(key).gap.rename("with")
            out[p] = pd.concat([a, b], axis=1, join="inner")
    return out


def paired_test(g) -> dict:
    """Does local search lower the gap? ``jaco.research.compare`` of the two forms over the paired
    (map, query, seed) runs of ``g`` (columns ``without``, ``with``): the two-sided Wilcoxon
    signed-rank test (a failed run counts as worse than any success, both failed is a tie, ties keep
    their ranks split between the signs). Returns the counts of better / equal / worse pairs with
    local search and the p-value."""
    import pandas as pd

    from jaco.research.compare import compare

    pairing = list(g.index.names)  # map, query, seed (and planner, pooled)
    runs = g.reset_index()
    long = pd.concat([runs.assign(form=f, gap=runs[f]) for f in ("without", "with")], ignore_index=True)
    c = compare(long[["form", *pairing, "gap"]], by="form", pairing=pairing, n_boot=1)
    row = c.pairwise.iloc[0]
    with_better = row.a_better if row.a == "with" else row.b_better
    return dict(better=int(with_better), equal=int(row.ties), worse=int(row.pairs - row.ties - with_better),
                p=float(row.p))


def with_and_without(part, fig_rel: str) -> list:
    """Lines of the section comparing each planner with local search to itself without (one budget):
    gaps over all maps and over the three largest, success, and the paired test."""
    both = pairs(part)
    if not both:
        return []
    largest = by_size(part)[-3:]

    def row(label, g):
        t = paired_test(g)
        big = g[g.index.get_level_values("map").isin(largest)]
        return [label, quartiles(g["without"]), quartiles(g["with"]), quartiles(big["without"]), quartiles(big["with"]),
                f"{100 * np.isfinite(g['without']).mean():.0f}%", f"{100 * np.isfinite(g['with']).mean():.0f}%",
                f"{t['better']} / {t['equal']} / {t['worse']}", f"{t['p']:.2g}"]

    body = [row(p.removesuffix("+shortcut"), g) for p, g in both.items()]
    if len(both) > 1:
        body.append(row("all planners (pooled)", pd_concat(both, names=["planner"])))
    return best_with_local_search(part) + [
        "#### With and without local search (fixed budget)", "",
        "Each planner against itself with the octile shortcut (`+shortcut`) on the same (map, query, seed) runs: "
        f"median gap in % [quartiles] over all maps and over the three largest ({', '.join(largest)}), success over "
        "all maps, how many runs are better / equal / worse with it, and the p-value of the two-sided Wilcoxon "
        "signed-rank test of the pairs by `jaco.research.compare` (a failed run counts as worse than any success, "
        "both failed is a tie; ties keep their ranks, split between the signs).", "",
        table(["planner", "gap without", "gap with", "gap without, 3 largest", "gap with, 3 largest", "success without",
               "success with", "better / equal / worse", "p (Wilcoxon)"], body), "",
        f"![gap with local search against without]({fig_rel})", ""]


def best_with_local_search(part, suffix: str = "+shortcut") -> list:
    """Lines: the planner with local search that solves the most runs (then: the lowest mean of
    its per-map median gaps), its success and median gap on every map, and its gaps on the
    longest query of each map (one per seed)."""
    mine = part[part.planner.str.endswith(suffix)]
    if mine.empty:
        return []

    def rank(p):
        g = mine[mine.planner == p]
        med = g.groupby("map").gap.median()
        ok = np.isfinite(g.gap)
        return -float(ok.mean()), float(np.mean(np.minimum(med, FAILED))), float(g.gap[ok].mean()) if ok.any() else np.inf

    best = min(dict.fromkeys(mine.planner), key=rank)
    g = mine[mine.planner == best]
    maps = by_size(g)
    per_map = ", ".join(f"{m} {quartiles(g[g['map'] == m].gap).split(' ')[0]} % ({100 * g[g['map'] == m].success.mean():.0f}%)"
                        for m in maps)
    longest = []
    for m, x in ((m, g[g["map"] == m]) for m in maps):
        q = x[x.optimal == x.optimal.max()]
        longest.append(f"{m} (optimum {q.optimal.iloc[0]:.1f}) " + " / ".join(
            "failed" if not np.isfinite(v) else f"{decimals(100 * v, 1)} %" for v in q.sort_values("seed").gap))
    return ["#### The best planner with local search", "",
            f"**{best}** (the most runs solved, then the lowest mean of its per-map median gaps, then the lowest "
            "mean gap): solved "
            f"{int(g.success.sum())} of {len(g)} runs. Median gap (success) per map: {per_map}.", "",
            "Its gap on each map's longest query, one per seed: " + "; ".join(longest) + ".", ""]


def pd_concat(frames, **kw):
    import pandas as pd

    return pd.concat(frames if isinstance(frames, dict) else list(frames), **kw)


def local_search_figure(part, path: Path):
    """Every paired run's gap with local search against its gap without (one budget), one colour per map."""
    import matplotlib

    matplotlib.use("Agg")  # a script, not a notebook
    import matplotlib.pyplot as plt

    both = pairs(part)
    if not both:
        return
    pooled = pd_concat(both.values()).reset_index()
    finite = np.concatenate([g[np.isfinite(g)] for g in (pooled["without"], pooled["with"])])
    top = 100 * max(float(finite.max()) if finite.size else 1.0, 1.0) * 2  # failed runs drawn on this line
    fig, ax = plt.subplots(figsize=(7, 6))
    colours = plt.get_cmap("tab20")(np.r_[0:20:2, 1:20:2])  # the dark shades first: eleven maps told apart
    for i, m in enumerate(by_size(part)):
        g = pooled[pooled["map"] == m]
        x = np.where(np.isfinite(g["without"]), 100 * g["without"], top)
        y = np.where(np.isfinite(g["with"]), 100 * g["with"], top)
        ax.scatter(x, y, s=8, alpha=0.6, color=colours[i % 20], label=m)
    ax.plot([0, top], [0, top], color="grey", lw=0.8)
    ax.axhline(top, color="grey", lw=0.5, ls=":")
    ax.axvline(top, color="grey", lw=0.5, ls=":")
    ax.set_xscale("symlog", linthresh=1)
    ax.set_yscale("symlog", linthresh=1)
    ax.set_xlim(left=0)
    ax.set_ylim(bottom=0)
    ax.set_xlabel("gap without local search (%); failed runs on the dotted line")
    ax.set_ylabel("gap with local search (%)")
    ax.set_title("Every run (planner, map, query, seed):\nthe gap with the octile shortcut against without", fontsize=10)
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1), borderaxespad=0)
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=110, format="png")
    plt.close(fig)


def figure(df, path: Path):
    import matplotlib

    matplotlib.use("Agg")  # a script, not a notebook
    import matplotlib.pyplot as plt

    part = df[df.budget == "fixed"]
    fig, ax = plt.subplots(figsize=(12, 7))
    colours = [*plt.get_cmap("tab20")(np.linspace(0, 1, 20)), *plt.get_cmap("tab20b")(np.linspace(0, 1, 20))]
    bases = list(dict.fromkeys(p.removesuffix("+shortcut") for p in part.planner))
    groups = dict(tuple(part.groupby("planner", sort=False)))
    for p, g in ((p, groups[p]) for p in ordered(part.planner)):  # a planner's colour, dashed with local search
        i = bases.index(p.removesuffix("+shortcut"))
        pts = g.groupby("optimal").gap.median().sort_index()
        y = np.where(np.isfinite(pts.values), 100 * pts.values, np.nan)
        ax.plot(pts.index, y, marker="o", ms=3, lw=1, color=colours[i % len(colours)],
                ls="--" if p.endswith("+shortcut") else ("-" if i < len(colours) else ":"), label=textwrap.fill(p, 48))
    ax.set_xscale("log")
    ax.set_yscale("symlog", linthresh=1)
    ax.set_ylim(bottom=0)  # a gap is never negative
    ax.set_xlabel("optimal length of the scenario (cells)")
    ax.set_ylabel("median gap over seeds (%); gaps of failed runs left out")
    ax.set_title("Gap to the optimum on the MovingAI maps, 50 ants × 100 iterations (dashed: with local search)")
    ax.legend(fontsize=5, loc="upper left", bbox_to_anchor=(1.01, 1), borderaxespad=0, ncol=2 if len(bases) > 20 else 1)
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=110, format="png")
    plt.close(fig)


def main(argv=None):
    import pandas as pd

    args = parse_args(argv)
    cfg = SMOKE if args.smoke else FULL
    out = args.out
    t0 = time.perf_counter()
    shown = sys.argv[1:] if argv is None else list(argv)
    command = " ".join(["python experiments/movingai_suite.py", *shown])
    csv = out / "movingai_suite.csv"
    kept = pd.read_csv(csv) if (args.update or args.report) and csv.exists() else None

    def publish(df, footer=""):
        """The figure and results.md's section from the table ``df``."""
        figure(df, out / "figures" / "movingai_suite_gap.png")
        local_search_figure(df[df.budget == "fixed"], out / LOCAL_FIGURE)
        text = report(df, "`; `".join(dict.fromkeys(df.command)), "figures/movingai_suite_gap.png")
        write_section(out / "results.md", SECTION, text + footer + "\n", intro="# Results\n")
        return text

    if args.report:
        if kept is None:
            raise SystemExit(f"--report: no {csv} to report")
        print(publish(kept))
        return 0

    def write(rows):
        df = pd.DataFrame(rows).assign(command=command)
        if kept is not None:  # the other planners' rows of an earlier run
            # a (map, planner) run again replaces its old rows; a new selection replaces the old one's
            # on the same maps
            again = set(zip(df["map"], df.planner, df.budget))
            prefix = selected_prefix(cfg, args)
            redo = kept.apply(lambda r: (r["map"], r.planner, r.budget) in again or (
                r.planner.startswith(prefix) and df.planner.str.startswith(prefix).any()), axis=1)
            old = kept[~redo.astype(bool)]
            if args.larger_planners is None:  # the larger budget stays with each map's best three
                best = {m: best_three(pd.concat([old, df]).to_dict("records"), m) for m in set(old["map"])}
                old = old[[r.budget != "larger" or r.planner in best[r.map] for r in old.itertuples()]]
            df = pd.concat([old, df], ignore_index=True)
        out.mkdir(parents=True, exist_ok=True)
        write_text(csv, df.to_csv(index=False, lineterminator="\n"))
        return publish(df, f"\nTime of the last run: {time.perf_counter() - t0:.0f} s.")

    earlier = kept.to_dict("records") if kept is not None else ()
    print(write(run_suite(cfg, args, checkpoint=write, earlier=earlier)))
    print(f"wrote {out / 'results.md'}, {out / 'figures' / 'movingai_suite_gap.png'}, {csv}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
