"""A mesh, ray or kernel file named by its content (a spec carries its sha256): copies up to
:data:`MAX_COPY_BYTES` are kept beside the cache and in the run folders that use it, so :func:`source` finds the
file again when it moves or changes."""

from __future__ import annotations

import os
import shutil
import warnings
from pathlib import Path

from ..common import Notice, UserError, atomic_write
from ..common.location import cache_dir
from .spec import file_sha256

__all__ = ["KERNELS_FOLDER", "MAX_COPY_BYTES", "RAYS_FOLDER", "RUN_FOLDER", "adopt", "copy_into_run", "kept", "source"]

#: Mesh files up to this size are copied into the cache and into the run folders that use them.
MAX_COPY_BYTES = 32 * 1024 * 1024
#: The run folder's subfolder of mesh copies.
RUN_FOLDER = "meshes"
#: The run folder's subfolder of ray file copies.
RAYS_FOLDER = "rays"
#: The run folder's subfolder of kernel file copies (``--kernel-file``: the C source each run compiled).
KERNELS_FOLDER = "kernel_files"
#: What each folder's files are, for messages.
_WHAT = {RUN_FOLDER: "mesh file", RAYS_FOLDER: "ray file", KERNELS_FOLDER: "kernel file"}


def _name(sha256: str, suffix: str) -> str:
    return f"{sha256}{suffix.lower()}"


def _store(folder: str) -> Path:
    return cache_dir() / folder


def _copy(path: Path, folder: Path, sha256: str) -> None:
    """Copy ``path`` into ``folder`` under its content's name, atomically, unless it is there or too large."""
    target = folder / _name(sha256, path.suffix)
    if target.is_file() or path.stat().st_size > MAX_COPY_BYTES:
        return
    if os.path.lexists(target):  # a folder or a dangling link where the copy goes: the copy is optional
        warnings.warn(f"{target} is not a regular file: no copy of {path.name} is kept there", Notice, stacklevel=3)
        return
    with open(path, "rb") as src, atomic_write(target, "wb") as dst:
        shutil.copyfileobj(src, dst)


def kept(path: str | Path, sha256: str, folder: str = RUN_FOLDER) -> Path:
    """:func:`source`, with a copy of what it found kept beside the cache (done when its workload is built)."""
    found = source(path, sha256, folder)
    _copy(found, _store(folder), sha256)
    return found


def copy_into_run(run_dir: str | Path, path: str | Path, sha256: str, folder: str = RUN_FOLDER) -> None:
    """Copy the file into ``run_dir/meshes/`` (or ``folder``; done when a sweep starts), from wherever it is found."""
    _copy(source(path, sha256, folder), Path(run_dir) / folder, sha256)


def adopt(run_dir: str | Path) -> None:
    """Add ``run_dir``'s mesh and ray file copies to the cache's, each checked against the hash it is named by."""
    for name in _WHAT:
        folder = Path(run_dir) / name
        for copy in sorted(folder.glob("*")) if folder.is_dir() else []:
            if copy.is_file() and not copy.is_symlink() and file_sha256(copy) == copy.stem:
                _copy(copy, _store(name), copy.stem)


def source(path: str | Path, sha256: str, folder: str = RUN_FOLDER) -> Path:
    """A file holding what ``path`` held when its spec was made: ``path`` itself, else the cache's copy; a
    UserError naming the file and what to do when neither has that content."""
    path = Path(path)
    if path.is_file() and file_sha256(path) == sha256:
        return path
    copy = _store(folder) / _name(sha256, path.suffix)
    if copy.is_file() and file_sha256(copy) == sha256:
        return copy
    state = "has changed" if path.exists() else "is gone"
    raise UserError(
        f"{_WHAT[folder]} {path} {state} since this workload was defined (sha256 {sha256[:12]}...), and no copy of it "
        "is kept (a copy is kept up to 32 MB): put the file back, or analyse the run folder that holds a copy"
    )
