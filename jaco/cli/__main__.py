"""``python -m jaco.cli``: the ``jaco`` command."""

from . import entry

entry()
