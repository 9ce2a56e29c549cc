"""The commands ``demo``, ``solve``, ``sweep``, ``compare``, ``rerun``, ``planners`` (``variants``),
``maps`` and ``info`` (``cmd_*``), one module per family; ``search`` is :mod:`jaco.cli.search`.
Heavy modules are imported inside the functions."""

from __future__ import annotations

from .compare import cmd_compare
from .listing import cmd_info, cmd_maps, cmd_planners
from .rerun import cmd_rerun, report_rerun
from .run import cmd_demo, cmd_solve
from .sweep import cmd_sweep

__all__ = [
    "cmd_compare",
    "cmd_demo",
    "cmd_info",
    "cmd_maps",
    "cmd_planners",
    "cmd_rerun",
    "cmd_solve",
    "cmd_sweep",
    "report_rerun",
]
