"""Builds the native walks (jaco/engine/walk.cc) as an optional extension: where it cannot be
compiled, the install still succeeds and jaco uses the JAX walk.

The built kernel is kept in a per-user cache (``$JACO_CACHE_DIR``, else ``$XDG_CACHE_HOME/jaco``,
else ``~/.cache/jaco``), under the sha256 of what the binary depends on: the kernel's sources, the
compiler and linker commands with their flags, the compiler's version, the jaxlib version (whose
XLA FFI headers it includes) and the extension's file name (Python tag, platform). A second install
of the same sources (an extra, another virtual environment) copies it instead of compiling for a
minute; a changed source, compiler, flag or jaxlib builds it anew. Where the compiler does not say
its version the cache is not used.
"""

import hashlib
import os
import platform
import shutil
import subprocess
import tempfile
import threading
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext

# The lane kernels (jaco/engine/walk_lanes.cc, jaco/planners/iaca_lanes.cc) are compiled once per instruction set, with that
# set's flags and lane count; the kernel uses, at run time, the widest one the CPU has (walk.cc).
# Nothing else is built with machine-specific flags, so the library runs on any CPU of its
# platform. JACO_NATIVE_ISAS (comma-separated names) builds only the sets named, e.g. "baseline".
_X86 = platform.machine().lower() in ("x86_64", "amd64")
_ISAS = {
    "baseline": ([], 4),  # SSE2 on x86-64 (4 floats a vector), NEON on arm64
    "avx2": (["-mavx2", "-mfma", "-mbmi", "-mbmi2", "-mpopcnt"], 8),
    "avx512": (["-mavx512f", "-mavx512bw", "-mavx512vl", "-mavx512dq", "-mavx2", "-mfma", "-mbmi", "-mbmi2", "-mpopcnt",
                "-mprefer-vector-width=512"], 16),
}
_LANES = ["jaco/engine/walk_lanes.cc", "jaco/planners/iaca_lanes.cc", "jaco/engine/weights_lanes.cc",
          "jaco/engine/pheromone_lanes.cc"]


def _isas() -> dict:
    """The instruction sets to build: all of _ISAS on x86-64, the baseline elsewhere, as JACO_NATIVE_ISAS narrows."""
    names = list(_ISAS) if _X86 else ["baseline"]
    wanted = os.environ.get("JACO_NATIVE_ISAS")
    if wanted:
        names = [n for n in names if n in {w.strip() for w in wanted.split(",")}] or ["baseline"]
    return {n: _ISAS[n] for n in dict.fromkeys(["baseline", *names])}


_COMMANDS = ("compiler_so", "compiler_so_cxx", "compiler_cxx", "linker_so", "linker_so_cxx")  # those setuptools has


def _cache_dir() -> Path:
    if os.environ.get("JACO_CACHE_DIR"):
        return Path(os.environ["JACO_CACHE_DIR"])
    return Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "jaco"


def _cpu_flags() -> str:
    """This CPU's feature flags (Linux), else its processor name: for a build tuned to it."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith(("flags", "Features")):
                return line
    except OSError:
        pass
    return platform.processor()


def _one_process_per_source(compile):
    """``compile`` (a distutils compiler's) running the compiler on each source at once, one process
    a source, as many at a time as the machine has cores; the objects in the sources' order."""
    gate = threading.BoundedSemaphore(os.cpu_count() or 1)

    def run(sources, *args, **kwargs):
        def one(source):
            with gate:
                return compile([source], *args, **kwargs)

        with ThreadPoolExecutor(len(sources) or 1) as pool:
            return [obj for objects in pool.map(one, sources) for obj in objects]

    return run


class BuildNative(build_ext):
    def build_extension(self, ext):
        try:
            import jax  # a build requirement: the XLA FFI headers ship with jaxlib
            import jaxlib

            ext.include_dirs.append(jax.ffi.include_dir())
        except Exception as e:  # noqa: BLE001 - any failure means: no native walk
            print(f"jaco: not building the native walk ({e}); the JAX walk will be used")
            return
        out = Path(self.get_ext_fullpath(ext.name))
        key = self._cache_key(ext, jaxlib.__version__, out.name)
        cached = _cache_dir() / "native" / key / out.name if key else None
        if cached is not None and cached.is_file():
            out.parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(cached, out)
            print(f"jaco: reusing the native walk built before from the same sources, compiler and jaxlib: {cached}")
            return
        serial = self.compiler.compile
        self.compiler.compile = _one_process_per_source(serial)  # a minute of compiling, on every core
        try:
            self._build_lanes(ext)
            super().build_extension(ext)
        finally:
            self.compiler.compile = serial
        if cached is not None and out.is_file():
            try:  # a temporary file renamed into place: concurrent installs never see half a kernel
                cached.parent.mkdir(parents=True, exist_ok=True)
                fd, tmp = tempfile.mkstemp(dir=cached.parent, prefix=".tmp-")
                os.close(fd)
                shutil.copyfile(out, tmp)
                os.replace(tmp, cached)
                print(f"jaco: kept the native walk for later installs in {cached}")
            except OSError as e:
                print(f"jaco: could not keep the native walk in {cached.parent} ({e}); it is installed all the same")

    def _build_lanes(self, ext):
        """Compile the lane kernels once per instruction set (the sets at once) into objects linked
        with walk.cc. A set the compiler refuses is left out (walk.cc then never offers it); the
        baseline must build."""
        isas = _isas()

        def compile_set(isa):
            flags, lanes = isas[isa]
            return self.compiler.compile(
                _LANES,
                output_dir=os.path.join(self.build_temp, f"lanes-{isa}"),
                macros=[("JACO_ISA", isa), ("JACO_LANES", str(lanes))],
                include_dirs=ext.include_dirs,
                extra_postargs=[*ext.extra_compile_args, *flags],
            )

        with ThreadPoolExecutor(len(isas)) as pool:
            built = {isa: pool.submit(compile_set, isa) for isa in isas}
        for isa, job in built.items():
            try:
                objects = job.result()
            except Exception as e:  # noqa: BLE001 - a compiler without this set
                if isa == "baseline":
                    raise
                print(f"jaco: the lane kernels for {isa} were not built ({e}); the others will be used")
                continue
            ext.extra_objects = [*(ext.extra_objects or []), *objects]
            if isa != "baseline":
                ext.define_macros = [*ext.define_macros, (f"JACO_HAVE_{isa.upper()}", "1")]

    def _cache_key(self, ext, jaxlib_version: str, name: str):
        """The sha256 of what the built kernel depends on, or None when the compiler's version is unknown."""
        h = hashlib.sha256()
        for path in [*ext.sources, *ext.depends]:
            h.update(path.encode() + b"\0" + Path(path).read_bytes() + b"\0")
        commands = [getattr(self.compiler, attr, None) for attr in _COMMANDS]
        commands = [c for c in commands if c]
        # What the build assumes of the CPU: the instruction sets compiled (each used only where the
        # CPU has it) and, where the compiler's own flags ask for this machine's CPU, this CPU.
        assumed = [_isas(), platform.machine()]
        if any("native" in flag for c in commands for flag in c):
            assumed.append(_cpu_flags())
        for part in (commands, ext.extra_compile_args, ext.extra_link_args, ext.define_macros, jaxlib_version, name,
                     assumed):
            h.update(repr(part).encode() + b"\0")
        for program in dict.fromkeys(c[0] for c in commands):
            try:
                run = subprocess.run([program, "--version"], capture_output=True, timeout=60)
            except (OSError, subprocess.SubprocessError):
                return None
            if run.returncode != 0 or not run.stdout.strip():
                return None
            h.update(run.stdout + b"\0")
        return h.hexdigest()


setup(
    ext_modules=[
        Extension(
            "jaco.engine._walk",
            # One kernel per file, next to the code it serves; one library.
            ["jaco/engine/walk.cc", "jaco/planners/iaca.cc", "jaco/engine/weights.cc", "jaco/engine/pheromone.cc", "jaco/engine/local_search.cc",
             "jaco/potential.cc"],
            depends=[*_LANES, "jaco/engine/walk_lanes.h", "jaco/planners/iaca_lanes.h", "jaco/engine/weights_lanes.h", "jaco/engine/pheromone_lanes.h", "jaco/engine/walk_shared.h", "jaco/engine/kernel_threads.h"],
            include_dirs=["jaco/engine"],
            language="c++",
            extra_compile_args=["-std=c++17", "-O3", "-ffp-contract=off"],
            optional=True,
        )
    ],
    cmdclass={"build_ext": BuildNative},
)
