"""The workload cache: one ``.npz`` file per workload, named by its id, under ``$TRIBENCH_CACHE``.

A file holds the arrays and a JSON ``meta`` member; its zip comment seals everything before it (its sha256), so
any change is detected. A file that fails the seal or whose format, identity, version or id does not match is
never used: :func:`make` and :func:`load` rebuild it with a :class:`CacheWarning`, :func:`list_cached` marks it."""

from __future__ import annotations

import hashlib
import io
import json
import os
import stat
import warnings
import zipfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TypeVar

import numpy as np

from ..common import Notice, UserError, write_bytes
from ..common.location import cache_dir
from .kinds import generate, spec_from_dict
from .spec import (
    MeshSpec,
    Spec,
    canonical_json,
    identity,
    workload_id,
)
from .workload import Workload

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

# 2: the whole file sealed by a sha256 in the zip comment (1 checked the arrays only); 3: every
# workload stores ref_edge_clearance (the same specs, ids and answers: older files are rebuilt)
CACHE_FORMAT = 3
_SEAL_PREFIX = b"tribench-sha256:"
_SEAL_LEN = len(_SEAL_PREFIX) + 64
T = TypeVar("T")


class CacheWarning(Notice):
    """A cache file was invalid and has been rebuilt."""


class Invalid(Exception):
    """Why a cache file cannot be used (internal to the caches: never reaches a caller)."""


@dataclass(frozen=True)
class CachedWorkload:
    """One file of the cache as listed (only its ``meta`` is read); ``problem`` is why it cannot be used, or None."""

    workload_id: str
    path: Path
    size_bytes: int
    spec: dict[str, Any] | None
    achieved: dict[str, Any] | None
    problem: str | None


def _path(wid: str) -> Path:
    return cache_dir() / f"{wid}.npz"


def not_a_file(path: Path) -> str | None:
    """Why ``path`` cannot be a cache file (a folder, a link, a device in its place), or None if it is a
    regular file or nothing (a link is never followed: it could point anywhere)."""
    try:
        mode = os.lstat(path).st_mode
    except (FileNotFoundError, NotADirectoryError):  # nothing there (a file in a folder's place fails the write)
        return None
    except OSError as e:
        return f"cannot be read ({e.strerror or e})"
    if stat.S_ISREG(mode):
        return None
    what = "a link" if stat.S_ISLNK(mode) else "a folder" if stat.S_ISDIR(mode) else "not a regular file"
    return f"is {what}, not a cache file (remove it to cache it again)"


def _seal(body: bytes) -> bytes:
    return _SEAL_PREFIX + hashlib.sha256(body).hexdigest().encode()


def _encode(w: Workload) -> bytes:
    arrays = w.arrays()
    meta = {
        "format": CACHE_FORMAT,
        "workload_id": w.workload_id,
        "version": w.spec.version,
        "spec": w.spec.to_dict(),
        "identity": identity(w.spec),
        "achieved": w.achieved,
        "arrays": sorted(arrays),
    }
    return sealed_npz(meta, arrays)


def sealed_npz(meta: dict[str, Any], arrays: dict[str, np.ndarray]) -> bytes:
    """An ``.npz`` of ``arrays`` and ``meta`` (as JSON), sealed by the sha256 in its zip comment."""
    buf = io.BytesIO()
    np.savez(buf, meta=np.array(json.dumps(meta)), **arrays)  # type: ignore[arg-type]  # numpy's stub takes **arrays for allow_pickle
    with zipfile.ZipFile(buf, "a") as z:
        z.comment = bytes(_SEAL_LEN)  # room for the seal: the comment is the file's last bytes
    body = buf.getvalue()[:-_SEAL_LEN]
    return body + _seal(body)


def read_sealed(path: Path, arrays: bool = True) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """The ``meta`` and (if ``arrays``) the arrays of a file :func:`sealed_npz` made, if its seal matches them
    (else :class:`Invalid`). Only a regular file is read: a link, folder or pipe in its place is never opened."""
    if not stat.S_ISREG(os.lstat(path).st_mode):
        raise Invalid("not a regular file (a link, folder or pipe in a cache file's place)")
    data = path.read_bytes()
    if len(data) <= _SEAL_LEN or data[-_SEAL_LEN:] != _seal(data[:-_SEAL_LEN]):
        raise Invalid(
            "its checksum does not match: the file was changed, cut or not written by this version of tribench"
        )
    try:
        with np.load(io.BytesIO(data), allow_pickle=False) as npz:
            meta = json.loads(str(npz["meta"][()]))
            found = {name: npz[name] for name in npz.files if name != "meta"} if arrays else {}
    except Exception as e:  # garbage under a valid seal
        raise Invalid(f"unreadable metadata ({type(e).__name__})") from None
    if not isinstance(meta, dict):
        raise Invalid("unreadable metadata")
    return meta, found


def _claimed_meta(path: Path) -> dict[str, Any]:
    """The ``meta`` a file claims, its seal unchecked ({} if unreadable)."""
    try:
        with open(path, "rb") as f, np.load(f, allow_pickle=False) as npz:
            meta = json.loads(str(npz["meta"][()]))
    except Exception:
        return {}
    return meta if isinstance(meta, dict) else {}


def _check_meta(meta: dict[str, Any]) -> None:
    if meta.get("format") != CACHE_FORMAT:
        old = isinstance(meta.get("format"), int) and 0 < meta["format"] < CACHE_FORMAT
        raise Invalid(
            f"stale: cache format {meta['format']}, current {CACHE_FORMAT}" if old else "unknown cache format"
        )
    for key, kind in (("spec", dict), ("identity", dict), ("achieved", dict), ("arrays", list)):
        if not isinstance(meta.get(key), kind):
            raise Invalid(f"metadata key {key!r} is missing or not a {kind.__name__}")


def _read(path: Path, spec: Spec | None) -> Workload:
    """The workload in ``path``, checked against ``spec`` (or against its own stored spec)."""
    meta, arrays = read_sealed(path)
    _check_meta(meta)
    try:
        if spec is None:
            spec = spec_from_dict(meta["spec"])
        if meta.get("version") != spec.version:
            raise Invalid(f"stale: generator version {meta.get('version')}, current {spec.version}")
        if canonical_json(meta["identity"]) != canonical_json(identity(spec)):
            raise Invalid("spec does not match")
        if spec_from_dict(meta["spec"]) != spec:  # as a spec: a file before #52 spells the RNG seed "seed"
            raise Invalid("stored spec does not match")
        if meta.get("workload_id") != path.stem or path.stem != workload_id(spec):
            raise Invalid("workload id does not match")
        if sorted(arrays) != sorted(meta["arrays"]):
            raise Invalid("arrays do not match the metadata")
        return Workload(workload_id=path.stem, spec=spec, achieved=meta["achieved"], **arrays)
    except Invalid:
        raise
    except Exception as e:  # garbage under a valid seal, a spec this version cannot rebuild...
        raise Invalid(f"{type(e).__name__}: {e}") from None


def through_cache(
    path: Path, what: str, read: Callable[[], T], compute: Callable[[], T], encode: Callable[[T], bytes]
) -> T:
    """``read()`` the cache file ``path``, else ``compute()`` the value and write ``encode(value)`` there. The
    cache never stops anything: a file that is invalid (``read`` raised :class:`Invalid`: rebuilt), in the way
    (never followed nor replaced) or unwritable is a :class:`CacheWarning`, ``what`` then kept in memory."""
    in_the_way = not_a_file(path)
    if in_the_way:
        warnings.warn(f"cache file {path} {in_the_way}: the {what} is kept in memory", CacheWarning, stacklevel=3)
    elif path.exists():
        try:
            return read()
        except Invalid as e:
            warnings.warn(f"cache file {path} is invalid ({e}); rebuilding it", CacheWarning, stacklevel=3)
    value = compute()
    if not in_the_way:
        try:
            write_bytes(path, encode(value))
        except UserError as e:  # a cache that cannot be written stops nothing (docs/input.md)
            warnings.warn(f"{e}: the {what} is kept in memory", CacheWarning, stacklevel=3)
    return value


def _generate(spec: Spec) -> Workload:
    """``generate(spec)``, but a BVH workload takes its brute-force twin's arrays and figures from the cache (made
    there if missing): the same rays and answers, under its own spec and id, without computing them again."""
    if isinstance(spec, MeshSpec) and spec.accel != "brute":
        twin = make(spec.brute_twin())
        return Workload(workload_id=workload_id(spec), spec=spec, achieved=twin.achieved, **twin.arrays())
    return generate(spec)


def make(spec: Spec) -> Workload:
    """The workload of ``spec``: cached if valid, else built and cached (an invalid file: a :class:`CacheWarning`)."""
    path = _path(workload_id(spec))
    return through_cache(path, "workload", lambda: _read(path, spec), lambda: _generate(spec), _encode)


def cached(spec: Spec) -> bool:
    """Whether a file is cached under ``spec``'s id (valid or not: :func:`make` checks)."""
    return _path(workload_id(spec)).exists()


def load(wid: str) -> Workload:
    """A cached workload by id, rebuilt from its stored spec if the file is invalid; ``FileNotFoundError`` if
    there is none, ``ValueError`` if it is invalid and its spec cannot be read back."""
    path = _path(wid)
    if not path.is_file():
        raise FileNotFoundError(f"no cached workload {wid!r} in {cache_dir()} (see `tribench workloads list`)")
    try:
        return _read(path, None)
    except Invalid as e:
        invalid = e
    try:  # the spec of an invalid file, used only when it hashes to the file's own id
        spec = spec_from_dict(_claimed_meta(path)["spec"])
    except Exception:
        spec = None
    if spec is None or workload_id(spec) != wid:
        raise UserError(
            f"cache file {path} is invalid ({invalid}) and holds no spec that still gives this id "
            f"(a mesh file changed or moved?): make the workload again"
        )
    return make(spec)


def resolve_id(prefix: str) -> str:
    """The one cached id starting with ``prefix``; ``FileNotFoundError`` if none does, ``ValueError`` if several do."""
    if not prefix or not all(c.isalnum() or c in "-_" for c in prefix):  # an id, never a path or a pattern
        raise UserError(f"{prefix!r:.80} is not a workload id (see `tribench workloads list`)")
    if _path(prefix).is_file():
        return prefix
    ids = sorted(p.stem for p in cache_dir().glob("*.npz") if p.stem.startswith(prefix))
    if not ids:
        raise FileNotFoundError(f"no cached workload {prefix!r} in {cache_dir()} (see `tribench workloads list`)")
    if len(ids) > 1:
        raise UserError(f"{prefix!r} matches several workloads: {', '.join(ids)}")
    return ids[0]


def list_cached() -> list[CachedWorkload]:
    """Every ``.npz`` file of the cache, sorted by id, checked as :func:`load` checks it; ``problem`` says why one
    cannot be used (its spec and figures are then those it claims, None if unreadable)."""
    out = []
    for path in sorted(cache_dir().glob("*.npz")):
        spec = achieved = problem = None
        try:
            st = os.lstat(path)
        except OSError:  # removed meanwhile
            continue
        try:
            w = _read(path, None)
            spec, achieved = w.spec.to_dict(), dict(w.achieved)
        except Invalid as e:
            problem = str(e)
            claimed = _claimed_meta(path) if stat.S_ISREG(st.st_mode) else {}  # a pipe would block, a link lead out
            spec, achieved = claimed.get("spec"), claimed.get("achieved")
        out.append(
            CachedWorkload(
                path.stem,
                path,
                st.st_size,
                spec if isinstance(spec, dict) else None,
                achieved if isinstance(achieved, dict) else None,
                problem,
            )
        )
    return out
