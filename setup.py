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
import shutil
import subprocess
import tempfile
from pathlib import Path

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext

_COMMANDS = ("compiler_so", "compiler_so_cxx", "compiler_cxx", "linker_so", "linker_so_cxx")  # those setuptools has


def _cache_dir() -> Path:
    if os.environ.get("JACO_CACHE_DIR"):
        return Path(os.environ["JACO_CACHE_DIR"])
    return Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "jaco"


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
        super().build_extension(ext)
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

    def _cache_key(self, ext, jaxlib_version: str, name: str):
        """The sha256 of what the built kernel depends on, or None when the compiler's version is unknown."""
        h = hashlib.sha256()
        for path in [*ext.sources, *ext.depends]:
            h.update(path.encode() + b"\0" + Path(path).read_bytes() + b"\0")
        commands = [getattr(self.compiler, attr, None) for attr in _COMMANDS]
        commands = [c for c in commands if c]
        for part in (commands, ext.extra_compile_args, ext.extra_link_args, ext.define_macros, jaxlib_version, name):
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
            ["jaco/engine/walk.cc"],
            language="c++",
            extra_compile_args=["-std=c++17", "-O3", "-ffp-contract=off"],
            optional=True,
        )
    ],
    cmdclass={"build_ext": BuildNative},
)
