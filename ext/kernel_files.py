"""Kernels of the user's own (docs/own-kernel.md): a C file written against the kernel contract, compiled with
every C file of the extension by the process's toolchain (:func:`tribench.ext.toolchain.current`), cached
under ``cache_dir()/kernel_builds`` by the hash of the file, sources, compiler and flags, and joined to the
registry. A kernel file's content is the file with every local header it includes (``#include "x.h"``
beside the includer) written in place under ``#line`` marks, so an edit to a header compiles it again and a
run folder's copy compiles on its own elsewhere."""

from __future__ import annotations

import hashlib
import os
import re
import shlex
import subprocess
from dataclasses import dataclass
from pathlib import Path

from ..common import UserError
from .registry import adopt
from .toolchain import cached_module, current, module_file

__all__ = ["KernelFile", "KernelFileError", "kernel_file_of", "load_kernels", "loaded_kernel_files"]

#: The largest kernel file read (a kernel is a page or two of C).
MAX_KERNEL_FILE_BYTES = 1 << 20


class KernelFileError(UserError):
    """A kernel file that cannot be read, does not compile, or declares a name it may not."""


@dataclass(frozen=True)
class KernelFile:
    """A kernel file loaded into this process: its resolved ``path``, the ``sha256`` of what was compiled, the
    ``kernels`` it declares (in its order), its ``citation``, its compiled ``module`` file (in the cache) and the
    ``text`` file that holds what was compiled (``path`` itself unless it includes local headers)."""

    path: str
    sha256: str
    kernels: tuple[str, ...]
    citation: str
    module: str
    text: str


_LOADED: dict[str, KernelFile] = {}  # kernel name -> the file that declared it


def loaded_kernel_files() -> tuple[KernelFile, ...]:
    """The kernel files loaded into this process, in the order loaded."""
    return tuple(dict.fromkeys(_LOADED.values()))


def kernel_file_of(kernel: str) -> KernelFile | None:
    """The kernel file that declared ``kernel``; None for a built-in kernel."""
    return _LOADED.get(kernel)


def load_kernels(path: str | os.PathLike) -> tuple[str, ...]:
    """Compile (or take from the cache) the kernel file at ``path``, join its kernels to the registry and return
    their names; after an edit the new code takes over its names.

    Raises :class:`KernelFileError` when the file cannot be read, does not compile (with the compiler's
    ``file:line`` messages) or declares a built-in kernel's name. No answer is checked here: callers check a
    file's kernels against the reference before timing them."""
    source, raw = _read(path)
    text = _with_local_headers(source, raw)
    sha = hashlib.sha256(text).hexdigest()
    toolchain = current()
    key = hashlib.sha256(text + toolchain.key.encode()).hexdigest()  # the file and all else the module depends on
    name, module_path = module_file("_kf_", key)
    compiled = source if text == raw else module_path.with_name(f"{source.stem}.c")
    if compiled != source and not (compiled.is_file() and compiled.read_bytes() == text):
        compiled.parent.mkdir(parents=True, exist_ok=True)
        compiled.write_bytes(text)
    same = next((f for f in loaded_kernel_files() if f.path == str(source) and f.module == str(module_path)), None)
    if same is not None and all(kernel_file_of(k) is same for k in same.kernels):
        return same.kernels

    def failed(result: subprocess.CompletedProcess) -> KernelFileError:  # every file includes the kernel file
        return KernelFileError(f"{source} does not compile ({shlex.join(toolchain.cc)}):\n{_own_lines(result, source)}")

    defines = [f'-DTB_KERNEL_FILE="{compiled}"']
    module = cached_module(toolchain, name, module_path, defines, failed, KernelFileError, str(source))
    taken = [
        f"{k} (declared by {f.path})"
        for k in module.kernel_names(True)
        if (f := _LOADED.get(k)) is not None and f.path != str(source) and f.sha256 != sha
    ]
    if taken:  # the same text elsewhere (a run folder's copy) may take over; other code may not
        raise KernelFileError(f"{', '.join(taken)}: the name of another kernel file's kernel; give it another name")
    try:
        names = adopt(module, str(source))
    except UserError as e:
        raise KernelFileError(f"{source} declares {e}") from None
    loaded = KernelFile(str(source), sha, names, module.FILE_CITATION, str(module_path), str(compiled))
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


_LOCAL_INCLUDE = re.compile(rb'^[ \t]*#[ \t]*include[ \t]*"([^"\n]+)"[^\n]*$', re.M)
#: How deep local headers may include each other (a header that includes itself would never end).
MAX_INCLUDE_DEPTH = 16


def _with_local_headers(path: Path, text: bytes, depth: int = 0) -> bytes:
    """``text`` (of the file ``path``) with each local header it includes in place, recursively, each between
    ``#line`` marks; the same bytes when it includes none (tribench's own headers and the system's are left
    to the compiler's include path)."""
    parts, at = [], 0
    for m in _LOCAL_INCLUDE.finditer(text):
        header = (path.parent / m.group(1).decode(errors="replace")).resolve()
        if not header.is_file():
            continue
        if depth >= MAX_INCLUDE_DEPTH:
            raise KernelFileError(f"{path}: its local headers include each other over {MAX_INCLUDE_DEPTH} deep")
        after = text.count(b"\n", 0, m.end()) + 2  # the line after the include, as the compiler counts
        inner = _with_local_headers(header, header.read_bytes(), depth + 1)
        parts += [text[at : m.start()], b'#line 1 "%s"\n' % str(header).encode(), inner]
        parts.append(b'\n#line %d "%s"\n' % (after, str(path).encode()))
        at = m.end() + 1 if text[m.end() : m.end() + 1] == b"\n" else m.end()
    if not parts:
        return text
    return b"".join([b'#line 1 "%s"\n' % str(path).encode(), *parts, text[at:]])


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
