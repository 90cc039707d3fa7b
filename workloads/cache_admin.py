"""What the cache holds (:func:`entries`: every file, its size, when it was last used and why it cannot be used,
if so), and pruning (:func:`prune`) what no installed build can use, then, under a size bound, the regenerable
files used longest ago."""

from __future__ import annotations

import os
import re
import stat
from dataclasses import dataclass
from pathlib import Path

from ..common import UserError
from ..common.location import cache_dir

__all__ = ["Entry", "Pruned", "entries", "parse_size", "prune"]

#: Kinds a size bound may remove: each is made again when it is next needed.
REGENERABLE = ("workload", "bvh", "front", "kernel build")
_UNITS = {"": 1, "b": 1, "k": 10**3, "m": 10**6, "g": 10**9, "t": 10**12}
_BINARY = {"ki": 2**10, "mi": 2**20, "gi": 2**30, "ti": 2**40}


@dataclass(frozen=True)
class Entry:
    """One file of the cache; ``problem`` is None if some installed build can use it."""

    kind: str
    path: Path
    size_bytes: int
    used: float
    problem: str | None


@dataclass(frozen=True)
class Pruned:
    """What :func:`prune` removed, and what the cache holds after it."""

    removed: list[Entry]
    kept_bytes: int


def parse_size(text: str) -> int:
    """A size in bytes from ``500MB``, ``1.5G``, ``200MiB`` or ``0`` (MB: 10**6 bytes, MiB: 2**20).

    >>> parse_size("500MB"), parse_size("1.5G"), parse_size("2MiB")
    (500000000, 1500000000, 2097152)
    """
    m = re.fullmatch(r"\s*(\d+(?:\.\d*)?)\s*([kmgt]i?)?b?\s*", text.lower())
    if not m:
        raise UserError(f"--max-size {text!r}: expected a size such as 500MB, 2GB or 0")
    unit = m.group(2) or ""
    size = float(m.group(1)) * (_BINARY[unit] if unit.endswith("i") else _UNITS[unit])
    if not size < 2**63:  # a 400-digit number is infinite as a float
        raise UserError(f"--max-size {text[:40]!r}: too large; give at most 8EiB, e.g. 500MB or 2GB")
    return int(size)


def _kind(rel: Path) -> str:
    if rel.name.endswith(".tmp") and rel.name.startswith("."):
        return "temporary"
    if len(rel.parts) == 1:
        return "workload" if rel.suffix == ".npz" else "other"
    kinds = {
        "bvh": "bvh",
        "front": "front",
        "meshes": "mesh",
        "rays": "ray file",
        "kernel_files": "kernel file",
        "kernel_builds": "kernel build",
    }
    return kinds.get(rel.parts[0], "other")


def _bvh_problem(path: Path) -> str | None:
    from .. import ext
    from .bvh_cache import BVH_FORMAT
    from .cache import read_sealed

    identity = read_sealed(path, arrays=False)[0].get("identity")
    current = {"format": BVH_FORMAT, "build_version": ext.BVH_BUILD_VERSION, "extension_sha256": ext.extension_sha256()}
    if not isinstance(identity, dict) or any(identity.get(k) != v for k, v in current.items()):
        return "made by another build of the extension"
    return None


def _front_problem(path: Path) -> str | None:
    from .cache import read_sealed
    from .front import FRONT_VERSION

    if read_sealed(path, arrays=False)[0].get("front_version") != FRONT_VERSION:
        return "made by another version of the front-face reference"
    return None


def _temporary_problem(path: Path) -> str | None:
    """A temporary file is in use while the process named in it (``.NAME.PID.TOKEN.tmp``) runs."""
    parts = path.name.split(".")
    try:
        os.kill(int(parts[-3]), 0)
    except (ValueError, IndexError, ProcessLookupError):
        return "left by a write that never finished"
    except PermissionError:  # another user's running process
        pass
    return None


def _mesh_problem(path: Path) -> str | None:
    from .spec import file_sha256

    return None if file_sha256(path) == path.stem else "its content does not match its name"


def _problem(kind: str, path: Path, workload_problems: dict[Path, str]) -> str | None:
    from .cache import Invalid

    checks = {"bvh": _bvh_problem, "front": _front_problem, "temporary": _temporary_problem, "mesh": _mesh_problem}
    if kind == "workload":
        return workload_problems.get(path)
    if kind not in checks:
        return None
    try:
        return checks[kind](path)
    except Invalid as e:
        return str(e)


def entries() -> list[Entry]:
    """Every file under the cache folder by path (a folder or link in a cache file's place: a problem, not followed)."""
    from .cache import list_cached

    root = cache_dir()
    if not root.is_dir():
        return []
    workload_problems = {e.path: e.problem for e in list_cached() if e.problem}
    out = []
    for dirpath, dirnames, filenames in os.walk(root):
        folder = Path(dirpath)
        for name in sorted(filenames + [d for d in dirnames if d.endswith(".npz")]):
            path = folder / name
            try:
                st = os.lstat(path)
            except OSError:  # removed meanwhile
                continue
            kind = _kind(path.relative_to(root))
            if stat.S_ISLNK(st.st_mode) or stat.S_ISDIR(st.st_mode):
                what = "a link" if stat.S_ISLNK(st.st_mode) else "a folder"
                out.append(Entry(kind, path, 0, st.st_mtime, f"{what} in place of a cache file"))
                continue
            used = max(st.st_atime, st.st_mtime)
            out.append(Entry(kind, path, st.st_size, used, _problem(kind, path, workload_problems)))
        dirnames[:] = sorted(d for d in dirnames if not d.endswith(".npz"))
    return sorted(out, key=lambda e: str(e.path))


def prune(max_bytes: int | None = None, dry_run: bool = False) -> Pruned:
    """Remove every cache file no installed build can use; then, while the rest is over ``max_bytes``, the
    workloads, BVH trees and front-face references used longest ago. Never removed by the bound: mesh copies
    (one may be the only copy of a mesh), files tribench did not write, folders. A link in a cache file's
    place is removed, not what it points at."""
    found = entries()
    folder = [e for e in found if e.path.is_dir() and not e.path.is_symlink()]  # a user's, perhaps: kept
    doomed = [e for e in found if e.problem is not None and e.kind != "other" and e not in folder]
    kept = [e for e in found if e not in doomed]
    total = sum(e.size_bytes for e in kept)
    if max_bytes is not None:
        for e in sorted((e for e in kept if e.kind in REGENERABLE), key=lambda e: e.used):
            if total <= max_bytes:
                break
            doomed.append(e)
            total -= e.size_bytes
    removed = []
    for e in doomed:
        try:
            if not dry_run:
                e.path.unlink()
        except FileNotFoundError:
            continue
        except OSError as exc:
            raise UserError(f"cannot remove {e.path}: {exc.strerror or exc}") from None
        removed.append(e)
    return Pruned(removed, total)
