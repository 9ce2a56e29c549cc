"""A record's JSON: floats that survive inf and NaN, cells as lists of ints, and strict,
readable text that is checked to read back before it is written."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from ..outputs import check_output, write_text
from .record_errors import RecordError


def _num(x):
    """A float for JSON: finite as is (repr round-trips), +inf as null, -inf/nan as strings."""
    x = float(x)
    if math.isfinite(x):
        return x
    return None if x == math.inf else str(x)


def _unnum(x) -> float:
    return math.inf if x is None else float(x)


def _dumps(x, indent: int = 0) -> str:
    """Readable, strict JSON: mappings one key per line, lists of numbers (and lists of pairs)
    on one line, lists of strings (map rows) one per line."""
    pad, inner = " " * indent, " " * (indent + 1)
    scalar = lambda v: v is None or isinstance(v, (bool, int, float))  # noqa: E731
    if isinstance(x, dict):
        if not x:
            return "{}"
        items = [f"{inner}{json.dumps(str(k))}: {_dumps(v, indent + 1)}" for k, v in x.items()]
        return "{\n" + ",\n".join(items) + "\n" + pad + "}"
    if isinstance(x, list):
        if all(scalar(v) or (isinstance(v, list) and all(scalar(u) for u in v)) for v in x):
            return json.dumps(x, allow_nan=False)
        return "[\n" + ",\n".join(inner + _dumps(v, indent + 1) for v in x) + "\n" + pad + "]"
    return json.dumps(x, allow_nan=False)


def _json_text(doc: dict) -> str:
    text = _dumps(doc) + "\n"
    json.loads(text)  # never write a file that does not read back
    return text


def _write_json(doc: dict, path: Path, what: str = "record") -> Path:
    path = check_output(path, what)
    return write_text(path, _json_text(doc), what)


def _cells(x):
    """A (row, col) pair, a list of pairs, or None, as JSON lists of ints."""
    if x is None:
        return None
    a = np.asarray(x)
    if a.dtype.kind not in "iu" and not np.all(a == np.round(a)):
        raise RecordError(f"cells must be integers, got {x!r}")
    return a.astype(np.int64).tolist()


def _uncells(x):
    if x is None:
        return None
    a = np.asarray(x, dtype=np.int64)
    if a.ndim == 1:
        return tuple(int(v) for v in a)
    return [tuple(int(v) for v in row) for row in a]
