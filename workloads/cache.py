"""The workload cache: one ``.npz`` file per workload, named by its id.

Directory: ``$TRIBENCH_CACHE``, default ``~/.cache/tribench/workloads``.

A file holds the arrays and one JSON member, ``meta``: the cache format, the
workload id, the spec, its identity (spec + generator version + mesh file
hash), the achieved figures and the sha256 of the arrays. On load all of them
are checked; a file that fails to open or parse, or whose identity, version or
checksum does not match, is rebuilt with a :class:`CacheWarning` -- never
used. Files are written to a temporary name in the same directory and renamed
(``os.replace``), so an interrupted write never leaves half a file under a
workload's name.
"""

from __future__ import annotations

import json
import os
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from tribench.common import UserError, atomic_write

from .spec import (
    MeshSpec,
    PairSpec,
    Spec,
    canonical_json,
    identity,
    spec_from_dict,
    workload_id,
)
from .workload import Workload, arrays_sha256

__all__ = [
    "CACHE_FORMAT",
    "CacheWarning",
    "CachedWorkload",
    "cache_dir",
    "generate",
    "make",
    "load",
    "list_cached",
    "resolve_id",
]

CACHE_FORMAT = 1


class CacheWarning(UserWarning):
    """A cache file was invalid and has been rebuilt."""


class _Invalid(Exception):
    """Why a cache file cannot be used (internal)."""


@dataclass(frozen=True)
class CachedWorkload:
    """One file of the cache, as listed (only its ``meta`` member is read).

    ``problem`` is None for a file that looks usable, else why it is not.
    """

    workload_id: str
    path: Path
    size_bytes: int
    spec: dict[str, Any] | None
    achieved: dict[str, Any] | None
    problem: str | None


def cache_dir() -> Path:
    """The cache directory (not created here)."""
    return Path(os.environ.get("TRIBENCH_CACHE") or "~/.cache/tribench/workloads").expanduser()


def _path(wid: str) -> Path:
    return cache_dir() / f"{wid}.npz"


def generate(spec: Spec) -> Workload:
    """Build the workload of ``spec`` without touching the cache."""
    wid = workload_id(spec)
    if isinstance(spec, PairSpec):
        from .pairs import generate_pairs

        return generate_pairs(spec, wid)
    if spec.kind == "seed":
        from .seed_workload import generate_seed_workload  # lazy: traces a scene on use

        return generate_seed_workload(spec, wid)
    from .rays import generate_mesh_workload  # lazy: pulls in trimesh on use

    return generate_mesh_workload(spec, wid)


def _write(w: Workload, path: Path) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    arrays = w.arrays()
    meta = {
        "format": CACHE_FORMAT,
        "workload_id": w.workload_id,
        "version": w.spec.version,
        "spec": w.spec.to_dict(),
        "identity": identity(w.spec),
        "achieved": w.achieved,
        "arrays": sorted(arrays),
        "checksum": arrays_sha256(arrays),
    }
    with atomic_write(path, "wb") as f:  # the usual permissions; a failed write leaves no file
        np.savez(f, meta=np.array(json.dumps(meta)), **arrays)


def _read_meta(npz) -> dict[str, Any]:
    try:
        meta = json.loads(str(npz["meta"][()]))
    except Exception as e:
        raise _Invalid(f"unreadable metadata ({type(e).__name__})") from None
    if not isinstance(meta, dict) or meta.get("format") != CACHE_FORMAT:
        raise _Invalid("unknown cache format")
    return meta


def _read(path: Path, spec: Spec | None) -> Workload:
    """The workload in ``path``, checked against ``spec`` (or against its own stored spec)."""
    try:
        return _read_checked(path, spec)
    except _Invalid:
        raise
    except Exception as e:  # truncated, garbage, not a zip, missing members, malformed JSON...
        raise _Invalid(f"{type(e).__name__}: {e}") from None


def _read_checked(path: Path, spec: Spec | None) -> Workload:
    with open(path, "rb") as f, np.load(f, allow_pickle=False) as npz:
        meta = _read_meta(npz)
        if spec is None:
            spec = spec_from_dict(meta["spec"])
        if meta.get("version") != spec.version:
            raise _Invalid(f"generator version {meta.get('version')} != {spec.version}")
        if canonical_json(meta.get("identity")) != canonical_json(identity(spec)):
            raise _Invalid("spec does not match")
        if meta.get("workload_id") != path.stem or path.stem != workload_id(spec):
            raise _Invalid("workload id does not match")
        arrays = {name: npz[name] for name in meta["arrays"]}
    if arrays_sha256(arrays) != meta.get("checksum"):
        raise _Invalid("checksum does not match")
    return Workload(workload_id=path.stem, spec=spec, achieved=meta["achieved"], **arrays)


def _build(spec: Spec, path: Path, invalid: _Invalid | None = None) -> Workload:
    if invalid is not None:
        warnings.warn(f"cache file {path} is invalid ({invalid}); rebuilding it", CacheWarning, stacklevel=3)
    w = generate(spec)
    _write(w, path)
    return w


def make(spec: Spec) -> Workload:
    """The workload of ``spec``: from the cache if a valid file is there, else built and cached.

    An invalid file under the spec's id is rebuilt with a :class:`CacheWarning`.
    """
    path = _path(workload_id(spec))
    if not path.exists():
        return _build(spec, path)
    try:
        return _read(path, spec)
    except _Invalid as e:
        return _build(spec, path, e)


def load(wid: str) -> Workload:
    """A cached workload by id (rebuilt from its stored spec if the file is invalid).

    Raises
    ------
    FileNotFoundError
        No such workload in the cache.
    ValueError
        The file is invalid and its spec cannot be read back to rebuild it.
    """
    path = _path(wid)
    if not path.is_file():
        raise FileNotFoundError(f"no cached workload {wid!r} in {cache_dir()} (see `tribench workloads list`)")
    try:
        return _read(path, None)
    except _Invalid as e:
        invalid = e
    spec = _stored_spec(path)
    if spec is None or workload_id(spec) != wid:
        raise UserError(
            f"cache file {path} is invalid ({invalid}) and holds no spec that still gives this id "
            f"(a mesh file changed or moved?): make the workload again"
        )
    return _build(spec, path, invalid)


def _stored_spec(path: Path) -> Spec | None:
    try:
        with open(path, "rb") as f, np.load(f, allow_pickle=False) as npz:
            return spec_from_dict(_read_meta(npz)["spec"])
    except Exception:
        return None


def resolve_id(prefix: str) -> str:
    """The one cached workload id that starts with ``prefix`` (like a short git hash).

    Raises
    ------
    FileNotFoundError
        None matches.
    ValueError
        Several match.
    """
    if _path(prefix).is_file():
        return prefix
    ids = sorted(p.stem for p in cache_dir().glob(f"{prefix}*.npz"))
    if not ids:
        raise FileNotFoundError(f"no cached workload {prefix!r} in {cache_dir()} (see `tribench workloads list`)")
    if len(ids) > 1:
        raise UserError(f"{prefix!r} matches several workloads: {', '.join(ids)}")
    return ids[0]


def list_cached() -> list[CachedWorkload]:
    """Every ``.npz`` file of the cache, sorted by id, with its spec and achieved figures."""
    out = []
    for path in sorted(cache_dir().glob("*.npz")):
        spec = achieved = problem = None
        try:
            with open(path, "rb") as f, np.load(f, allow_pickle=False) as npz:
                meta = _read_meta(npz)
            spec, achieved = meta.get("spec"), meta.get("achieved")
            kind = (spec or {}).get("kind")
            cls = {"pairs": PairSpec, "mesh": MeshSpec}.get(kind)
            if kind == "seed":
                from .seed_workload import SeedSpec as cls
            if cls is None:
                problem = "unknown kind"
            elif meta.get("version") != cls.version:
                problem = f"stale: generator version {meta.get('version')}, current {cls.version}"
        except _Invalid as e:
            problem = str(e)
        except Exception as e:
            problem = f"cannot open ({type(e).__name__})"
        out.append(CachedWorkload(path.stem, path, path.stat().st_size, spec, achieved, problem))
    return out
