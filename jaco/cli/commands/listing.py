"""``jaco planners`` (``variants``), ``jaco maps`` and ``jaco info``: what jaco has and runs on."""

from __future__ import annotations

import argparse


def cmd_planners(args: argparse.Namespace) -> int:
    from ...planners.registry import PLANNERS

    width = max(len(name) for name in PLANNERS)  # the sources column starts at one place
    for v in PLANNERS.values():
        print(v.describe(width))
        if args.verbose:
            import textwrap

            print(textwrap.indent(textwrap.fill(v.doc, 96), "    "))
            print()
    return 0


def cmd_maps(args: argparse.Namespace) -> int:
    from ... import maps

    print("named maps (start/goal built in):")
    for name in maps.NAMED:
        g = maps.named(name)
        print(f"  {name:14s} {g.height:>3d}x{g.width:<3d}  start {g.meta['start']} -> goal {g.meta['goal']}")
    folders: dict = {}  # each folder that holds bundled files, as it is on disk, with its files
    for name in maps.BUNDLED:
        folders.setdefault(maps.bundled(name).parent, []).append(name)
    for folder, names in folders.items():
        print(f"\nbundled files in {folder}:")
        for name in names:
            print(f"  {name}")
    print(
        "\nA MAP argument is a file path, a named map, or a bundled file's bare name (no folder), e.g.\n"
        "  jaco solve random-32-32-10.map --scen random-32-32-10-even-10.scen --index 34"
    )
    return 0


def cmd_info(args: argparse.Namespace) -> int:
    import platform

    import jax
    import jaxlib
    import numpy as np

    from ... import __version__
    from ...engine import native

    print(f"jaco {__version__}")
    print(
        f"jax {jax.__version__}, jaxlib {jaxlib.__version__}, numpy {np.__version__}, "
        f"python {platform.python_version()} ({platform.machine()})"
    )
    devices = jax.devices()
    print(f"devices: {len(devices)} x {devices[0].platform} ({', '.join(str(d) for d in devices)})")
    walk = native.active_walk()
    if walk == "native":
        print("walk: native (the C++ kernel through jax.ffi on CPU; the JAX walk elsewhere)")
    elif native.available():
        print("walk: jax (chosen with --walk, jaco.set_walk or JACO_WALK; the native walk is built)")
    else:
        print(f"walk: jax ({native.unavailable_reason()}; the JAX walk gives the same results, slower on CPU)")
    if native.available():  # the lane kernels' instruction sets (JACO_NATIVE_ISA chooses; same moves in each)
        print("native instruction sets: " + ", ".join(f"{name} ({state})" for name, state in native.isas().items()))
    return 0
