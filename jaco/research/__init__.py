"""The research workflow on top of the engine and the registry: sweeps (:mod:`.sweeps`) over
experimental designs (:mod:`.designs`), tuning with optax (:mod:`.tuning`), and reproducible
records of runs and sweeps (:mod:`.record_format` writes a run's files, :mod:`.records` loads,
reruns and saves sweeps)."""

from .. import _submodules_on_access

__getattr__ = _submodules_on_access(__name__)
