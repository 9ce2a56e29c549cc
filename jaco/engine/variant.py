"""What a planner is: a :class:`Variant`, a NamedTuple of pure functions and small static
choices (the fourth of the five concepts). The planners (:mod:`jaco.planners`) build variants
with :func:`make_variant`; the registry (:mod:`jaco.planners.registry`) collects them.
"""

from __future__ import annotations

from typing import Callable, Iterator, Mapping, NamedTuple

from . import heuristics
from . import pheromone as ph
from .colony import eta_factor, single_colony
from .cost import path_length
from .params import Params, param_names


class FrozenMap(Mapping):
    """A read-only, hashable mapping (a planner's defaults), so that a :class:`Variant` is hashable
    and compiled programs are cached by the planner itself."""

    __slots__ = ("_items",)

    def __init__(self, items=()):
        object.__setattr__(self, "_items", dict(items))

    def __getitem__(self, key):
        return self._items[key]

    def __iter__(self) -> Iterator:
        return iter(self._items)

    def __len__(self) -> int:
        return len(self._items)

    def __hash__(self) -> int:
        return hash(tuple(self._items.items()))

    def __eq__(self, other) -> bool:
        return isinstance(other, Mapping) and dict(self._items) == dict(other)

    def __repr__(self) -> str:
        return f"FrozenMap({self._items!r})"


def constant(params: Params, t, n_iters) -> Params:
    """No schedule: the same parameters at every iteration."""
    return params


class Variant(NamedTuple):
    """One planner. ``params`` names the :class:`Params` fields it reads; ``defaults`` overrides
    the dataclass defaults; ``pheromone_on`` is ``"moves"`` (τ_ij) or ``"cells"`` (τ_j);
    ``transition`` is ``"roulette"`` or ``"pseudo-random"`` (q0 rule, eq. 2-14);
    ``schedule(params, t, n_iters)`` gives the parameters of iteration t (branch-free);
    ``factor(variant, trail, problem, params, t, n_iters)`` is the log of a move's weight besides
    τ^α (by default β·log η of ``heuristic``); ``construct`` builds an iteration's candidate paths
    (:mod:`jaco.engine.colony`: one colony of ants that die at dead ends by default);
    ``local_search(variant, problem, colony, params)`` improves an iteration's candidates before the
    pheromone update (:mod:`jaco.engine.local_search`; None: none, as every published planner)."""

    name: str
    source: str
    doc: str
    params: tuple
    defaults: Mapping
    heuristic: Callable
    rule: ph.Rule
    pheromone_on: str = "moves"
    transition: str = "roulette"
    schedule: Callable = constant
    cost: Callable = path_length
    construct: Callable = single_colony
    factor: Callable = eta_factor
    local_search: Callable | None = None

    def default_params(self) -> Params:
        return Params(**dict(self.defaults))

    def describe(self, name_width: int = 12) -> str:
        """One line: the name (padded to ``name_width``), the source, the default parameters."""
        values = self.default_params().to_dict()
        shown = ", ".join(f"{k}={values[k]:g}" for k in self.params)
        return f"{self.name:<{name_width}} {self.source}  [{shown}]"


def make_variant(name, source, doc, params, defaults, rule, **kw) -> Variant:
    """A :class:`Variant` with checked parameter names; ``heuristic`` defaults to η = 1/L_goal."""
    assert set(params) <= set(param_names()) and set(defaults) <= set(params), name
    return Variant(
        name=name,
        source=source,
        doc=doc,
        params=tuple(params),
        defaults=FrozenMap(defaults),
        heuristic=kw.pop("heuristic", heuristics.inverse_goal_distance),
        rule=rule,
        **kw,
    )
