"""The planners: one module per source, each defining its :class:`~jaco.engine.planner.Planner`\\ s.

``classic`` (AS, its density/quantity forms, EAS, RAS, ACS, MMAS), ``double`` (DACA, IDACA),
``iaca``, ``iaaco``, ``apf_guided`` (APF-ACO, PF-ACO), ``chaos`` and ``pg``: each declares its
components (:func:`jaco.planners.compose.component`) and defines its planners as compositions of
them (``PLANNERS``); :data:`MODULES` lists the modules, and :mod:`.registry` collects their
planners in ``jaco.PLANNERS``. A planner module imports
the engine and :mod:`.compose` (and :mod:`jaco.potential`, :mod:`jaco.metrics`), never the
registry or anything above it. docs/adding_a_planner.md says how to add one.
"""

from .. import _submodules_on_access

# Each planner module declares its components (jaco.planners.compose.component) when it loads, so
# that compose(...) finds every one by name whichever planner module a program imports first.
from . import apf_guided, chaos, classic, double, iaaco, iaca, pg  # noqa: E402

#: The planner modules, in the order the registry lists their planners (the classic family, the
#: thesis's, the papers', pg-aco; docs/algorithms.md §2–§8): the one list a new module joins.
MODULES = (classic, double, iaca, iaaco, apf_guided, chaos, pg)

__getattr__ = _submodules_on_access(__name__)
