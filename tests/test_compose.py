"""Planners composed from components by name: every registered planner is a composition (and gives
the bits it gave before it was one), the
combinations that cannot work are clear errors, compositions are found by name (records rerun
them) and a sweep takes several planners as a categorical axis."""

import hashlib
import itertools
import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import jaco
from jaco.planners.compose import COMPONENTS, KINDS, compose, parse

GRID = jaco.maps.random_map(12, 0.2, seed=3)
ENDS = (GRID.meta["start"], GRID.meta["goal"])
TINY = dict(n_ants=10, n_iters=6)


PARTS = ("construct", "heuristic", "factor", "rule", "schedule", "cost", "transition", "pheromone_on", "local_search")


@pytest.mark.parametrize("name", sorted(jaco.PLANNERS))
def test_every_registered_planner_is_a_composition(name):
    """A registered planner is defined as ``compose(...)`` plus its own name and defaults: the
    composition it records has the very same functions and the same parameters."""
    planner = jaco.PLANNERS[name]
    composed = parse(planner.composition)
    assert composed is not None and composed.name == planner.composition
    for part in PARTS:
        assert getattr(planner, part) is getattr(composed, part), (name, part)
    assert set(planner.params) == set(composed.params)


def _kinds(name):
    inner = name[len("compose("):-1]
    return dict(part.strip().split("=") for part in inner.split(","))


def test_the_docs_table_of_registered_planners_is_their_compositions():
    text = (Path(__file__).resolve().parents[1] / "docs" / "compose.md").read_text(encoding="utf-8")
    rows = {}
    for line in text.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) == 1 + len(KINDS) and cells[0].startswith("`"):
            rows[cells[0].strip("`")] = dict(zip(KINDS, cells[1:]))
    assert rows == {name: _kinds(v.composition) for name, v in jaco.PLANNERS.items()}


def fingerprint(name: str) -> dict:
    """Hashes of one planner's run (tests/data/planner-fingerprints.json): a solve on the demo map
    (its path, history and final pheromone) and its length."""

    def h(*arrays):
        m = hashlib.sha256()
        for a in arrays:
            a = np.asarray(a)
            m.update(str(a.dtype).encode())
            m.update(a.tobytes())
        return m.hexdigest()[:16]

    g = jaco.maps.named("demo")
    r = jaco.solve(g, g.meta["start"], g.meta["goal"], name, seed=0, n_ants=10, n_iters=12, keep_pheromone=True)
    return {f"{name}/solve/0": [h(r.path, *[r.history[k] for k in sorted(r.history)], r.pheromone), float(r.length)]}


OLD = json.loads((Path(__file__).parent / "data" / "planner-fingerprints.json").read_text())["fingerprints"]


@pytest.mark.slow  # a program per planner
@pytest.mark.parametrize("name", sorted({k.split("/")[0] for k in OLD}))
def test_every_planner_equals_its_self_before_it_became_a_composition(name):
    """The fingerprints were taken at the commit before planners were compositions of components
    owning their parameters and state: every registered planner, a cost and local-search variant
    and three cross-source compositions give the same bits. (The file also holds each one's sweep
    hash from then; a sweep's rows equal single runs by the contract, tests/test_variants.py.)"""
    assert fingerprint(name) == {f"{name}/solve/0": OLD[f"{name}/solve/0"]}


def test_every_combination_composes_or_says_why_in_one_line():
    """Every choice of components either builds a planner or is refused with a one-line reason about
    the algorithm (no combination is refused for lack of room in the trail)."""
    reasons = ("needs construct 'dying'", "schedule must be 'constant'", "distances to the goal only",
               "one needs pheromone on cells, another on moves")
    built = refused = 0
    for combo in itertools.product(*(COMPONENTS[k] for k in KINDS)):
        kw = dict(zip(KINDS, combo))
        try:
            v = compose(**kw)
        except jaco.JacoError as e:
            assert "\n" not in str(e) and any(r in str(e) for r in reasons), str(e)
            refused += 1
        else:
            assert v.name == "compose(" + ", ".join(f"{k}={kw[k]}" for k in KINDS) + ")"
            built += 1
    assert built > 5 * refused > 0


@pytest.mark.slow  # a program per composition
def test_a_sample_of_the_compositions_runs_cleanly():
    """Five compositions drawn from every combination that builds: each runs, with no NaN in its
    history, a valid path whenever it succeeds, and most of them succeed on a small map."""
    import random

    combos = []
    for combo in itertools.product(*(COMPONENTS[k] for k in KINDS)):
        try:
            combos.append(compose(**dict(zip(KINDS, combo))))
        except jaco.JacoError:
            pass
    succeeded = 0
    for v in random.Random(0).sample(combos, 5):
        r = jaco.solve(GRID, *ENDS, v, seed=0, **TINY)
        assert not np.isnan(r.history["best"]).any() and not np.isnan(r.history["mean"]).any(), v.name
        if r.success:
            assert jaco.metrics.validate_path(GRID, r.path, *ENDS) == [], v.name
            succeeded += 1
    assert succeeded >= 3


def test_apf_guidance_with_policy_gradient_pheromone_works():
    """Two components with state of their own (the APF table, the logits and adam's moments) in one
    trail: the composition runs, finds a valid path, and its pheromone is the learned policy."""
    v = compose(heuristic="apf", rule="pg")
    assert "apf" in v.source and "pg" in v.name and "alpha" not in v.params
    r = jaco.solve(GRID, *ENDS, v, seed=0, keep_pheromone=True, **TINY)
    assert r.success and jaco.metrics.validate_path(GRID, r.path, *ENDS) == []
    lo, hi = np.exp(-jaco.planners.pg.LOGIT_MAX), np.exp(jaco.planners.pg.LOGIT_MAX)
    assert (r.pheromone >= lo * (1 - 1e-6)).all() and (r.pheromone <= hi).all() and not (r.pheromone == 1.0).all()


def test_names_defaults_and_the_same_object_for_the_same_arguments():
    v = compose(construct="backtrack", heuristic="iaaco", rule="mmas")
    assert v.name == (
        "compose(construct=backtrack, heuristic=iaaco, rule=mmas, transition=roulette, schedule=constant, cost=length)"
    )
    assert v is compose(construct="backtrack", heuristic="iaaco", rule="mmas") is parse(v.name)
    assert jaco.planners.registry.get_planner(v.name) is v
    assert v.pheromone_on == "cells"  # backtracking ants keep pheromone on cells
    d = dict(v.defaults)
    assert d["alpha"] == jaco.PLANNERS["mmas"].defaults["alpha"]  # the rule's α
    assert d["beta"] == jaco.PLANNERS["iaaco"].defaults["beta"] and d["lam"] == 3.0  # the heuristic's
    assert d["rho_local"] == jaco.PLANNERS["iaca"].defaults["rho_local"]  # the construct's
    assert compose(rule="acs").transition == "pseudo-random"  # the rule's own transition by default
    assert compose(rule="iaaco").schedule is jaco.planners.iaaco.q0_schedule
    assert "alpha" not in compose(rule="pg").params  # α ≡ 1 for the policy's logits
    assert {"alpha", "beta"}.isdisjoint(compose(construct="double", rule="idaca", schedule="idaca").params)
    assert parse("mmas") is None  # not a composition's name


@pytest.mark.parametrize(
    "kw, match",
    [
        (dict(construct="sideways"), "unknown construct 'sideways'; constructs: dying, double, backtrack"),
        (dict(heuristic="exact"), "unknown heuristic 'exact'"),
        (dict(rule="tsp"), "unknown rule 'tsp'"),
        (dict(transition="greedy"), "unknown transition 'greedy'"),
        (dict(cost=["length"]), "unknown cost"),
        (dict(construct="backtrack", rule="pg"), "rule 'pg' .* needs construct 'dying'"),
        (dict(construct="double", heuristic="apf"), "distances to the goal only"),
        (dict(rule="pg", schedule="idaca"), "schedule must be 'constant'"),
        (dict(construct="backtrack", rule="pg", heuristic="distance"), "needs construct 'dying'"),
    ],
)
def test_combinations_that_cannot_work_are_clear_errors(kw, match):
    with pytest.raises(jaco.JacoError, match=match):
        compose(**kw)


def test_a_name_that_is_not_a_composition_is_a_clear_error():
    with pytest.raises(jaco.JacoError, match="expected compose\\(kind=value"):
        parse("compose(walk=dying)")
    with pytest.raises(jaco.JacoError, match="unknown planner 'compose'"):
        jaco.solve(GRID, *ENDS, "compose", **TINY)


def test_a_composition_is_recorded_and_reruns_bit_for_bit(tmp_path):
    v = compose(construct="backtrack", heuristic="iaaco", rule="mmas")
    r = jaco.solve(GRID, *ENDS, v, seed=2, **TINY)
    assert r.variant == v.name
    r.save(tmp_path / "run.json")
    assert jaco.load_run(tmp_path / "run.json").rerun().matched


@pytest.mark.slow  # a program per planner (tests/test_sweeps.py and test_cli.py sweep several planners in the normal run)
def test_a_sweep_over_planners_is_a_categorical_axis(tmp_path):
    planners = ["mmas", compose(construct="backtrack", rule="mmas"), "compose(heuristic=iaaco, rule=acs)"]
    table = jaco.sweep(GRID, *ENDS, planners, params={"beta": [2.0, 6.0]}, seeds=2, **TINY)
    names = [jaco.planners.registry.get_planner(p).name for p in planners]
    assert list(table.columns[:1]) == ["planner"] and table["planner"].unique().tolist() == names
    assert len(table) == 3 * 2 * 2 and set(table.attrs["sweep"]) == set(names)
    for p, name in zip(planners, names):  # each planner's rows are its own sweep's
        alone = jaco.sweep(GRID, *ENDS, p, params={"beta": [2.0, 6.0]}, seeds=2, **TINY)
        mine = table[table["planner"] == name].dropna(axis=1, how="all").reset_index(drop=True)
        pd.testing.assert_frame_equal(mine, alone[mine.columns], check_exact=True)
    summary = jaco.summarize(table)
    assert len(summary) == 3 * 2 and summary["planner"].nunique() == 3  # planners' own parameters stay apart
    jaco.research.records.save_sweep(table, tmp_path / "s.csv", GRID, *ENDS, planners, {"beta": [2.0, 6.0]}, 2, **TINY)
    assert jaco.load_run(tmp_path / "s.csv").rerun().matched
    with pytest.raises(jaco.ParamError, match="parameter 'p_best' belongs to mmas only"):
        jaco.sweep(GRID, *ENDS, ["mmas", "acs"], params={"p_best": [0.05]}, seeds=1, **TINY)
    with pytest.raises(jaco.JacoError, match="listed twice"):
        jaco.sweep(GRID, *ENDS, ["mmas", "mmas"], seeds=1, **TINY)


def test_with_cost_names_resolve_too():
    v = jaco.planners.registry.get_planner("acs+multi")
    assert v is jaco.planners.registry.with_cost("acs", "multi")
