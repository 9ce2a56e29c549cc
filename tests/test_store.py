"""jaco.sweep(..., store=PATH): finished chunks survive a kill; the resumed table equals an
uninterrupted sweep bit for bit. Several processes sharing a store: tests/test_shared_sweep.py."""

import sqlite3
import subprocess
import sys
import textwrap

import pytest

import jaco
from jaco.research.store import StoreError

from test_search import ENDS, GRID  # the small map with walls both test files plan on

AXES = {"beta": [1.0, 2.0, 4.0, 8.0], "rho": [0.1, 0.3]}
KW = dict(seeds=2, n_ants=6, n_iters=12, progress=False)


def _chunks(path) -> int:
    with sqlite3.connect(path) as con:
        return con.execute("SELECT COUNT(*) FROM chunks").fetchone()[0]


@pytest.mark.slow  # a sweep three ways (the kill test below checks the same bit for bit)
def test_a_stored_sweep_equals_the_plain_one_and_the_second_call_runs_nothing(tmp_path):
    plain = jaco.sweep(GRID, *ENDS, "acs", AXES, **KW)
    store = tmp_path / "sweep.db"
    first = jaco.sweep(GRID, *ENDS, "acs", AXES, store=store, **KW)
    assert first.equals(plain) and first.attrs["sweep"]["resumed_runs"] == 0
    assert _chunks(store) == first.attrs["sweep"]["chunks"] == 8  # 16 runs in about STORE_CHUNKS chunks
    again = jaco.sweep(GRID, *ENDS, "acs", AXES, store=store, **KW)
    assert again.equals(plain) and again.attrs["sweep"]["resumed_runs"] == 16 and _chunks(store) == 8
    other = jaco.sweep(GRID, *ENDS, "acs", {"beta": [1.0, 2.0]}, store=store, **KW)  # another sweep, same store
    assert other.attrs["sweep"]["resumed_runs"] == 0 and other.equals(jaco.sweep(GRID, *ENDS, "acs", {"beta": [1.0, 2.0]}, **KW))


@pytest.mark.slow  # a second chunk size is a second program
def test_a_resumed_sweep_may_cut_its_chunks_differently(tmp_path):
    store = tmp_path / "s.db"
    plain = jaco.sweep(GRID, *ENDS, ["acs", "mmas"], {"beta": [1.0, 2.0, 4.0]}, **KW)
    part = jaco.sweep(GRID, *ENDS, "acs", {"beta": [1.0, 2.0, 4.0]}, store=store, chunk=5, **KW)
    assert part.attrs["sweep"]["chunks"] == 2
    both = jaco.sweep(GRID, *ENDS, ["acs", "mmas"], {"beta": [1.0, 2.0, 4.0]}, store=store, chunk=2, **KW)
    assert both.equals(plain)
    assert both.attrs["sweep"]["acs"]["resumed_runs"] == 6 and both.attrs["sweep"]["mmas"]["resumed_runs"] == 0


def test_a_foreign_file_is_one_line(tmp_path):
    foreign = tmp_path / "notes.db"
    foreign.write_text("not a database at all, just text " * 50)
    with pytest.raises(StoreError, match="not a jaco sweep store"):
        jaco.sweep(GRID, *ENDS, "acs", AXES, store=foreign, **KW)
    assert foreign.read_text().startswith("not a database")  # never overwritten
    other = tmp_path / "other.db"
    with sqlite3.connect(other) as con:
        con.execute("CREATE TABLE results (x)")
    with pytest.raises(StoreError, match="not a jaco sweep store"):
        jaco.sweep(GRID, *ENDS, "acs", AXES, store=other, **KW)
    with pytest.raises(jaco.JacoError, match="is a directory"):
        jaco.sweep(GRID, *ENDS, "acs", AXES, store=tmp_path, **KW)
    with pytest.raises(jaco.JacoError, match="chunk must be a positive number"):
        jaco.sweep(GRID, *ENDS, "acs", AXES, chunk=0, **KW)


KILLED = textwrap.dedent("""
    import sys, jaco
    grid = jaco.Grid.from_rows({rows!r})
    jaco.sweep(grid, {start}, {goal}, "acs", {axes!r}, seeds=2, n_ants=20, n_iters=400, chunk=2, store=sys.argv[1],
               progress=False)
""")


@pytest.mark.slow
def test_a_killed_sweep_resumes_to_the_uninterrupted_table_bit_for_bit(tmp_path, kill_after):
    store = tmp_path / "k.db"
    axes = {"beta": [1.0, 2.0, 3.0, 4.0, 6.0, 8.0], "rho": [0.1, 0.3]}
    script = KILLED.format(rows=GRID.to_rows(), start=ENDS[0], goal=ENDS[1], axes=axes)
    proc = subprocess.Popen([sys.executable, "-c", script, str(store)], cwd=tmp_path)
    kill_after(proc, lambda: _chunks(store), 2, "sweep")
    stored = _chunks(store)
    assert 2 <= stored < 12
    kw = dict(seeds=2, n_ants=20, n_iters=400, progress=False)
    resumed = jaco.sweep(GRID, *ENDS, "acs", axes, chunk=2, store=store, **kw)
    assert resumed.attrs["sweep"]["resumed_runs"] == 2 * stored
    assert resumed.equals(jaco.sweep(GRID, *ENDS, "acs", axes, **kw))  # one chunk, never interrupted
