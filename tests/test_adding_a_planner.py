"""A planner that is not in the package passes the same contract as the registered ones, with no
edit anywhere else: docs/adding_a_planner.md in practice.

The toy below is written the way a new file in ``jaco/planners/`` would be; registering it is what
its one line in ``jaco/planners/registry.py`` would do. Every contract test of
``tests/test_variants.py`` is collected here again, and this module's ``name`` fixture hands them
the toy instead of the registered planners.
"""

import inspect
from contextlib import contextmanager

import pytest

import jaco
from jaco.engine import pheromone as ph
from jaco.engine.variant import make_variant
from jaco.planners.registry import register

import test_variants
from test_variants import maps_  # noqa: F401 (a fixture the contract tests use)

#: Ant System in which only the iteration's best ant deposits: τ ← (1−ρ)τ, then τ += Q/L_ib on
#: the iteration-best path (thesis eqs. 2-2 and 2-17's deposit, without MMAS's bounds).
TOY = make_variant(
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
    sweeps and the registry's checks find it by name), then removed again."""
    register(variant)
    try:
        yield variant.name
    finally:
        del jaco.VARIANTS[variant.name]


@pytest.fixture
def name():
    with registered(TOY) as registered_name:
        yield registered_name


CONTRACT = {
    key: test
    for key, test in vars(test_variants).items()
    if key.startswith("test_") and "name" in inspect.signature(test).parameters
}
globals().update(CONTRACT)  # collected here with this module's `name` fixture


def test_the_whole_contract_is_collected_here():
    assert len(CONTRACT) >= 8 and "test_sweep_rows_equal_solve" in CONTRACT


def test_registering_is_checked_and_undone():
    with registered(TOY) as registered_name:
        assert jaco.VARIANTS[registered_name] is TOY and register(TOY) is TOY  # the same object: harmless
        with pytest.raises(jaco.JacoError, match="already registered"):
            register(TOY._replace(doc="another planner under the same name"))
        with pytest.raises(jaco.JacoError, match="only a Variant"):
            register("mmas")
    assert TOY.name not in jaco.VARIANTS
