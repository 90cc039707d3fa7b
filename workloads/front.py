"""The front-face reference of a workload, what a kernel that culls back faces must answer, cached beside it
(every worker of a sweep checks its culling kernels) in a sealed file naming :data:`FRONT_VERSION` and the
workload's checksum; a file that fails any of these is recomputed with a
:class:`~tribench.workloads.cache.CacheWarning`."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from . import reference
from .cache import Invalid, cache_dir, read_sealed, sealed_npz, through_cache
from .workload import Workload

__all__ = ["FRONT_VERSION", "compute_front_reference", "front_path", "front_reference"]

#: Bump when the front-face reference is computed differently: older files are then recomputed.
FRONT_VERSION = 1


def compute_front_reference(w: Workload) -> tuple[np.ndarray, np.ndarray]:
    """Index and t of every ray's closest front-face hit (-1 and nan for none), float64, uncached. A two-sided
    hit on a front face stands, a two-sided miss misses; only rays whose closest hit is a back face (few on a
    closed mesh seen from outside) meet a brute-force search, so a million triangles stay cheap."""
    if w.mode == "pairs":
        raise ValueError("a pairs workload has no closest hit: test its pairs with reference.intersect_pairs")
    assert w.ref_index is not None and w.ref_t is not None  # closest and any-hit workloads carry both
    index, t = w.ref_index.copy(), w.ref_t.copy()
    rows = np.flatnonzero(index >= 0)
    t_max = None if w.t_max is None else w.t_max[rows]
    front = reference.intersect_pairs(
        w.origins[rows], w.directions[rows], w.triangles[index[rows]], t_max=t_max, front_only=True
    ).hit
    back = rows[~front]
    if len(back):
        t_max = None if w.t_max is None else w.t_max[back]
        index[back], t[back] = reference.intersect_closest(
            w.origins[back], w.directions[back], w.triangles, t_max=t_max, front_only=True
        )
    return index, t


def front_path(workload_id: str) -> Path:
    """Where the front-face reference of a workload is cached."""
    return cache_dir() / "front" / f"{workload_id}.npz"


def front_reference(w: Workload) -> tuple[np.ndarray, np.ndarray]:
    """:func:`compute_front_reference`, from the cache when a valid file is there, else computed and cached."""
    path = front_path(w.workload_id)

    def encode(reference: tuple[np.ndarray, np.ndarray]) -> bytes:
        return sealed_npz(_meta(w), dict(zip(("index", "t"), reference, strict=True)))

    return through_cache(path, "reference", lambda: _read(path, w), lambda: compute_front_reference(w), encode)


def _meta(w: Workload) -> dict[str, object]:
    return {"front_version": FRONT_VERSION, "workload_id": w.workload_id, "workload_sha256": w.checksum()}


def _read(path: Path, w: Workload) -> tuple[np.ndarray, np.ndarray]:
    meta, arrays = read_sealed(path)
    if meta != _meta(w):
        raise Invalid("made from another workload or by another version")
    index, t = arrays.get("index"), arrays.get("t")
    n = len(w.origins)
    if index is None or t is None or (index.shape, index.dtype, t.shape, t.dtype) != ((n,), np.int64, (n,), np.float64):
        raise Invalid("its arrays do not fit the workload")
    return index, t
