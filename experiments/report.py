"""What the experiment scripts share: number formatting, markdown tables, writing one marked
section of a markdown file (BENCHMARKS.md, docs/results.md) without touching the rest, and the
sources of git revisions for the scripts that compile kernels of several revisions side by side."""

from __future__ import annotations

import math
import shutil
import subprocess
import tempfile
from pathlib import Path

from jaco.outputs import write_text

INTRO = (
    "# Benchmarks\n\n"
    "Figures measured by the scripts in `experiments/`. Each section is written by the script it names, "
    "with the command that produced it; run the command again to refresh the section. No test asserts a "
    "time: the tests only run the scripts at `--smoke` size.\n"
)


def unsigned_zero(text: str) -> str:
    """``"-0.0"`` -> ``"0.0"``: a float32 length a hair below the float64 optimum (or an exact
    -0.0) rounds to a zero that keeps its sign, which a table should not show."""
    return text[1:] if text.startswith("-") and not text.strip("-0.,%") else text


def fmt(x, digits=3):
    """A figure for a table: ints with thousands separators, floats to ``digits`` significant
    digits, "–" for None and non-finite values."""
    if isinstance(x, str):
        return x
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "–"
    if isinstance(x, int):
        return f"{x:,}"
    ax = abs(x)
    if ax >= 1e6:
        return f"{x:.3g}" if ax < 1e9 else f"{x:.3e}"
    if ax >= 100:
        return f"{x:,.0f}"
    return unsigned_zero(f"{x:.{digits}g}")


def fixed(x, digits=2):
    """A figure to ``digits`` decimals; "–" for None and non-finite values; never "-0.00"."""
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "–"
    return unsigned_zero(f"{x:.{digits}f}")


def table(header, rows) -> str:
    out = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    out += ["| " + " | ".join(fmt(v) for v in r) + " |" for r in rows]
    return "\n".join(out)


def output_dir(out, smoke: bool) -> Path:
    """Where a script writes its markdown and figures: ``--out`` when given; else, for a
    ``--smoke`` run, a fresh temporary folder (a smoke run never touches the committed ``docs/``);
    else the repository's ``docs/``."""
    if out is not None:
        return Path(out)
    if smoke:
        return Path(tempfile.mkdtemp(prefix="jaco-smoke-"))
    return Path(__file__).resolve().parents[1] / "docs"


def write_section(path: Path, tag: str, body: str, intro: str = INTRO) -> None:
    """Replace the text between ``<!-- tag:start -->`` and ``<!-- tag:end -->`` in ``path``, or
    append the section (to ``intro`` when the file does not exist), so that the rest of the file
    survives a re-run. Written to a temporary file beside it and renamed into place: an
    interrupted run leaves the old file whole."""
    path = Path(path)
    start, end = f"<!-- {tag}:start -->", f"<!-- {tag}:end -->"
    block = f"{start}\n{body.rstrip()}\n{end}\n"
    text = path.read_text() if path.exists() else intro
    if start in text and end in text:
        text = text[: text.index(start)] + block + text[text.index(end) + len(end) + 1 :]
    else:
        text = text.rstrip() + "\n\n" + block
    write_text(path, text)


def publish(text: str, tag: str, out, smoke: bool) -> None:
    """Print a script's section and write it as section ``tag``: to ``out`` when given, else to
    the repository's BENCHMARKS.md, except after a ``--smoke`` run (nothing then)."""
    print(text)
    path = out or (None if smoke else Path(__file__).resolve().parents[1] / "BENCHMARKS.md")
    if path is not None:
        write_section(Path(path), tag, text)
        print(f"wrote {path}")


ROOT = Path(__file__).resolve().parents[1]


def revision_sources(rev: str, paths: list[str], out: Path) -> Path:
    """The files ``paths`` (relative to the repository) of git revision ``rev`` (``.``: the
    working tree), flat in folder ``out``."""
    out.mkdir()
    for path in paths:
        dst = out / Path(path).name
        if rev == ".":
            shutil.copy(ROOT / path, dst)
        else:
            text = subprocess.run(["git", "show", f"{rev}:{path}"], cwd=ROOT, capture_output=True, check=True).stdout
            dst.write_bytes(text)
    return out


def revision_labels(revs: list[str]) -> list[str]:
    """Each revision's short hash, ``.`` as it is (the working tree)."""
    return [r if r == "." else subprocess.run(["git", "rev-parse", "--short", r], cwd=ROOT, capture_output=True,
                                              text=True, check=True).stdout.strip() for r in revs]


def kernel_isa(built: tuple[str, ...] = ("avx2",)) -> str:
    """The widest lane set of jaco's kernel that a side-by-side build can use here: the widest of
    ``built`` (the sets the script has flags for) whose lanes the installed kernel runs on this CPU,
    else baseline."""
    from jaco.engine import native

    runs = [isa for isa, state in native.isas().items() if state in ("active", "runs") and isa in built]
    return runs[-1] if runs else "baseline"
