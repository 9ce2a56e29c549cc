"""Outputs onto anything a user can name (:mod:`jaco.outputs`), through every writer: symbolic links
are followed and their targets written atomically (the link stays a link); character devices,
FIFOs and file descriptors are written in place; ``-`` is standard output; nothing is created in
``/dev``; two processes writing one path leave one whole file of one of them."""

import contextlib
import errno
import json
import os
import pickle
import stat
import subprocess
import sys
import textwrap
import threading
from pathlib import Path

import pandas as pd
import pytest

import jaco
from jaco import maps, outputs, plot
from jaco.cli import main
from jaco.errors import OutputError
from jaco.research.records import load_run, save_sweep

ROOT = Path(__file__).resolve().parents[1]
GRID = jaco.Grid.from_rows(["......", ".@@...", "...@..", "......"])
SMALL = dict(n_ants=4, n_iters=3)


@pytest.fixture(scope="module")
def result():
    return jaco.solve(GRID, (0, 0), (3, 5), "acs", seed=3, keep_pheromone="history", **SMALL)


@pytest.fixture(scope="module")
def writers(result):
    """``name -> (suffix, write(path, in_place) -> path)``: every Python writer of jaco. ``in_place``:
    the path names no format (``-``, a device, a FIFO), so a writer of several formats is given one."""
    figure = plot.plot_paths(GRID, {"acs": result.path}, start=(0, 0), goal=(3, 5))
    animation = plot.animate_pheromone(GRID, result.pheromone[:2])
    return {
        "Result.save": (".json", lambda p, s: result.save(p)),
        "Result.save_path csv": (".csv", lambda p, s: result.save_path(p, frame="cells", format="csv" if s else None)),
        "Result.save_path json": (".json", lambda p, s: result.save_path(p, frame="cells", format="json" if s else None)),
        "plot.save": (".png", lambda p, s: plot.save(figure, p, format="png" if s else None)),
        "plot.save_gif": (".gif", lambda p, s: plot.save_gif(animation, p)),
        "maps.save_text": (".txt", lambda p, s: maps.save_text(GRID, p)),
        "outputs.write_text": (".csv", lambda p, s: outputs.write_text(p, "a,b\n1,2\n")),  # --json, --csv, reports
    }


WRITERS = ["Result.save", "Result.save_path csv", "Result.save_path json", "plot.save", "plot.save_gif",
           "maps.save_text", "outputs.write_text"]


def comparable(data: bytes):
    """A record's bytes without its time of writing; other outputs as they are."""
    if data.startswith(b"{") and b'"created"' in data:
        doc = json.loads(data)
        doc.pop("created")
        return doc
    return data


@pytest.fixture(scope="module")
def reference(writers, tmp_path_factory):
    """What each writer writes to a plain new file."""
    folder = tmp_path_factory.mktemp("reference")
    out = {}
    for name, (suffix, write) in writers.items():
        out[name] = comparable(Path(write(folder / f"x{suffix}", False)).read_bytes())
    return out


def listing(*folders) -> dict:
    """Every entry of the folders: name -> (kind, link target or bytes)."""
    out = {}
    for folder in folders:
        for p in sorted(Path(folder).iterdir()):
            if p.is_symlink():
                out[str(p)] = ("link", os.readlink(p))
            elif p.is_file():
                out[str(p)] = ("file", p.read_bytes())
            else:
                out[str(p)] = ("node", stat.S_IFMT(p.lstat().st_mode), p.lstat().st_rdev)
    return out


# -- symbolic links --------------------------------------------------------------------------------
@pytest.mark.parametrize("name", WRITERS)
@pytest.mark.parametrize("link", ["relative", "absolute", "chain", "dangling", "folder link"])
def test_a_link_is_followed_and_its_target_written_atomically(writers, reference, tmp_path, name, link):
    suffix, write = writers[name]
    real, links = tmp_path / "real", tmp_path / "links"
    real.mkdir()
    links.mkdir()
    target = real / f"target{suffix}"
    if link != "dangling":
        target.write_bytes(b"old content")
    given = links / f"out{suffix}"
    if link == "relative":
        given.symlink_to(Path("..") / "real" / target.name)
    elif link == "absolute":
        given.symlink_to(target)
    elif link == "chain":  # out -> hop1 (relative) -> hop2 (absolute) -> target
        (links / "hop2").symlink_to(target)
        (links / "hop1").symlink_to("hop2")
        given.symlink_to("hop1")
    elif link == "dangling":
        given.symlink_to(target)
    else:  # a link to a folder on the way
        (links / "sub").symlink_to(real)
        given = links / "sub" / target.name
    written = write(given, False)
    assert Path(written) == given  # the name as the user gave it
    assert comparable(target.read_bytes()) == reference[name]
    links_now = listing(links)
    assert all(kind == "link" for kind, *_ in links_now.values()), links_now  # every link is still a link
    assert sorted(p.name for p in real.iterdir()) == [target.name]  # no temporary file left


@pytest.mark.parametrize("name", ["Result.save", "plot.save", "outputs.write_text"])
def test_links_that_cannot_be_written_through_are_errors(writers, tmp_path, name):
    suffix, write = writers[name]
    (tmp_path / "folder").mkdir()
    (tmp_path / "to-folder").symlink_to("folder")
    (tmp_path / "into-nowhere").symlink_to(tmp_path / "missing" / f"x{suffix}")
    (tmp_path / "loop-a").symlink_to("loop-b")
    (tmp_path / "loop-b").symlink_to("loop-a")
    before = listing(tmp_path)
    for given, needle in (("to-folder", "is a directory"),
                          ("into-nowhere", "dangling symbolic link whose target's folder does not exist"),
                          ("loop-a", "too many levels of symbolic links")):
        with pytest.raises(OutputError, match=needle) as e:
            write(tmp_path / given, False)
        assert str(tmp_path / given) in str(e.value) and "\n" not in str(e.value)
    assert listing(tmp_path) == before
    assert not (tmp_path / "missing").exists()  # never the folders a stale link points into


def test_the_sweep_record_pair_through_links(result, tmp_path):
    table = jaco.sweep(GRID, (0, 0), (3, 5), "acs", None, 1, **SMALL)
    real = tmp_path / "real"
    real.mkdir()
    (tmp_path / "s.csv").symlink_to(Path("real") / "table.csv")  # dangling: the table is created
    sidecar = save_sweep(table, tmp_path / "s.csv", GRID, (0, 0), (3, 5), "acs", None, 1, **SMALL)
    assert sidecar == tmp_path / "s.json" and (tmp_path / "s.csv").is_symlink()
    assert sorted(p.name for p in real.iterdir()) == ["table.csv"]
    assert load_run(sidecar).rerun().matched


# -- devices, FIFOs, descriptors, standard output ------------------------------------------------
@pytest.fixture
def device(tmp_path):
    """``make(name, minor)``: a private character device like /dev/null (1, 3) or /dev/full (1, 7)."""
    if os.geteuid() != 0:
        pytest.skip("os.mknod of a character device needs root")

    def make(name, minor):
        path = tmp_path / "dev" / name
        path.parent.mkdir(exist_ok=True)
        try:
            os.mknod(path, 0o666 | stat.S_IFCHR, os.makedev(1, minor))
            os.close(os.open(path, os.O_WRONLY))
        except OSError as e:
            pytest.skip(f"no private character device here ({e})")
        return path

    return make


def is_device(path, minor) -> bool:
    st = os.lstat(path)
    return stat.S_ISCHR(st.st_mode) and st.st_rdev == os.makedev(1, minor)


@pytest.mark.parametrize("name", WRITERS)
def test_a_character_device_is_written_in_place(writers, device, name):
    suffix, write = writers[name]
    null, full = device("null", 3), device("full", 7)
    assert Path(write(null, True)) == null
    with pytest.raises(OutputError, match="cannot write: No space left on device") as e:
        write(full, True)
    assert str(full) in str(e.value) and "\n" not in str(e.value)
    assert is_device(null, 3) and is_device(full, 7)  # still the devices: nothing replaced them
    assert sorted(p.name for p in null.parent.iterdir()) == ["full", "null"]  # and nothing beside them


def read_all(fd_or_path, into: list) -> threading.Thread:
    def run():
        with open(fd_or_path, "rb") as f:
            into.append(f.read())

    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    return thread


@pytest.mark.parametrize("name", WRITERS)
def test_a_fifo_is_written_in_place_for_its_reader(writers, reference, tmp_path, name):
    suffix, write = writers[name]
    fifo = tmp_path / f"pipe{suffix}"
    os.mkfifo(fifo)
    got: list = []
    reader = read_all(fifo, got)
    write(fifo, True)
    reader.join(10)
    assert comparable(got[0]) == reference[name]
    assert stat.S_ISFIFO(os.lstat(fifo).st_mode) and [p.name for p in tmp_path.iterdir()] == [fifo.name]


@pytest.mark.parametrize("name", WRITERS)
@pytest.mark.parametrize("folder", ["/proc/self/fd", "/dev/fd"])
def test_a_descriptor_path_writes_to_the_open_descriptor(writers, reference, name, folder):
    suffix, write = writers[name]
    r, w = os.pipe()
    got: list = []
    reader = read_all(r, got)
    try:
        assert outputs.target(f"{folder}/{w}").kind == "fd"
        write(f"{folder}/{w}", True)
    finally:
        os.close(w)
    reader.join(10)
    assert comparable(got[0]) == reference[name]


def test_write_errors_are_one_line_output_errors(monkeypatch, tmp_path):
    r, w = os.pipe()
    os.close(r)  # nobody reads: EPIPE
    try:
        with pytest.raises(OutputError, match=rf"record '/proc/self/fd/{w}': cannot write: Broken pipe$"):
            outputs.write_text(f"/proc/self/fd/{w}", "{}\n", "record")
    finally:
        os.close(w)

    def failing(fd, data):
        raise OSError(errno.EIO, os.strerror(errno.EIO))

    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    got: list = []
    reader = read_all(fifo, got)
    monkeypatch.setattr(outputs.os, "write", failing)
    with pytest.raises(OutputError, match="--csv '.*pipe': cannot write: Input/output error$"):
        outputs.write_text(fifo, "a\n", "--csv")
    reader.join(10)
    assert got == [b""]


def test_what_a_path_names():
    assert outputs.target("-").kind == "stdout"
    if os.path.islink("/dev/stdout"):
        assert outputs.target("/dev/stdout") == outputs.Target("fd", Path(f"/proc/{os.getpid()}/fd/1"), 1)
    assert outputs.target("/dev/null").kind == "stream" and outputs.is_stream("/dev/null")
    assert outputs.target("./-").kind == "file" and outputs.as_path("./-", "x") == Path.cwd() / "-"
    for new in ("/dev/jaco-new.json", "/dev/jaco-new/x.json", "/proc/jaco-new.json", "/sys/jaco-new.json"):
        with pytest.raises(OutputError, match="never creates, renames or removes anything in '/(dev|proc|sys)'"):
            outputs.check_output(new, "--json")
        assert not os.path.lexists(new)


def test_several_outputs_may_discard_but_not_share_a_file_or_standard_output(tmp_path):
    outputs.check_distinct({"--json": "/dev/null", "--plot": "/dev/null"})
    with pytest.raises(OutputError, match="--path-csv and --json name standard output"):
        outputs.check_distinct({"--json": "-", "--path-csv": "/dev/stdout"})
    (tmp_path / "link.json").symlink_to("run.json")
    with pytest.raises(OutputError, match="--record and --json name the same file"):
        outputs.check_distinct({"--json": tmp_path / "run.json", "--record": tmp_path / "link.json"})


def run_cli(capsys, *argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def test_solve_json_to_standard_output_is_parseable(capsys, tmp_path):
    code, out, err = run_cli(capsys, "solve", "demo", "--ants", "4", "--iters", "3", "--json", tmp_path / "r.json")
    assert code == 0, err
    code, out, err = run_cli(capsys, "solve", "demo", "--ants", "4", "--iters", "3", "--json", "-")
    assert code == 0, err
    assert json.loads(out) == json.loads((tmp_path / "r.json").read_text())  # stdout holds the JSON only
    assert "map       demo" in err and "wrote -" in err  # the summary went to stderr


def test_solve_json_to_proc_self_fd_1(capfd):
    code = main(["solve", "demo", "--ants", "4", "--iters", "3", "--json", "/proc/self/fd/1"])
    out, err = capfd.readouterr()
    assert code == 0, err
    assert json.loads(out)["planner"] == "mmas" and "map       demo" in err


def test_sweep_csv_to_standard_output(capsys, tmp_path):
    args = ["sweep", "demo", "--ants", "4", "--iters", "3", "--param", "beta=2,4", "--seeds", "2"]
    assert main([*args, "--csv", str(tmp_path / "t.csv")]) == 0
    capsys.readouterr()
    code, out, err = run_cli(capsys, *args, "--csv", "-")
    assert code == 0, err
    assert out == (tmp_path / "t.csv").read_text() and "best: mmas" in err


def test_cli_outputs_onto_links_fifos_and_descriptors(capsys, tmp_path):
    """One solve and one sweep (the runs of the tests above) write every output through a link, a
    FIFO or a descriptor: the same bytes as into plain files, every link and FIFO left as it was."""
    solve = ["solve", "demo", "--ants", "4", "--iters", "3"]
    sweep = ["sweep", "demo", "--ants", "4", "--iters", "3", "--param", "beta=2,4", "--seeds", "2"]
    plain = tmp_path / "plain"
    assert main([*solve, "--json", str(plain / "r.json"), "--path-csv", str(plain / "p.csv")]) == 0
    assert main([*sweep, "--csv", str(plain / "t.csv"), "--record", str(plain / "s.csv")]) == 0
    capsys.readouterr()
    real, links = tmp_path / "real", tmp_path / "links"
    real.mkdir()
    links.mkdir()
    os.mkfifo(links / "r.json")
    (links / "p.csv").symlink_to(Path("..") / "real" / "p.csv")  # dangling: created
    (links / "t.csv").symlink_to(real / "t.csv")
    (real / "t.csv").write_text("old")
    (links / "s.csv").symlink_to("t2.csv")
    (links / "t2.csv").symlink_to(real / "s.csv")  # a chain
    r, w = os.pipe()
    got: list = []
    readers = [read_all(links / "r.json", got), read_all(r, got)]
    try:
        assert main([*solve, "--json", str(links / "r.json"), "--path-csv", str(links / "p.csv"),
                     "--record", f"/dev/fd/{w}"]) == 0
    finally:
        os.close(w)
    assert main([*sweep, "--csv", str(links / "t.csv"), "--record", str(links / "s.csv")]) == 0
    for t in readers:
        t.join(10)
    json_text, record_text = sorted(got, key=lambda b: b'"format"' in b)
    assert json_text == (plain / "r.json").read_bytes() and json.loads(record_text)["kind"] == "run"
    assert (real / "p.csv").read_bytes() == (plain / "p.csv").read_bytes()
    assert (real / "t.csv").read_bytes() == (plain / "t.csv").read_bytes()
    assert (real / "s.csv").read_bytes() == (plain / "s.csv").read_bytes()
    assert stat.S_ISFIFO(os.lstat(links / "r.json").st_mode)
    assert sorted(p.name for p in links.iterdir() if not p.is_symlink()) == ["r.json", "s.json"]  # the sidecar
    assert sorted(p.name for p in real.iterdir()) == ["p.csv", "s.csv", "t.csv"]
    assert f"wrote /dev/fd/{w}\n" in capsys.readouterr().out  # no "rerun it with" a descriptor


def test_experiment_reports_through_a_link(tmp_path):
    sys.path.insert(0, str(ROOT / "experiments"))
    try:
        import report
    finally:
        sys.path.remove(str(ROOT / "experiments"))
    (tmp_path / "docs").mkdir()
    (tmp_path / "docs" / "results.md").write_text("# Results\n\nkept\n")
    (tmp_path / "results.md").symlink_to(Path("docs") / "results.md")
    report.write_section(tmp_path / "results.md", "x", "new section")
    assert (tmp_path / "results.md").is_symlink()
    assert (tmp_path / "docs" / "results.md").read_text() == "# Results\n\nkept\n\n<!-- x:start -->\nnew section\n<!-- x:end -->\n"


def test_plot_to_standard_output_needs_a_format(capsysbinary, tmp_path):
    code = main(["solve", "demo", "--ants", "4", "--iters", "3", "--plot", "-"])
    out, err = capsysbinary.readouterr()
    assert code == 2 and out == b""
    assert err.decode().strip() == ("jaco: error: --plot '-' has no suffix to name the format: give it with "
                                    "--plot-format (one of " + ", ".join(s[1:] for s in plot.figure_suffixes()) + ")")
    code = main(["solve", "demo", "--ants", "4", "--iters", "3", "--plot", "-", "--plot-format", "png"])
    out, err = capsysbinary.readouterr()
    assert code == 0, err
    assert out.startswith(b"\x89PNG\r\n\x1a\n") and b"wrote -" in err
    code = main(["demo", "--ants", "4", "--iters", "3", "--out", "-"])
    out, err = capsysbinary.readouterr()
    assert code == 2 and b"jaco solve demo --plot - --plot-format png" in err
    for argv, needle in ((["--plot", tmp_path / "p.png", "--plot-format", "svg"], "names the format '.png', but the "
                          "format given is 'svg'"), (["--plot", "-", "--plot-format", "xyz"], "unsupported format 'xyz'")):
        code = main(["solve", "demo", "--ants", "4", "--iters", "3", *map(str, argv)])
        out, err = capsysbinary.readouterr()
        assert code == 2 and out == b"" and needle in err.decode(), err
    assert not (tmp_path / "p.png").exists()
    plot.save(plot.plot_map(GRID), tmp_path / "p.data", format="svg")  # a name of no figure format: the format given
    assert (tmp_path / "p.data").read_text().startswith("<?xml")


def test_cli_write_failure_says_the_run_finished(capsys, device, tmp_path):
    full = device("full", 7)
    for argv in (["solve", "demo", "--ants", "4", "--iters", "3", "--json", full],  # the runs of the tests above
                 ["sweep", "demo", "--ants", "4", "--iters", "3", "--param", "beta=2,4", "--seeds", "2", "--csv", full]):
        code, out, err = run_cli(capsys, *argv)
        assert code == 2 and len(err.strip().splitlines()) == 1, err
        assert err.startswith(f"jaco: error: {argv[-2]} '{full}': cannot write: No space left on device; "
                              "the run itself finished"), err
        assert is_device(full, 7)


def test_cli_broken_standard_output(monkeypatch, capsys):
    r, w = os.pipe()
    os.close(r)
    broken = open(w, "w")
    monkeypatch.setattr(sys, "stdout", broken)
    try:
        code = main(["solve", "demo", "--ants", "4", "--iters", "3", "--json", "-"])
    finally:
        monkeypatch.undo()
        with contextlib.suppress(BrokenPipeError):  # what the buffer still held
            broken.close()
    err = capsys.readouterr().err
    assert code == 2
    assert err.strip().splitlines()[-1] == (
        "jaco: error: --json '-' (standard output): cannot write: Broken pipe; the run itself finished (its "
        "summary above is complete), but this output and any after it were not written")


# -- concurrent writers ------------------------------------------------------------------------------
WRITER = textwrap.dedent("""
    import os, pickle, sys, time
    from pathlib import Path
    import pandas as pd
    kind, path, tag, ready = sys.argv[1], Path(sys.argv[2]), sys.argv[3], Path(sys.argv[4])
    if kind == "text":
        from jaco.outputs import write_text
        text = (tag * 63 + "\\n") * 4000  # 256 KB: many write() calls
        write = lambda: write_text(path, text)
    elif kind == "record":
        result = pickle.loads(Path(sys.argv[5]).read_bytes())  # the two processes' results differ
        write = lambda: result.save(path)
    else:
        from jaco.research.records import save_sweep
        import jaco
        grid = jaco.Grid.from_rows(["......", ".@@...", "...@..", "......"])
        table = pd.DataFrame({"seed": [0, 1], "length": [5.0, 6.0], "tag": [tag, tag]})
        write = lambda: save_sweep(table, path, grid, (0, 0), (3, 5), "acs", None, 2)
    (ready / tag).touch()
    while len(list(ready.iterdir())) < 2:  # both start writing together, after their imports
        time.sleep(0.001)
    for _ in range(150):
        write()
""")


@pytest.mark.parametrize("kind", ["text", "record", "sweep record"])
def test_two_processes_writing_one_output_leave_one_whole_file(result, tmp_path, kind):
    import time

    script = tmp_path / "writer.py"
    script.write_text(WRITER)
    for tag, seed in (("a", 3), ("b", 4)):
        run = result if seed == 3 else jaco.solve(GRID, (0, 0), (3, 5), "acs", seed=seed, **SMALL)
        (tmp_path / f"{tag}.pkl").write_bytes(pickle.dumps(run))
    out = tmp_path / "out" / ("x.csv" if kind != "record" else "run.json")
    out.parent.mkdir()
    (tmp_path / "ready").mkdir()
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    procs = [subprocess.Popen([sys.executable, str(script), kind.split()[0], str(out), tag, str(tmp_path / "ready"),
                               str(tmp_path / f"{tag}.pkl")], env=env, stderr=subprocess.PIPE, text=True)
             for tag in "ab"]
    seen = set()
    while any(p.poll() is None for p in procs):  # a reader sees a whole file at every moment
        if out.exists() and kind == "text":
            data = out.read_text()
            assert data in (("a" * 63 + "\n") * 4000, ("b" * 63 + "\n") * 4000), len(data)
            seen.add(data[0])
        time.sleep(0.01)
    for p in procs:
        assert p.wait(60) == 0, p.stderr.read()[-2000:]
    names = sorted(p.name for p in out.parent.iterdir())
    if kind == "text":
        assert names == ["x.csv"] and out.read_text()[0] in "ab" and seen
    elif kind == "record":
        assert names == ["run.json"]
        rec = load_run(out)  # a whole record of one of them
        assert rec.call["seed"] in (3, 4) and rec.rerun().matched
    else:
        assert names == ["x.csv", "x.json"]
        rec = load_run(out.with_suffix(".json"))
        assert not [w for w in rec.warnings if "sha256" in w], rec.warnings  # table and sidecar of one writer
        assert set(pd.read_csv(out)["tag"]) in ({"a"}, {"b"})
