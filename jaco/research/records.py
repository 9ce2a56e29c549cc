"""Reproducible run records: load a run or a sweep record, rerun it and check the rerun; save
a sweep.

A *record* is everything needed to run a result again without the original files, plus the
result itself so that a rerun can be compared bit for bit (docs/records.md has the format):

* a **run** (:meth:`jaco.Result.save`, written by :mod:`jaco.research.record_format`): one JSON
  file;
* a **sweep** (:func:`save_sweep`): the table as CSV plus a JSON sidecar (same stem, ``.json``).

The map is always embedded (text rows up to :data:`EMBED_ROWS_MAX` cells, above that a packed bit
mask), together with its sha256 (:func:`map_hash`) and, when it is a named map or a bundled file,
that name, so a record never depends on the file it was made from. ``load_run(path).rerun()``
runs the same call again and reports whether path, length, cost and history (or, for a sweep, the
whole table) are identical; when the record was written by other versions of jaco / jax / jaxlib
or on another backend, it says so (one warning line naming both versions), because XLA may then
legitimately produce different floating point rounding.

>>> import jaco, tempfile, os
>>> grid = jaco.maps.named("demo")
>>> r = jaco.solve(grid, grid.meta["start"], grid.meta["goal"], seed=1, n_ants=8, n_iters=5)
>>> path = r.save(os.path.join(tempfile.mkdtemp(), "run.json"))
>>> jaco.load_run(path).rerun().matched
True
"""

from __future__ import annotations

import hashlib
import inspect
import json
import math
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..engine.planner import Planner
from ..engine.result import Result
from ..errors import JacoError, one_line, resolve_aliases
from ..grid import Grid
from ..metrics import gap
from ..outputs import as_path, atomic_paths, check_output, write_text
from .record_errors import RecordError, RecordWarning
from .record_format import recordable_name, save_path, save_run
from .record_json import cells_from_json, cells_to_json, json_text, number_from_json
from .record_map import EMBED_ROWS_MAX, grid_from_entry, map_entry, map_hash
from .record_schema import check_record
from .record_versions import CHECKED_VERSIONS, FORMAT, FORMAT_VERSION, record_header, version_warnings, versions

__all__ = [
    "CHECKED_VERSIONS",
    "EMBED_ROWS_MAX",
    "FORMAT",
    "FORMAT_VERSION",
    "RecordError",
    "RecordWarning",
    "Rerun",
    "RunRecord",
    "SweepRecord",
    "load_run",
    "map_hash",
    "save_path",
    "save_run",
    "save_sweep",
    "versions",
]


@dataclass
class Rerun:
    """The outcome of :meth:`RunRecord.rerun` / :meth:`SweepRecord.rerun`.

    ``matched`` is True when everything recorded came out identical; ``differences`` lists what
    did not; ``warnings`` the version / map notes; ``result`` is the new :class:`jaco.Result`
    (run) or DataFrame (sweep).
    """

    matched: bool
    differences: list
    warnings: list
    result: object
    what: str

    def summary(self) -> str:
        """Lines for a person: the warnings, then whether the rerun matched and, if not, how."""
        lines = [f"warning: {w}" for w in self.warnings]
        if self.matched:
            lines.append(f"rerun matched the record bit for bit ({self.what})")
        else:
            lines.append(f"rerun did NOT match the record ({len(self.differences)} difference(s)):")
            lines += [f"  {d}" for d in self.differences]
        return "\n".join(lines)

    def __str__(self) -> str:
        return self.summary()


def _same_float(a, b) -> bool:
    a, b = float(a), float(b)
    return (a == b and math.copysign(1, a) == math.copysign(1, b)) or (math.isnan(a) and math.isnan(b))


@dataclass
class RunRecord:
    """A loaded run record: ``call`` (the solve arguments), ``grid``, ``result`` (the recorded
    :class:`jaco.Result`), ``versions``, ``warnings`` (version and map notes)."""

    path: Path
    call: dict
    grid: Grid
    result: Result
    versions: dict
    map_sha256: str
    pheromone_sha256: str | None = None
    warnings: list = field(default_factory=list)

    def solve_kwargs(self) -> dict:
        c = self.call
        kw = dict(
            seed=c["seed"],
            n_ants=c["n_ants"],
            n_iters=c["n_iters"],
            steplimit=c["steplimit"],
            connectivity=c["connectivity"],
            keep_pheromone=c["keep_pheromone"],
            **c["params"],
        )
        if c.get("waypoints"):
            kw["waypoints"] = cells_from_json(c["waypoints"])
        return kw

    def rerun(self, *, warn: bool = True) -> Rerun:
        """Run the recorded call again and compare path, length, cost, success, best iteration,
        coverage, optimum, history (every array, bitwise) and the pheromone hash if recorded.

        With ``warn``, version and map notes are also issued as :class:`RecordWarning`."""
        from ..api import solve

        if warn:
            for w in self.warnings:
                warnings.warn(w, RecordWarning, stacklevel=2)
        c = self.call
        try:
            new = solve(
                self.grid, cells_from_json(c["start"]), cells_from_json(c["goal"]), c["variant"], **self.solve_kwargs()
            )
        except TypeError as e:  # e.g. a waypoints record on a jaco without waypoints
            raise RecordError(f"{self.path}: this jaco cannot rerun the recorded call ({e})") from None
        old = self.result
        diffs = []
        if not np.array_equal(np.asarray(old.path), np.asarray(new.path)):
            diffs.append(
                f"path: recorded {len(old.path)} cells, rerun {len(new.path)} cells"
                + ("" if len(old.path) != len(new.path) else " (different cells)")
            )
        for name in ("success", "best_iteration"):
            if getattr(old, name) != getattr(new, name):
                diffs.append(f"{name}: recorded {getattr(old, name)}, rerun {getattr(new, name)}")
        for name in ("length", "cost", "optimal", "coverage"):
            if not _same_float(getattr(old, name), getattr(new, name)):
                diffs.append(f"{name}: recorded {getattr(old, name)!r}, rerun {getattr(new, name)!r}")
        for k in sorted(set(old.history) | set(new.history)):
            a, b = old.history.get(k), new.history.get(k)
            if a is None or b is None:
                diffs.append(f"history[{k}]: only in the {'rerun' if a is None else 'record'}")
                continue
            a, b = np.asarray(a), np.asarray(b).astype(a.dtype)
            if a.shape != b.shape or a.tobytes() != b.tobytes():
                n = int(np.sum(a != b)) if a.shape == b.shape else "all"
                diffs.append(f"history[{k}]: {n} of {len(b)} iterations differ")
        if self.pheromone_sha256 is not None and new.pheromone is not None:
            h = hashlib.sha256(np.ascontiguousarray(new.pheromone).tobytes()).hexdigest()
            if h != self.pheromone_sha256:
                diffs.append("pheromone: the final pheromone differs (sha256)")
        what = (
            f"path {len(new.path)} cells, length {new.length:.6g}, "
            f"history {len(next(iter(new.history.values()), []))} iterations"
        )
        return Rerun(not diffs, diffs, list(self.warnings), new, what)


def _backtracks(name: str) -> bool:
    """Whether the recorded planner's ants step back (False where this jaco does not know it)."""
    from ..planners.registry import get_planner

    try:
        return bool(get_planner(name).back_steps)
    except JacoError:
        return False


def _result_from(doc: dict, grid: Grid):
    c, r = doc["call"], doc["result"]
    history = {
        k: np.array([number_from_json(x) for x in v], dtype=np.dtype(r.get("history_dtype", {}).get(k, "float32")))
        for k, v in r["history"].items()
    }
    length, optimal = number_from_json(r["length"]), number_from_json(r["optimal"])
    res = Result(
        variant=c["variant"],
        path=np.asarray(r["path"], np.int64).reshape(-1, 2),
        length=length,
        success=bool(r["success"]),
        cost=number_from_json(r["cost"]),
        optimal=optimal,
        gap=number_from_json(r["gap"]) if "gap" in r else gap(length, optimal),
        best_iteration=int(r["best_iteration"]),
        history=history,
        coverage=number_from_json(r["coverage"]),
        seed=int(c["seed"]),
        params=dict(c["params"]),
        n_ants=int(c["n_ants"]),
        n_iters=int(c["n_iters"]),
        steplimit=int(c["steplimit"]),
        start=cells_from_json(c["start"]),
        goal=cells_from_json(c["goal"]),
        grid=grid,
    )
    for name, value in (
        ("connectivity", int(c.get("connectivity", 8))),
        ("waypoints", cells_from_json(c.get("waypoints"))),
        ("back_steps", _backtracks(c["variant"])),
    ):
        if hasattr(res, name) and value is not None:
            setattr(res, name, value)
    return res


# -- sweeps ---------------------------------------------------------------------------------
def _sidecar(path: Path) -> Path:
    return path.with_suffix(".json")


def _csv_text(table) -> str:
    from .tables import csv_text

    return csv_text(table)


def _encode_grids(grid):
    if isinstance(grid, Grid):
        return map_entry(grid)
    grids = list(grid)
    if not grids or not all(isinstance(g, Grid) for g in grids):
        raise RecordError("grid: expected a jaco.Grid or a list of Grids")
    return [map_entry(g) for g in grids]


def _jsonable(name: str, value):
    try:
        json.dumps(value, allow_nan=False)
    except (TypeError, ValueError):
        raise RecordError(f"sweep argument {name}={value!r} cannot be written to a record (not plain JSON)") from None
    return value


def save_sweep(table: Any, path: Any, *args: Any, **kwargs: Any) -> Path:
    """Write a :func:`jaco.sweep` table as CSV at ``path`` and a JSON sidecar beside it
    (``path`` with suffix ``.json``); returns the sidecar's path, which :func:`load_run` reads
    (it also accepts the CSV's path).

    ``jaco.sweep`` returns a plain DataFrame that does not carry its arguments, so after the table
    and the path pass the same arguments the sweep was called with (positional or by keyword, e.g.
    ``save_sweep(df, "s.csv", grid, start, goal, "acs", {"q0": [0.5, 0.9]}, 8, n_ants=20)``).
    They are bound to ``jaco.sweep``'s own signature (its defaults fill the rest) and recorded;
    ``progress`` is not. The table must have as many rows, and the same seeds, as those
    arguments give, so a wrong argument is caught here; the rest is checked by a rerun.
    """
    from ..planners.registry import get_planner

    path = check_output(path, "sweep record")
    if path.suffix.lower() != ".csv":
        raise RecordError(f"a sweep record is a .csv table plus a .json sidecar; got {path.name!r} (use a .csv name)")
    check_output(_sidecar(path), "sweep record sidecar")
    given = _sweep_arguments(args, kwargs)
    several = isinstance(given["variant"], (list, tuple)) and not isinstance(given["variant"], Planner)
    variant_names = [recordable_name(get_planner(v)) for v in (given["variant"] if several else [given["variant"]])]
    n_configs, recorded_params = _recorded_params(given["params"])
    seeds_arg = given["seeds"]
    seed_list = list(range(int(seeds_arg))) if isinstance(seeds_arg, (int, np.integer)) else [int(s) for s in seeds_arg]
    _check_table_size(table, given, len(variant_names), n_configs, seed_list)

    call = {}
    for name, value in given.items():
        if name == "grid":
            call[name] = _encode_grids(value)
        elif name in ("start", "goal"):
            call[name] = cells_to_json(value)
        elif name == "variant":
            call[name] = variant_names if several else variant_names[0]
        elif name == "params":
            call[name] = recorded_params
        elif name == "seeds":
            call[name] = int(value) if isinstance(value, (int, np.integer)) else seed_list
        else:
            call[name] = _jsonable(name, value.item() if isinstance(value, np.generic) else value)
    return _write_sweep_record(table, path, call)


def _sweep_arguments(args: tuple, kwargs: dict) -> dict:
    """The arguments of a :func:`jaco.sweep` call, bound to its signature with its defaults, as a
    record names them (``variant`` for ``planner``; ``progress`` left out)."""
    from . import sweeps

    try:
        bound = inspect.signature(sweeps.sweep).bind(*args, **resolve_aliases(dict(kwargs)))
    except TypeError as e:
        raise RecordError(f"save_sweep: {e} (pass the arguments of jaco.sweep)") from None
    bound.apply_defaults()
    # the record's field keeps the name records have always used, "variant"
    given = {("variant" if k == "planner" else k): v for k, v in bound.arguments.items()}
    given.pop("progress", None)
    return given


def _recorded_params(params: Any) -> tuple[int, dict]:
    """The number of configurations of a sweep's ``params`` and how the record holds them: a dict of
    axes as its axes, a Design or DataFrame as explicit rows."""
    from .designs import as_design

    design = as_design(params)  # a dict of axes is a full grid; a Design or DataFrame as given
    rows = {k: [float(x) for x in v] for k, v in design.values.items()}
    if isinstance(params, dict) or params is None:
        axes = {
            k: [float(x) for x in np.atleast_1d(np.asarray(vals, np.float64))] for k, vals in (params or {}).items()
        }
        return math.prod(len(x) for x in axes.values()), axes
    # recorded as explicit rows, rebuilt with jaco.research.designs.table on rerun
    return len(design), {"design": rows}


def _check_table_size(table: Any, given: dict, n_planners: int, n_configs: int, seed_list: list) -> None:
    """The table has the rows and seeds these arguments give (a wrong argument is caught here)."""
    grids = [given["grid"]] if isinstance(given["grid"], Grid) else list(given["grid"])
    pair = lambda x: np.ndim(x) == 1 and len(x) == 2  # noqa: E731
    n_q = max(
        len(grids), 1 if pair(given["start"]) else len(given["start"]), 1 if pair(given["goal"]) else len(given["goal"])
    )
    expected = n_planners * n_q * n_configs * len(seed_list)
    if len(table) != expected:
        raise RecordError(
            f"the table has {len(table)} rows but these arguments give {expected} "
            f"({n_planners} planners x {n_q} queries x {n_configs} configurations x {len(seed_list)} seeds): "
            "pass the arguments the sweep was called with"
        )
    if "seed" in table and set(int(s) for s in table["seed"]) != set(seed_list):
        raise RecordError("the table's seeds are not the seeds given: pass the arguments the sweep was called with")


def _write_sweep_record(table: Any, path: Path, call: dict) -> Path:
    """The table's CSV at ``path`` and its JSON sidecar (``call``, the table's hash); returns the sidecar."""
    text = _csv_text(table)
    doc = record_header("sweep")
    doc["call"] = call
    doc["table"] = {
        "file": path.name,
        "rows": len(table),
        "columns": list(map(str, table.columns)),
        "sha256": hashlib.sha256(text.encode()).hexdigest(),
    }
    # both files complete before either replaces an old one; renamed together (sidecar, then
    # table) under a lock, so two processes saving one record never leave a mixed pair
    sidecar = _sidecar(path)
    with atomic_paths([sidecar, path], "sweep record") as (sidecar_tmp, table_tmp):
        write_text(sidecar_tmp, json_text(doc))
        write_text(table_tmp, text)
    return sidecar


@dataclass
class SweepRecord:
    """A loaded sweep record: ``call`` (the sweep arguments, maps rebuilt in ``grids``),
    ``table`` (the recorded DataFrame, in the current layout: :func:`jaco.research.tables.read_table`),
    ``table_text`` (its CSV as written), ``versions``, ``warnings``."""

    path: Path
    call: dict
    grids: object
    table: Any
    table_text: str
    versions: dict
    warnings: list = field(default_factory=list)
    format_version: int = FORMAT_VERSION

    def sweep_kwargs(self) -> dict:
        kw = dict(self.call)
        kw["grid"] = self.grids
        kw["start"], kw["goal"] = cells_from_json(kw["start"]), cells_from_json(kw["goal"])
        if isinstance(kw.get("params"), dict) and "design" in kw["params"]:  # explicit rows (a Design)
            from .designs import table

            kw["params"] = table(kw["params"]["design"])
        return kw

    def _rerun_old_default(self, kw):
        """The sweep with the default step limit of the jaco that wrote the record, each planner's."""
        from ..engine.checks import legacy_steplimit
        from ..planners.registry import get_planner
        from .sweeps import sweep, sweep_each_planner

        grid = self.grids if isinstance(self.grids, Grid) else self.grids[0]

        def one(v):
            v = get_planner(v)
            return sweep(**{**kw, "planner": v, "steplimit": legacy_steplimit(grid, v, self.format_version)})

        planners = kw["planner"]
        if isinstance(planners, (list, tuple)) and not isinstance(planners, Planner):
            return sweep_each_planner(planners, one, kw.get("params"))
        return one(planners)

    def rerun(self, *, warn: bool = True) -> Rerun:
        """Run the recorded sweep again and compare the whole table value by value, every number
        to the last bit at the precision it was recorded in (float32 in tables written by this
        jaco, float64 in older ones; :func:`jaco.research.tables.differences`), in the current
        layout or an older one; differences name the first differing rows and columns."""
        from .sweeps import sweep
        from .tables import differences

        if warn:
            for w in self.warnings:
                warnings.warn(w, RecordWarning, stacklevel=2)
        kw = self.sweep_kwargs()
        if "variant" in kw:  # the record's name of sweep's planner= (variant= would warn as a former name)
            kw["planner"] = kw.pop("variant")
        try:
            if kw.get("steplimit") is None and self.format_version < FORMAT_VERSION:
                new = self._rerun_old_default(kw)
            else:
                new = sweep(**kw)
        except TypeError as e:
            raise RecordError(f"{self.path}: this jaco cannot rerun the recorded sweep ({e})") from None
        diffs = [] if _csv_text(new) == self.table_text else differences(self.table, _as_recorded(new, self))
        what = f"{len(new)} rows x {len(new.columns)} columns"
        return Rerun(not diffs, diffs, list(self.warnings), new, what)


def _as_recorded(new, record: SweepRecord):
    """The rerun's table as the record's jaco wrote it: a one-planner table written before every
    table named its planner has no ``planner`` column (its sidecar's ``call.variant`` names it),
    so the rerun's is checked against the call and left out."""
    from .tables import PLANNER

    if PLANNER not in new.columns or PLANNER in record.table.columns:
        return new
    named = record.call["variant"]
    if isinstance(named, str) and set(new[PLANNER]) == {named}:
        return new.drop(columns=PLANNER)
    return new  # a different planner: the columns differ, and the rerun says so


# -- loading --------------------------------------------------------------------------------
def load_run(path: Any) -> RunRecord | SweepRecord:
    """Load a record written by :meth:`jaco.Result.save` (returns a :class:`RunRecord`) or by
    :func:`save_sweep` (a :class:`SweepRecord`; the sidecar ``.json`` or its ``.csv`` table).
    ``load_run(path).rerun()`` reruns it and reports whether it matched."""
    path = as_path(path, "record", RecordError)
    if path.suffix.lower() == ".csv":
        path = _sidecar(path)
    if not path.is_file():
        raise RecordError(f"record {str(path)!r} not found")
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except (json.JSONDecodeError, UnicodeDecodeError) as e:
        raise RecordError(f"{path.name}: not a JSON record ({one_line(e)})") from None
    except RecursionError:
        raise RecordError(f"{path.name}: not a jaco record (JSON nested too deeply)") from None
    if not isinstance(doc, dict) or doc.get("format") != FORMAT:
        raise RecordError(f'{path.name}: not a jaco record (no "format": "{FORMAT}")')
    check_record(doc, path.name)
    if doc.get("format_version", 0) > FORMAT_VERSION:
        raise RecordError(
            f"{path.name}: record format version {doc.get('format_version')} is newer than this "
            f"jaco reads ({FORMAT_VERSION}): upgrade jaco"
        )
    recorded = doc.get("versions", {})
    notes = version_warnings(recorded, doc.get("format_version", 0))
    try:
        if doc.get("kind") == "run":
            grid, map_notes = grid_from_entry(doc["map"], path.name)
            rec = RunRecord(
                path,
                doc["call"],
                grid,
                _result_from(doc, grid),
                recorded,
                doc["map"].get("sha256"),
                doc["result"].get("pheromone_sha256"),
                notes + map_notes,
            )
            return rec
        if doc.get("kind") == "sweep":
            entries = doc["call"]["grid"]
            grids: Grid | list[Grid]
            if isinstance(entries, dict):
                grids, map_notes = grid_from_entry(entries, path.name)
            else:
                built = [grid_from_entry(e, path.name) for e in entries]
                grids, map_notes = [g for g, _ in built], [n for _, ns in built for n in ns]
            table_path = path.parent / doc["table"]["file"]
            if not table_path.is_file():
                raise RecordError(
                    f"{path.name}: its table {table_path.name!r} is missing (expected beside the sidecar)"
                )
            text = table_path.read_text(encoding="utf-8")
            if hashlib.sha256(text.encode()).hexdigest() != doc["table"].get("sha256"):
                map_notes.append(
                    f"table {table_path.name}: its sha256 differs from the sidecar's: the table was modified"
                )
            from .tables import read_table

            table = read_table(text)
            return SweepRecord(
                path, doc["call"], grids, table, text, recorded, notes + map_notes, doc.get("format_version", 0)
            )
    except (KeyError, TypeError, ValueError) as e:
        raise RecordError(f"{path.name}: incomplete record ({type(e).__name__}: {e})") from None
    raise RecordError(f"{path.name}: unknown record kind {doc.get('kind')!r} (expected 'run' or 'sweep')")
