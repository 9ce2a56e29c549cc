"""Planners composed from components by name: every registered planner is a composition, the
combinations that cannot work are clear errors, compositions are found by name (records rerun
them) and a sweep takes several planners as a categorical axis."""

import numpy as np
import pandas as pd
import pytest

import jaco
from jaco.planners.compose import COMPONENTS, KINDS, REGISTERED, compose, parse

GRID = jaco.maps.random_map(12, 0.2, seed=3)
ENDS = (GRID.meta["start"], GRID.meta["goal"])
TINY = dict(n_ants=10, n_iters=6)


@pytest.mark.parametrize(
    "name", [n if n in ("as", "iaca", "iaaco") else pytest.param(n, marks=pytest.mark.slow) for n in sorted(REGISTERED)]
)
def test_every_registered_planner_is_its_composition_bit_for_bit(name):
    """With the planner's own defaults, the composition of its components runs exactly the
    registered planner: the same path, history and pheromone."""
    planner, composed = jaco.VARIANTS[name], compose(**REGISTERED[name])
    assert set(composed.params) == set(planner.params) and composed.pheromone_on == planner.pheromone_on
    a = jaco.solve(GRID, *ENDS, planner, seed=4, keep_pheromone=True, **TINY)
    b = jaco.solve(GRID, *ENDS, composed, seed=4, keep_pheromone=True, **TINY, **dict(planner.defaults))
    np.testing.assert_array_equal(a.path, b.path)
    np.testing.assert_array_equal(a.pheromone, b.pheromone)
    for k in a.history:
        np.testing.assert_array_equal(a.history[k], b.history[k])


def test_every_component_comes_from_a_registered_planner():
    used = {kind: set() for kind in KINDS}
    for kw in REGISTERED.values():
        for kind, value in _kinds(compose(**kw).name).items():
            used[kind].add(value)
    for kind in KINDS:
        assert used[kind] == set(COMPONENTS[kind]), (kind, set(COMPONENTS[kind]) - used[kind])


def _kinds(name):
    inner = name[len("compose("):-1]
    return dict(part.strip().split("=") for part in inner.split(","))


def test_names_defaults_and_the_same_object_for_the_same_arguments():
    v = compose(construct="backtrack", heuristic="iaaco", rule="mmas")
    assert v.name == (
        "compose(construct=backtrack, heuristic=iaaco, rule=mmas, transition=roulette, schedule=constant, cost=length)"
    )
    assert v is compose(construct="backtrack", heuristic="iaaco", rule="mmas") is parse(v.name)
    assert jaco.planners.registry.get_variant(v.name) is v
    assert v.pheromone_on == "cells"  # backtracking ants keep pheromone on cells
    d = dict(v.defaults)
    assert d["alpha"] == jaco.VARIANTS["mmas"].defaults["alpha"]  # the rule's α
    assert d["beta"] == jaco.VARIANTS["iaaco"].defaults["beta"] and d["lam"] == 3.0  # the heuristic's
    assert d["rho_local"] == jaco.VARIANTS["iaca"].defaults["rho_local"]  # the construct's
    assert compose(rule="acs").transition == "pseudo-random"  # the rule's own transition by default
    assert compose(rule="iaaco").schedule is jaco.planners.iaaco.q0_schedule
    assert "alpha" not in compose(rule="pg").params  # α ≡ 1 for the policy's logits
    assert {"alpha", "beta"}.isdisjoint(compose(construct="double", rule="idaca", schedule="idaca").params)
    assert parse("mmas") is None  # not a composition's name


@pytest.mark.parametrize(
    "kw, match",
    [
        (dict(construct="sideways"), "unknown construct 'sideways'; constructs: dying, backtrack, double"),
        (dict(heuristic="exact"), "unknown heuristic 'exact'"),
        (dict(rule="tsp"), "unknown rule 'tsp'"),
        (dict(transition="greedy"), "unknown transition 'greedy'"),
        (dict(cost=["length"]), "unknown cost"),
        (dict(construct="backtrack", rule="pg"), "rule 'pg' .* needs construct 'dying'"),
        (dict(construct="double", heuristic="apf"), "distances to the goal only"),
        (dict(rule="pg", heuristic="pf"), "its own trail"),
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
    with pytest.raises(jaco.JacoError, match="unknown variant 'compose'"):
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
    names = [jaco.planners.registry.get_variant(p).name for p in planners]
    assert list(table.columns[:1]) == ["variant"] and table["variant"].unique().tolist() == names
    assert len(table) == 3 * 2 * 2 and set(table.attrs["sweep"]) == set(names)
    for p, name in zip(planners, names):  # each planner's rows are its own sweep's
        alone = jaco.sweep(GRID, *ENDS, p, params={"beta": [2.0, 6.0]}, seeds=2, **TINY)
        mine = table[table["variant"] == name].drop(columns="variant").dropna(axis=1, how="all").reset_index(drop=True)
        pd.testing.assert_frame_equal(mine, alone[mine.columns], check_exact=True)
    summary = jaco.summarize(table)
    assert len(summary) == 3 * 2 and summary["variant"].nunique() == 3  # planners' own parameters stay apart
    jaco.research.records.save_sweep(table, tmp_path / "s.csv", GRID, *ENDS, planners, {"beta": [2.0, 6.0]}, 2, **TINY)
    assert jaco.load_run(tmp_path / "s.csv").rerun().matched
    with pytest.raises(jaco.ParamError, match="unknown parameter 'p_best'"):
        jaco.sweep(GRID, *ENDS, ["mmas", "acs"], params={"p_best": [0.05]}, seeds=1, **TINY)
    with pytest.raises(jaco.JacoError, match="listed twice"):
        jaco.sweep(GRID, *ENDS, ["mmas", "mmas"], seeds=1, **TINY)


def test_with_cost_names_resolve_too():
    v = jaco.planners.registry.get_variant("acs+multi")
    assert v is jaco.planners.registry.with_cost("acs", "multi")
