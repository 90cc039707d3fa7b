"""Compiling the extension's C files into a module of its own, for a kernel file or a build: a
:class:`Toolchain` (compiler, flags, link), :func:`compile_module` (every C file in parallel, linked
atomically), :func:`import_module` (which removes a damaged module, so it compiles again) and, on them,
:func:`cached_module`, a module from the cache (:func:`module_file`) or compiled into it. Kernel files
are compiled by the process's :func:`current` toolchain: the installed one, or the build a worker runs."""

from __future__ import annotations

import contextlib
import functools
import hashlib
import importlib.machinery
import importlib.util
import os
import shlex
import signal
import subprocess
import sysconfig
import tempfile
import threading
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType

from ..common import UserError, write_text
from ..common.files import file_sha256
from ..common.location import cache_dir
from .registry import build_info

EXT = Path(__file__).resolve().parent
#: The extension's C files (setup.py's SOURCES) and every header they include.
SOURCES = tuple(sorted(EXT.glob("*.c")))
_HEADERS = tuple(sorted([*EXT.glob("*.h"), *(EXT / "kernels").glob("*.h")]))


@dataclass(frozen=True)
class Toolchain:
    """A compiler (its command), the flags every C file is compiled with, and the link command."""

    cc: tuple[str, ...]
    flags: tuple[str, ...]
    link: tuple[str, ...]

    @functools.cached_property
    def version(self) -> str:
        """The compiler's ``--version``, whole ("" if it does not run)."""
        try:
            return subprocess.run([*self.cc, "--version"], capture_output=True, text=True, timeout=60).stdout
        except (OSError, subprocess.SubprocessError):
            return ""

    @functools.cached_property
    def key(self) -> str:
        """The hash of everything a module compiled by this toolchain depends on but the kernel file:
        the extension's sources and headers, the compiler, its version, the flags and the link."""
        h = hashlib.sha256()
        for f in (*SOURCES, *_HEADERS):
            h.update(f.name.encode() + b"\0" + f.read_bytes())
        h.update(repr((self.cc, self.flags, self.link, self.version, sysconfig.get_config_var("EXT_SUFFIX"))).encode())
        return h.hexdigest()


@functools.cache
def installed() -> Toolchain:
    """The installed extension's toolchain: ``sysconfig``'s compiler and link, the module's recorded flags."""
    flags = shlex.split(build_info()["flags"]) + shlex.split(sysconfig.get_config_var("CCSHARED") or "-fPIC")
    link = shlex.split(sysconfig.get_config_var("LDSHARED") or "cc -shared")
    link += [f for f in flags if f.startswith("-fsanitize")]  # a sanitized build links its runtime
    return Toolchain(tuple(shlex.split(sysconfig.get_config_var("CC") or "cc")), tuple(flags), tuple(link))


_CURRENT: list[Toolchain] = []


def current() -> Toolchain:
    """The toolchain kernel files are compiled with in this process: the installed one, or the build's in use."""
    return _CURRENT[-1] if _CURRENT else installed()


def set_current(toolchain: Toolchain) -> None:
    _CURRENT[:] = [toolchain]


def compile_module(
    toolchain: Toolchain,
    name: str,
    module_path: Path,
    defines: list[str],
    failed: Callable[[subprocess.CompletedProcess], UserError],
    sources: tuple[Path, ...] = SOURCES,
    libs: tuple[str, ...] = (),
) -> None:
    """Compile ``sources`` (every C file of the extension) with ``defines`` and link them, and ``libs``, into
    ``module_path`` (atomically); ``failed(result)`` makes the error raised for the first unit to fail."""
    defines = [
        *defines,
        f"-DTB_MODULE_NAME={name}",
        "-DTB_BUILD_FLAGS=" + '"' + shlex.join(toolchain.flags).replace('"', "'") + '"',
    ]
    includes = [f"-I{EXT}", f"-I{sysconfig.get_paths()['include']}"]
    module_path.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(dir=module_path.parent) as tmp:
        objects = [Path(tmp) / f"{c.stem}.o" for c in sources]
        compile_c = [*toolchain.cc, *toolchain.flags, *defines, *includes, "-c"]
        first = _first_failure([[*compile_c, str(c), "-o", str(o)] for c, o in zip(sources, objects, strict=True)])
        if first is not None:
            raise failed(first)
        link = [*toolchain.link, *map(str, objects), *libs, "-o", str(Path(tmp) / module_path.name)]
        linked = _finish(_start(link), link)
        if linked.returncode or not (Path(tmp) / module_path.name).is_file():
            said = linked.stderr.strip() or "it wrote no module"
            raise UserError(f"does not link ({shlex.join(toolchain.link)}):\n{said}")
        write_text(_seal(module_path), file_sha256(Path(tmp) / module_path.name))  # before the module: no stale seal
        os.replace(Path(tmp) / module_path.name, module_path)


def module_file(prefix: str, key: str) -> tuple[str, Path]:
    """The name and cache file of a compiled module, by the hash ``key`` of all it is compiled from."""
    name = f"{prefix}{key[:20]}"
    return name, cache_dir() / "kernel_builds" / key[:20] / f"{name}{sysconfig.get_config_var('EXT_SUFFIX')}"


def cached_module(
    toolchain: Toolchain,
    name: str,
    path: Path,
    defines: list[str],
    failed: Callable[[subprocess.CompletedProcess], UserError],
    error: type[UserError],
    what: str,
) -> ModuleType:
    """The module at ``path``, compiled by :func:`compile_module` first unless the cache holds it whole; a
    failure is an ``error``: ``failed(result)``'s for a unit that does not compile, else one starting ``what: ``."""
    module = import_module(name, path)
    if module is None:
        try:
            compile_module(toolchain, name, path, defines, failed)
        except error:
            raise
        except UserError as e:
            raise error(f"{what}: {e}") from None
        module = import_module(name, path)
        if module is None:
            raise error(f"{what}: compiled, but its module {path} does not import")
    return module


def _seal(module_path: Path) -> Path:
    """The file beside a compiled module holding its sha256: a cut or changed module is compiled again, never loaded
    (a truncated shared object kills the process that loads it with SIGBUS, before any ImportError)."""
    return module_path.with_name(f"{module_path.name}.sha256")


def _first_failure(commands: list[list[str]]) -> subprocess.CompletedProcess | None:
    """Runs the compile commands, as many at once as there are cores, and returns the first that fails,
    having stopped the others (its error is the answer: the rest would only take seconds to say more),
    or None when every one succeeds. An exception here (Ctrl-C) stops them all too."""
    lock, stop = threading.Lock(), threading.Event()
    running: set[subprocess.Popen] = set()
    failure: list[subprocess.CompletedProcess] = []

    def stop_all() -> None:  # under the lock
        stop.set()
        for proc in running:
            _kill(proc)

    def compile_one(argv: list[str]) -> None:
        with lock:
            if stop.is_set():
                return
            proc = _start(argv)
            running.add(proc)
        try:
            done = _finish(proc, argv)
        finally:
            with lock:
                running.discard(proc)
        with lock:
            if done.returncode and not stop.is_set():  # one stopped here fails too, but after the first
                failure.append(done)
                stop_all()

    with ThreadPoolExecutor(max_workers=os.cpu_count() or 1) as pool:
        try:
            for done in [pool.submit(compile_one, argv) for argv in commands]:
                done.result()
        except BaseException:
            with lock:
                stop_all()
            raise
    return failure[0] if failure else None


def _start(argv: list[str]) -> subprocess.Popen:
    """A compiler started in a process group of its own (so that stopping it stops the programs it runs,
    gcc's cc1 and as), its output piped as text; a missing compiler is a UserError."""
    try:
        # errors="replace": a compiler quotes the source, whose bytes need not be UTF-8
        return subprocess.Popen(
            argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, errors="replace", process_group=0
        )
    except FileNotFoundError:
        raise UserError(f"no compiler: {argv[0]} is not installed") from None


def _kill(proc: subprocess.Popen) -> None:
    """Stops a started compiler and what it runs (its process group: Ctrl-C does not reach it)."""
    with contextlib.suppress(ProcessLookupError):
        os.killpg(proc.pid, signal.SIGKILL)


def _finish(proc: subprocess.Popen, argv: list[str]) -> subprocess.CompletedProcess:
    """Wait for a started compiler: one over 10 minutes, or interrupted (Ctrl-C), is stopped with a UserError."""
    try:
        out, err = proc.communicate(timeout=600)
    except BaseException as e:
        _kill(proc)
        proc.communicate()
        if isinstance(e, subprocess.TimeoutExpired):
            raise UserError(f"{argv[0]} took over 10 minutes on one file; stopped") from None
        raise
    return subprocess.CompletedProcess(argv, proc.returncode, out, err)


def import_module(name: str, path: Path) -> ModuleType | None:
    """The compiled module at ``path``, or None if it does not match its seal or does not import (a damaged cache
    file: removed, with its seal, so it compiles again)."""
    qualified = f"tribench.ext.{name}"
    loader = importlib.machinery.ExtensionFileLoader(qualified, str(path))
    spec = importlib.util.spec_from_file_location(qualified, path, loader=loader)
    if spec is None:
        return None
    try:
        if _seal(path).read_text().strip() != file_sha256(path):
            raise ImportError(f"{path} does not match its sha256")
        module = importlib.util.module_from_spec(spec)
        loader.exec_module(module)
    except (ImportError, OSError):
        for stale in (path, _seal(path)):
            stale.unlink(missing_ok=True)
        return None
    return module
