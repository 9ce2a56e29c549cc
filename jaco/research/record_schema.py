"""The schema a record must have, checked on load: a small language of field checks (what a
field must be, and whether it is required) and the tables of a run and a sweep record."""

from __future__ import annotations

from typing import Any

from .record_errors import RecordError


def _is_int(v) -> bool:
    return isinstance(v, int) and not isinstance(v, bool)


def _is_num(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def _is_float_entry(v) -> bool:
    """A float as :func:`jaco.research.record_json.json_number` writes it: a number, null (+inf) or "-inf" / "nan"."""
    return v is None or _is_num(v) or v in ("-inf", "nan", "inf")


def _is_pair(v) -> bool:
    return isinstance(v, list) and len(v) == 2 and all(_is_int(x) for x in v)


def _list_of(pred):
    return lambda v: isinstance(v, list) and all(pred(x) for x in v)


def _map_of(pred):
    return lambda v: isinstance(v, dict) and all(isinstance(k, str) and pred(x) for k, x in v.items())


def _maybe(pred):
    return lambda v: v is None or pred(v)


def _either(*preds):
    return lambda v: any(p(v) for p in preds)


def _int_in(lo, hi):
    return lambda v: _is_int(v) and lo <= v < hi


def _is_dtype(v) -> bool:
    return v in ("float16", "float32", "float64")


_STR, _POS_INT = (lambda v: isinstance(v, str)), _int_in(1, 2**31)
_PAIRS = _either(_is_pair, _list_of(_is_pair))
_AXES = _map_of(_either(_is_num, _list_of(_is_num)))
# field: (check, what it must be, required)
_HEADER = {
    "format": (_STR, "a string", True),
    "format_version": (_int_in(0, 2**31), "an integer >= 0", False),
    "kind": (lambda v: v in ("run", "sweep"), "'run' or 'sweep'", True),
    "created": (_STR, "a string", False),
    "versions": (_map_of(_maybe(_STR)), "a mapping of names to version strings", False),
}
_MAP = {
    "name": (_STR, "a string", False),
    "shape": (
        lambda v: isinstance(v, list) and len(v) == 2 and all(_int_in(1, 2**31)(x) for x in v),
        "[height, width], two positive integers",
        True,
    ),
    "cell_size": (lambda v: _is_num(v) and v > 0, "a positive number", False),
    "resolution": (_maybe(lambda v: _is_num(v) and v > 0), "a positive number or null", False),
    "origin": (
        _maybe(lambda v: isinstance(v, list) and len(v) == 3 and all(_is_num(x) for x in v)),
        "[x, y, yaw] or null",
        False,
    ),
    "sha256": (_maybe(_STR), "a string", False),
    "source": (_maybe(_map_of(_STR)), "a mapping or null", False),
    "rows": (_list_of(_STR), "a list of strings", False),
    "packed": (_STR, "a base64 string", False),
}
_RUN_CALL = {
    "variant": (_STR, "a planner name (a string)", True),
    "seed": (_int_in(0, 2**32), "an integer in [0, 2**32)", True),
    "n_ants": (_POS_INT, "a positive integer", True),
    "n_iters": (_POS_INT, "a positive integer", True),
    "steplimit": (_POS_INT, "a positive integer", True),
    "connectivity": (lambda v: v in (4, 8) and _is_int(v), "4 or 8", False),
    "keep_pheromone": (lambda v: isinstance(v, bool) or v == "history", "true, false or 'history'", False),
    "params": (_map_of(_is_num), "a mapping of parameter names to numbers", True),
    "start": (_is_pair, "[row, col], two integers", True),
    "goal": (_is_pair, "[row, col], two integers", True),
    "waypoints": (_maybe(_list_of(_is_pair)), "a list of [row, col] pairs or null", False),
}
_RESULT = {
    "success": (lambda v: isinstance(v, bool), "true or false", True),
    "path": (_list_of(_is_pair), "a list of [row, col] pairs", True),
    **{k: (_is_float_entry, "a number, null or '-inf'/'nan'", True) for k in ("length", "cost", "optimal", "coverage")},
    "gap": (_is_float_entry, "a number, null or '-inf'/'nan'", False),
    "best_iteration": (_int_in(-1, 2**31), "an integer >= -1", True),
    "history": (_map_of(_list_of(_is_float_entry)), "a mapping of names to lists of numbers", True),
    "history_dtype": (_map_of(_is_dtype), "a mapping of names to float dtypes", False),
    "pheromone_sha256": (_maybe(_STR), "a string or null", False),
}
_SWEEP_CALL = {
    "grid": (
        lambda v: isinstance(v, dict) or (isinstance(v, list) and v and all(isinstance(x, dict) for x in v)),
        "a map entry or a non-empty list of them",
        True,
    ),
    "start": (_PAIRS, "[row, col] or a list of them", True),
    "goal": (_PAIRS, "[row, col] or a list of them", True),
    "variant": (
        _either(_STR, lambda v: isinstance(v, list) and v and all(isinstance(x, str) for x in v)),
        "a planner name or a list of names",
        True,
    ),
    "params": (
        _either(_AXES, lambda v: isinstance(v, dict) and list(v) == ["design"] and _AXES(v["design"])),
        "a mapping of parameter names to lists of numbers",
        True,
    ),
    "seeds": (
        _either(_POS_INT, lambda v: isinstance(v, list) and v and all(_int_in(0, 2**32)(x) for x in v)),
        "a positive count or a list of integers in [0, 2**32)",
        True,
    ),
    "n_ants": (_POS_INT, "a positive integer", True),
    "n_iters": (_POS_INT, "a positive integer", True),
    "steplimit": (_maybe(_POS_INT), "a positive integer or null", True),
    "connectivity": (lambda v: v in (4, 8) and _is_int(v), "4 or 8", False),
    "memory_budget": (lambda v: _is_int(v) and v >= 1, "a positive integer", False),
}
_TABLE = {
    "file": (lambda v: isinstance(v, str) and v and "/" not in v and "\\" not in v, "a file name", True),
    "rows": (_int_in(0, 2**63), "an integer >= 0", False),
    "columns": (_list_of(_STR), "a list of strings", False),
    "sha256": (_maybe(_STR), "a string", False),
}


def _show(v) -> str:
    text = repr(v)
    return f"{type(v).__name__} {text if len(text) <= 60 else text[:57] + '...'}"


def _check_fields(obj, schema: dict, where: str, name: str) -> None:
    if not isinstance(obj, dict):
        raise RecordError(f"{name}: field {where} must be a mapping (JSON object), got {_show(obj)}")
    for key, (ok, expected, required) in schema.items():
        field_name = f"{where}.{key}" if where else key
        if key not in obj:
            if required:
                raise RecordError(f"{name}: field {field_name} is missing")
            continue
        if not ok(obj[key]):
            raise RecordError(f"{name}: field {field_name} must be {expected}, got {_show(obj[key])}")


def check_record(doc: Any, name: str) -> None:
    """A :class:`RecordError` naming the first field of a loaded record (``doc``, parsed JSON)
    whose type or value does not fit the format (docs/records.md, "Schema")."""
    _check_fields(doc, _HEADER, "", name)
    if doc["kind"] == "run":
        _check_fields(doc.get("call"), _RUN_CALL, "call", name)
        _check_fields(doc.get("map"), _MAP, "map", name)
        _check_fields(doc.get("result"), _RESULT, "result", name)
        maps = [("map", doc["map"])]
    else:
        _check_fields(doc.get("call"), _SWEEP_CALL, "call", name)
        _check_fields(doc.get("table"), _TABLE, "table", name)
        grid = doc["call"]["grid"]
        maps = [("call.grid", grid)] if isinstance(grid, dict) else [(f"call.grid[{i}]", g) for i, g in enumerate(grid)]
    for where, entry in maps:
        _check_fields(entry, _MAP, where, name)
        if "rows" not in entry and "packed" not in entry:
            raise RecordError(f"{name}: field {where} has neither rows nor packed (the embedded map)")
