"""Argument types of the command line and how a mistake is reported (:class:`UsageError`)."""

from __future__ import annotations

import argparse
import math


class UsageError(Exception):
    """A command-line mistake: reported as one ``jaco: error: ...`` line, exit code 2."""


class RaisingParser(argparse.ArgumentParser):
    """ArgumentParser whose errors raise :class:`UsageError` instead of printing usage and
    exiting, so that :func:`main` reports every mistake the same way and returns 2."""

    def error(self, message):  # noqa: D401 - argparse API
        raise UsageError(f"{message} (see '{self.prog} --help')")


# -- argument types -------------------------------------------------------------------------------
def parse_cell(text: str) -> tuple[int, int]:
    """``"R,C"`` -> ``(R, C)``."""
    parts = text.replace(" ", "").split(",")
    try:
        if len(parts) != 2:
            raise ValueError
        return int(parts[0]), int(parts[1])
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a cell as ROW,COL (two integers, e.g. 3,7), got {text!r}") from None


def parse_world_point(text: str) -> tuple[float, float]:
    """``"X,Y"`` (metres) -> ``(X, Y)``; finite numbers only."""
    parts = text.replace(" ", "").split(",")
    try:
        if len(parts) != 2:
            raise ValueError
        x, y = float(parts[0]), float(parts[1])
        if not (math.isfinite(x) and math.isfinite(y)):
            raise ValueError
        return x, y
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected a world point as X,Y in metres (two finite numbers, e.g. 1.5,-0.25), got {text!r}"
        ) from None


def int_at_least(low: int, what: str):
    """An argparse type: an integer >= ``low``, with one clear message for both mistakes."""

    def parse(text: str) -> int:
        try:
            v = int(text)
        except ValueError:
            v = low - 1
        if v < low:
            raise argparse.ArgumentTypeError(f"expected {what}, got {text!r}")
        return v

    return parse


parse_nonnegative_int = int_at_least(0, "an integer >= 0")
parse_positive_int = int_at_least(1, "a positive integer")


def _bounds(text: str, what: str, cast):
    """``"LO:HI"``, ``"LO:"``, ``":HI"`` or ``"X"`` -> ``(lo, hi)`` inclusive, None for an open end."""
    parts = text.replace(" ", "").split(":")
    try:
        if len(parts) == 1:
            lo = hi = cast(parts[0])
        elif len(parts) == 2 and any(parts):
            lo, hi = (cast(p) if p else None for p in parts)
        else:
            raise ValueError
        if isinstance(lo, float) and not math.isfinite(lo) or isinstance(hi, float) and not math.isfinite(hi):
            raise ValueError
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected {what} as X, LO:HI, LO: or :HI (both ends included), got {text!r}"
        ) from None
    if lo is not None and hi is not None and lo > hi:
        raise argparse.ArgumentTypeError(f"expected LO <= HI in {text!r}")
    return lo, hi


def parse_bucket(text: str):
    """``--bucket 80:`` -> ``(80, None)``: a bucket or an inclusive range of buckets."""
    return _bounds(text, "a bucket (an integer)", int)


def parse_optimal_range(text: str):
    """``--optimal 300:400``: an inclusive range of optimal lengths."""
    return _bounds(text, "an optimal length", float)


def parse_indices(text: str):
    """``--index 3``, ``3,7,9``, ``10:19`` (inclusive) or ``800:`` (to the end): a list of
    ``(lo, hi)`` ranges of scenario positions, hi None for the end of the file."""
    out = []
    for part in text.replace(" ", "").split(","):
        lo, hi = _bounds(part, "scenario positions (integers >= 0)", int) if part else (None, None)
        if lo is None or lo < 0:
            raise argparse.ArgumentTypeError(
                f"expected --index K, K,L,M or LO:HI (integers >= 0, both ends included), got {text!r}"
            )
        out.append((lo, hi))
    return out


def parse_seed(text: str) -> int:
    """A seed: an integer in [0, 2**32) (jax keys take 32 bits; a larger seed is not wrapped)."""
    v = parse_nonnegative_int(text)
    if v >= 2**32:
        raise argparse.ArgumentTypeError(f"expected a seed in [0, 2**32), got {text!r}")
    return v


def parse_seconds(text: str) -> float:
    """``--timeout``, ``--grace-period`` ...: a positive finite number of seconds."""
    try:
        v = float(text)
    except ValueError:
        v = math.nan
    if not 0 < v < math.inf:
        raise argparse.ArgumentTypeError(f"expected a positive finite number of seconds, got {text!r}")
    return v


def parse_param_number(name: str, text: str) -> float:
    try:
        return float(text)
    except ValueError:
        raise UsageError(f"--param {name}: {text!r} is not a number") from None


def split_params(items) -> list[tuple[str, str]]:
    """``["alpha=1", ...]`` -> ``[("alpha", "1"), ...]``; duplicates and missing '=' rejected."""
    out, seen = [], set()
    for item in items or ():
        name, sep, value = item.partition("=")
        name, value = name.strip(), value.strip()
        if not sep or not name or not value:
            raise UsageError(f"--param expects NAME=VALUE (e.g. alpha=1.5), got {item!r}")
        if name in seen:
            raise UsageError(f"--param {name} given more than once")
        seen.add(name)
        out.append((name, value))
    return out


def parse_params(items: list[str] | None) -> dict[str, float]:
    """``--param NAME=VALUE`` for one run: one float per name."""
    out = {}
    for name, value in split_params(items):
        if any(ch in value for ch in ",:"):
            raise UsageError(
                f"--param {name}={value}: solve takes one value per parameter "
                "(lists a,b,c and ranges a:b:n are for 'jaco sweep')"
            )
        out[name] = parse_param_number(name, value)
    return out


def parse_axis(name: str, value: str) -> list[float]:
    """A sweep axis: ``a:b:n`` (n values from a to b inclusive), ``a,b,c`` or one number."""
    import numpy as np

    if ":" in value:
        parts = value.split(":")
        if len(parts) != 3:
            raise UsageError(f"--param {name}={value}: a range is START:STOP:COUNT, e.g. 0.5:3:6")
        a, b = parse_param_number(name, parts[0]), parse_param_number(name, parts[1])
        try:
            n = int(parts[2])
        except ValueError:
            n = 0
        if n < 1:
            raise UsageError(f"--param {name}={value}: COUNT in START:STOP:COUNT must be a positive integer")
        from ..engine.memory import CONFIG_BYTES, check_memory

        check_memory(CONFIG_BYTES * n, f"--param {name}={value} ({n} configurations)", "use fewer values")
        return [float(x) for x in np.linspace(a, b, n)]
    if "," in value:
        return [parse_param_number(name, v) for v in value.split(",") if v.strip() != ""] or [
            parse_param_number(name, value)
        ]
    return [parse_param_number(name, value)]


def parse_sweep_params(items: list[str] | None) -> dict[str, list[float]]:
    return {name: parse_axis(name, value) for name, value in split_params(items)}
