"""The notebooks run top to bottom in a fresh kernel and show the figures they are stored with.

Each notebook is executed as a user's Jupyter would run it (nbclient, the ``python3`` kernel), with
``MPLBACKEND=Agg`` set from outside (the notebooks never choose a backend; their
``%matplotlib inline`` renders without a display). A cell that raises fails the test with the
cell's traceback; a notebook that draws fewer figures than its stored copy shows fails too.
"""

import os
from pathlib import Path

import nbclient
import nbformat
import pytest

NOTEBOOKS = sorted((Path(__file__).resolve().parents[1] / "notebooks").glob("*.ipynb"))


def _figures(nb) -> int:
    return sum("image/png" in o.get("data", {}) for c in nb.cells if c.cell_type == "code" for o in c.get("outputs", []))


def test_every_notebook_is_found():
    assert [p.name[:2] for p in NOTEBOOKS] == ["01", "02", "03", "04", "05", "07"]


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.stem)
def test_notebook_runs_and_shows_its_figures(path, monkeypatch):
    monkeypatch.setenv("MPLBACKEND", "Agg")
    stored = nbformat.read(path, as_version=4)
    assert _figures(stored) > 0, "stored without its figures"
    assert all(c.get("outputs") or c.source.strip() == "" for c in stored.cells if c.cell_type == "code"), \
        "a code cell stored without its output"
    for c in stored.cells:  # nothing from the machine that ran it
        for o in c.get("outputs", []):
            text = "".join(o.get("text", "")) + "".join(o.get("data", {}).get("text/plain", ""))
            assert "Traceback" not in text and os.sep + "site-packages" not in text, text[:300]
    run = nbformat.read(path, as_version=4)
    nbclient.NotebookClient(run, timeout=600, kernel_name="python3", resources={"metadata": {"path": str(path.parent)}}).execute()
    assert _figures(run) == _figures(stored)
