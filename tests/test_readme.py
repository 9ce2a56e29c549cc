"""The README's Python example runs as a script and prints what its comments promise."""

import re
from pathlib import Path

import pytest

README = Path(__file__).resolve().parents[1] / "README.md"


def python_blocks() -> list[str]:
    return re.findall(r"```python\n(.*?)```", README.read_text(encoding="utf-8"), re.S)


@pytest.mark.slow
def test_readme_python_example_runs_and_prints(tmp_path, monkeypatch, capsys):
    code = python_blocks()[0]
    monkeypatch.chdir(tmp_path)
    exec(compile(code, "README.md", "exec"), {"__name__": "__main__"})
    out = capsys.readouterr().out.splitlines()
    length, optimum = map(float, re.match(r"length ([\d.]+), optimum ([\d.]+), gap", out[0]).groups())
    assert length >= optimum > 0
    assert out[1].startswith("[[2, 21], ")  # the path starts on the start cell
    assert re.match(r"\s*beta\s+q0\s+success_rate\s+length_median\s+gap_median", out[2])
    words = out.index(next(line for line in out if line.startswith("3 configurations (planner) compared on gap")))
    assert words == 3 + 9 + 3 and out[words - 2] == "True"  # nine configurations; the record reran bit for bit
    assert out[words - 3].startswith("via ((10, 5), (20, 20)): length ")
    assert "'beta':" in out[words - 1]
    assert any(line.startswith("iaca is better than as: signed ranks favour iaca 501 to 27") for line in out[words:])
    assert {p.name for p in tmp_path.iterdir()} == {"paths.png", "heatmap.png", "run.json", "cd.png"}


@pytest.mark.slow
def test_readme_search_example_runs_stores_and_resumes(tmp_path, monkeypatch, capsys):
    code = python_blocks()[1]
    assert "jaco.search(" in code
    monkeypatch.chdir(tmp_path)
    exec(compile(code, "README.md", "exec"), {"__name__": "__main__"})
    out = capsys.readouterr().out.splitlines()
    assert out[0].startswith("{'planner': ") and out[0].endswith("%")
    assert {p.name for p in tmp_path.iterdir()} == {"study.db"}
    exec(compile(code, "README.md", "exec"), {"__name__": "__main__"})  # the same call again: resumed, done
    assert capsys.readouterr().out.splitlines()[0] == out[0]
