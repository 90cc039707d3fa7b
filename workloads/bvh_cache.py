"""The BVH cache: a kernel's BVH over a mesh's triangles, built once per machine, not once per process.

``bvh/bvh-<16 hex>.npz`` is named by the sha256 of :func:`bvh_identity` and sealed as workload files are; a file
that fails the seal, names another identity or that :func:`tribench.ext.adopt_bvh` refuses is rebuilt with a
:class:`~tribench.workloads.cache.CacheWarning`."""

from __future__ import annotations

import hashlib
import time
from pathlib import Path
from typing import Any

import numpy as np

from .. import ext
from ..common import UserError
from .cache import Invalid, cache_dir, read_sealed, sealed_npz, through_cache
from .spec import canonical_json

__all__ = ["BVH_FORMAT", "bvh_identity", "bvh_path", "cached_bvh"]

#: Layout of a BVH cache file: bump when its members or their meaning change.
BVH_FORMAT = 1
_ARRAYS = ("nodes", "perm", "records")


def bvh_identity(kernel: str, triangles: np.ndarray, max_leaf: int) -> dict[str, Any]:
    """What names the BVH of ``kernel`` over ``triangles`` with leaves of at most ``max_leaf``."""
    tris = np.ascontiguousarray(triangles)
    return {
        "format": BVH_FORMAT,
        "build_version": ext.BVH_BUILD_VERSION,
        "extension_sha256": ext.extension_sha256(),
        "kernel": kernel,
        "max_leaf": int(max_leaf),
        "dtype": str(tris.dtype),
        "triangles": len(tris),
        "triangles_sha256": hashlib.sha256(tris.data).hexdigest(),
    }


def bvh_path(identity: dict[str, Any]) -> Path:
    """The cache file of a BVH identity."""
    digest = hashlib.sha256(canonical_json(identity).encode()).hexdigest()
    return cache_dir() / "bvh" / f"bvh-{digest[:16]}.npz"


def cached_bvh(kernel: str, triangles: np.ndarray, max_leaf: int = ext.DEFAULT_MAX_LEAF) -> tuple[ext.BVH, int]:
    """``kernel``'s BVH over ``triangles`` (as :func:`tribench.ext.build_bvh` makes it), from the cache if a sound
    file is there, else built and cached; and its build's time in ns, by whichever process built it."""
    if kernel not in ext.bvh_kernel_names():  # before hashing anything
        raise UserError(f"{kernel} cannot be a BVH's leaf test; these can: {', '.join(ext.bvh_kernel_names())}")
    identity = bvh_identity(kernel, triangles, max_leaf)

    def build() -> tuple[ext.BVH, int]:
        t0 = time.perf_counter_ns()
        bvh = ext.build_bvh(kernel, triangles, max_leaf=max_leaf)
        return bvh, time.perf_counter_ns() - t0

    def encode(built: tuple[ext.BVH, int]) -> bytes:
        bvh, build_ns = built
        arrays = {"nodes": bvh.nodes, "perm": bvh.perm, "records": bvh.prepared.records}
        return sealed_npz({"identity": identity, "build_ns": build_ns}, arrays)

    path = bvh_path(identity)
    return through_cache(path, "BVH", lambda: _read(path, identity, triangles), build, encode)


def _read(path: Path, identity: dict[str, Any], triangles: np.ndarray) -> tuple[ext.BVH, int]:
    meta, arrays = read_sealed(path)
    if sorted(arrays) != sorted(_ARRAYS):
        raise Invalid("its arrays are not nodes, perm and records")
    if canonical_json(meta.get("identity")) != canonical_json(identity):
        raise Invalid("stale: made by another version of the build, format or extension, or for other triangles")
    build_ns = meta.get("build_ns")
    if isinstance(build_ns, bool) or not isinstance(build_ns, int) or build_ns < 0:
        raise Invalid("metadata key 'build_ns' is not a count of nanoseconds")
    try:
        bvh = ext.adopt_bvh(identity["kernel"], triangles, max_leaf=identity["max_leaf"], **arrays)
    except UserError as e:
        raise Invalid(str(e)) from None
    return bvh, build_ns
