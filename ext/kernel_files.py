"""Kernels of the user's own (docs/own-kernel.md): a C file written against the kernel contract, compiled with
every C file of the extension by the process's toolchain (:func:`tribench.ext.toolchain.current`), its
kernels in place of the built-in list, cached under ``cache_dir()/kernel_builds`` by the hash of the file,
the sources, the compiler and the flags, and joined to the registry."""

from __future__ import annotations

import hashlib
import os
import shlex
import subprocess
import sysconfig
from dataclasses import dataclass
from pathlib import Path

from ..common import UserError
from ..common.location import cache_dir
from .registry import adopt
from .toolchain import Toolchain, compile_module, current, import_module

__all__ = ["KernelFile", "KernelFileError", "kernel_file_of", "load_kernels", "loaded_kernel_files"]

#: The largest kernel file read (a kernel is a page or two of C).
MAX_KERNEL_FILE_BYTES = 1 << 20


class KernelFileError(UserError):
    """A kernel file that cannot be read, does not compile, or declares a name it may not."""


@dataclass(frozen=True)
class KernelFile:
    """A kernel file loaded into this process: its resolved ``path``, the ``sha256`` of what was compiled, the
    ``kernels`` it declares (in its order), its ``citation`` and its compiled ``module`` file (in the cache)."""

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
    """Compile (or take from the cache) the kernel file at ``path``, join its kernels to the registry and return
    their names.

    Loading the same file again is free; after an edit it is compiled again and the new code takes over its
    names. Raises :class:`KernelFileError` when the file cannot be read, does not compile (with the compiler's
    ``file:line`` messages) or declares a built-in kernel's name. No answer is checked here: the command line
    and ``tribench.sweep`` check a file's kernels against the float64 reference before timing them."""
    source, text = _read(path)
    sha = hashlib.sha256(text).hexdigest()
    toolchain = current()
    key = _build_key(text, toolchain)
    name = f"_kf_{key[:20]}"
    module_path = cache_dir() / "kernel_builds" / key[:20] / f"{name}{sysconfig.get_config_var('EXT_SUFFIX')}"
    same = next((f for f in loaded_kernel_files() if f.path == str(source) and f.module == str(module_path)), None)
    if same is not None and all(kernel_file_of(k) is same for k in same.kernels):
        return same.kernels
    module = import_module(name, module_path) if module_path.is_file() else None
    if module is None:
        _compile(source, name, module_path, toolchain)
        module = import_module(name, module_path)
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
        text = source.read_bytes()
    except OSError as e:
        raise KernelFileError(f"{source}: cannot read it ({e.strerror})") from None
    if b"\0" in text:  # a compiler would quote pages of it back
        raise KernelFileError(f"{source}: not C source: it holds NUL bytes (a binary file?)")
    return source, text


def _build_key(text: bytes, toolchain: Toolchain) -> str:
    """The hash that names a kernel file's build: the file and everything else the module depends on."""
    return hashlib.sha256(text + toolchain.key.encode()).hexdigest()


def _compile(source: Path, name: str, module_path: Path, toolchain: Toolchain) -> None:
    """Compile every C file of the extension with ``source``'s kernels, into ``module_path`` (atomically)."""

    def failed(result: subprocess.CompletedProcess) -> KernelFileError:  # every file includes the kernel file
        return KernelFileError(f"{source} does not compile ({shlex.join(toolchain.cc)}):\n{_own_lines(result, source)}")

    try:
        compile_module(toolchain, name, module_path, [f'-DTB_KERNEL_FILE="{source}"'], failed)
    except KernelFileError:
        raise
    except UserError as e:
        raise KernelFileError(f"{source}: {e}") from None


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
    lines = [line if len(line) <= 300 else f"{line[:300]}..." for b in (own or errors[:1] or blocks) for line in b]
    return "\n".join(lines[:most] + ([f"... ({len(lines) - most} more lines)"] if len(lines) > most else []))
