"""The planners: one module per source, each defining its :class:`~jaco.engine.variant.Variant`\\ s.

``classic`` (AS, its density/quantity forms, EAS, RAS, ACS, MMAS), ``double`` (DACA, IDACA),
``iaca``, ``iaaco``, ``apf_guided`` (APF-ACO, PF-ACO), ``chaos`` and ``pg``; :mod:`.registry`
collects them in ``jaco.VARIANTS``. A planner imports the engine (and :mod:`jaco.potential`,
:mod:`jaco.metrics`), never the registry or anything above it. docs/adding_a_planner.md says how
to add one.
"""

from .. import _submodules_on_access

__getattr__ = _submodules_on_access(__name__)
