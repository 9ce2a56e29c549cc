"""State slots: the composition, not the component's code, names where a component keeps its
state in the trail (``Trail.state[slot]``), and refuses two components that would share one."""

import jax.numpy as jnp
import numpy as np
import pytest

import jaco
from jaco.engine import pheromone as ph
from jaco.engine.checks import params_from, resolve_params
from jaco.engine.colony import ALPHA
from jaco.engine.problem import make_problem, to_device
from jaco.planners.compose import COMPONENTS, component, slot

N_ITERS = 7


def _counting(slot_: str) -> dict:
    """A rule that counts its updates in its slot and sets τ to the count: τ = n_iters at the end
    only if the count was carried from each iteration to the next."""

    def init(trail, problem, params):
        return ph.with_own(trail._replace(tau=jnp.ones_like(trail.tau)), slot_, jnp.float32(0.0))

    def update(trail, walks, problem, params):
        count = ph.own(trail, slot_) + 1.0
        return ph.with_own(trail._replace(tau=jnp.full_like(trail.tau, count)), slot_, count)

    return dict(rule=ph.Rule(init, update))


@pytest.fixture
def counter():
    c = component("rule", "test-counter", state=_counting, params=(ALPHA,), source="counts its updates")
    yield c
    del COMPONENTS["rule"]["test-counter"]


def _state(planner):
    grid = jaco.maps.named("demo")
    problem = to_device(make_problem(grid, grid.meta["start"], grid.meta["goal"]))
    params = params_from(resolve_params(planner, {}, where="test"))
    trail = ph.Trail(jnp.zeros(8 * grid.n_cells), jnp.float32(0), jnp.float32(jnp.inf))
    return planner.rule.init(trail, problem, params).state


def test_a_stateful_component_gets_its_slot_and_keeps_its_state_across_iterations(counter):
    planner = jaco.compose(rule=counter)
    assert slot(counter) == "test-counter" and set(_state(planner)) == {"test-counter"}
    grid = jaco.maps.named("demo")
    r = jaco.solve(
        grid, grid.meta["start"], grid.meta["goal"], planner, seed=0, n_ants=4, n_iters=N_ITERS, keep_pheromone=True
    )
    np.testing.assert_array_equal(r.pheromone, np.full_like(r.pheromone, N_ITERS))
    # Beside another stateful component each keeps its own slot: the APF table is the heuristic's.
    both = _state(jaco.compose(heuristic="apf", rule=counter))
    assert set(both) == {"apf", "test-counter"} and float(both["test-counter"]) == 0.0
    assert both["apf"].shape == (grid.n_cells,)


def test_two_components_that_would_share_a_slot_are_refused(counter):
    heuristic = component("heuristic", "test-counter", state=lambda s: {}, source="a second state under the name")
    try:
        with pytest.raises(
            jaco.JacoError,
            match=r"^these components cannot be composed: the heuristic 'test-counter' "
            r"and the rule 'test-counter' would keep state in one trail slot 'test-counter'",
        ):
            jaco.compose(heuristic=heuristic, rule=counter)
    finally:
        del COMPONENTS["heuristic"]["test-counter"]


def test_the_sources_stateful_components_are_declared_so():
    stateful = {(k, n) for k, cs in COMPONENTS.items() for n, c in cs.items() if c.state is not None}
    assert {("rule", "pg"), ("heuristic", "apf"), ("heuristic", "pf")} <= stateful
    assert set(_state(jaco.PLANNERS["pg-aco"])) == {"pg"} and set(_state(jaco.PLANNERS["pf-aco"])) == {"pf"}
