"""Kernels of the user's own: a C file written against the kernel contract
(``docs/own-kernel.md``), compiled as the built-in kernels are, cached, and
joined to the registry.

A kernel file is what a built-in kernel's file is (``ext/kernels/<name>.h``,
the contract in ``ext/kernels.h`` and ``ext/native.h``) plus its own
registration lines, ``TB_FILE_KERNELS(X)``, and ``TB_FILE_CITATION``. It is
compiled with every C file of the extension, by the compiler and with the
flags the installed extension recorded (``build_info()``), with the file's
kernels in place of the built-in list: the loops, the BVH traversal and the
glue are the built-in kernels' own. The module is cached under
``cache_dir()/kernel_builds``, named by the hash of the file, the extension's
sources, the compiler and the flags, so a second load costs an import.
"""

from __future__ import annotations

import hashlib
import importlib.machinery
import importlib.util
import os
import shlex
import shutil
import subprocess
import sysconfig
import tempfile
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType

from tribench.common import UserError
from tribench.common.location import cache_dir

from .registry import adopt, build_info

__all__ = ["KernelFile", "KernelFileError", "kernel_file_of", "load_kernels", "loaded_kernel_files"]

#: The largest kernel file read (a kernel is a page or two of C).
MAX_KERNEL_FILE_BYTES = 1 << 20
_EXT = Path(__file__).resolve().parent
# the extension's C files (setup.py's SOURCES) and every header they include
_SOURCES = sorted(_EXT.glob("*.c"))
_HEADERS = sorted([*_EXT.glob("*.h"), *(_EXT / "kernels").glob("*.h")])


class KernelFileError(UserError):
    """A kernel file that cannot be read, does not compile, or declares a name it may not."""


@dataclass(frozen=True)
class KernelFile:
    """A kernel file loaded into this process.

    Attributes
    ----------
    path : str
        The file, resolved.
    sha256 : str
        Of its content when it was compiled.
    kernels : tuple[str, ...]
        The names it declares (its registration lines), in its order.
    citation : str
        The paper it cites (``TB_FILE_CITATION``).
    module : str
        The compiled module's file (in the cache).
    """

    path: str
    sha256: str
    kernels: tuple[str, ...]
    citation: str
    module: str


_LOADED: dict[str, KernelFile] = {}  # kernel name -> the file that declared it


def loaded_kernel_files() -> tuple[KernelFile, ...]:
    """The kernel files loaded into this process, in the order loaded."""
    return tuple(dict.fromkeys(_LOADED.values()))


def kernel_file_of(kernel: str) -> KernelFile | None:
    """The kernel file that declared ``kernel``; None for a built-in kernel."""
    return _LOADED.get(kernel)


def load_kernels(path: str | os.PathLike) -> tuple[str, ...]:
    """Compile (or take from the cache) the kernel file at ``path`` and join its kernels to the registry.

    Returns the names the file declares. They are then known to every call
    of :mod:`tribench.ext` (``kernel_info``, ``intersect``, ``make_job``,
    ``build_bvh`` for a native kernel). Loading the same file again is
    free; loading it after an edit compiles it again and the new code takes
    over its names. Raises :class:`KernelFileError` when the file cannot be
    read, does not compile (with the compiler's own ``file:line`` messages),
    or declares the name of a built-in kernel. This checks no answer: the
    command line and ``tribench.sweep`` check a file's kernels against the
    float64 reference before timing them.
    """
    source, text = _read(path)
    sha = hashlib.sha256(text).hexdigest()
    same = next((f for f in loaded_kernel_files() if f.path == str(source) and f.sha256 == sha), None)
    if same is not None and all(kernel_file_of(k) is same for k in same.kernels):
        return same.kernels
    key = _build_key(text)
    name = f"_kf_{key[:20]}"
    module_path = cache_dir() / "kernel_builds" / key[:20] / f"{name}{sysconfig.get_config_var('EXT_SUFFIX')}"
    module = _import(name, module_path) if module_path.is_file() else None
    if module is None:
        _compile(source, name, module_path)
        module = _import(name, module_path)
        if module is None:
            raise KernelFileError(f"{source}: compiled, but its module {module_path} does not import")
    try:
        names = adopt(module, str(source))
    except UserError as e:
        raise KernelFileError(f"{source} declares {e}") from None
    loaded = KernelFile(str(source), sha, names, module.FILE_CITATION, str(module_path))
    _LOADED.update(dict.fromkeys(names, loaded))
    return names


def _read(path: str | os.PathLike) -> tuple[Path, bytes]:
    if not isinstance(path, (str, os.PathLike)):
        raise KernelFileError(f"a kernel file is a path, got {type(path).__name__}")
    source = Path(path).expanduser().resolve()
    if not source.is_file():
        raise KernelFileError(f"{path}: no such kernel file")
    if any(c in str(source) for c in '"\\\n'):
        raise KernelFileError(f"{source}: a kernel file's path may not hold a quote, a backslash or a new line")
    if source.stat().st_size > MAX_KERNEL_FILE_BYTES:
        raise KernelFileError(f"{source}: over {MAX_KERNEL_FILE_BYTES >> 20} MB, too large for a kernel file")
    try:
        return source, source.read_bytes()
    except OSError as e:
        raise KernelFileError(f"{source}: cannot read it ({e.strerror})") from None


def _toolchain() -> tuple[list[str], list[str], list[str]]:
    """The compiler, the compile flags and the link command of the installed extension."""
    cc = shlex.split(sysconfig.get_config_var("CC") or "cc")
    flags = shlex.split(build_info()["flags"]) + shlex.split(sysconfig.get_config_var("CCSHARED") or "-fPIC")
    link = shlex.split(sysconfig.get_config_var("LDSHARED") or "cc -shared")
    link += [f for f in flags if f.startswith("-fsanitize")]  # a sanitized build links its runtime
    return cc, flags, link


def _build_key(text: bytes) -> str:
    """The hash that names a kernel file's build: the file, the sources, the compiler and the flags."""
    h = hashlib.sha256(text)
    for f in (*_SOURCES, *_HEADERS):
        h.update(f.name.encode() + b"\0" + f.read_bytes())
    cc, flags, link = _toolchain()
    h.update(repr((cc, flags, link, _compiler_version(cc), sysconfig.get_config_var("EXT_SUFFIX"))).encode())
    return h.hexdigest()


def _compiler_version(cc: list[str]) -> str:
    try:
        return subprocess.run([*cc, "--version"], capture_output=True, text=True, timeout=60).stdout
    except (OSError, subprocess.SubprocessError):
        return ""


def _compile(source: Path, name: str, module_path: Path) -> None:
    """Compile every C file of the extension with ``source``'s kernels, into ``module_path`` (atomically)."""
    cc, flags, link = _toolchain()
    defines = [
        f'-DTB_KERNEL_FILE="{source}"',
        f"-DTB_MODULE_NAME={name}",
        "-DTB_BUILD_FLAGS=" + '"' + shlex.join(flags).replace('"', "'") + '"',
    ]
    includes = [f"-I{_EXT}", f"-I{sysconfig.get_paths()['include']}"]
    module_path.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(dir=module_path.parent) as tmp:
        objects = [Path(tmp) / f"{c.stem}.o" for c in _SOURCES]

        def compile_one(c: Path, o: Path) -> subprocess.CompletedProcess:
            return _run([*cc, *flags, *defines, *includes, "-c", str(c), "-o", str(o)])

        with ThreadPoolExecutor(max_workers=os.cpu_count() or 1) as pool:
            done = list(pool.map(compile_one, _SOURCES, objects))
        failed = next((r for r in done if r.returncode), None)
        if failed is not None:  # every file includes the kernel file: one file's messages say it all
            raise KernelFileError(f"{source} does not compile ({shlex.join(cc)}):\n{_own_lines(failed, source)}")
        linked = _run([*link, *map(str, objects), "-o", str(Path(tmp) / module_path.name)])
        if linked.returncode:
            raise KernelFileError(f"{source} does not link ({shlex.join(link)}):\n{linked.stderr.strip()}")
        os.replace(Path(tmp) / module_path.name, module_path)


def _run(argv: list[str]) -> subprocess.CompletedProcess:
    try:
        return subprocess.run(argv, capture_output=True, text=True, timeout=600)
    except FileNotFoundError:
        raise KernelFileError(f"no compiler: {argv[0]} is not installed (kernel files need the extension's)") from None
    except subprocess.TimeoutExpired:
        raise KernelFileError(f"{argv[0]} took over 10 minutes on a kernel file; stopped") from None


def _own_lines(result: subprocess.CompletedProcess, source: Path, most: int = 60) -> str:
    """The compiler's messages about the kernel file (each with its quoted source lines); if none, its first
    error alone (what follows it is the cascade). At most ``most`` lines."""
    blocks: list[list[str]] = []
    for line in result.stderr.splitlines():
        if line.lstrip().startswith("from "):  # the rest of an include chain
            continue
        if line.startswith((" ", "\t")) and blocks:
            blocks[-1].append(line)
        elif not line.startswith("In file included from"):
            blocks.append([line])
    own = [b for b in blocks if b[0].startswith(f"{source}:")]
    errors = [b for b in blocks if ": error:" in b[0] or ": fatal error:" in b[0]]
    lines = [line for b in (own or errors[:1] or blocks) for line in b]
    return "\n".join(lines[:most] + ([f"... ({len(lines) - most} more lines)"] if len(lines) > most else []))


def _import(name: str, path: Path) -> ModuleType | None:
    """The compiled module at ``path``, or None if it does not import (a damaged cache file: rebuilt)."""
    qualified = f"tribench.ext.{name}"
    loader = importlib.machinery.ExtensionFileLoader(qualified, str(path))
    spec = importlib.util.spec_from_file_location(qualified, path, loader=loader)
    if spec is None:
        return None
    try:
        module = importlib.util.module_from_spec(spec)
        loader.exec_module(module)
    except ImportError:
        shutil.rmtree(path.parent, ignore_errors=True)
        return None
    return module
