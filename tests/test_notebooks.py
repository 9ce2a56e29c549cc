"""The notebooks run top to bottom in a fresh kernel and show the figures they are stored with.

Each notebook is executed as a user's Jupyter would run it (nbclient, the ``python3`` kernel), with
``MPLBACKEND=Agg`` set from outside (the notebooks never choose a backend; their
``%matplotlib inline`` renders without a display). A cell that raises fails the test with the
cell's traceback; a notebook that draws fewer figures than its stored copy shows fails too.

The notebooks are stored as this test runs them, without the progress bars a live session shows
(they belong to the session, not to the page):
``MPLBACKEND=Agg python tests/test_notebooks.py notebooks/07_comparing_planners.ipynb`` executes
and stores the notebooks named.
"""

import os
import re
import sys
from pathlib import Path

import nbclient
import nbformat
import pytest

NOTEBOOKS = sorted((Path(__file__).resolve().parents[1] / "notebooks").glob("*.ipynb"))


def _figures(nb) -> int:
    return sum("image/png" in o.get("data", {}) for c in nb.cells if c.cell_type == "code" for o in c.get("outputs", []))


# a tqdm bar (a carriage return, "12/30", "[00:01<...]"), or the "compiling…" line before it
PROGRESS = re.compile(r"\r|\d+/\d+ \[|compiling…|it/s|chunk/s|step/s")


def _is_progress(output) -> bool:
    """A progress bar's output: stderr text that is a bar, or the bare line end a closed bar leaves."""
    text = "".join(output.get("text", ""))
    return output.get("output_type") == "stream" and output.get("name") == "stderr" and \
        (bool(PROGRESS.search(text)) or not text.strip())


def execute(nb, folder: Path):
    nbclient.NotebookClient(nb, timeout=600, kernel_name="python3", resources={"metadata": {"path": str(folder)}}).execute()
    return nb


def store(path: Path) -> None:
    """Execute a notebook and store it with its outputs, the progress bars left out."""
    nb = execute(nbformat.read(path, as_version=4), path.parent)
    for c in nb.cells:
        if c.cell_type == "code":
            c.outputs = [o for o in c.outputs if not _is_progress(o)]
            c.metadata.pop("execution", None)
    nbformat.write(nb, path)


def test_every_notebook_is_found():
    assert [p.name[:2] for p in NOTEBOOKS] == ["01", "02", "03", "04", "05", "06", "07", "08"]


# the notebooks that take more than ten seconds run with the slow checks (pytest -m slow, .ci/run)
SLOW = {"02_planners_gallery", "03_hyperparameter_sweep", "04_tuning", "05_paper_table", "06_search", "07_comparing_planners", "08_local_search"}


@pytest.mark.parametrize("path", [pytest.param(p, marks=pytest.mark.slow) if p.stem in SLOW else p for p in NOTEBOOKS],
                         ids=lambda p: p.stem)
def test_notebook_runs_and_shows_its_figures(path, monkeypatch):
    monkeypatch.setenv("MPLBACKEND", "Agg")
    stored = nbformat.read(path, as_version=4)
    assert _figures(stored) > 0, "stored without its figures"
    assert all(c.get("outputs") or c.source.strip() == "" for c in stored.cells if c.cell_type == "code"), \
        "a code cell stored without its output"
    for c in stored.cells:  # nothing from the machine that ran it, no progress bar
        for o in c.get("outputs", []):
            text = "".join(o.get("text", "")) + "".join(o.get("data", {}).get("text/plain", ""))
            assert "Traceback" not in text and os.sep + "site-packages" not in text, text[:300]
            assert not _is_progress(o) and "\r" not in text, text[:300]
    run = execute(nbformat.read(path, as_version=4), path.parent)
    assert _figures(run) == _figures(stored)


if __name__ == "__main__":
    for arg in sys.argv[1:]:
        store(Path(arg))
        print(f"stored {arg}")
