"""The named maps: the embedded demo map and the generated maps of the thesis and the papers, by
name (:data:`NAMED`, :func:`named`), each with its start and goal in ``meta``."""

from __future__ import annotations

from typing import Callable

from ..errors import ProblemError
from ..grid import Grid
from .generators import circle, complex_30, h_shape, random_map, s_shape, simple_20, utrap, wall, with_endpoints

# A small default map (20 x 30) for examples and the CLI: two offset walls and a block, so the
# optimal path snakes over the first wall and under the second rather than going straight.
DEMO_ROWS = (
    ".........#....................",
    ".........#....................",
    ".........#....................",
    ".........#..........#.........",
    ".........#..........#.........",
    "....................#.........",
    "....................#.........",
    "....................#.........",
    ".............####...#.........",
    ".........#...####...#.........",
    ".........#...####...#.........",
    ".........#...####...#.........",
    ".........#..........#.........",
    ".........#..........#.........",
    ".........#..........#.........",
    ".........#..........#.........",
    ".........#..........#.........",
    ".........#..........#.........",
    ".........#....................",
    ".........#....................",
)
DEMO_START = (17, 2)
DEMO_GOAL = (2, 27)


def demo() -> Grid:
    """The embedded 20x30 demo map (:data:`DEMO_ROWS`), start ``(17, 2)``, goal ``(2, 27)``."""
    grid = Grid.from_rows(DEMO_ROWS)
    return with_endpoints(grid.free, "demo", DEMO_START, DEMO_GOAL)


def _named_random(size: int, p: float) -> Callable[[], Grid]:
    # p = 0.5 is above the connectivity threshold (see random_map): those maps are carved.
    method = "carve" if p >= 0.5 else "resample"

    def make() -> Grid:
        g = random_map(size, p, seed=size * 100 + int(round(p * 100)), method=method)
        return g.replace(name=f"random-{size}-{int(round(p * 100)):02d}")

    make.__doc__ = f"{size}x{size} random map, obstacle ratio {p} ({method})."
    return make


#: Named maps: name -> zero-argument function that builds the :class:`Grid`.
NAMED: dict[str, Callable[[], Grid]] = {
    "demo": demo,
    "utrap-15": lambda: utrap(15),
    "utrap-20": lambda: utrap(20),
    "utrap-30": lambda: utrap(30),
    "wall-40": lambda: wall(40),
    "circle-40": lambda: circle(40),
    "h-40": lambda: h_shape(40),
    "s-40": lambda: s_shape(40),
    "simple-20": simple_20,
    "complex-30": complex_30,
    **{
        f"random-{n}-{int(round(p * 100)):02d}": _named_random(n, p)
        for n in (20, 30, 40)
        for p in (0.05, 0.1, 0.3, 0.5)
    },
}


def named(name: str) -> Grid:
    """Build the named map ``name`` (see :data:`NAMED`); its start/goal are in ``meta``."""
    try:
        make = NAMED[name]
    except (KeyError, TypeError):
        raise ProblemError(f"unknown map name {name!r}; valid names: {', '.join(sorted(NAMED))}") from None
    return make()
