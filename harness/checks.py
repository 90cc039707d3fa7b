"""A kernel's answers against the float64 reference: once per workload before its batches, and every
batch's checksum against ``loops`` times the verified one-pass checksum."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from .. import ext
from ..workloads import reference
from ..workloads.front import front_reference

__all__ = [
    "T_SUM_RTOL",
    "Checksum",
    "KernelCheckError",
    "check_batch",
    "one_pass_checksum",
]

#: Relative tolerance on sums of t, by precision: a kernel's own sum against
#: the reference's (on the rays both hit), and a batch's sum against
#: ``loops`` times the one-pass sum (only summation order differs there).
T_SUM_RTOL = {"float32": 1e-4, "float64": 1e-9}


class KernelCheckError(Exception):
    """A kernel gave answers that disagree with the reference."""


@dataclass(frozen=True)
class Checksum:
    """A kernel's one-pass checksum on a workload: hits, the sum of t, the sum of u + v (``closest_uv``, else 0)."""

    hits: int
    t_sum: float
    uv_sum: float = 0.0


def one_pass_checksum(kernel: str, workload: Any, bvh: ext.BVH | None = None) -> tuple[Checksum, dict[str, int]]:
    """Check ``kernel``'s per-ray answers on ``workload``; return its checksum and the counts of disagreements.

    Answers must equal the reference's outside ``workload.ambiguous()``, the sum of t (and u + v) within
    :data:`T_SUM_RTOL` where both hit; an any-hit answer may be any hit triangle, so its t is checked against that
    triangle's. A culling kernel is held to the front-face reference; with ``bvh`` the answers are the BVH's. Raises
    KernelCheckError naming the first ray that differs, but for the seed's replays: faithful copies of code with known
    flaws (a small triangle vanishes for ``moller_seed``), which is what the seed experiment is about, so checks.csv
    records their differences rather than the sweep stopping."""
    w = workload
    if bvh is None:
        r = ext.intersect(kernel, w.origins, w.directions, w.triangles, w.mode, t_max=w.t_max)
    else:
        r = bvh.intersect(w.origins, w.directions, w.mode, t_max=w.t_max).hits
    hit, t = r.hit, r.t
    ref_index, ref_t = (w.ref_index, w.ref_t) if w.mode != "pairs" else (None, w.ref_t)
    ref_hits = w.hits
    if ext.kernel_info(kernel).culls_back_faces:
        if w.mode == "pairs":
            ref_hits = reference.intersect_pairs(
                w.origins, w.directions, w.triangles, t_max=w.t_max, front_only=True
            ).hit
        else:  # computed once per workload and kept in the cache: every process checks against it
            ref_index, ref_t = front_reference(w)
            ref_hits = ref_index >= 0
    differs = hit != ref_hits if w.mode in ("pairs", "any") else r.index != ref_index
    ambiguous = w.ambiguous()
    wrong = differs & ~ambiguous
    counts = {
        "rays": len(differs),
        "ambiguous_rays": int(ambiguous.sum()),
        "disagreements": int(differs.sum()),
        "ambiguous_disagreements": int((differs & ambiguous).sum()),
    }
    where = f"kernel {kernel!r} on workload {w.workload_id} ({w.spec.summary()})"
    if wrong.any() and not ext.kernel_info(kernel).seed_replay:
        first = int(np.argmax(wrong))
        raise KernelCheckError(
            f"{where}: {int(wrong.sum())} of {len(wrong)} rays differ from the reference "
            f"outside the ambiguous ones (first: ray {first})"
        )
    agree = hit & ref_hits & ~differs
    own = {"t": t[agree], "u + v": r.u[agree] + r.v[agree]}
    if w.mode in ("any", "closest_uv"):
        # the reference on the triangle each ray's answer names
        tri = w.triangles[r.index[agree]]
        ref_pairs = reference.intersect_pairs(w.origins[agree], w.directions[agree], tri)
        ref = {"t": ref_pairs.t, "u + v": ref_pairs.u + ref_pairs.v}
    else:
        ref = {"t": ref_t[agree]}
    for name in ref if w.mode != "any" else ("t",):
        a, b = math.fsum(own[name].astype(float).tolist()), math.fsum(ref[name].tolist())
        if not math.isclose(a, b, rel_tol=T_SUM_RTOL[w.spec.dtype], abs_tol=1e-300):
            raise KernelCheckError(f"{where}: sum of {name} {a!r} differs from the reference's {b!r}")
    uv_sum = math.fsum((r.u[hit].astype(float) + r.v[hit]).tolist()) if w.mode == "closest_uv" else 0.0
    return Checksum(int(hit.sum()), math.fsum(t[hit].astype(float).tolist()), uv_sum), counts


def check_batch(batch: ext.Batch, expected: Checksum, kernel: str, workload: Any) -> None:
    """Raise :class:`KernelCheckError` unless ``batch`` is ``loops`` one-pass checksums."""
    hits, t_sum, uv_sum = (batch.loops * x for x in (expected.hits, expected.t_sum, expected.uv_sum))

    def close(a: float, b: float) -> bool:
        return math.isclose(a, b, rel_tol=T_SUM_RTOL["float64"], abs_tol=1e-300)

    problem = (
        f"{batch.hits} hits in {batch.loops} loops, expected {hits}"
        if batch.hits != hits
        else f"sum of t {batch.t_sum!r}, expected {t_sum!r}"
        if not close(batch.t_sum, t_sum)
        else f"sum of u + v {batch.uv_sum!r}, expected {uv_sum!r}"
        if not close(batch.uv_sum, uv_sum)
        else None
    )
    if problem:  # the message (and the spec's summary) only when it fails: this runs every batch
        raise KernelCheckError(
            f"kernel {kernel!r} on workload {workload.workload_id} "
            f"({workload.spec.summary()}): checksum failed, {problem}"
        )
