"""What a record says about the code that wrote it: the format's name and version, the format
changes that break a rerun, the versions a bit-identical rerun depends on, and the header every
record begins with."""

from __future__ import annotations

import platform
from datetime import datetime, timezone

import numpy as np

FORMAT = "jaco-record"
FORMAT_VERSION = 4
#: Why a record of an older format no longer reruns bit for bit (the file itself still loads).
#: Formats 3 and 4 changed no rerun: a sweep record's ``steplimit: null`` (the default) means the
#: default of the jaco that wrote it, and reruns so (:func:`jaco.engine.checks.legacy_steplimit`):
#: before format 3, 4·(H + W) at most the free cells for every planner; in format 3 twice that
#: for backtracking ants; since format 4 :func:`jaco.engine.checks.default_steplimit`.
FORMAT_CHANGES = {
    2: "its random numbers were drawn as one uniform table per iteration; since format 2 each "
    "uniform is Threefry of the iteration key, the ant and the step, so the rerun draws other "
    "numbers and takes other paths (rerun it with the jaco that wrote it to reproduce it)",
}
#: Versions whose difference is reported before a rerun (bit-for-bit equality is promised only
#: for the same jaco, jax, jaxlib and backend).
CHECKED_VERSIONS = ("jaco", "jax", "jaxlib", "backend")


def versions() -> dict:
    """Versions that decide whether a rerun can be bit-identical (read at call time)."""
    import jax
    import pandas

    import jaco

    try:
        import jaxlib

        jaxlib_version = jaxlib.__version__
    except (ImportError, AttributeError):  # pragma: no cover - jaxlib ships with jax
        jaxlib_version = None
    return {
        "jaco": jaco.__version__,
        "jax": jax.__version__,
        "jaxlib": jaxlib_version,
        "backend": jax.default_backend(),
        "numpy": np.__version__,
        "pandas": pandas.__version__,
        "python": platform.python_version(),
    }


def version_warnings(recorded: dict, format_version: int = FORMAT_VERSION) -> list[str]:
    """One line per checked version that differs between a record and this installation, and
    one per format change since the record's format version."""
    now = versions()
    out = [
        f"record format {format_version}, this jaco writes format {FORMAT_VERSION}: {why}"
        for version, why in sorted(FORMAT_CHANGES.items())
        if format_version < version
    ]
    for k in CHECKED_VERSIONS:
        old, new = recorded.get(k), now.get(k)
        if old != new:
            out.append(
                f"record written with {k} {old}, this is {k} {new}: the rerun may differ in floating point rounding"
            )
    return out


def record_header(kind: str) -> dict:
    return {
        "format": FORMAT,
        "format_version": FORMAT_VERSION,
        "kind": kind,
        "created": datetime.now(timezone.utc).isoformat(timespec="seconds"),
        "versions": versions(),
    }
