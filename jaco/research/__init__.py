"""The research workflow on top of the engine and the registry: sweeps (:mod:`.sweeps`) over
experimental designs (:mod:`.designs`), tuning with optax (:mod:`.tuning`), reproducible
records of runs and sweeps (:mod:`.record_format` writes a run's files, :mod:`.records` loads,
reruns and saves sweeps), result tables as files (:mod:`.tables`) and the statistics that compare
planners on them (:mod:`.compare`)."""

from .. import _submodules_on_access

__getattr__ = _submodules_on_access(__name__)
