"""Quality against the exact optimum (mmas and acs within 5 % of it in median).

Random maps 20-40 cells a side with 10-30 % obstacles and MovingAI 32x32 scenarios, 50 ants x
100 iterations, default parameters, seeds 0-3; mmas's and acs's paths are checked cell by cell.
"""

import numpy as np
import pytest

import jaco
from jaco.metrics import validate_path


def _queries():
    out = []
    for n in (20, 30, 40):
        for p in (0.1, 0.2, 0.3):
            g = jaco.maps.random_map(n, p, seed=int(n * 10 + p * 100))
            out.append((g, (0, 0), (n - 1, n - 1)))
    for m, s in [("random-32-32-10", "random-32-32-10-even-10.scen"), ("room-32-32-4", "room-32-32-4-even-10.scen"), ("maze-32-32-2", "maze-32-32-2-even-10.scen")]:
        g = jaco.maps.load(jaco.maps.bundled(m + ".map"))
        rows = sorted(jaco.maps.load_scenarios(jaco.maps.bundled(s)), key=lambda x: -x.optimal)
        for x in (rows[len(rows) // 4], rows[len(rows) // 2]):
            out.append((g, x.start, x.goal))
    return out


SEEDS = range(4)  # one seed decides too little: a hard query fails in some seeds, not in others


def _gaps(variant):
    """Gap to the exact optimum of every query and seed (inf where the run failed), one batched
    sweep per query; no run is shorter than the optimum."""
    gaps = []
    for grid, start, goal in _queries():
        table = jaco.sweep(grid, start, goal, variant, seeds=SEEDS, n_ants=50, n_iters=100)
        ok = table.success.to_numpy()
        assert (table.length[ok] >= table.optimal[ok] - 1e-4).all()
        gaps += table.gap.tolist()
    return np.array(gaps)


@pytest.mark.slow  # 50 ants x 100 iterations on 15 queries x 4 seeds (test_iaca checks IACA's quality in the normal run)
@pytest.mark.parametrize("variant", ["mmas", "acs"])
def test_median_gap_within_five_percent_and_every_path_valid(variant):
    gaps = _gaps(variant)
    assert np.median(gaps) <= 0.05, gaps
    assert np.isfinite(gaps).mean() >= 0.8, gaps
    for grid, start, goal in _queries():  # seed 0 again, through solve, to check each path cell by cell
        r = jaco.solve(grid, start, goal, variant, seed=0, n_ants=50, n_iters=100)
        assert not r.success or validate_path(grid, r.path, start, goal) == []


# The papers' planners, default parameters. Measured (15 queries x seeds 0-3): failures of 60 /
# median gap: iaaco 5 / 1.0 %, iaaco-printed 6 / 0.7 %, apf-aco 11 / 2.3 %, pf-aco 6 / 3.4 %,
# chaos-aco 3 / 4.8 % (mmas 9 / 2.1 %, acs 0 / 1.6 %). The bounds leave margin for the spread
# between seeds.
# The papers' planners, with the slow checks.
@pytest.mark.slow
@pytest.mark.parametrize("variant", ["iaaco", "chaos-aco", "iaaco-printed", "apf-aco", "pf-aco"])
def test_papers_planners_fail_at_most_one_run_in_four(variant):
    gaps = _gaps(variant)
    assert np.sum(~np.isfinite(gaps)) <= len(gaps) // 4, gaps
    assert np.median(gaps) <= 0.15, gaps
