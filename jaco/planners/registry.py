"""The registry: every planner of :mod:`jaco.planners` by name, in :data:`PLANNERS`.

``jaco.solve(..., "mmas")`` and every other entry point that takes a name resolves it here
(:func:`get_planner`), and the contract test (``tests/test_variants.py``) runs on every entry, so
a planner added to the folder and listed below is checked with no other edit
(docs/adding_a_planner.md). The registry imports the planners; no planner imports the registry.
"""

from __future__ import annotations

from ..engine.cost import COSTS, MULTI_PARAMS
from ..engine.planner import FrozenMap, Planner
from ..errors import JacoError, ParamError, accepts_aliases, did_you_mean
from . import (
    apf_guided,  # APF-ACO and its PF-ACO baseline (Dong & Zhao 2021)
    chaos,  # chaos ACO (the Xi'an Technological University paper)
    classic,  # docs/algorithms.md §2
    double,  # thesis chapter 3
    iaaco,  # IAACO (Miao et al. 2021)
    iaca,  # thesis chapter 4
    pg,  # policy-gradient ACO (Meuleau & Dorigo 2002)
)
from .compose import LOCAL_SEARCHES, parse

__all__ = ["PLANNERS", "VARIANTS", "get_planner", "get_variant", "register", "with_cost", "with_local_search"]

#: Every planner the modules define (their ``PLANNERS``), by name: the classic family, the thesis's,
#: the papers' and pg-aco (docs/algorithms.md §2–§8).
PLANNERS: dict[str, Planner] = {
    v.name: v for module in (classic, double, iaca, iaaco, apf_guided, chaos, pg) for v in module.PLANNERS
}
#: The name before planners had one name (jaco 0.1), kept because users' code types it: the same dict.
VARIANTS = PLANNERS


@accepts_aliases
def get_planner(planner: str | Planner) -> Planner:
    """A :class:`Planner` as it is, or one by name: a registered planner, a composition's name
    (``compose(construct=..., ...)``, :func:`jaco.planners.compose.compose`), or either with
    another cost (``"acs+multi"``, :func:`with_cost`) or a local search (``"iaca+shortcut"``,
    :func:`with_local_search`).

    The one place every entry point (``jaco.solve``, ``jaco.sweep``, ``jaco.search``, the CLI)
    resolves a name: in any case (``"IACA"`` is ``iaca``, ``"IACA+Shortcut"`` is ``iaca+shortcut``);
    an unknown name raises :class:`~jaco.errors.JacoError` with the closest names ("did you mean
    'iaca'?", difflib) before the registered list."""
    if isinstance(planner, Planner):
        return planner
    if isinstance(planner, str):
        found = _registered(planner)
        if found is not None:
            return found
        composed = parse(planner)
        if composed is not None:
            return composed
        base, _, suffix = planner.rpartition("+")
        suffix = suffix.strip().lower()
        if base and (suffix in COSTS or (suffix in LOCAL_SEARCHES and suffix != "none")):
            try:
                found = get_planner(base)
            except JacoError:
                found = None
            if found is not None:
                return with_cost(found, suffix) if suffix in COSTS else with_local_search(found, suffix)
    if not isinstance(planner, str):
        several = (
            " (several planners are a sweep axis: jaco.sweep(..., planner=[...]))"
            if isinstance(planner, (list, tuple))
            else ""
        )
        raise JacoError(
            f"a planner must be a name (str) or a Planner, got {type(planner).__name__} {planner!r}{several}"
        )
    raise JacoError(
        f"unknown planner {planner!r}{_did_you_mean(planner)}; registered: {', '.join(sorted(PLANNERS))} "
        "(or a composition: compose(construct=..., heuristic=..., rule=...); a suffix adds a cost or a local "
        f"search: +{', +'.join(sorted(COSTS))}, +{', +'.join(k for k in LOCAL_SEARCHES if k != 'none')})"
    )


def _registered(name: str) -> Planner | None:
    """The registered planner of that name, in any case (``"IACA"`` is ``iaca``), or None."""
    if name in PLANNERS:
        return PLANNERS[name]
    folded = name.strip().casefold()
    hits = [v for k, v in PLANNERS.items() if k.casefold() == folded]
    return hits[0] if len(hits) == 1 else None


def _did_you_mean(name: str) -> str:
    """``" (did you mean 'iaca'?)"`` for the registered names closest to a misspelt one (difflib, in
    any case), a name with a suffix (``"iaca+shortcutt"``) among the names with one; or ``""``."""
    base, plus, _ = name.strip().rpartition("+")
    suffixes = [*sorted(COSTS), *(k for k in LOCAL_SEARCHES if k != "none")]
    candidates = [f"{k}+{s}" for k in PLANNERS for s in suffixes] if plus and base else list(PLANNERS)
    return did_you_mean(name.strip().casefold(), [c.casefold() for c in candidates])


@accepts_aliases
def register(planner: Planner) -> Planner:
    """Add a planner defined outside :mod:`jaco.planners` to :data:`PLANNERS` (so it is found by
    name, recorded and rerun like the built-in ones); returns it. Registering the same object
    twice is harmless; another planner under a taken name is an error."""
    if not isinstance(planner, Planner):
        raise JacoError(f"only a Planner can be registered, got {type(planner).__name__}")
    taken = PLANNERS.get(planner.name)
    if taken is not None and taken is not planner:
        raise JacoError(f"a different planner is already registered as {planner.name!r}")
    PLANNERS[planner.name] = planner
    return planner


_WITH_COST: dict = {}


@accepts_aliases
def with_cost(planner: str | Planner, cost: str = "multi") -> Planner:
    """``planner`` (a name or a :class:`Planner`) with another cost: ``"multi"``
    (:func:`jaco.engine.cost.multi_objective`, and its weights become sweepable parameters) or
    ``"length"``.

    Cached: the same arguments return the same object, so repeated runs never recompile.
    The new planner is named ``"<name>+<cost>"``.

    >>> import jaco
    >>> v = jaco.planners.registry.with_cost("acs", "multi")
    >>> v.name, v is jaco.planners.registry.with_cost("acs", "multi"), "k_safe" in v.params
    ('acs+multi', True, True)
    """
    if cost not in COSTS:
        raise ParamError(f"unknown cost {cost!r}; valid: {', '.join(sorted(COSTS))}")
    base = get_planner(planner)
    key = (base, cost)
    hit = _WITH_COST.get(key)
    if hit is None:
        if base.cost is COSTS[cost]:
            new = base
        else:
            extra = [p for p in (MULTI_PARAMS if cost == "multi" else ()) if p.name not in base.params]
            params = base.params + tuple(p.name for p in extra)
            defaults = FrozenMap({**base.defaults, **{p.name: p.default for p in extra}})
            new = base._replace(name=f"{base.name}+{cost}", cost=COSTS[cost], params=params, defaults=defaults)
        hit = _WITH_COST[key] = new
    return hit


_WITH_SEARCH: dict = {}


@accepts_aliases
def with_local_search(planner: str | Planner, local_search: str = "shortcut") -> Planner:
    """``planner`` (a name or a :class:`Planner`) with a local search of the compose vocabulary
    (:data:`jaco.planners.compose.LOCAL_SEARCHES`, :mod:`jaco.engine.local_search`), named
    ``"<name>+<local search>"``; a composition gets its own name's ``local_search=...`` instead
    (``compose(..., local_search="shortcut")``). ``"none"`` gives the planner without one.

    Cached: the same arguments return the same object, so repeated runs never recompile.

    >>> import jaco
    >>> v = jaco.planners.registry.with_local_search("iaca")
    >>> v.name, v is jaco.planners.registry.get_planner("iaca+shortcut"), jaco.PLANNERS["iaca"].local_search is None
    ('iaca+shortcut', True, True)
    """
    from .compose import LOCAL_SEARCH_SOURCES, compose

    if not isinstance(local_search, str) or local_search not in LOCAL_SEARCHES:
        raise JacoError(f"unknown local search {local_search!r}; valid: {', '.join(LOCAL_SEARCHES)}")
    base = get_planner(planner)
    key = (base, local_search)
    hit = _WITH_SEARCH.get(key)
    if hit is None:
        if parse(base.name) is base:  # a composition: the local search is one of its components
            new = compose(**{**_composition_kwargs(base.name), "local_search": local_search})
        elif base.local_search is not None:
            raise JacoError(f"{base.name!r} has a local search already; add one to the planner without it")
        elif local_search == "none":
            new = base
        else:
            new = base._replace(
                name=f"{base.name}+{local_search}",
                local_search=LOCAL_SEARCHES[local_search],
                source=f"{base.source}; {LOCAL_SEARCH_SOURCES[local_search]}",
                doc=f"{base.doc} Local search: {LOCAL_SEARCH_SOURCES[local_search]}.",
            )
        hit = _WITH_SEARCH[key] = new
    return hit


def _composition_kwargs(name: str) -> dict:
    inner = name.strip()[len("compose(") : -1]
    return dict((k.strip(), v.strip()) for k, _, v in (p.partition("=") for p in inner.split(",") if p.strip()))


#: The name before planners had one name (jaco 0.1), kept because users' code types it.
get_variant = get_planner
