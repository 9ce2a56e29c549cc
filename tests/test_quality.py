"""Quality against the exact optimum (mmas and acs within 5 % of it in median).

Random maps 20-40 cells a side with 10-30 % obstacles and MovingAI 32x32 scenarios, 50 ants x
100 iterations, default parameters. Every returned path is checked cell by cell.
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


def _checked_gaps(variant):
    """Gap to the exact optimum on every query (inf where the run failed); every returned path
    is checked cell by cell and is no shorter than the optimum."""
    gaps = []
    for grid, start, goal in _queries():
        r = jaco.solve(grid, start, goal, variant, seed=0, n_ants=50, n_iters=100)
        if r.success:
            assert validate_path(grid, r.path, start, goal) == []
            assert r.length >= r.optimal - 1e-4
        gaps.append(r.gap)
    return gaps


@pytest.mark.parametrize("variant", ["mmas", "acs"])
def test_median_gap_within_five_percent(variant):
    gaps = _checked_gaps(variant)
    assert np.median(gaps) <= 0.05, gaps
    assert np.isfinite(gaps).mean() >= 0.8, gaps


# The papers' planners, default parameters. Measured (seed 0): failures / median gap
# iaaco 1 / 0.5 %, iaaco-printed 1 / 0.0 %, apf-aco 1 / 5.4 %, pf-aco 0 / 1.9 %, chaos-aco 1;
# the bound on the median gap leaves margin for other engines' random streams.
@pytest.mark.parametrize("variant", ["iaaco", "iaaco-printed", "apf-aco", "pf-aco", "chaos-aco"])
def test_papers_planners_succeed_on_all_but_one(variant):
    gaps = _checked_gaps(variant)
    assert np.sum(~np.isfinite(gaps)) <= 1, gaps
    assert np.median(gaps) <= 0.15, gaps
