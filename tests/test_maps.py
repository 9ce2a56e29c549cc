"""Map loaders, bundled benchmark maps, scenario files and seeded generators (jaco.maps)."""

from __future__ import annotations

import hashlib
import math
import re
from pathlib import Path

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st
from PIL import Image

import jaco
from jaco import maps
from jaco.errors import MapFormatError, ProblemError
from jaco.exact import reachable, shortest_path
from jaco.grid import Grid

DATA = Path(jaco.__file__).parent / "maps" / "data"

MOVINGAI_MAPS = [
    "empty-16-16.map",
    "random-32-32-10.map",
    "maze-32-32-2.map",
    "room-32-32-4.map",
    "arena.map",
    "den312d.map",
    "bloodvenomfalls.map",
    "lak303d.map",
    "Berlin_1_256.map",
    "maze-128-128-1.map",
    "warehouse-10-20-10-2-1.map",
]
SCENARIOS = {
    "empty-16-16-even-10.scen": "empty-16-16.map",
    "random-32-32-10-even-10.scen": "random-32-32-10.map",
    "maze-32-32-2-even-10.scen": "maze-32-32-2.map",
    "room-32-32-4-even-10.scen": "room-32-32-4.map",
    "arena.map.scen": "arena.map",
    "den312d.map.scen": "den312d.map",
    "bloodvenomfalls.map.scen": "bloodvenomfalls.map",
    "lak303d.map.scen": "lak303d.map",
    "Berlin_1_256.map.scen": "Berlin_1_256.map",
    "maze-128-128-1-even-1.scen": "maze-128-128-1.map",
    "warehouse-10-20-10-2-1-even-10.scen": "warehouse-10-20-10-2-1.map",
}
# W x H as printed in movingai/SOURCES.md.
MOVINGAI_W_H = {
    "empty-16-16.map": (16, 16),
    "random-32-32-10.map": (32, 32),
    "maze-32-32-2.map": (32, 32),
    "room-32-32-4.map": (32, 32),
    "arena.map": (49, 49),
    "den312d.map": (65, 81),
    "bloodvenomfalls.map": (512, 512),
    "lak303d.map": (194, 194),
    "Berlin_1_256.map": (256, 256),
    "maze-128-128-1.map": (128, 128),
    "warehouse-10-20-10-2-1.map": (161, 63),
}
# free / occupied / unknown as printed in ros/SOURCES.md.
ROS_COUNTS = {
    "map": (7939, 795, 138722),
    "depot": (179481, 5947, 0),
    "smoothers_world": (79424, 10576, 0),
    "lse_arena": (4455, 345, 0),
}
ROS_FRAME = {  # resolution, origin
    "map": (0.05, (-10.0, -10.0, 0.0)),
    "depot": (0.05, (0.0, 0.0, 0.0)),
    "smoothers_world": (0.05, (0.0, 0.0, 0.0)),
    "lse_arena": (0.05, (0.0, 0.0, 0.0)),
}


def connected(grid: Grid, start, goal) -> bool:
    return bool(reachable(grid, start)[tuple(goal)])


# ---------------------------------------------------------------------------------------------
# bundled files
# ---------------------------------------------------------------------------------------------
def _sources_sha256(sub: str) -> dict[str, str]:
    """File name -> sha256 from the SOURCES.md table shipped beside the files."""
    text = (DATA / sub / "SOURCES.md").read_text()
    return dict(re.findall(r"^\| `([^`]+)` \|.*\| `([0-9a-f]{64})` \|\s*$", text, flags=re.M))


@pytest.mark.parametrize("sub", ["movingai", "ros"])
def test_bundled_files_are_unedited_copies(sub):
    sha = _sources_sha256(sub)
    files = sorted(p.name for p in (DATA / sub).iterdir() if p.name != "SOURCES.md")
    assert files and set(files) <= set(sha)
    for name in files:
        assert hashlib.sha256((DATA / sub / name).read_bytes()).hexdigest() == sha[name], name
        assert name in maps.BUNDLED


def test_bundled_paths_live_in_the_package():
    expected = set(MOVINGAI_MAPS) | set(SCENARIOS) | {
        f"{n}.{ext}" for n in ROS_COUNTS for ext in ("yaml", "pgm")
    }
    assert set(maps.BUNDLED) == expected
    for name in maps.BUNDLED:
        p = maps.bundled(name)
        assert p.is_file() and p.name == name
        assert p.resolve().is_relative_to(DATA.resolve())
    assert maps.bundled("arena") == maps.bundled("arena.map")
    assert maps.bundled("ros/depot.yaml").name == "depot.yaml"
    assert maps.bundled("depot").name == "depot.yaml"
    with pytest.raises(MapFormatError, match="no bundled map file 'nope.map'.*arena.map"):
        maps.bundled("nope.map")


# ---------------------------------------------------------------------------------------------
# MovingAI maps
# ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize("name", MOVINGAI_MAPS)
def test_movingai_bundled_maps(name):
    text = (DATA / "movingai" / name).read_text()
    lines = text.splitlines()
    header = dict(ln.split() for ln in lines[1:3])
    h, w = int(header["height"]), int(header["width"])
    body = lines[4 : 4 + h]
    grid = maps.load_bundled(name)
    assert (grid.width, grid.height) == MOVINGAI_W_H[name]
    assert grid.shape == (h, w)
    # counted straight from the text: '.', 'G', 'S' passable
    n_free = sum(row.count(ch) for row in body for ch in ".GS")
    assert grid.n_free == n_free
    assert grid.n_cells - grid.n_free == sum(row.count(ch) for row in body for ch in "@OTW")
    expected = np.array([[ch in ".GS" for ch in row] for row in body])
    np.testing.assert_array_equal(grid.free, expected)  # row 0 is the first map line
    assert grid.name == name.removesuffix(".map")
    assert grid.meta["format"] == "movingai" and grid.meta["source"] == name


def test_den312d_orientation():
    """den312d is 65 wide and 81 high: the grid is (81 rows, 65 cols), row r = map line 5 + r."""
    grid = maps.load_bundled("den312d.map")
    assert grid.shape == (81, 65)
    lines = (DATA / "movingai" / "den312d.map").read_text().splitlines()
    for r in (0, 40, 80):
        assert "".join("." if f else "x" for f in grid.free[r]) == "".join(
            "." if ch in ".GS" else "x" for ch in lines[4 + r]
        )


def test_bloodvenomfalls_swamp_passable_water_blocked():
    grid = maps.load_bundled("bloodvenomfalls.map")
    body = (DATA / "movingai" / "bloodvenomfalls.map").read_text().splitlines()[4:]
    chars = np.array([list(row) for row in body])
    assert (chars == "S").any() and (chars == "W").any()
    assert grid.free[chars == "S"].all()
    assert not grid.free[chars == "W"].any() and not grid.free[chars == "T"].any()


# ---------------------------------------------------------------------------------------------
# ROS maps
# ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize("name", sorted(ROS_COUNTS))
def test_ros_bundled_counts_and_frame(name):
    grid = maps.load_bundled(name + ".yaml")
    occ = grid.meta["occupancy"]
    counts = ((occ == 0).sum(), (occ == 1).sum(), (occ == -1).sum())
    assert counts == ROS_COUNTS[name]
    assert grid.n_free == ROS_COUNTS[name][0]  # unknown cells are not free
    np.testing.assert_array_equal(grid.free, occ == 0)
    assert grid.meta["format"] == "ros" and grid.name == name
    res, origin = ROS_FRAME[name]
    assert grid.resolution == pytest.approx(res)
    assert grid.origin == pytest.approx(origin)
    # the bottom-left cell's centre is half a cell from the origin
    x, y = grid.cell_to_world((grid.height - 1, 0))
    assert (x, y) == pytest.approx((origin[0] + 0.5 * res, origin[1] + 0.5 * res))
    x, y = grid.cell_to_world((0, grid.width - 1))
    assert (x, y) == pytest.approx(
        (origin[0] + (grid.width - 0.5) * res, origin[1] + (grid.height - 0.5) * res)
    )


def test_ros_orientation_matches_the_image():
    """Row 0 of the grid is the top row of the image (checked against Pillow's own reading)."""
    img = np.asarray(Image.open(DATA / "ros" / "depot.pgm"))
    grid = maps.load_bundled("depot.yaml")
    assert grid.shape == img.shape == (307, 604)
    p = (255 - img.astype(float)) / 255
    np.testing.assert_array_equal(grid.free, p < 0.25)
    assert grid.n_free > 0 and (img == 205).any() and grid.free[img == 205].all()


# ---------------------------------------------------------------------------------------------
# scenarios
# ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize("scen_name", sorted(SCENARIOS))
def test_scenarios(scen_name):
    lines = (DATA / "movingai" / scen_name).read_text().splitlines()
    scen = maps.load_scenarios(maps.bundled(scen_name))
    assert len(scen) == sum(1 for ln in lines[1:] if ln.strip())
    raw = lines[1].split("\t")
    s0 = scen[0]
    assert s0.bucket == int(raw[0]) and s0.map == raw[1]
    assert (s0.width, s0.height) == (int(raw[2]), int(raw[3]))
    assert s0.start == (int(raw[5]), int(raw[4]))  # (row, col) = (y, x)
    assert s0.goal == (int(raw[7]), int(raw[6]))
    assert s0.optimal == float(raw[8])
    with pytest.raises(AttributeError):
        s0.start = (0, 0)  # frozen

    grid = maps.load_bundled(SCENARIOS[scen_name])
    assert {s.map for s in scen} == {SCENARIOS[scen_name]}
    assert all((s.height, s.width) == grid.shape for s in scen)
    starts = np.array([s.start for s in scen])
    goals = np.array([s.goal for s in scen])
    assert grid.free[starts[:, 0], starts[:, 1]].all()
    assert grid.free[goals[:, 0], goals[:, 1]].all()
    # the (row, col) reading reproduces the benchmark's optimal lengths
    for s in scen[:: max(1, len(scen) // 3)][:3]:
        length, _ = shortest_path(grid, s.start, s.goal)
        assert length == pytest.approx(s.optimal, abs=1e-4)


def test_scenario_version_1_0_and_errors(tmp_path):
    ok = tmp_path / "a.scen"
    ok.write_text("version 1.0\n0\tm.map\t4\t3\t1\t2\t3\t0\t3.5\n\n")
    (s,) = maps.load_scenarios(ok)
    assert s.start == (2, 1) and s.goal == (0, 3) and s.optimal == 3.5 and s.map == "m.map"

    cases = {
        "version 2\n": r"line 1: expected 'version 1'",
        "version 1\n0\tm.map\t4\t3\t1\t2\t3\t0\n": r"line 2: expected 9 tab-separated columns",
        "version 1\n0\tm.map\t4\t3\t1\t2\t3\t0\t1\n0\tm.map\tx\t3\t1\t2\t3\t0\t1\n": (
            r"line 3: columns"
        ),
        "version 1\n0\tm.map\t4\t3\t4\t0\t0\t0\t1\n": r"line 2: start x=4, y=0 is outside",
        "version 1\n0\tm.map\t4\t3\t0\t0\t0\t0\tnan\n": r"line 2: optimal length",
    }
    for text, msg in cases.items():
        ok.write_text(text)
        with pytest.raises(MapFormatError, match=msg):
            maps.load_scenarios(ok)
    with pytest.raises(MapFormatError, match="not found"):
        maps.load_scenarios(tmp_path / "missing.scen")
    with pytest.raises(MapFormatError, match="load_scenarios"):
        maps.load(maps.bundled("arena.map.scen"))


# ---------------------------------------------------------------------------------------------
# malformed MovingAI files
# ---------------------------------------------------------------------------------------------
GOOD_MAP = "type octile\nheight 3\nwidth 4\nmap\n.@..\n.TG.\nSW.O\n"


def _write(tmp_path, name, text, newline="\n"):
    p = tmp_path / name
    p.write_bytes(text.replace("\n", newline).encode())
    return p


def test_movingai_small_map_and_crlf(tmp_path):
    lf = maps.load(_write(tmp_path, "lf.map", GOOD_MAP))
    crlf = maps.load(_write(tmp_path, "crlf.map", GOOD_MAP, newline="\r\n"))
    expected = [[1, 0, 1, 1], [1, 0, 1, 1], [1, 0, 1, 0]]
    np.testing.assert_array_equal(lf.free, np.array(expected, bool))
    np.testing.assert_array_equal(crlf.free, lf.free)
    assert crlf.name == "crlf"
    # width/height may come in either order
    swapped = GOOD_MAP.replace("height 3\nwidth 4", "width 4\nheight 3")
    np.testing.assert_array_equal(maps.load(_write(tmp_path, "sw.map", swapped)).free, lf.free)


@pytest.mark.parametrize(
    "text, msg",
    [
        (
            "type octile\nheight 3\n",
            r"bad\.map line 3: expected 'width <integer>', found end of file",
        ),
        ("", r"bad\.map line 1: expected 'type octile'"),
        (
            "type octile\nheight three\nwidth 4\nmap\n",
            r"bad\.map line 2: height must be an integer, found 'three'",
        ),
        ("type octile\nheight 3\nwidth 4\nmop\n.@..\n", r"bad\.map line 4: expected 'map'"),
        (
            "type octile\nheight 3\nheight 4\nmap\n",
            r"bad\.map line 3: expected 'width <integer>', found 'height 4'",
        ),
        ("type octile\nsize 3\n", r"line 2: expected 'height <integer>' or 'width <integer>'"),
        (GOOD_MAP.replace(".TG.", ".TX."), r"bad\.map line 6 column 3: unknown map symbol 'X'"),
        (
            GOOD_MAP.replace(".TG.", ".TG"),
            r"bad\.map line 6: row 1 has 3 cells, header says width 4",
        ),
        (GOOD_MAP.replace("SW.O\n", ""), r"bad\.map: header says height 3 but 2 map rows"),
        (GOOD_MAP + "....\n", r"header says height 3 but 4 map rows"),
    ],
)
def test_movingai_errors(tmp_path, text, msg):
    p = _write(tmp_path, "bad.map", text)
    with pytest.raises(MapFormatError, match=msg):
        maps.load(p)


def test_truncated_header_names_end_of_file(tmp_path):
    p = _write(tmp_path, "t.map", "type octile\nheight 3\n")
    with pytest.raises(MapFormatError, match=r"t\.map line 3: .*end of file \(truncated header\)"):
        maps.load(p)


# ---------------------------------------------------------------------------------------------
# ROS yaml + images
# ---------------------------------------------------------------------------------------------
YAML = (
    "image: {image}\nresolution: {res}\norigin: [1.0, 2.0, 0.0]\nnegate: {neg}\n"
    "occupied_thresh: {occ}\nfree_thresh: {free}\n{extra}"
)


def _ros(tmp_path, image="m.pgm", res=0.1, neg=0, occ=0.65, free=0.196, extra="", name="m.yaml"):
    p = tmp_path / name
    p.write_text(YAML.format(image=image, res=res, neg=neg, occ=occ, free=free, extra=extra))
    return p


# 3 x 2 image: p = (255 - v)/255 -> 0.004 free, 1.0 occupied, 0.196 unknown /
#                                   0 free, 0.61 unknown, 0.96 occupied
P2_VALUES = [[254, 0, 205], [255, 100, 10]]
P2_CODES = [[0, 1, -1], [0, -1, 1]]
P2_TEXT = """P2
# a comment in the header
3 # width
2
# another comment
255
254 0 205 # comment in the body
# a full comment line in the body
255 100
10
"""


def test_p2_ascii_with_comments(tmp_path):
    (tmp_path / "m.pgm").write_text(P2_TEXT)
    values, maxval = maps.read_pnm(tmp_path / "m.pgm")
    assert maxval == 255
    np.testing.assert_array_equal(values, P2_VALUES)
    grid = maps.load(_ros(tmp_path))
    np.testing.assert_array_equal(grid.meta["occupancy"], P2_CODES)
    np.testing.assert_array_equal(grid.free, np.array(P2_CODES) == 0)
    assert grid.resolution == 0.1 and grid.origin == (1.0, 2.0, 0.0)
    assert grid.cell_to_world((1, 0)) == pytest.approx((1.05, 2.05))


def test_p5_binary_equals_p2(tmp_path):
    raw = np.array(P2_VALUES, dtype=np.uint8)
    (tmp_path / "m.pgm").write_bytes(b"P5\n# c\n3 2\n255\n" + raw.tobytes())
    np.testing.assert_array_equal(maps.load(_ros(tmp_path)).meta["occupancy"], P2_CODES)


def _pillow_values(path):
    with Image.open(path) as img:
        return np.asarray(img).astype(np.int64)


PNM_AS_WRITTEN = {  # maxval 255, or 65535 in grey: Pillow keeps the samples as they are
    "p2-comments.pgm": P2_TEXT.encode(),
    "p5.pgm": b"P5\n# c\n3 2\n255\n" + np.array(P2_VALUES, np.uint8).tobytes(),
    "p3.ppm": b"P3 2 1 255\n255 0 0  10 20 30\n",
    "p6.ppm": b"P6\n2 1\n255\n" + bytes([255, 0, 0, 10, 20, 30]),
    "p2-16.pgm": b"P2 3 1 65535\n65535 0 30000\n",
    "p5-16.pgm": b"P5 3 1 65535\n" + np.array([[65535, 0, 30000]], ">u2").tobytes(),
}


def test_pillow_reads_the_usual_pnm_files_as_written(tmp_path):
    """Files of maxval 255 (and grey 65535), the bundled ROS images included, go through Pillow:
    its pixels are the file's samples, exactly what the raster reader finds."""
    from jaco.maps import image

    paths = [DATA / "ros" / f"{n}.pgm" for n in ROS_COUNTS]
    for name, data in PNM_AS_WRITTEN.items():
        (tmp_path / name).write_bytes(data)
        paths.append(tmp_path / name)
    for p in paths:
        written = image._pnm_raster(p.read_bytes(), p.name)
        np.testing.assert_array_equal(_pillow_values(p), written, err_msg=p.name)
        values, _ = maps.read_pnm(p)
        np.testing.assert_array_equal(values, written, err_msg=p.name)


def test_pillow_stretches_other_maxvals_so_they_are_read_here(tmp_path):
    """Pillow rescales the samples of any other maxval to 8 bits (16 for grey) and cuts 16-bit
    colour to 8 bits; read_pnm keeps the file's values, so brightness = value / maxval exactly."""
    (tmp_path / "half.pgm").write_bytes(b"P2 3 1 100\n0 50 100\n")
    assert _pillow_values(tmp_path / "half.pgm").tolist() == [[0, 128, 255]]  # 128/255 > 1/2
    values, maxval = maps.read_pnm(tmp_path / "half.pgm")
    assert values.tolist() == [[0, 50, 100]] and maxval == 100
    # Exactly half is not brighter than the threshold 0.5: blocked (Pillow's 128/255 would be free).
    assert maps.load(tmp_path / "half.pgm").free.tolist() == [[False, False, True]]
    colour = np.array([[[65535, 0, 1234]]], ">u2")
    (tmp_path / "deep.ppm").write_bytes(b"P6 1 1 65535\n" + colour.tobytes())
    assert _pillow_values(tmp_path / "deep.ppm").tolist() == [[[255, 0, 5]]]
    values, maxval = maps.read_pnm(tmp_path / "deep.ppm")
    assert values.tolist() == [[[65535, 0, 1234]]] and maxval == 65535


def test_pgm_maxval_scaling_and_16_bit(tmp_path):
    # maxval 15: 15 is white (free), 0 black (occupied), 8 is p = 7/15 = 0.47 (unknown)
    (tmp_path / "m.pgm").write_text("P2 3 1 15\n15 0 8\n")
    np.testing.assert_array_equal(maps.load(_ros(tmp_path)).meta["occupancy"], [[0, 1, -1]])
    big = np.array([[65535, 0, 30000]], dtype=">u2")
    (tmp_path / "m.pgm").write_bytes(b"P5 3 1 65535\n" + big.tobytes())
    np.testing.assert_array_equal(maps.load(_ros(tmp_path)).meta["occupancy"], [[0, 1, -1]])


def test_ros_negate_and_modes(tmp_path):
    (tmp_path / "m.pgm").write_text(P2_TEXT)
    neg = maps.load(_ros(tmp_path, neg=1))
    # negate: p = v/255 -> 254 occ, 0 free, 205 (0.80) occ / 255 occ, 100 (0.39) unknown, 10 free
    np.testing.assert_array_equal(neg.meta["occupancy"], [[1, 0, 1], [1, -1, 0]])
    override = maps.load(_ros(tmp_path), negate=True)  # the keyword overrides the yaml
    np.testing.assert_array_equal(override.meta["occupancy"], neg.meta["occupancy"])
    scale = maps.load(_ros(tmp_path, extra="mode: scale\n"))
    np.testing.assert_array_equal(scale.meta["occupancy"], P2_CODES)  # the cost band is not free
    # raw: the value is the occupancy in percent: 0 free, 100 occupied, 19 free (<= 19.6),
    # 50 unknown, 65 occupied, 255 unknown
    (tmp_path / "m.pgm").write_text("P2 3 2 255\n0 100 19\n50 65 255\n")
    raw = maps.load(_ros(tmp_path, extra="mode: raw\n"))
    np.testing.assert_array_equal(raw.meta["occupancy"], [[0, 1, 0], [-1, 1, -1]])
    assert raw.meta["mode"] == "raw"


def test_ros_png_image(tmp_path):
    Image.fromarray(np.array(P2_VALUES, dtype=np.uint8)).save(tmp_path / "m.png")
    grid = maps.load(_ros(tmp_path, image="m.png"))
    np.testing.assert_array_equal(grid.meta["occupancy"], P2_CODES)
    rgb = np.repeat(np.array(P2_VALUES, dtype=np.uint8)[..., None], 3, axis=2)
    Image.fromarray(rgb).save(tmp_path / "c.png")
    np.testing.assert_array_equal(
        maps.load(_ros(tmp_path, image="c.png")).meta["occupancy"], P2_CODES
    )


def test_ros_threshold_is_read_not_hard_coded(tmp_path):
    """Grey 205 is unknown at free_thresh 0.196 and free at 0.25 (as in depot.yaml)."""
    (tmp_path / "m.pgm").write_text("P2 1 1 255\n205\n")
    assert maps.load(_ros(tmp_path, free=0.196)).meta["occupancy"].tolist() == [[-1]]
    assert maps.load(_ros(tmp_path, free=0.25)).meta["occupancy"].tolist() == [[0]]


@pytest.mark.parametrize(
    "kw, msg",
    [
        (
            {"image": "missing.pgm"},
            r"image file .*missing\.pgm.* not found \(referenced by m\.yaml\)",
        ),
        ({"occ": 1.5}, r"m\.yaml: occupied_thresh must be in \[0, 1\], got 1\.5"),
        ({"free": -0.1}, r"free_thresh must be in \[0, 1\]"),
        ({"free": 0.7}, r"free_thresh \(0\.7\) must be below occupied_thresh \(0\.65\)"),
        ({"res": 0}, r"resolution must be a positive number"),
        ({"res": "fast"}, r"resolution must be a number"),
        ({"extra": "mode: fuzzy\n"}, r"unknown mode 'fuzzy'; use one of trinary, scale, raw"),
        ({"neg": 2}, r"negate must be 0 or 1"),
    ],
)
def test_ros_yaml_errors(tmp_path, kw, msg):
    (tmp_path / "m.pgm").write_text(P2_TEXT)
    with pytest.raises(MapFormatError, match=msg):
        maps.load(_ros(tmp_path, **kw))


def test_ros_yaml_missing_keys_and_bad_yaml(tmp_path):
    (tmp_path / "m.yaml").write_text("image: m.pgm\norigin: [0, 0, 0]\nfree_thresh: 0.1\n")
    msg = r"m\.yaml: missing key\(s\) resolution, occupied_thresh"
    with pytest.raises(MapFormatError, match=msg):
        maps.load(tmp_path / "m.yaml")
    (tmp_path / "m.yaml").write_text("- just\n- a list\n")
    with pytest.raises(MapFormatError, match="must be a mapping"):
        maps.load(tmp_path / "m.yaml")
    (tmp_path / "m.yaml").write_text("image: [unclosed\n")
    with pytest.raises(MapFormatError, match="not valid YAML"):
        maps.load(tmp_path / "m.yaml")
    (tmp_path / "m.pgm").write_text(P2_TEXT)
    p = _ros(tmp_path)
    p.write_text(p.read_text().replace("[1.0, 2.0, 0.0]", "[1.0, 2.0]"))
    with pytest.raises(MapFormatError, match=r"origin must be a list \[x, y, yaw\]"):
        maps.load(p)


@pytest.mark.parametrize(
    "data, msg",
    [
        (b"P7\n3 2\n255\n" + bytes(6), r"m\.pgm: bad PGM magic number b'P7'"),
        (b"GIF89a", r"bad PGM magic number"),
        # binary, maxval 255: Pillow reads the pixels, and says what is wrong
        (b"P5\n3 2\n255\n" + bytes(5), r"m\.pgm: cannot read image \(image file is truncated"),
        # plain (ascii) files and other maxvals: read here, every value counted
        (b"P2\n3 2\n255\n1 2 3 4 5\n", r"m\.pgm: truncated PGM pixel data: 3x2 needs 6 values, found 5$"),
        (b"P2\n3 2\n255\n1 2 3 4 5 6 7\n", r"m\.pgm: extra PGM pixel values: 3x2 needs 6 values, found 7$"),
        (b"P2\n3 2\n255\n1 2 3\n4 5 6\n\n7 # after the last row\n", r"extra PGM pixel values: 3x2 needs 6 values, found 7$"),
        (b"P2\n3 2\n100\n1 2 3 4 5 6 7 8\n", r"extra PGM pixel values: 3x2 needs 6 values, found 8$"),
        (b"P3\n1 2\n255\n1 2 3 4 5\n", r"truncated PGM pixel data: 1x2 needs 6 values \(3 per pixel\), found 5$"),
        (b"P3\n1 1\n255\n1 2 3 4\n", r"extra PGM pixel values: 1x1 needs 3 values \(3 per pixel\), found 4$"),
        (b"P2\n2 1\n255\n1 z\n", r"pixel value b'z' is not an integer"),
        (b"P2\n2 1\n255\n1 300\n", r"above maxval 255"),
        (b"P2\n2 1\n255\n1 -1\n", r"pixel value b'-1' is not an integer in 0\.\.maxval"),
        (b"P5\n3 2\n100\n" + bytes(5), r"truncated PGM pixel data: 3x2 needs 6 bytes, found 5"),
        (b"P2\n3 2\n100\n1 2 3 4 5\n", r"truncated PGM pixel data: 3x2 needs 6 values, found 5"),
        (b"P2\n2 1\n100\n1 z\n", r"pixel value b'z' is not an integer"),
        (b"P2\n2 1\n100\n1 200\n", r"above maxval 100"),
        # the header is read here in every case
        (b"P5\n3 2\n", r"truncated PGM header"),
        (b"P5\n3 x 255\n", r"header field b'x' is not a positive integer"),
        (b"P5\n3 2\n70000\n" + bytes(12), r"maxval must be in 1\.\.65535"),
    ],
)
def test_malformed_pgm(tmp_path, data, msg):
    (tmp_path / "m.pgm").write_bytes(data)
    with pytest.raises(MapFormatError, match=msg):
        maps.load(_ros(tmp_path))
    with pytest.raises(MapFormatError, match=msg):  # loaded directly as an image too
        maps.load(tmp_path / "m.pgm")


# ---------------------------------------------------------------------------------------------
# text, numpy and image maps
# ---------------------------------------------------------------------------------------------
def test_text_round_trip(tmp_path):
    grid = maps.demo()
    p = maps.save_text(grid, tmp_path / "demo.txt")
    back = maps.load(p)
    np.testing.assert_array_equal(back.free, grid.free)
    assert back.name == "demo" and back.meta["format"] == "text"
    (tmp_path / "x.txt").write_text("..#\n.@.\r\n...\n")
    expected = [[1, 1, 0], [1, 0, 1], [1, 1, 1]]
    np.testing.assert_array_equal(maps.load(tmp_path / "x.txt").free, expected)
    (tmp_path / "bad.txt").write_text("..#\n.x.\n")
    with pytest.raises(MapFormatError, match=r"bad\.txt: unknown map symbol 'x' in row 1"):
        maps.load(tmp_path / "bad.txt")
    (tmp_path / "ragged.txt").write_text("..#\n..\n")
    with pytest.raises(MapFormatError, match=r"ragged\.txt: row 1 has 2 cells"):
        maps.load(tmp_path / "ragged.txt")


def test_npy_round_trip(tmp_path):
    free = maps.random_map(12, 0.3, seed=5).free
    np.save(tmp_path / "b.npy", free)
    np.save(tmp_path / "i.npy", free.astype(np.int32))
    np.testing.assert_array_equal(maps.load(tmp_path / "b.npy").free, free)
    np.testing.assert_array_equal(maps.load(tmp_path / "i.npy").free, free)  # 1 = free
    np.save(tmp_path / "f.npy", free.astype(float))
    with pytest.raises(MapFormatError, match=r"f\.npy: a map array must be bool or 0/1 integers"):
        maps.load(tmp_path / "f.npy")
    np.save(tmp_path / "two.npy", np.array([[0, 2]]))
    with pytest.raises(MapFormatError, match="0/1 integers"):
        maps.load(tmp_path / "two.npy")
    np.save(tmp_path / "cube.npy", np.ones((2, 2, 2), bool))
    with pytest.raises(MapFormatError, match=r"must be 2-D"):
        maps.load(tmp_path / "cube.npy")
    (tmp_path / "junk.npy").write_bytes(b"not numpy")
    with pytest.raises(MapFormatError, match=r"junk\.npy: not a readable \.npy"):
        maps.load(tmp_path / "junk.npy")


def test_png_round_trip(tmp_path):
    free = maps.random_map((9, 14), 0.3, seed=2).free
    Image.fromarray(np.where(free, 255, 0).astype(np.uint8)).save(tmp_path / "g.png")
    grid = maps.load(tmp_path / "g.png")
    np.testing.assert_array_equal(grid.free, free)
    assert grid.shape == (9, 14) and grid.name == "g"
    np.testing.assert_array_equal(maps.load(tmp_path / "g.png", negate=True).free, ~free)
    # threshold: grey 100/255 = 0.39 is free at 0.3, blocked at 0.5
    Image.fromarray(np.array([[100, 255]], np.uint8)).save(tmp_path / "t.png")
    assert maps.load(tmp_path / "t.png", threshold=0.3).free.tolist() == [[True, True]]
    assert maps.load(tmp_path / "t.png").free.tolist() == [[False, True]]
    # the same through the PGM reader
    (tmp_path / "t.pgm").write_text("P2 2 1 255\n100 255\n")
    assert maps.load(tmp_path / "t.pgm").free.tolist() == [[False, True]]
    (tmp_path / "broken.png").write_bytes(b"\x89PNG\r\n\x1a\nnope")
    with pytest.raises(MapFormatError, match=r"broken\.png: cannot read image"):
        maps.load(tmp_path / "broken.png")


def test_unknown_suffix_and_missing_file(tmp_path):
    (tmp_path / "m.foo").write_text("...")
    msg = r"unsupported map file suffix '\.foo'.*supported: \.map, \.yaml"
    with pytest.raises(MapFormatError, match=msg):
        maps.load(tmp_path / "m.foo")
    with pytest.raises(MapFormatError, match=r"map file .*nowhere\.map.* not found"):
        maps.load(tmp_path / "nowhere.map")
    with pytest.raises(MapFormatError, match=r"load_bundled\('arena\.map'\)"):
        maps.load(tmp_path / "arena.map")  # a hint toward the bundled copy
    (tmp_path / "dir.map").mkdir()
    with pytest.raises(MapFormatError, match="is a directory"):
        maps.load(tmp_path / "dir.map")
    assert maps.load(maps.bundled("arena.map"), name="x", cell_size=10).name == "x"


# ---------------------------------------------------------------------------------------------
# generators
# ---------------------------------------------------------------------------------------------
def test_random_map_is_seeded():
    a = maps.random_map(25, 0.3, seed=7)
    b = maps.random_map(25, 0.3, seed=7)
    c = maps.random_map(25, 0.3, seed=8)
    np.testing.assert_array_equal(a.free, b.free)
    assert not np.array_equal(a.free, c.free)
    assert a.meta["start"] == (0, 0) and a.meta["goal"] == (24, 24)
    assert connected(a, (0, 0), (24, 24))


@pytest.mark.parametrize("p", [0.0, 0.05, 0.1, 0.3])
def test_random_map_obstacle_ratio(p):
    grid = maps.random_map((20, 30), p, seed=11)
    blocked = grid.n_cells - grid.n_free
    assert blocked == round(p * 600)  # exactly, so the ratio is p up to rounding
    assert abs(blocked / grid.n_cells - p) <= 0.5 / 600
    assert grid.free[0, 0] and grid.free[19, 29]


def test_random_map_custom_endpoints_and_errors():
    g = maps.random_map(15, 0.3, seed=3, start=(7, 0), goal=(0, 14))
    assert g.free[7, 0] and g.free[0, 14] and connected(g, (7, 0), (0, 14))
    with pytest.raises(ProblemError, match=r"obstacle ratio p must be in \[0, 0\.9\)"):
        maps.random_map(10, 0.95, seed=0)
    with pytest.raises(ProblemError, match="outside the 10x10 map"):
        maps.random_map(10, 0.1, seed=0, goal=(10, 3))
    with pytest.raises(ProblemError, match="method must be"):
        maps.random_map(10, 0.1, seed=0, method="magic")
    # 50 % obstacles on 40x40 is above the connectivity threshold: resampling gives up...
    with pytest.raises(ProblemError, match=r"in 20 draws .*method='carve'"):
        maps.random_map(40, 0.5, seed=1, max_tries=20)
    # ...and carving plants a corridor while keeping the ratio exact
    g = maps.random_map(40, 0.5, seed=1, method="carve")
    assert g.n_cells - g.n_free == 800 and connected(g, (0, 0), (39, 39))


@settings(max_examples=25, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    h=st.integers(2, 18),
    w=st.integers(2, 18),
    p=st.floats(0.0, 0.3),
    carve_p=st.floats(0.0, 0.85),
)
@example(seed=454, h=18, w=2, p=0.296875, carve_p=0.0)  # a narrow map no resampled draw connects
def test_random_map_always_connected(seed, h, w, p, carve_p):
    for method, ratio in (("resample", p), ("carve", carve_p)):
        try:
            g = maps.random_map((h, w), ratio, seed=seed, method=method)
        except jaco.ProblemError as e:
            # resampling a narrow map (18x2 at 30 %) may find no connected draw: the documented
            # one-line error naming the remedies, never a disconnected map; carving always connects
            assert method == "resample" and "use method='carve'" in str(e), e
            continue
        assert g.shape == (h, w)
        assert g.free[0, 0] and g.free[h - 1, w - 1]
        assert connected(g, (0, 0), (h - 1, w - 1))
        # exactly round(p * H * W) obstacles, unless the map is too small to hold them beside
        # start/goal (resample) or beside the carved corridor of H + W - 1 cells (carve)
        room = h * w - (2 if method == "resample" else h + w - 1)
        assert g.n_cells - g.n_free == min(round(ratio * h * w), room)


def test_every_named_map_is_connected():
    assert len(maps.NAMED) == 10 + 12
    for name in maps.NAMED:
        g = maps.named(name)
        assert g.name == name
        s, t = g.meta["start"], g.meta["goal"]
        assert g.free[s] and g.free[t] and s != t
        assert connected(g, s, t), name
    # rebuilt identically each time
    np.testing.assert_array_equal(maps.named("complex-30").free, maps.named("complex-30").free)


def test_named_random_family():
    for n in (20, 30, 40):
        for p, tag in ((0.05, "05"), (0.1, "10"), (0.3, "30"), (0.5, "50")):
            g = maps.named(f"random-{n}-{tag}")
            assert g.shape == (n, n)
            assert g.meta["seed"] == n * 100 + int(tag)
            assert (g.n_cells - g.n_free) / g.n_cells == pytest.approx(p, abs=1e-3)
            assert g.meta["start"] == (0, 0) and g.meta["goal"] == (n - 1, n - 1)


def test_named_unknown():
    msg = r"unknown map name 'nope'; valid names: circle-40, complex-30, demo, h-40"
    with pytest.raises(ProblemError, match=msg):
        maps.named("nope")


@pytest.mark.parametrize("size", [15, 20, 30])
def test_utrap_start_is_inside_the_u(size):
    g = maps.named(f"utrap-{size}")
    assert g.shape == (size, size)
    (sr, sc), (gr, gc) = g.meta["start"], g.meta["goal"]
    assert sr == gr and gc > sc  # the goal is straight to the right
    f = g.free
    assert not f[sr, sc:gc].all()  # the straight line toward the goal hits the back wall
    assert not f[:sr, sc].all() and not f[sr + 1 :, sc].all()  # arms above and below
    assert f[sr, : sc + 1].all()  # the opening faces left, away from the goal
    length, _ = shortest_path(g, (sr, sc), (gr, gc))
    assert length > 1.5 * (gc - sc)  # the way out is a real detour


@pytest.mark.parametrize("name", ["wall-40", "circle-40", "h-40", "s-40"])
def test_thesis_maps(name):
    g = maps.named(name)
    assert g.shape == (40, 40)
    assert g.meta["start"] == (0, 0) and g.meta["goal"] == (39, 39)
    assert 0.02 < 1 - g.n_free / g.n_cells < 0.3  # sparse
    length, _ = shortest_path(g, (0, 0), (39, 39))
    assert length > 39 * math.sqrt(2) + 1  # the obstacle sits across the diagonal
    diag = [g.free[i, i] for i in range(40)]
    assert not all(diag)


def test_seed_003_look_alikes():
    s = maps.simple_20()
    c = maps.complex_30()
    assert s.shape == (20, 20) and s.meta["start"] == (19, 0) and s.meta["goal"] == (0, 19)
    assert c.shape == (30, 30) and c.meta["start"] == (0, 0) and c.meta["goal"] == (29, 29)
    assert 1 - c.n_free / c.n_cells > 1 - s.n_free / s.n_cells  # complex is more cluttered
    length, _ = shortest_path(c, (0, 0), (29, 29))
    assert length > 29 * math.sqrt(2) + 1


def test_demo_map():
    g = maps.demo()
    assert g.shape == (20, 30) and g.name == "demo"
    assert g.to_rows() == [r.replace("#", "@") for r in maps.DEMO_ROWS]
    s, t = g.meta["start"], g.meta["goal"]
    length, path = shortest_path(g, s, t)
    assert length > math.dist(s, t) + 2  # the walls force a detour
    assert len(path) > 1


# choosing queries ---------------------------------------------------------------------------------
BERLIN = maps.load_scenarios(maps.bundled("Berlin_1_256.map.scen"))


def test_select_scenarios_by_bucket_length_position_and_count():
    long = maps.select_scenarios(BERLIN, bucket=(85, None))
    assert long == [s for s in BERLIN if s.bucket >= 85] and len(long) == 60
    assert [s.index for s in long] == list(range(850, 910))  # a scenario knows its position
    assert maps.select_scenarios(BERLIN, bucket=85) == [s for s in BERLIN if s.bucket == 85]
    mid = maps.select_scenarios(BERLIN, optimal=(100.0, 120.5))
    assert mid == [s for s in BERLIN if 100.0 <= s.optimal <= 120.5]
    assert maps.select_scenarios(BERLIN, index=[5, 2, 5]) == [BERLIN[5], BERLIN[2]]  # as given, once
    both = maps.select_scenarios(BERLIN, index=range(840, 870), bucket=(85, 86))
    assert [s.index for s in both] == list(range(850, 870))
    assert maps.select_scenarios(maps.bundled("Berlin_1_256.map.scen"), index=3) == [BERLIN[3]]  # a path


def test_count_spreads_over_the_optimal_lengths():
    spread = maps.select_scenarios(BERLIN, bucket=(80, None), count=5)
    pool = sorted((s for s in BERLIN if s.bucket >= 80), key=lambda s: (s.optimal, s.index))
    assert len(spread) == 5
    lengths = [s.optimal for s in spread]
    assert min(lengths) == pool[0].optimal and max(lengths) == pool[-1].optimal  # the extremes
    ranks = sorted(pool.index(s) for s in spread)
    assert ranks == [round(x) for x in np.linspace(0, len(pool) - 1, 5)]  # evenly spaced ranks
    assert [s.index for s in spread] == sorted(s.index for s in spread)  # in the file's order
    assert maps.select_scenarios(BERLIN[:3], count=10) == BERLIN[:3]  # fewer than asked: all


@pytest.mark.parametrize("kw, match", [
    (dict(bucket=(95, None)), r"no scenario has bucket 95\.\.: the 910 scenarios have buckets 0\.\.90"),
    (dict(optimal=(5.0, 1.0)), "low 5.0 is above high 1.0"),
    (dict(index=[910]), "index 910 is out of range"),
    (dict(count=0), "count must be a positive integer"),
    (dict(bucket="80:"), "bucket must be a number or a"),
])
def test_select_scenarios_mistakes(kw, match):
    with pytest.raises(jaco.JacoError, match=match):
        maps.select_scenarios(BERLIN, **kw)


def test_select_scenarios_example_runs():
    import doctest

    from jaco.maps import movingai

    assert doctest.testmod(movingai).failed == 0
