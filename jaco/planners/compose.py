"""Planners composed from the sources' components by name.

``compose(construct=..., heuristic=..., rule=..., transition=..., schedule=..., cost=...)`` builds a
:class:`~jaco.engine.planner.Planner` from one component of each kind, taken from the planners of
this folder:

====================  ========================================================================
kind                  components
====================  ========================================================================
``construct``         ``dying`` (one colony, an ant dies at a dead end), ``backtrack`` (IACA's
                      backtracking ants with the local update 4-2..4-4 and the infeasible-path
                      rule 4-6; pheromone on cells), ``double`` (two colonies with complete
                      crossover, DACA/IDACA)
``heuristic``         ``distance`` (η = 1/distance to the goal, thesis 3-7), ``step`` (η = 1/d_ij,
                      textbook 2-1), ``iaca`` (eq. 4-5; per step over the ant's allowed moves
                      with ``backtrack``), ``iaaco`` / ``iaaco-printed`` (ε-adaptive η, angle
                      guidance μ^λ, obstacle exclusion ξ), ``apf`` / ``pf`` (η from the improved /
                      classic artificial potential field), ``chaos`` (η^β times the selection
                      shares (P_free·P_θ)^γ)
``rule``              the pheromone rule of a planner: ``as``, ``as-density``, ``as-quantity``,
                      ``eas``, ``ras``, ``acs``, ``mmas``, ``daca``, ``idaca``, ``iaca``,
                      ``iaaco``, ``apf``, ``chaos``, ``pg`` (REINFORCE on the logits; dying ants only)
``transition``        ``roulette``, ``q0`` (ACS's pseudo-random proportional rule, 2-14),
                      ``adaptive-q0`` (IAACO's q0 = δ0·exp(−½(Nc/Nmax)²), eqs. 6-7)
``schedule``          ``constant``, ``idaca`` (IDACA's α, β, ρ schedules, 3-8..3-10)
``cost``              ``length``, ``multi`` (J = kL·L + kS·S + kE·E)
``local_search``      ``none`` (the default), ``shortcut`` (the octile shortcut of the iteration's
                      best paths before the pheromone update, :mod:`jaco.engine.local_search`)
====================  ========================================================================

Each argument is a component's name or the :class:`Component` itself (what :func:`component`
returns): a component defined in a notebook cell or a test composes like the sources' own, and no
engine module names the kinds' members.

Each component is declared where its equations are (:func:`component`, called by the planner
modules and, for the engine's own pieces, below) with the parameters it reads and their defaults
(:class:`~jaco.engine.params.Param`): the rule owns α and its own (ρ, Q, τ0, …), the heuristic β
and its own, the construct, transition, schedule and cost theirs; where two claim a parameter,
the later of construct, rule, heuristic, transition, schedule, cost gives the default. A
component may keep state in the trail, in the slot the composition gives it (``Trail.state[slot]``,
the slot its name: :func:`slot`), and fix parameters itself (IDACA's schedule sets α and β). Pheromone lives on cells when a component needs it (``backtrack``,
``iaca``), else on moves. Combinations that cannot work together are a
:class:`~jaco.errors.JacoError` naming the algorithmic reason.

A composition is named by its components, ``compose(construct=backtrack, heuristic=iaaco,
rule=mmas, transition=roulette, schedule=constant, cost=length)`` (a local search other than
``none`` is appended: ``..., cost=length, local_search=shortcut)``); the registry resolves such a
name (:func:`jaco.planners.registry.get_planner`), so records store and rerun compositions, and
the same arguments give the same object (no recompiles). Every registered planner is defined as a
composition with its own name and defaults (``MMAS = compose(rule="mmas").named("mmas", ...)`` in
:mod:`jaco.planners.classic`); docs/compose.md has the table.
"""

from __future__ import annotations

import re
from typing import Any, Callable, Mapping, NamedTuple

from ..engine import cost as costs
from ..engine import heuristics
from ..engine import local_search as ls
from ..engine import pheromone as ph
from ..engine import schedules as sch
from ..engine.colony import BETA, Q0, eta_factor, single_colony
from ..engine.params import Param, declare
from ..engine.planner import FrozenMap, Planner, constant
from ..errors import JacoError

__all__ = [
    "compose",
    "component",
    "lookup",
    "parts",
    "slot",
    "add_local_search",
    "parse",
    "default_transition",
    "Component",
    "COMPONENTS",
    "KINDS",
    "SEARCH",
]

#: The kinds every planner has one of, in the order its composition's name lists them.
KINDS = ("construct", "heuristic", "rule", "transition", "schedule", "cost")
#: The optional kind: a planner has none or one, added after the others (name: ``local_search=...``).
SEARCH = "local_search"
#: The order in which components are applied: a later one gives a part or a default both set.
ORDER = ("construct", "rule", "heuristic", "transition", "schedule", "cost")


class Component(NamedTuple):
    """One component of a planner: what it sets on the :class:`~jaco.engine.planner.Planner`
    (``parts``: ``heuristic``, ``factor``, ``construct``, ``rule``, ``schedule``, ``cost``,
    ``transition``, ``local_search``, and what a component declares of itself, ``back_steps`` and
    ``per_step_heuristic``; a ``rule`` part of a non-rule component, such as a table the heuristic keeps
    in the trail, is chained before the pheromone rule), the parameters it reads with its
    defaults, its source in a few words, the pheromone layout it needs (``"cells"``, ``"moves"``
    or None), the parameters it sets itself (taken out of the planner's), and ``why_not(chosen)``:
    the reason it cannot work with the other chosen components (their names by kind), or None.
    A rule's ``default_transition`` part names the transition :func:`compose` takes when given none.
    ``state``: for a component that keeps state in the trail, ``state(slot) -> parts``, the parts
    that read and write it built for the slot the composition gives it (:func:`parts`)."""

    kind: str
    name: str
    parts: Mapping
    params: tuple
    source: str
    pheromone_on: str | None = None
    fixes: tuple = ()
    why_not: Callable | None = None
    state: Callable[[str], Mapping] | None = None


_CACHE: dict = {}  # compositions by their arguments

#: Every component by kind and name, filled by :func:`component`.
COMPONENTS: dict[str, dict[str, Component]] = {kind: {} for kind in KINDS + (SEARCH,)}


def component(
    kind: str,
    name: str,
    *,
    source: str,
    params: tuple = (),
    pheromone_on: str | None = None,
    fixes: tuple = (),
    why_not: Callable | None = None,
    state: Callable[[str], Mapping] | None = None,
    **parts: Any,
) -> Component:
    """Declare a component of ``kind`` under ``name`` (a module that defines a new heuristic, rule,
    construct step, transition, schedule, cost or local search calls this once, at import), so
    that :func:`compose` finds it by name; returns it (:func:`compose` takes the value too). ``params``: the
    :class:`~jaco.engine.params.Param` declarations it reads, with its defaults. ``state``: for a
    component that keeps state in the trail, a function of its slot (a ``Trail.state`` key, given
    by :func:`compose`) returning the parts that use it, so its code names no key. Declaring the
    same name again replaces the component (a notebook cell run twice)."""
    if kind not in COMPONENTS:
        raise JacoError(f"unknown kind {kind!r}; kinds: {', '.join(COMPONENTS)}")
    if pheromone_on not in (None, "cells", "moves"):
        raise JacoError(f"pheromone_on must be None, 'cells' or 'moves', got {pheromone_on!r}")
    if not all(isinstance(p, Param) for p in params):
        raise JacoError(f"component {name!r}: params must be Param declarations (jaco.engine.params.Param)")
    declare(*params)
    c = Component(kind, name, FrozenMap(parts), tuple(params), source, pheromone_on, tuple(fixes), why_not, state)
    COMPONENTS[kind][name] = c
    _CACHE.clear()  # compositions built with an older declaration are rebuilt
    return c


# -- the engine's own components ---------------------------------------------------------------
component("construct", "dying", construct=single_colony, source="thesis ch. 2: ants die at dead ends")
component(
    "heuristic",
    "distance",
    heuristic=heuristics.inverse_goal_distance,
    factor=eta_factor,
    params=(BETA.with_default(4.0),),
    source="thesis eq. 3-7",
)
component(
    "heuristic",
    "step",
    heuristic=heuristics.inverse_step,
    factor=eta_factor,
    params=(BETA.with_default(1.0),),
    source="thesis eq. 2-1",
)
component("transition", "roulette", transition="roulette", source="thesis eq. 2-1")
component(
    "transition",
    "q0",
    transition="pseudo-random",
    params=(Q0.with_default(0.8),),
    source="Dorigo & Gambardella 1997, thesis 2-14",
)
component("schedule", "constant", schedule=constant, source="no schedule")
component(
    "schedule",
    "idaca",
    schedule=sch.idaca,
    params=sch.IDACA_PARAMS,
    fixes=("alpha", "beta"),
    source="thesis eqs. 3-8..3-10",
)
component("cost", "length", cost=costs.path_length, source="path length")
component(
    "cost",
    "multi",
    cost=costs.multi_objective,
    params=costs.MULTI_PARAMS,
    source="Miao et al. 2021: J = kL·L + kS·S + kE·E",
)

# The local searches (``compose(..., local_search=...)``, ``"<planner>+<local search>"``): beyond the
# sources, none of them is part of a published planner. Each is a ``Planner.local_search`` with
# its static choices (:func:`jaco.engine.local_search.shortcut_search`; docs/compose.md says why these).
component("local_search", "none", local_search=None, source="no local search")
component(
    "local_search",
    "shortcut",
    local_search=ls.shortcut_search(window=ls.WINDOW, passes=ls.PASSES, best=ls.BEST),
    source=f"octile shortcut of the {ls.BEST} best paths of each iteration, window {ls.WINDOW}, at most "
    f"{ls.PASSES} passes, before the pheromone update (daemon action, Dorigo & Stützle 2004)",
)
_NAME = re.compile(r"^compose\((.*)\)$")


def lookup(kind: str, value: "str | Component") -> Component:
    """The component ``value`` of ``kind``: a declared name, or a :class:`Component` itself (one
    whose name is declared must be that declaration, so that the composition's name, which
    records store, stands for it)."""
    if isinstance(value, Component):
        if value.kind != kind:
            raise JacoError(f"{value.name!r} is a {value.kind} component, given as the {kind}")
        declared = COMPONENTS[kind].get(value.name)
        if declared is not None and declared != value:
            raise JacoError(f"another {kind} is declared as {value.name!r}: give this one another name")
        return value
    if not isinstance(value, str) or value not in COMPONENTS[kind]:
        plural = "local searches" if kind == SEARCH else f"{kind}s"
        raise JacoError(f"unknown {kind} {value!r}; {plural}: {', '.join(COMPONENTS[kind])}")
    return COMPONENTS[kind][value]


def slot(c: Component) -> str:
    """The ``Trail.state`` key a stateful component gets in a composition: its name (two
    stateful components of one name cannot be composed)."""
    return c.name


_BOUND: dict = {}  # a stateful component's parts by (state, slot): the same functions, no recompiles


def parts(c: Component) -> Mapping:
    """What ``c`` sets on a planner: its parts, with those of its ``state`` built for its slot."""
    if c.state is None:
        return c.parts
    key = (c.state, slot(c))
    if key not in _BOUND:
        _BOUND[key] = FrozenMap({**c.parts, **c.state(slot(c))})
    return _BOUND[key]


def _check_slots(pieces) -> None:
    """One slot per stateful component: two that would share one cannot be composed."""
    seen: dict = {}
    for p in pieces:
        if p.state is not None:
            other = seen.setdefault(slot(p), p)
            if other is not p:
                raise JacoError(
                    f"these components cannot be composed: the {other.kind} {other.name!r} and the {p.kind} "
                    f"{p.name!r} would keep state in one trail slot {slot(p)!r}; give one another name"
                )


def default_transition(rule: "str | Component") -> str:
    """The transition a rule brings when :func:`compose` is given none (its component's
    ``transition`` part: ``q0`` for ``acs`` and ``iaca``, ``adaptive-q0`` for ``iaaco``), else
    ``roulette``."""
    r = rule if isinstance(rule, Component) else COMPONENTS["rule"].get(rule)
    return parts(r).get("default_transition", "roulette") if r is not None else "roulette"


def compose(
    construct: "str | Component" = "dying",
    heuristic: "str | Component" = "distance",
    rule: "str | Component" = "as",
    transition: "str | Component | None" = None,
    schedule: "str | Component" = "constant",
    cost: "str | Component" = "length",
    local_search: "str | Component" = "none",
) -> Planner:
    """A planner made of one component of each kind (the module docstring lists them), each
    given by name or as the :class:`Component` value.

    ``transition=None`` takes the rule's own: ``q0`` for ``acs`` and ``iaca``, ``adaptive-q0`` for
    ``iaaco``, else ``roulette``. ``local_search``: ``"none"`` or a local search component.
    The same arguments return the same object (so repeated runs never recompile).

    >>> import jaco
    >>> v = jaco.compose(construct="backtrack", heuristic="iaaco", rule="mmas")
    >>> v.name
    'compose(construct=backtrack, heuristic=iaaco, rule=mmas, transition=roulette, schedule=constant, cost=length)'
    >>> v is jaco.compose(construct="backtrack", heuristic="iaaco", rule="mmas"), v.pheromone_on
    (True, 'cells')
    """
    given = dict(construct=construct, heuristic=heuristic, rule=rule, schedule=schedule, cost=cost)
    given["transition"] = default_transition(rule) if transition is None else transition
    given["local_search"] = local_search
    pieces = {kind: lookup(kind, given[kind]) for kind in KINDS + (SEARCH,)}
    key = tuple(pieces.values())
    hit = _CACHE.get(key)
    if hit is None:
        _check_slots(pieces.values())
        search = pieces.pop(SEARCH)
        hit = _build(pieces) if search.name == "none" else add_local_search(compose(**pieces), search)
        _CACHE[key] = hit
    return hit


def add_local_search(base: Planner, search: Component) -> Planner:
    """``base`` with the local search component ``search``. A composition's name gets
    ``local_search=...``, another planner's ``+<name>``."""
    composed = base.composition == base.name
    name = base.name[:-1] + f", local_search={search.name})" if composed else f"{base.name}+{search.name}"
    return base._replace(
        name=name,
        composition=name if composed else base.composition,
        source=f"{base.source}; local_search {search.name}: {search.source}"
        if composed
        else f"{base.source}; {search.source}",
        doc=f"{base.doc} Local search: {search.source}.",
        local_search=parts(search)["local_search"],
    )


def _build(pieces: dict) -> Planner:
    c = {kind: p.name for kind, p in pieces.items()}  # the components' names by kind
    pieces = {kind: pieces[kind] for kind in ORDER}
    for p in pieces.values():
        why = p.why_not(c) if p.why_not is not None else None
        if why:
            raise JacoError(f"these components cannot be composed: {why}")
    bound = {kind: parts(p) for kind, p in pieces.items()}
    layouts = {p.pheromone_on for p in pieces.values()} - {None}
    if len(layouts) > 1:
        raise JacoError("these components cannot be composed: one needs pheromone on cells, another on moves")
    fields: dict = {}
    defaults: dict = {}
    schedules_: list = []
    # every component's pheromone pieces, the heuristic's first (a table the rule's init keeps)
    rules = [bound[k]["rule"] for k in sorted(bound, key=lambda k: k != "heuristic") if "rule" in bound[k]]
    for p in pieces.values():
        for k, v in bound[p.kind].items():
            if k == "schedule":
                schedules_.append(v)
            elif k not in ("rule", "default_transition"):
                fields[k] = v
        defaults.update({q.name: q.default for q in p.params})
    for p in pieces.values():
        for name in p.fixes:
            defaults.pop(name, None)  # set by the component itself (IDACA's schedule: α, β; pg's rule: α ≡ 1)
    schedules_ = [s for s in schedules_ if s is not constant]
    name = "compose(" + ", ".join(f"{k}={c[k]}" for k in KINDS) + ")"
    source = "; ".join(f"{kind} {c[kind]}: {p.source}" for kind, p in pieces.items())
    cells = "cells" in layouts
    doc = (
        f"A composition: {c['construct']} construct, {c['heuristic']} heuristic, the {c['rule']} pheromone "
        f"rule, {c['transition']} transition, {c['schedule']} schedule, {c['cost']} cost (jaco.compose). "
        f"Pheromone on {'cells' if cells else 'moves'}. Sources: {source}."
    )
    return Planner(
        name=name,
        source=source,
        doc=doc,
        params=tuple(defaults),
        defaults=FrozenMap(defaults),
        rule=rules[0] if len(rules) == 1 else ph.chain(*rules),
        pheromone_on="cells" if cells else "moves",
        composition=name,
        schedule=sch.compose(*schedules_) if len(schedules_) > 1 else (schedules_[0] if schedules_ else constant),
        **fields,
    )


def parse(name: str) -> Planner | None:
    """The composition a name made by :func:`compose` stands for (None for any other name)."""
    m = _NAME.match(name.strip()) if isinstance(name, str) else None
    if m is None:
        return None
    kw = {}
    for part in filter(None, (p.strip() for p in m.group(1).split(","))):
        kind, _, value = part.partition("=")
        kind, value = kind.strip(), value.strip()
        if kind not in KINDS + (SEARCH,) or not value:
            raise JacoError(
                f"cannot read {name!r}: expected compose(kind=value, ...) with kinds {', '.join(KINDS)}, {SEARCH}"
            )
        kw[kind] = value
    return compose(**kw)
