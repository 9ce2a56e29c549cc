"""A planner that is not in the package passes the same contract as the registered ones, with no
edit anywhere else: docs/adding_a_planner.md in practice.

The guide's notebook cell (a pheromone rule with a new hyperparameter and a state of its own) is
run here as it is printed, and ``jaco.testing.check_planner`` (the contract of
``tests/test_variants.py``) runs inside it. A toy built from functions with ``make_planner``
passes the same contract.
"""

import hashlib
import re
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pytest

import jaco
from jaco.engine import pheromone as ph
from jaco.engine.planner import make_planner
from jaco.planners.compose import COMPONENTS
from jaco.planners.registry import register

ROOT = Path(__file__).resolve().parents[1]
GUIDE = ROOT / "docs" / "adding_a_planner.md"

#: Ant System in which only the iteration's best ant deposits: τ ← (1−ρ)τ, then τ += Q/L_ib on
#: the iteration-best path (thesis eqs. 2-2 and 2-17's deposit, without MMAS's bounds).
TOY = make_planner(
    "toy-iteration-best",
    "tests/test_adding_a_planner.py: thesis eqs. 2-2, 2-17 (deposit only)",
    "A toy planner for the contract test: Ant System whose pheromone is deposited by the "
    "iteration-best ant only, Q/L_ib on each move it took.",
    ("alpha", "beta", "rho", "q", "tau0"),
    dict(alpha=1.0, beta=4.0, rho=0.2, q=1.0, tau0=0.1),
    ph.chain(ph.init_constant(), ph.evaporate(), ph.deposit_iteration_best()),
)


@contextmanager
def registered(variant):
    """``variant`` in the registry for the length of the block (so ``jaco.solve(..., name)``,
    sweeps and records find it by name), then removed again."""
    register(variant)
    try:
        yield variant.name
    finally:
        del jaco.PLANNERS[variant.name]


def _package_digest() -> str:
    h = hashlib.sha256()
    for path in sorted((ROOT / "jaco").rglob("*.py")):
        h.update(path.read_bytes())
    return h.hexdigest()


def _cell() -> str:
    text = GUIDE.read_text(encoding="utf-8")
    section = text[text.index("## A planner in a notebook cell"):]
    return re.search(r"```python\n(.*?)```", section, re.S).group(1)


@pytest.fixture(scope="module")
def cell():
    """The guide's cell run in a namespace of its own; its component and planner removed after."""
    before = _package_digest()
    namespace: dict = {}
    exec(compile(_cell(), str(GUIDE), "exec"), namespace)
    yield namespace
    jaco.PLANNERS.pop("as-restart", None)
    COMPONENTS["rule"].pop("as-restart", None)
    assert _package_digest() == before


def test_the_guide_cell_adds_a_hyperparameter_and_a_state_without_touching_the_package(cell, tmp_path):
    planner = cell["AS_RESTART"]
    # Nothing in the package names the new parameter: it lives in the cell (and the guide) only.
    for path in (ROOT / "jaco").rglob("*.py"):
        assert "restart_after" not in path.read_text(encoding="utf-8"), path
    assert "restart_after" in planner.params and planner.defaults["restart_after"] == 10.0
    assert jaco.engine.params.SPECS["restart_after"].describe() == "[1, 1e+06]"
    grid = jaco.maps.named("demo")
    ends = grid.meta["start"], grid.meta["goal"]
    # Its range is checked like any other parameter's, before anything compiles.
    with pytest.raises(jaco.ParamError, match="'restart_after' = 0 is out of range"):
        jaco.solve(grid, *ends, "as-restart", restart_after=0, n_ants=8, n_iters=4)
    # The state is the rule's own: with restart_after = 1 the pheromone is reset to τ0 in every
    # iteration that does not improve the best-so-far path, so a long run ends at τ0 everywhere.
    r = jaco.solve(grid, *ends, "as-restart", seed=0, restart_after=1, n_ants=8, n_iters=30, keep_pheromone=True)
    assert r.success and np.allclose(r.pheromone, r.params["tau0"])
    never = jaco.solve(grid, *ends, "as-restart", seed=0, restart_after=1e6, n_ants=8, n_iters=30, keep_pheromone=True)
    assert not np.allclose(never.pheromone, never.params["tau0"])
    # A sweep over the new parameter, and a record that reruns bit for bit by name.
    table = jaco.sweep(grid, *ends, "as-restart", params={"restart_after": [2.0, 50.0]}, seeds=2, n_ants=8, n_iters=6)
    assert list(table["restart_after"]) == [2.0, 2.0, 50.0, 50.0] or sorted(set(table["restart_after"])) == [2.0, 50.0]
    r.save(tmp_path / "run.json")
    assert jaco.load_run(tmp_path / "run.json").rerun().matched
    # The new rule composes with another source's heuristic.
    mixed = jaco.compose(rule="as-restart", heuristic="iaaco")
    assert "restart_after" in mixed.params and "lam" in mixed.params


def test_a_toy_built_from_functions_passes_the_contract():
    with registered(TOY):
        jaco.testing.check_planner(TOY)


def test_registering_is_checked_and_undone():
    with registered(TOY) as registered_name:
        assert jaco.PLANNERS[registered_name] is TOY and register(TOY) is TOY  # the same object: harmless
        with pytest.raises(jaco.JacoError, match="already registered"):
            register(TOY._replace(doc="another planner under the same name"))
        with pytest.raises(jaco.JacoError, match="only a Planner"):
            register("mmas")
    assert TOY.name not in jaco.PLANNERS


# -- a transition, a local search and a cost, each defined here alone ------------------------------
@pytest.fixture
def own_components():
    """Three components declared in this file only (what a notebook cell would declare): they
    compose like the package's own, by value or by name, and the ``+<name>`` suffixes find them."""
    import jax.numpy as jnp

    from jaco.engine.colony import Q0
    from jaco.planners.compose import component

    def copy_best(planner, problem, colony, params):  # every ant takes the iteration's best path
        b = jnp.argmin(colony.cost)

        def best(x):
            return jnp.broadcast_to(x[..., b][..., None], x.shape)

        fields = ("cells", "targets", "step_len", "cost", "length", "n_steps")
        return colony._replace(**{f: best(getattr(colony, f)) for f in fields})

    declared = dict(
        greedy=component(
            "transition", "test-greedy", transition="pseudo-random", params=(Q0.with_default(1.0),), source="q0 = 1"
        ),
        copy=component("local_search", "test-copy-best", local_search=copy_best, source="copy the best path"),
        steps=component(
            "cost", "test-steps", cost=lambda tours, problem, params: tours.n_steps.astype(jnp.float32), source="moves"
        ),
    )
    yield declared
    for c in declared.values():
        del COMPONENTS[c.kind][c.name]


def test_a_transition_a_local_search_and_a_cost_defined_outside_the_package_compose(own_components):
    grid = jaco.maps.named("demo")
    ends = grid.meta["start"], grid.meta["goal"]
    small = dict(seed=0, n_ants=8, n_iters=6)
    for name in ("test-greedy", "test-copy-best", "test-steps"):  # no package file names them
        assert not any(name in p.read_text(encoding="utf-8") for p in (ROOT / "jaco").rglob("*.py"))
    c = own_components
    # By value and by name: the same composition (the same object, so no recompile).
    greedy = jaco.compose(rule="acs", transition=c["greedy"])
    assert greedy is jaco.compose(rule="acs", transition="test-greedy")
    assert greedy.defaults["q0"] == 1.0 and greedy.transition == "pseudo-random"
    # q0 = 1: every ant takes the argmax move, so an iteration's ants walk one path: all arrive or
    # none, and the mean cost is the best one.
    h = jaco.solve(grid, *ends, greedy, **small).history
    assert set(np.unique(h["success_rate"])) <= {0.0, 1.0}
    arrived = h["success_rate"] == 1.0
    assert arrived.any() and np.array_equal(h["mean"][arrived], h["iteration_best"][arrived])
    # The local search replaces each ant's path with the best one before the update: success 1
    # whenever one ant arrived, mean = best; as a suffix on a registered planner too.
    plain = jaco.solve(grid, *ends, "as", **small).history
    for planner in (jaco.compose(local_search=c["copy"]), "as+test-copy-best"):
        h = jaco.solve(grid, *ends, planner, **small).history
        some = plain["success_rate"] > 0
        assert np.array_equal(h["success_rate"][some], np.ones(some.sum(), np.float32))
        assert np.array_equal(h["mean"][some], h["iteration_best"][some])
    # The cost counts moves: the best path's cost is its number of steps.
    for planner in ("as+test-steps", jaco.compose(cost=c["steps"])):
        r = jaco.solve(grid, *ends, planner, **small)
        assert r.success and r.cost == len(r.path) - 1 and r.cost != r.length
    # A value must be of its kind, and cannot take a declared name it is not.
    with pytest.raises(jaco.JacoError, match="is a cost component, given as the transition"):
        jaco.compose(transition=c["steps"])
    with pytest.raises(jaco.JacoError, match="another local_search is declared as 'test-copy-best'"):
        jaco.compose(local_search=c["copy"]._replace(source="another"))
