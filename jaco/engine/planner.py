"""What a planner is: a :class:`Planner`, a NamedTuple of pure functions and small static
choices (the fourth of the five concepts), and the protocols of its components (the public
extension contract; :func:`jaco.testing.check_planner` runs a planner through it). The planners
(:mod:`jaco.planners`) are compositions of components (:func:`jaco.compose`); :func:`make_planner`
builds one from functions directly.
"""

from __future__ import annotations

from typing import Any, Iterable, Iterator, Mapping, NamedTuple, Protocol

import jax

from ..errors import JacoError
from . import heuristics
from . import pheromone as ph
from .colony import eta_factor, single_colony
from .cost import path_length
from .params import SPECS, Param, Params, declare
from .pheromone import Trail


class FrozenMap(Mapping):
    """A read-only, hashable mapping (a planner's defaults), so that a :class:`Planner` is hashable
    and compiled programs are cached by the planner itself."""

    __slots__ = ("_items",)
    _items: dict

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


def constant(params: Params, t: Any, n_iters: int) -> Params:
    """No schedule: the same parameters at every iteration."""
    return params


# -- the extension contract: what each kind of component is -------------------------------------
class Heuristic(Protocol):
    """``heuristic(problem, params, t, n_iters) -> η (N, 8)``: the desirability of every move."""

    def __call__(self, problem: Any, params: Params, t: Any, n_iters: int) -> jax.Array: ...


class Factor(Protocol):
    """``factor(planner, trail, problem, params, t, n_iters) -> (N, 8)``: the log of a move's weight
    besides τ^α (by default β·log η, :func:`jaco.engine.colony.eta_factor`)."""

    def __call__(
        self, planner: "Planner", trail: Trail, problem: Any, params: Params, t: Any, n_iters: int
    ) -> jax.Array: ...


class Construct(Protocol):
    """``construct(planner, problem, trail, params, t, n_iters, key, *, n_ants, steplimit) ->
    (trail, Colony)``: an iteration's candidate paths (:mod:`jaco.engine.colony`)."""

    def __call__(
        self,
        planner: "Planner",
        problem: Any,
        trail: Trail,
        params: Params,
        t: Any,
        n_iters: int,
        key: jax.Array,
        *,
        n_ants: int,
        steplimit: int,
    ) -> tuple[Trail, Any]: ...


class Schedule(Protocol):
    """``schedule(params, t, n_iters) -> params``: the parameters of iteration ``t`` (branch-free)."""

    def __call__(self, params: Params, t: Any, n_iters: int) -> Params: ...


class Cost(Protocol):
    """``cost(tours, problem, params) -> (A,)``: what each ant's path costs (:mod:`jaco.engine.cost`)."""

    def __call__(self, tours: Any, problem: Any, params: Params) -> jax.Array: ...


class LocalSearch(Protocol):
    """``local_search(planner, problem, colony, params) -> colony``: improves an iteration's
    candidates before the pheromone update (:mod:`jaco.engine.local_search`)."""

    def __call__(self, planner: "Planner", problem: Any, colony: Any, params: Params) -> Any: ...


class Planner(NamedTuple):
    """One planner. ``params`` names the parameters it reads and ``defaults`` holds a default for
    each (their ranges and meaning: :data:`jaco.engine.params.SPECS`); ``pheromone_on`` is
    ``"moves"`` (τ_ij) or ``"cells"`` (τ_j); ``transition`` is ``"roulette"`` or
    ``"pseudo-random"`` (q0 rule, eq. 2-14); ``heuristic``, ``factor``, ``construct``,
    ``schedule``, ``cost`` and ``local_search`` follow the protocols above (:class:`Heuristic`,
    :class:`Factor`, :class:`Construct`, :class:`Schedule`, :class:`Cost`, :class:`LocalSearch`;
    ``local_search`` None: none, as every published planner); ``rule`` is a pheromone
    :class:`~jaco.engine.pheromone.Rule`. ``back_steps`` and ``per_step_heuristic`` are what the
    construct and the heuristic declare of themselves (IACA's backtracking ants and eq. 4-5): the
    step limit and the backtracking walk read them. Planners are built by :func:`jaco.compose` (components
    by name) or :func:`make_planner` (functions given directly)."""

    name: str
    source: str
    doc: str
    params: tuple
    defaults: Mapping
    heuristic: Heuristic
    rule: ph.Rule
    pheromone_on: str = "moves"
    transition: str = "roulette"
    schedule: Schedule = constant
    cost: Cost = path_length
    construct: Construct = single_colony
    factor: Factor = eta_factor
    local_search: LocalSearch | None = None
    composition: str = ""  # the name of the composition it is (``compose(...)``), "" when built from functions
    back_steps: bool = False  # its ants step back from dead ends, and the steps back count against the step limit
    per_step_heuristic: bool = False  # a backtracking construct recomputes η over each step's allowed moves

    def default_params(self) -> Params:
        """The planner's parameters at their defaults."""
        return Params(**{k: self.defaults[k] for k in self.params})

    def describe(self, name_width: int = 12) -> str:
        """One line: the name (padded to ``name_width``), the source, the default parameters."""
        shown = ", ".join(f"{k}={self.defaults[k]:g}" for k in self.params)
        return f"{self.name:<{name_width}} {self.source}  [{shown}]"

    def named(self, name: str, *, source: str, doc: str, **defaults: float) -> "Planner":
        """This planner under its own name, source and description, with other defaults for some
        of its parameters (a registered planner is a composition plus such overrides). The names
        given in ``defaults`` come first in :attr:`params`, in their order."""
        unknown = [k for k in defaults if k not in self.params]
        if unknown:
            raise JacoError(f"{name!r}: {unknown[0]!r} is not a parameter of {self.name!r} ({', '.join(self.params)})")
        order = tuple(defaults) + tuple(k for k in self.params if k not in defaults)
        return self._replace(
            name=name,
            source=source,
            doc=doc,
            params=order,
            defaults=FrozenMap({k: float(defaults.get(k, self.defaults[k])) for k in order}),
        )


def declared(params: Iterable[Param | str], defaults: Mapping[str, float] = FrozenMap()) -> tuple[tuple, FrozenMap]:
    """Parameter names and a complete defaults map from declarations (:class:`Param`, declared on
    the spot) or names of parameters declared elsewhere, with ``defaults`` overriding."""
    names, values = [], {}
    for p in params:
        if isinstance(p, Param):
            declare(p)
            name, default = p.name, p.default
        elif isinstance(p, str) and p in SPECS:
            name, default = p, SPECS[p].default
        else:
            raise JacoError(f"a planner's parameters are Param declarations or declared names, got {p!r}")
        if name not in values:
            names.append(name)
        values[name] = float(default)
    extra = [k for k in defaults if k not in values]
    if extra:
        raise JacoError(f"defaults for {extra[0]!r}, which is not among the parameters {names}")
    values.update({k: float(v) for k, v in defaults.items()})
    return tuple(names), FrozenMap(values)


def make_planner(
    name: str,
    source: str,
    doc: str,
    params: Iterable[Param | str],
    defaults: Mapping[str, float],
    rule: ph.Rule,
    **kw: Any,
) -> Planner:
    """A :class:`Planner` from its functions. ``params``: :class:`~jaco.engine.params.Param`
    declarations (a new hyperparameter is declared right here) or names of declared parameters;
    ``defaults`` overrides theirs. ``heuristic`` defaults to η = 1/L_goal."""
    names, values = declared(params, defaults)
    return Planner(
        name=name,
        source=source,
        doc=doc,
        params=names,
        defaults=values,
        heuristic=kw.pop("heuristic", heuristics.inverse_goal_distance),
        rule=rule,
        **kw,
    )


#: The names before planners had one name (jaco 0.1): ``Variant`` is :class:`Planner` and
#: ``make_variant`` is :func:`make_planner`, kept because users' code types them.
Variant = Planner
make_variant = make_planner
