"""A record's JSON: floats that survive inf and NaN, cells as lists of ints, and strict,
readable text that is checked to read back before it is written."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from ..outputs import check_output, write_text
from .record_errors import RecordError


def json_number(x):
    """jaco's one JSON encoding of a float (records, study results, ``--json`` output): finite as
    is (repr round-trips), +inf (a failed run's length) as null, -inf and nan as the strings
    ``"-inf"`` and ``"nan"``; :func:`number_from_json` reads it back."""
    x = float(x)
    if math.isfinite(x):
        return x
    return None if x == math.inf else str(x)


def number_from_json(x) -> float:
    """The float :func:`json_number` wrote."""
    return math.inf if x is None else float(x)


def plain_json(x):
    """``x`` as plain JSON values: mappings (keys as strings), sequences and numpy arrays as
    lists, numpy scalars as Python ones, floats by :func:`json_number`; anything else as its
    string."""
    if isinstance(x, dict):
        return {str(k): plain_json(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [plain_json(v) for v in x]
    if isinstance(x, np.ndarray):
        return plain_json(x.tolist())
    if isinstance(x, (bool, np.bool_)):
        return bool(x)
    if isinstance(x, (int, np.integer)):
        return int(x)
    if isinstance(x, (float, np.floating)):
        return json_number(x)
    if x is None or isinstance(x, str):
        return x
    return str(x)


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


def json_text(doc: dict) -> str:
    text = _dumps(doc) + "\n"
    json.loads(text)  # never write a file that does not read back
    return text


def write_json(doc: dict, path: Path, what: str = "record") -> Path:
    path = check_output(path, what)
    return write_text(path, json_text(doc), what)


def cells_to_json(x):
    """A (row, col) pair, a list of pairs, or None, as JSON lists of ints."""
    if x is None:
        return None
    a = np.asarray(x)
    if a.dtype.kind not in "iu" and not np.all(a == np.round(a)):
        raise RecordError(f"cells must be integers, got {x!r}")
    return a.astype(np.int64).tolist()


def cells_from_json(x):
    if x is None:
        return None
    a = np.asarray(x, dtype=np.int64)
    if a.ndim == 1:
        return tuple(int(v) for v in a)
    return [tuple(int(v) for v in row) for row in a]
