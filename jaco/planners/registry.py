"""The registry: every planner of :mod:`jaco.planners` by name, in :data:`PLANNERS`.

``jaco.solve(..., "mmas")`` and every other entry point that takes a name resolves it here
(:func:`get_planner`), and the contract test (``tests/test_variants.py``) runs on every entry, so
a planner of a module in :data:`jaco.planners.MODULES` is checked with no other edit
(docs/adding_a_planner.md). The registry imports the planners; no planner imports the registry.
"""

from __future__ import annotations

from ..engine.planner import FrozenMap, Planner
from ..errors import JacoError, ParamError, accepts_aliases, did_you_mean
from . import MODULES
from .compose import COMPONENTS, add_local_search, parse, parts

__all__ = ["PLANNERS", "VARIANTS", "get_planner", "get_variant", "register", "with_cost", "with_local_search"]

#: Every planner the modules define (their ``PLANNERS``), by name, in :data:`jaco.planners.MODULES`' order.
PLANNERS: dict[str, Planner] = {v.name: v for module in MODULES for v in module.PLANNERS}
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
        if base and suffix in _suffixes():
            try:
                found = get_planner(base)
            except JacoError:
                found = None
            if found is not None:
                return with_cost(found, suffix) if suffix in COMPONENTS["cost"] else with_local_search(found, suffix)
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
        f"search: +{', +'.join(_suffixes())})"
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
    suffixes = _suffixes()
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
    """``planner`` (a name or a :class:`Planner`) with another cost component (by name: ``"multi"``,
    :func:`jaco.engine.cost.multi_objective`, whose weights become sweepable parameters;
    ``"length"``; or any declared with :func:`jaco.planners.compose.component`); the component's
    parameters join the planner's.

    Cached: the same arguments return the same object, so repeated runs never recompile.
    The new planner is named ``"<name>+<cost>"``.

    >>> import jaco
    >>> v = jaco.planners.registry.with_cost("acs", "multi")
    >>> v.name, v is jaco.planners.registry.with_cost("acs", "multi"), "k_safe" in v.params
    ('acs+multi', True, True)
    """
    if cost not in COMPONENTS["cost"]:
        raise ParamError(f"unknown cost {cost!r}; valid: {', '.join(sorted(COMPONENTS['cost']))}")
    chosen = COMPONENTS["cost"][cost]
    base = get_planner(planner)
    key = (base, chosen)
    hit = _WITH_COST.get(key)
    if hit is None:
        fn = parts(chosen)["cost"]
        if base.cost is fn:
            new = base
        else:
            extra = [p for p in chosen.params if p.name not in base.params]
            params = base.params + tuple(p.name for p in extra)
            defaults = FrozenMap({**base.defaults, **{p.name: p.default for p in extra}})
            new = base._replace(name=f"{base.name}+{cost}", cost=fn, params=params, defaults=defaults)
        hit = _WITH_COST[key] = new
    return hit


_WITH_SEARCH: dict = {}


@accepts_aliases
def with_local_search(planner: str | Planner, local_search: str = "shortcut") -> Planner:
    """``planner`` (a name or a :class:`Planner`) with a local search component (by name, as
    declared with :func:`jaco.planners.compose.component`; :mod:`jaco.engine.local_search`), named
    ``"<name>+<local search>"``; a composition gets its own name's ``local_search=...`` instead
    (``compose(..., local_search="shortcut")``). ``"none"`` gives the planner without one.

    Cached: the same arguments return the same object, so repeated runs never recompile.

    >>> import jaco
    >>> v = jaco.planners.registry.with_local_search("iaca")
    >>> v.name, v is jaco.planners.registry.get_planner("iaca+shortcut"), jaco.PLANNERS["iaca"].local_search is None
    ('iaca+shortcut', True, True)
    """
    from .compose import compose, lookup

    if not isinstance(local_search, str) or local_search not in COMPONENTS["local_search"]:
        raise JacoError(f"unknown local search {local_search!r}; valid: {', '.join(COMPONENTS['local_search'])}")
    search = lookup("local_search", local_search)
    base = get_planner(planner)
    key = (base, search)
    hit = _WITH_SEARCH.get(key)
    if hit is None:
        if parse(base.name) is base:  # a composition: the local search is one of its components
            new = compose(**{**_composition_kwargs(base.name), "local_search": search})
        elif base.local_search is not None:
            raise JacoError(f"{base.name!r} has a local search already; add one to the planner without it")
        elif search.name == "none":
            new = base
        else:
            new = add_local_search(base, search)
        hit = _WITH_SEARCH[key] = new
    return hit


def _composition_kwargs(name: str) -> dict:
    inner = name.strip()[len("compose(") : -1]
    return dict((k.strip(), v.strip()) for k, _, v in (p.partition("=") for p in inner.split(",") if p.strip()))


#: The name before planners had one name (jaco 0.1), kept because users' code types it.
get_variant = get_planner


def _suffixes() -> list[str]:
    """The ``+<suffix>`` a planner's name may end in: each cost, then each local search but none."""
    return [*sorted(COMPONENTS["cost"]), *(k for k in COMPONENTS["local_search"] if k != "none")]
