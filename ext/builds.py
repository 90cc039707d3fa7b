"""Builds of the extension by another compiler or with other flags (``--builds "gcc -O2;clang -O3"``; what a
build is: docs/builds.md). :data:`INSTALLED` is pip's build; :func:`use_build` makes a process's built-in
kernels, and the kernel files it loads afterwards, one build's: a worker of a sweep runs one build."""

from __future__ import annotations

import functools
import os
import shlex
import shutil
import subprocess
import sysconfig
from types import ModuleType

from ..common import UserError
from . import _core
from .registry import module_sha256, use_module
from .toolchain import Toolchain, cached_module, installed, module_file, set_current

__all__ = ["INSTALLED", "BuildError", "build_record", "load_build", "parse_builds", "use_build"]

#: The installed extension's build (the default).
INSTALLED = "installed"
#: Most builds one sweep compares (each is a full compile of the extension, about a minute on 2 cores).
MAX_BUILDS = 8
_REQUIRED = ("-std=c11", "-DNDEBUG")


class BuildError(UserError):
    """A build spec that cannot be read, or a build that does not compile."""


def parse_builds(text: str) -> tuple[str, ...]:
    """The build specs of ``--builds``: separated by ``;``, each a compiler and its flags, normalised.

    >>> parse_builds("gcc -O2; clang  -O3 -march=native;")
    ('gcc -O2', 'clang -O3 -march=native')
    """
    if not isinstance(text, str):
        raise BuildError(f"builds must be a string of specs separated by ';', got {type(text).__name__}")
    return check_builds([part for part in text.split(";") if part.strip()])


def check_builds(specs: object) -> tuple[str, ...]:
    """A list of build specs, each normalised (``shlex`` words joined by one space) and checked."""
    if isinstance(specs, (str, bytes)) or not isinstance(specs, (list, tuple)):
        raise BuildError(f"builds must be a list of build specs, got {specs!r:.80}")
    out = []
    for spec in specs:
        if not isinstance(spec, str):
            raise BuildError(f"a build spec is a string (a compiler and its flags), got {spec!r:.80}")
        try:
            words = shlex.split(spec)
        except ValueError as e:
            raise BuildError(f"build {spec!r:.80}: {e}") from None
        if not words:
            raise BuildError("an empty build spec: give a compiler and its flags, such as 'gcc -O2'")
        if words[0].startswith("-"):
            raise BuildError(f"build {spec!r:.80} starts with a flag: give the compiler first, such as 'gcc {spec}'")
        bad = [w for w in words[1:] if not w.startswith("-")]
        if bad and words != [INSTALLED]:
            raise BuildError(f"build {spec!r:.80}: {bad[0]!r} is not a flag (each spec is one compiler and its flags)")
        taken = next((w for w in words[1:] if _tribench_sets(w)), None)
        if taken is not None:
            raise BuildError(f"build {spec!r:.80}: {taken} {_tribench_sets(taken)}")
        out.append(shlex.join(words))
    if len(set(out)) != len(out):
        raise BuildError(f"a build is listed twice: {'; '.join(out)}")
    if len(out) > MAX_BUILDS:
        raise BuildError(f"{len(out)} builds; at most {MAX_BUILDS} (each compiles the whole extension)")
    return tuple(out)


def _tribench_sets(flag: str) -> str:
    """Why tribench refuses ``flag`` in a build spec ("" if it does not)."""
    if flag in ("-E", "-S", "-c", "-shared", "-static") or flag.startswith(("-o", "-M")):
        return "sets what the compiler writes: tribench compiles and links the module itself"
    if flag.startswith(("-DTB_", "-UTB_")):
        return "sets one of tribench's own macros (TB_*)"
    if flag.startswith("-fsanitize"):
        return (
            "needs the sanitizer's runtime loaded before Python starts: build the installed extension "
            "with TRIBENCH_SANITIZE=1 instead (setup.py)"
        )
    return ""


@functools.cache
def toolchain_of(spec: str) -> Toolchain:
    """The compiler, flags and link command of a build spec (:data:`INSTALLED`: the installed one's); one per
    spec and process, so its ``--version`` and its hash of the sources are made once."""
    if spec == INSTALLED:
        return installed()
    cc, *flags = shlex.split(spec)
    if shutil.which(cc) is None:
        raise BuildError(f"build {spec!r}: no compiler {cc!r} on this machine (install it, or give its path)")
    if not _is_a_c_compiler(cc):
        raise BuildError(f"build {spec!r}: {cc} is not a C compiler (it does not compile C to a predefined __STDC__)")
    shared = shlex.split(sysconfig.get_config_var("CCSHARED") or "-fPIC")
    return Toolchain((cc,), (*_REQUIRED, *shared, *flags), (cc, "-shared", *flags))


@functools.cache
def _is_a_c_compiler(cc: str) -> bool:
    """Whether ``cc`` preprocesses C as a C compiler does (``cc -E -dM -x c /dev/null`` defines ``__STDC__``)."""
    try:
        done = subprocess.run([cc, "-E", "-dM", "-x", "c", os.devnull], capture_output=True, text=True, timeout=60)
    except (OSError, subprocess.SubprocessError):
        return False
    return done.returncode == 0 and "#define __STDC__ " in done.stdout


@functools.cache
def load_build(spec: str) -> ModuleType:
    """The module of build ``spec``, compiled into the cache unless it is there (:data:`INSTALLED`: ``_core``)."""
    if spec == INSTALLED:
        return _core
    toolchain = toolchain_of(spec)
    name, path = module_file("_bd_", toolchain.key)

    def failed(result: subprocess.CompletedProcess) -> BuildError:
        errors = [line for line in result.stderr.splitlines() if "error" in line][:20]
        return BuildError(f"build {spec!r} does not compile:\n" + "\n".join(errors or result.stderr.splitlines()[:20]))

    return cached_module(toolchain, name, path, [], failed, BuildError, f"build {spec!r}")


def use_build(spec: str) -> None:
    """Make this process's built-in kernels, and the kernel files it loads from now on, build ``spec``'s.

    Call it before loading kernel files: a file loaded before keeps the build it was compiled with."""
    use_module(load_build(spec))
    set_current(toolchain_of(spec))


def build_record(spec: str) -> dict:
    """A build as a run records it: spec, the compiler's ``--version`` line, exact flags, and the module's sha256."""
    module, toolchain = load_build(spec), toolchain_of(spec)
    info = module.build_info()
    return {
        "spec": spec,
        "compiler": (toolchain.version.splitlines() or [info["compiler"]])[0],
        "flags": shlex.join(toolchain.flags) if spec != INSTALLED else info["flags"],
        "fast_math": bool(info["fast_math"]),
        "module_sha256": module_sha256(module.__file__ or ""),
    }
