"""The notebooks run under nbmake (``pytest notebooks`` or the default ``pytest``).

Headless: the kernels nbmake starts inherit this process's environment, so setting the backend
here (before any kernel starts) keeps the notebooks themselves free of ``matplotlib.use``. A
notebook's ``%matplotlib inline`` still selects the inline backend, which renders without a
display too.
"""

import os

os.environ.setdefault("MPLBACKEND", "Agg")
