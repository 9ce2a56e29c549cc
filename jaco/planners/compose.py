"""Planners composed from the sources' components by name.

``compose(construct=..., heuristic=..., rule=..., transition=..., schedule=..., cost=...)`` builds a
:class:`~jaco.engine.variant.Variant` from one component of each kind, taken from the planners of
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

Parameters and defaults come from the components: the rule owns α and its own (ρ, Q, τ0, …), the
heuristic β and its own, the construct, transition, schedule and cost theirs (where two claim a
parameter, the later of construct, rule, heuristic, transition, schedule, cost wins). Pheromone lives on cells when the construct or the rule
needs it (``backtrack``, ``iaca``), else on moves. Combinations that cannot work together are a
:class:`~jaco.errors.JacoError` naming the reason.

A composition is named by its components, ``compose(construct=backtrack, heuristic=iaaco,
rule=mmas, transition=roulette, schedule=constant, cost=length)`` (a local search other than
``none`` is appended: ``..., cost=length, local_search=shortcut)``); the registry resolves such a
name (:func:`jaco.planners.registry.get_variant`), so records store and rerun compositions, and
the same arguments give the same object (no recompiles). docs/compose.md has the table of which
registered planner is which composition.
"""

from __future__ import annotations

import re
from typing import NamedTuple

from ..engine import cost as costs
from ..engine import heuristics
from ..engine import local_search as ls
from ..engine import pheromone as ph
from ..engine import schedules as sch
from ..engine.colony import eta_factor, single_colony
from ..engine.variant import FrozenMap, Variant, constant
from ..errors import JacoError
from ..potential import apf_distance, classic_distance
from . import apf_guided, chaos, classic, double, iaaco, iaca, pg

__all__ = ["compose", "parse", "default_transition", "COMPONENTS", "KINDS", "LOCAL_SEARCHES"]

KINDS = ("construct", "heuristic", "rule", "transition", "schedule", "cost")


class Component(NamedTuple):
    """One component: what it sets on the variant (``parts``), the parameters it reads with their
    defaults, and its source in a few words."""

    parts: dict
    defaults: dict
    source: str
    cells: bool = False  # needs pheromone on cells
    moves: bool = False  # needs pheromone on moves


def _rule(variant, *names, cells=False, moves=False, rule=None) -> Component:
    """A registered planner's pheromone rule with its defaults for ``names`` (α and the rule's own)."""
    return Component(dict(rule=rule or variant.rule), {k: variant.defaults[k] for k in names if k in variant.defaults},
                     variant.source, cells=cells, moves=moves)


_IAACO_H = ("beta", "lam", "sigma1", "sigma2", "mu_min", "rs")
_BACKTRACK = ("rho_local", "q1", "q2", "q3", "rho1", "rho2", "q_step")

COMPONENTS: dict = {
    "construct": {
        "dying": Component(dict(construct=single_colony), {}, "thesis ch. 2: ants die at dead ends"),
        "backtrack": Component(dict(construct=iaca.backtrack_colony), {k: iaca.IACA.defaults[k] for k in _BACKTRACK},
                               "Hua Lu 2011 thesis 4.3, eqs. 4-2..4-4, 4-6", cells=True),
        "double": Component(dict(construct=double.double_colony), {}, "thesis ch. 3: two colonies, crossover"),
    },
    "heuristic": {
        "distance": Component(dict(heuristic=heuristics.inverse_goal_distance, factor=eta_factor), {"beta": 4.0},
                              "thesis eq. 3-7"),
        "step": Component(dict(heuristic=heuristics.inverse_step, factor=eta_factor), {"beta": 1.0}, "thesis eq. 2-1"),
        "iaca": Component(dict(heuristic=iaca.iaca_heuristic, factor=eta_factor), {"beta": 8.0}, "thesis eq. 4-5"),
        "iaaco": Component(dict(heuristic=iaaco.iaaco_heuristic, factor=iaaco.guided_factor(iaaco.mu_robust)),
                           {k: iaaco.IAACO.defaults[k] for k in _IAACO_H}, "Miao et al. 2021 eqs. 1-5"),
        "iaaco-printed": Component(dict(heuristic=iaaco.iaaco_heuristic, factor=iaaco.guided_factor(iaaco.mu_printed)),
                                   {k: iaaco.IAACO.defaults[k] for k in _IAACO_H}, "Miao et al. 2021 eqs. 1-5 as printed"),
        "apf": Component(dict(heuristic=apf_guided.APF_ACO.heuristic, factor=apf_guided.apf_factor,
                              table=apf_guided.apf_table(apf_distance)), {"beta": 20.0}, "Dong & Zhao 2021 eqs. 4, 5, 10"),
        "pf": Component(dict(heuristic=apf_guided.PF_ACO.heuristic, factor=apf_guided.apf_factor,
                             table=apf_guided.apf_table(classic_distance)),
                        {k: apf_guided.PF_ACO.defaults[k] for k in ("beta", "k_rep", "d0")}, "classic APF (Khatib)"),
        "chaos": Component(dict(heuristic=heuristics.inverse_goal_distance, factor=chaos.selection_factor),
                           {"beta": 8.0, "gamma": 4.0}, "Xi'an Technological University, rule (11)"),
    },
    "rule": {
        "as": _rule(classic.AS, "alpha", "rho", "q", "tau0"),
        "as-density": _rule(classic.AS_DENSITY, "alpha", "rho", "q", "tau0"),
        "as-quantity": _rule(classic.AS_QUANTITY, "alpha", "rho", "q", "tau0"),
        "eas": _rule(classic.EAS, "alpha", "rho", "q", "tau0", "sigma"),
        "ras": _rule(classic.RAS, "alpha", "rho", "q", "tau0", "w"),
        "acs": _rule(classic.ACS, "alpha", "rho", "q", "tau0", "xi"),
        "mmas": _rule(classic.MMAS, "alpha", "rho", "q", "p_best"),
        "daca": _rule(double.DACA, cells=True)._replace(defaults=dict(alpha=1.0, rho=0.6, q=10.0, tau0=0.1)),
        "idaca": _rule(double.IDACA, cells=True)._replace(
            defaults=dict(alpha=1.0, rho=0.7, q=20.0, tau_min=0.01, tau_max=20.0)),
        "iaca": _rule(iaca.IACA, "alpha", "rho", "q", "sigma", "tau_min", "tau_max", "k_init", cells=True),
        "iaaco": _rule(iaaco.IAACO, "alpha", "q", "tau0", "tau_min", "rho", "k_rho"),
        "apf": _rule(apf_guided.APF_ACO, "alpha", "rho", "q", "tau0",
                     rule=ph.chain(ph.init_constant(), ph.evaporate(), apf_guided.deposit_best_half())),
        "chaos": _rule(chaos.CHAOS_ACO, "alpha", "rho", "q", "tau0", "chaos_iters", "chaos_mu"),
        "pg": _rule(pg.PG_ACO, "rho", "q", "penalty", moves=True)._replace(
            parts=dict(rule=pg.PG_ACO.rule, construct=pg.PG_ACO.construct)),
    },
    "transition": {
        "roulette": Component(dict(transition="roulette"), {}, "thesis eq. 2-1"),
        "q0": Component(dict(transition="pseudo-random"), {"q0": 0.8}, "Dorigo & Gambardella 1997, thesis 2-14"),
        "adaptive-q0": Component(dict(transition="pseudo-random", schedule=iaaco.q0_schedule), {"delta0": 0.15},
                                 "Miao et al. 2021 eqs. 6-7"),
    },
    "schedule": {
        "constant": Component(dict(schedule=constant), {}, "no schedule"),
        "idaca": Component(dict(schedule=sch.idaca), {k: double.IDACA.defaults[k] for k in (
            "alpha_slope", "alpha_end", "beta_start", "beta_slope", "beta_end", "break_iter", "rho_min", "rho_decay")},
            "thesis eqs. 3-8..3-10"),
    },
    "cost": {
        "length": Component(dict(cost=costs.path_length), {}, "path length"),
        "multi": Component(dict(cost=costs.multi_objective), {k: iaaco.IAACO.defaults[k] for k in costs.COST_PARAMS},
                           "Miao et al. 2021: J = kL·L + kS·S + kE·E"),
    },
}

#: The local searches (``compose(..., local_search=...)``, ``"<planner>+<local search>"``): beyond the
#: sources, none of them is part of a published planner. Each is a ``Variant.local_search`` with
#: its static choices (:func:`jaco.engine.local_search.shortcut_search`; docs/compose.md says why these).
LOCAL_SEARCHES: dict = {
    "none": None,
    "shortcut": ls.shortcut_search(window=ls.WINDOW, passes=ls.PASSES, best=ls.BEST),
}
#: Each local search's source, in a few words.
LOCAL_SEARCH_SOURCES = {
    "shortcut": f"octile shortcut of the {ls.BEST} best paths of each iteration, window {ls.WINDOW}, at most "
                f"{ls.PASSES} passes, before the pheromone update (daemon action, Dorigo & Stützle 2004)",
}

#: Every registered planner as a composition: with the planner's own defaults
#: (``jaco.VARIANTS[name].defaults``) the composition runs exactly the planner.
REGISTERED = {
    "as": dict(rule="as"),
    "as-density": dict(rule="as-density"),
    "as-quantity": dict(rule="as-quantity"),
    "eas": dict(rule="eas"),
    "ras": dict(rule="ras"),
    "acs": dict(rule="acs"),
    "mmas": dict(rule="mmas"),
    "daca": dict(construct="double", heuristic="step", rule="daca"),
    "idaca": dict(construct="double", rule="idaca", schedule="idaca"),
    "iaca": dict(construct="backtrack", heuristic="iaca", rule="iaca"),
    "iaaco": dict(heuristic="iaaco", rule="iaaco", cost="multi"),
    "iaaco-printed": dict(heuristic="iaaco-printed", rule="iaaco", cost="multi"),
    "apf-aco": dict(heuristic="apf", rule="apf"),
    "pf-aco": dict(heuristic="pf", rule="apf"),
    "chaos-aco": dict(heuristic="chaos", rule="chaos"),
    "pg-aco": dict(rule="pg"),
}
_NAME = re.compile(r"^compose\((.*)\)$")


def _check(kind, value) -> str:
    if not isinstance(value, str) or value not in COMPONENTS[kind]:
        raise JacoError(f"unknown {kind} {value!r}; {kind}s: {', '.join(COMPONENTS[kind])}")
    return value


def _why_not(c: dict) -> str | None:
    """Why these components cannot work together (None when they can)."""
    if c["rule"] == "pg" and c["construct"] != "dying":
        return "rule 'pg' steps the logits of ants that die at dead ends: it needs construct 'dying'"
    if c["rule"] == "pg" and c["heuristic"] in ("apf", "pf"):
        return "rule 'pg' carries its own trail (logits and optimiser state): no room for the 'apf'/'pf' table"
    if c["construct"] == "double" and c["heuristic"] in ("apf", "pf"):
        return (f"construct 'double' walks a second colony from the goal to the start, but the "
                f"'{c['heuristic']}' table holds distances to the goal only")
    if c["rule"] == "pg" and c["schedule"] != "constant":
        return "rule 'pg' learns with a fixed step: schedule must be 'constant'"
    return None


_CACHE: dict = {}


def default_transition(rule: str) -> str:
    """The transition a rule brings when :func:`compose` is given none: ACS's and IACA's ``q0``,
    IAACO's ``adaptive-q0``, else ``roulette``."""
    return {"acs": "q0", "iaca": "q0", "iaaco": "adaptive-q0"}.get(rule, "roulette")


def compose(construct: str = "dying", heuristic: str = "distance", rule: str = "as", transition: str | None = None,
            schedule: str = "constant", cost: str = "length", local_search: str = "none") -> Variant:
    """A planner made of one component of each kind (the module docstring lists them).

    ``transition=None`` takes the rule's own: ``q0`` for ``acs`` and ``iaca``, ``adaptive-q0`` for
    ``iaaco``, else ``roulette``. ``local_search``: ``"none"`` or one of :data:`LOCAL_SEARCHES`.
    The same arguments return the same object (so repeated runs never recompile).

    >>> import jaco
    >>> v = jaco.compose(construct="backtrack", heuristic="iaaco", rule="mmas")
    >>> v.name
    'compose(construct=backtrack, heuristic=iaaco, rule=mmas, transition=roulette, schedule=constant, cost=length)'
    >>> v is jaco.compose(construct="backtrack", heuristic="iaaco", rule="mmas"), v.pheromone_on
    (True, 'cells')
    """
    c = dict(construct=construct, heuristic=heuristic, rule=rule, schedule=schedule, cost=cost)
    for kind in ("construct", "heuristic", "rule", "schedule", "cost"):
        _check(kind, c[kind])
    if transition is None:
        transition = default_transition(rule)
    c["transition"] = _check("transition", transition)
    if not isinstance(local_search, str) or local_search not in LOCAL_SEARCHES:
        raise JacoError(f"unknown local_search {local_search!r}; local searches: {', '.join(LOCAL_SEARCHES)}")
    key = tuple(c[k] for k in KINDS) + (local_search,)
    hit = _CACHE.get(key)
    if hit is None:
        hit = _CACHE[key] = _build(c) if local_search == "none" else _searching(compose(**c), local_search)
    return hit


def _searching(base: Variant, local_search: str) -> Variant:
    """``base`` (a composition) with a local search: its name gets ``local_search=...``."""
    source = f"{base.source}; local_search {local_search}: {LOCAL_SEARCH_SOURCES[local_search]}"
    return base._replace(name=base.name[:-1] + f", local_search={local_search})", source=source,
                         doc=f"{base.doc} Local search: {LOCAL_SEARCH_SOURCES[local_search]}.",
                         local_search=LOCAL_SEARCHES[local_search])


def _build(c: dict) -> Variant:
    why = _why_not(c)
    if why:
        raise JacoError(f"these components cannot be composed: {why}")
    # In this order the later component wins a part or a default both set (the rule 'pg' brings
    # its own construct step).
    pieces = {kind: COMPONENTS[kind][c[kind]] for kind in ("construct", "rule", "heuristic", "transition", "schedule", "cost")}
    cells = any(p.cells for p in pieces.values())
    if cells and any(p.moves for p in pieces.values()):
        raise JacoError("these components cannot be composed: one needs pheromone on cells, another on moves")
    parts: dict = {}
    defaults: dict = {}
    schedules_: list = []
    for kind, p in pieces.items():
        for k, v in p.parts.items():
            if k == "schedule":
                schedules_.append(v)
            elif k != "table":
                parts[k] = v
        defaults.update(p.defaults)
    if c["construct"] == "backtrack" and c["heuristic"] == "iaca":
        parts["construct"] = iaca.iaca_colony  # eq. 4-5 recomputed at every step, over the ant's allowed moves
    table = pieces["heuristic"].parts.get("table")
    rule = parts.pop("rule")
    if table is not None:
        rule = ph.chain(table, rule)  # the heuristic's table first: the rule's init keeps it in the trail
    if c["rule"] == "pg":
        defaults.pop("alpha", None)  # α ≡ 1: log τ is the logit
    if c["schedule"] == "idaca":
        defaults.pop("alpha", None), defaults.pop("beta", None)  # set by the schedule (eqs. 3-8, 3-9)
    schedules_ = [s for s in schedules_ if s is not constant]
    name = "compose(" + ", ".join(f"{k}={c[k]}" for k in KINDS) + ")"
    source = "; ".join(f"{kind} {c[kind]}: {p.source}" for kind, p in pieces.items())
    doc = (f"A composition: {c['construct']} construct, {c['heuristic']} heuristic, the {c['rule']} pheromone "
           f"rule, {c['transition']} transition, {c['schedule']} schedule, {c['cost']} cost (jaco.compose). "
           f"Pheromone on {'cells' if cells else 'moves'}. Sources: {source}.")
    return Variant(
        name=name,
        source=source,
        doc=doc,
        params=tuple(defaults),
        defaults=FrozenMap(defaults),
        rule=rule,
        pheromone_on="cells" if cells else "moves",
        schedule=sch.compose(*schedules_) if len(schedules_) > 1 else (schedules_[0] if schedules_ else constant),
        **parts,
    )


def parse(name: str) -> Variant | None:
    """The composition a name made by :func:`compose` stands for (None for any other name)."""
    m = _NAME.match(name.strip()) if isinstance(name, str) else None
    if m is None:
        return None
    kw = {}
    for part in filter(None, (p.strip() for p in m.group(1).split(","))):
        kind, _, value = part.partition("=")
        kind, value = kind.strip(), value.strip()
        if kind not in KINDS + ("local_search",) or not value:
            raise JacoError(f"cannot read {name!r}: expected compose(kind=value, ...) with kinds "
                            f"{', '.join(KINDS)}, local_search")
        kw[kind] = value
    return compose(**kw)

