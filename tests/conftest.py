"""Shared test data: ray-triangle pairs at a safe margin from every decision boundary."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from tribench.workloads import reference

# Barycentric margin from every edge, and the smallest |cos| between a ray and
# the triangle's normal: far enough from every boundary that float32 and the
# seed's epsilons cannot flip an answer.
MARGIN = 0.05
MIN_COS = 0.2


#: The installed command, beside this interpreter.
TRIBENCH = Path(sys.executable).parent / "tribench"


def run_tribench(*args, cwd, cache, timeout: float = 1200) -> subprocess.CompletedProcess:
    """The installed ``tribench ARGS`` in ``cwd``, with its own cache (``TRIBENCH_CACHE``), output captured."""
    env = {**os.environ, "TRIBENCH_CACHE": str(cache)}
    return subprocess.run(
        [TRIBENCH, *map(str, args)], capture_output=True, text=True, timeout=timeout, cwd=cwd, env=env
    )


def analysed(run_dir, baseline=None, margin=None, quick: bool = False):
    """What ``tribench sweep`` does after its last batch: the robustness suite (``quick``: at its quick
    sizes) where the folder lacks it, then every derived table; the tables made."""
    from tribench.harness.jobs.sweep import measure_robustness
    from tribench.reports import tables

    note = measure_robustness(run_dir, quick=quick)
    return tables.write_all(run_dir, baseline=baseline, margin=margin, validate_note=note)


def safe_pairs(n: int, seed: int, hit_rate: float = 0.5):
    """n (origin, direction, triangle) float64 pairs; about hit_rate of them hit.

    Hits aim at a point inside the triangle, misses at a point outside one
    edge, each at least MARGIN (barycentric) from any edge; t in [0.5, 4].
    """
    rng = np.random.default_rng(seed)
    tris = rng.normal(size=(4 * n, 3, 3))
    normal = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
    area2 = np.linalg.norm(normal, axis=1)
    tris, normal, area2 = tris[area2 > 0.5][:n], normal[area2 > 0.5][:n], area2[area2 > 0.5][:n]
    assert len(tris) == n
    hits = rng.random(n) < hit_rate
    bary = rng.dirichlet([2, 2, 2], n) * (1 - 3 * MARGIN) + MARGIN  # all >= MARGIN
    # a miss: push the point outside one edge by at least MARGIN
    out = rng.integers(0, 3, n)
    push = rng.uniform(MARGIN, 1.0, n)
    miss_bary = bary.copy()
    miss_bary[np.arange(n), out] = -push
    rest = 1 + push
    for k in range(3):
        others = out != k
        miss_bary[others, k] = rest[others] * bary[others, k] / (1 - bary[np.arange(n), out])[others]
    b = np.where(hits[:, None], bary, miss_bary)
    target = np.einsum("nk,nkj->nj", b, tris)
    # directions within MIN_COS of the normal's line, random side
    unit_n = normal / area2[:, None]
    tangent = rng.normal(size=(n, 3))
    tangent -= np.einsum("nj,nj->n", tangent, unit_n)[:, None] * unit_n
    tangent /= np.linalg.norm(tangent, axis=1)[:, None]
    cos = rng.uniform(MIN_COS, 1.0, n) * rng.choice([-1, 1], n)
    d = cos[:, None] * unit_n + np.sqrt(1 - cos**2)[:, None] * tangent
    t = rng.uniform(0.5, 4.0, n)
    o = target - t[:, None] * d
    return o, d, tris


def as_dtype(arrays, dtype):
    return tuple(np.ascontiguousarray(a, dtype=dtype) for a in arrays)


def reference_answers(o, d, tris, front_only: bool = False):
    """Reference on the arrays as the kernel sees them (after any rounding)."""
    return reference.intersect_pairs(
        o.astype(np.float64), d.astype(np.float64), tris.astype(np.float64), front_only=front_only
    )


def run_pairs(kernel, o, d, tris, **options):
    """(hit, t) of ray i against triangle i for any kernel: a wide kernel,
    which has no pairs mode, answers each pair as a one-triangle closest call."""
    from tribench import ext

    if "pairs" in ext.kernel_info(kernel).modes:
        return ext.intersect_pairs(kernel, o, d, tris, **options)
    answers = [
        ext.intersect(kernel, o[i : i + 1], d[i : i + 1], tris[i : i + 1], "closest", **options) for i in range(len(o))
    ]
    return np.array([a.index[0] >= 0 for a in answers]), np.array([a.t[0] for a in answers])


def pytest_collection_modifyitems(config, items):
    """Mark ``matrix`` every case that runs a kernel on an ISA other than the one it chooses on this CPU.

    The default run (the README's command) then tests each kernel on the ISA it runs on; the whole
    kernel x ISA x precision matrix runs under ``-m matrix`` (``.ci/run`` runs it too).
    """
    from tribench import ext

    known = set(ext.kernel_names(internal=True))
    for item in items:
        params = getattr(getattr(item, "callspec", None), "params", {})
        kernel, isa = params.get("kernel"), params.get("isa")
        if isinstance(kernel, str) and kernel in known and isinstance(isa, str):
            info = ext.kernel_info(kernel)
            if isa in info.isas and isa != info.isa:
                item.add_marker(pytest.mark.matrix)
