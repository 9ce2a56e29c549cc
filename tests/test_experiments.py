"""The experiment scripts run at --smoke size and write what they promise."""

import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_thesis_tables_smoke(tmp_path):
    out = subprocess.run(
        [sys.executable, str(ROOT / "experiments" / "thesis_tables.py"), "--smoke", "--out", str(tmp_path)],
        capture_output=True, text=True, timeout=600,
    )
    assert out.returncode == 0, out.stderr[-2000:]
    text = (tmp_path / "results_thesis_smoke.md").read_text()
    for name in ("random-20-10", "utrap-15"):
        row = next(line for line in text.splitlines() if line.startswith(f"| {name} | "))
        optimum = float(row.split("|")[2])
        assert optimum > 0
        # every reported best length is either missing (no success) or >= the exact optimum
        cells = [c.strip() for c in row.split("|")[3:-1]]
        for best in cells[::4]:
            assert best == "–" or float(best) >= optimum - 1e-6
    assert re.search(r"\| ACA best \| ACA gap %", text)
    pngs = sorted(p.name for p in (tmp_path / "figures").glob("*.png"))
    assert "thesis_paths_utrap-15.png" in pngs and "thesis_convergence_random-20-10.png" in pngs
    assert all((tmp_path / "figures" / p).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" for p in pngs)
