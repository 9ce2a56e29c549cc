"""``python -m jaco.cli``: the ``jaco`` command."""

import sys

from . import main

sys.exit(main())
