"""Builds the native walks (jaco/engine/walk.cc) as an optional extension: where it cannot be
compiled, the install still succeeds and jaco uses the JAX walk."""

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext


class BuildNative(build_ext):
    def build_extension(self, ext):
        try:
            import jax  # a build requirement: the XLA FFI headers ship with jaxlib

            ext.include_dirs.append(jax.ffi.include_dir())
        except Exception as e:  # noqa: BLE001 - any failure means: no native walk
            print(f"jaco: not building the native walk ({e}); the JAX walk will be used")
            return
        super().build_extension(ext)


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
