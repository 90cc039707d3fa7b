"""Build of the C extension tribench.ext._core (everything else is in pyproject.toml).

The extension lives here rather than in pyproject.toml for two reasons: its
exact compile flags are baked into the module (TB_BUILD_FLAGS) so every run
can record how its kernels were built, and its C files compile in parallel
(ParallelBuildExt), which pyproject cannot ask for.

Environment:
  TRIBENCH_SANITIZE=1  build with AddressSanitizer and UndefinedBehaviorSanitizer
                       (for the CI's sanitizer step; run with libasan preloaded).
  TRIBENCH_LINE_TABLES=1
                       keep line tables (-g1), which bench/bvh_counts.py needs to
                       split a ray's cost between the walk and the leaf test.
"""

import os
import sysconfig
from concurrent.futures import ThreadPoolExecutor

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext
from setuptools.command.build_py import build_py

# -ffp-contract=off: no silent FMA contraction (it changes results, and breaks
# watertight kernels); never -ffast-math (it removes the NaN/Inf handling the
# suite measures). No -march: one build runs on any CPU of its architecture.
# -Wno-psabi: the wide loops' vector helpers are always inlined, so the ABI note
# GCC gives for vector arguments in the SSE2 baseline build never applies.
# -g0: Python's own CFLAGS ask for debug info, which took a quarter of the
# compile time and changes no instruction (the sanitizer build asks for it again).
KERNEL_FLAGS = ["-std=c11", "-O3", "-ffp-contract=off", "-fno-math-errno", "-Wall", "-Wextra", "-Wno-psabi", "-g0"]
# -g1: line tables, all a sanitizer's report needs, at half -g's compile time; -O0: instrumented
# code compiles 4x faster than at -O1, and nothing is optimised out of the checks
# (docs/decisions.md, "The extension's compile time")
SANITIZE_FLAGS = ["-fsanitize=address,undefined", "-fno-sanitize-recover=all", "-fno-omit-frame-pointer", "-O0", "-g1"]

compile_flags = KERNEL_FLAGS + (SANITIZE_FLAGS if os.environ.get("TRIBENCH_SANITIZE") == "1" else [])
compile_flags += ["-g1"] if os.environ.get("TRIBENCH_LINE_TABLES") == "1" else []
link_flags = SANITIZE_FLAGS[:1] if os.environ.get("TRIBENCH_SANITIZE") == "1" else []
recorded = " ".join([sysconfig.get_config_var("CFLAGS") or ""] + compile_flags).strip()

# The module's translation units (ext/core.h says what each holds), largest
# first: the pool below starts them in this order (setuptools hands them over
# sorted by name), so the files of loops (about 95% of the work, of about one
# size: six on x86-64, four on aarch64, where the others are empty) spread
# over the cores and the small ones fill in at the end.
SOURCES = [
    *(f"ext/isa_{isa}_{p}.c" for isa in ("avx512", "avx2", "neon", "baseline") for p in ("f32", "f64")),
    "ext/registry.c",
    "ext/probes.c",
    "ext/bvh.c",
    "ext/_core.c",
]
if sorted(SOURCES) != sorted(f"ext/{f}" for f in os.listdir("ext") if f.endswith(".c")):
    raise SystemExit("setup.py: SOURCES must list every ext/*.c")


class ParallelBuildExt(build_ext):
    """build_ext that compiles an extension's sources concurrently, one compiler
    process per core (setuptools compiles them one after another), started in
    SOURCES order; the objects are linked in the order setuptools chose."""

    def build_extension(self, ext):
        compiler = self.compiler
        compile_one = compiler.compile

        def compile_all(sources, output_dir=None, **kwargs):
            for obj in compiler.object_filenames(sources, output_dir=output_dir):
                compiler.mkpath(os.path.dirname(obj))  # before the threads: mkpath is not thread-safe
            largest_first = sorted(sources, key=lambda s: SOURCES.index(s) if s in SOURCES else -1)
            with ThreadPoolExecutor(max_workers=os.cpu_count() or 1) as pool:
                compiled = pool.map(lambda s: compile_one([s], output_dir=output_dir, **kwargs), largest_first)
                objects = dict(zip(largest_first, compiled, strict=True))
            return [obj for source in sources for obj in objects[source]]

        compiler.compile = compile_all
        try:
            super().build_extension(ext)
        finally:
            del compiler.compile  # the class's own again


class BuildPackage(build_py):
    """build_py that leaves this script out of the package: the repository's root is the
    package `tribench` (pyproject.toml), and a PEP 517 build does not exclude it by itself."""

    def find_package_modules(self, package, package_dir):
        found = super().find_package_modules(package, package_dir)
        return [m for m in found if (m[0], m[1]) != ("tribench", "setup")]


setup(
    cmdclass={"build_ext": ParallelBuildExt, "build_py": BuildPackage},
    ext_modules=[
        Extension(
            "tribench.ext._core",
            sources=SOURCES,
            include_dirs=["ext"],
            # every header and every C file: a change to any rebuilds the module
            depends=[
                os.path.join(d, f)
                for d in ("ext", "ext/kernels")
                for f in sorted(os.listdir(d))
                if f.endswith((".h", ".c"))
            ],
            extra_compile_args=compile_flags,
            extra_link_args=link_flags,
            define_macros=[("TB_BUILD_FLAGS", '"' + recorded.replace('"', "'") + '"')],
        )
    ],
)
