"""The seed's ray stream as a workload: a reproducible sample (:func:`sample_runs`) of one kind of ray from a
scene's render against every triangle, with float64 reference answers; ``achieved`` holds what scales a timing
of the sample back to the render (``stream_tests / sample_tests``). Why and how: docs/methodology.md, "The
seed's replay". Misses are counted at the stage where Curless's early-exit test rejects them.

>>> s = SeedSpec("scene02", "shadow", sample=64, width=16, height=16)
>>> s.mode, s.summary()
('any', 'seed scene02 shadow sample=64 of 16x16 float32 rng_seed=0')
>>> SeedSpec(rays="diffuse")
Traceback (most recent call last):
...
tribench.common.errors.UserError: unknown rays 'diffuse': choose one of primary, reflected, shadow
"""

from __future__ import annotations

import functools
import math
import time
from typing import Any

import numpy as np

from ...common import UserError
from ..reference import all_pairs
from ..spec import MISS_STAGES, RAY_KINDS, SEED_VERSION, SeedSpec  # the spec is defined with the others
from ..workload import AMBIGUOUS_MARGIN, Workload, ambiguous_rays, library_versions
from .scene import Scene, load_scene

__all__ = [
    "EmptyStream",
    "ORIGIN_SHIFT",
    "RAY_KINDS",
    "SEED_VERSION",
    "STREAM_KERNEL",
    "SeedSpec",
    "RUN_LENGTH",
    "generate_seed_workload",
    "sample_runs",
    "stream_indices",
    "stream_trace",
    "trace_forecast",
]

#: Kernel and precision that trace the stream (why: docs/methodology.md, "The seed's replay").
STREAM_KERNEL = ("curless_seed", "float64")
#: Secondary rays start this far along their direction: the seed's 1e-4 on t.
ORIGIN_SHIFT = 1e-4
#: An inside crossing at |t| below this is on the ray's own surface: ambiguous.
T_NEAR_ZERO = 1e-5
#: Two hits within this relative distance in t: either may be the closest.
TIE_RTOL = 1e-4
#: Counts the full shadow stream's tests (scalar: stops at the first hit in index order).
_COUNTING_KERNEL = "moller_trumbore"


class EmptyStream(UserError):
    """The render shoots no ray of the asked kind that tests a triangle (e.g. no reflective material)."""


# ------------------------------------------------------------------ stream


@functools.lru_cache(maxsize=1)  # a 512 x 512 trace holds about 10^6 rays
def _trace(scene: str, sha256: str, width: int, height: int):
    from .trace import trace

    kernel, dtype = STREAM_KERNEL
    return trace(load_scene(scene), kernel, dtype, width, height)


def stream_trace(spec: SeedSpec):
    """The render whose rays ``spec`` samples (memoised: the three kinds of a scene share it)."""
    return _trace(spec.scene, spec.scene_identity()["scene_sha256"], spec.width, spec.height)


#: Sides of the small renders whose times forecast a full one's: a trace's cost is a fixed part plus a
#: part linear in its pixels, so two sizes give both.
FORECAST_SIDES = (32, 64)
#: A trace forecast to take longer than this is refused before it starts.
MAX_TRACE_S = 3600.0


def trace_forecast(spec: SeedSpec) -> float:
    """Seconds the render ``spec`` samples should take to trace, from timed small renders; a UserError past
    :data:`MAX_TRACE_S`."""
    from .trace import trace

    kernel, dtype = STREAM_KERNEL
    scene = load_scene(spec.scene)
    trace(scene, kernel, dtype, 4, 4)  # the first trace of a process pays for imports and first calls
    pixels, seconds = [], []
    for side in FORECAST_SIDES:
        start = time.perf_counter()
        trace(scene, kernel, dtype, side, side)
        pixels.append(side * side)
        seconds.append(time.perf_counter() - start)
    # the slope between the two, or (should noise make it tiny or negative) half the larger one's mean
    per_pixel = max((seconds[1] - seconds[0]) / (pixels[1] - pixels[0]), seconds[1] / pixels[1] / 2)
    forecast = seconds[1] + per_pixel * max(0, spec.width * spec.height - pixels[1])
    if forecast > MAX_TRACE_S:
        raise UserError(
            f"scene {spec.scene_label}: tracing its {spec.width}x{spec.height} render should take about "
            f"{forecast / 60:.0f} minutes, more than the {MAX_TRACE_S / 60:.0f} the seed replay allows "
            "(it traces brute force, as the seed's program does): give a scene with fewer triangles"
        )
    return forecast


def stream_indices(tr, rays: str) -> np.ndarray:
    """Rows of ``tr``'s ``rays`` set that test the triangles, in the seed's shooting order."""
    from .trace import KINDS

    kind, index = tr.seed_order()
    rows = index[kind == KINDS.index(rays)]
    if rays == "shadow":
        rows = rows[tr.shadow.hit_kind[rows] != Scene.SPHERE]  # stopped by a sphere first
    return rows


def _any_hit_tests(o, d, tri) -> np.ndarray:
    """Tests a scalar any-hit kernel runs per ray: up to its first hit in index order."""
    from ... import ext

    index = ext.intersect(_COUNTING_KERNEL, o, d, tri, "any").index
    return np.where(index >= 0, index + 1, len(tri))


# --------------------------------------------------------------- reference


def _reference(o: np.ndarray, d: np.ndarray, tri: np.ndarray, any_hit: bool) -> dict[str, Any]:
    """Closest hits, edge margins and Curless-order miss stages of every ray against every triangle."""
    m, k = len(o), len(tri)
    index = np.full(m, -1, np.int64)
    best = np.full(m, np.nan)
    margin, clearance = np.empty(m), np.empty(m)
    stages = np.zeros(len(MISS_STAGES), np.int64)
    tests = test_hits = ties = on_surface = beyond_light = 0
    for lo, hi, a in all_pairs(o, d, tri, budget=1 << 16):
        n = hi - lo
        hit, t = a.hit.reshape(n, k), a.t.reshape(n, k)
        v, w = a.v.reshape(n, k), a.w.reshape(n, k)
        th = np.where(hit, t, np.inf)
        j = np.argmin(th, axis=1)  # the first of equal minima: ties to the lowest index
        tj = th[np.arange(n), j]
        found = np.isfinite(tj)
        index[lo:hi] = np.where(found, j, -1)
        best[lo:hi] = np.where(found, tj, np.nan)
        # margin as in rays.closest_hits: the nearest brush with an edge among crossings that decide
        edge = np.abs(a.edge_margin.reshape(n, k))
        second = np.partition(th, 1, axis=1)[:, 1] if k > 1 else np.full(n, np.inf)
        with np.errstate(invalid="ignore"):
            decisive = np.isfinite(t) & (t > 0) & (t <= tj[:, None])
            near = np.where(decisive, edge, np.inf).min(axis=1)
            clear = np.where(decisive, np.abs(a.clearance.reshape(n, k)), np.inf).min(axis=1)
            surface = (np.abs(t) < T_NEAR_ZERO) & (a.edge_margin.reshape(n, k) > -AMBIGUOUS_MARGIN)
            tie = found & (second - tj <= TIE_RTOL * tj)
        unsure = surface.any(axis=1) | tie
        near, clear = np.where(unsure, 0.0, near), np.where(unsure, 0.0, clear)
        margin[lo:hi] = np.where(found, near, -near)
        clearance[lo:hi] = np.where(found, clear, -clear)
        ties += int(tie.sum())
        on_surface += int(surface.any(axis=1).sum())
        # the tests a kernel runs: all, or up to the first hit in index order
        ran = np.ones((n, k), bool)
        if any_hit:
            first = np.where(hit.any(axis=1), np.argmax(hit, axis=1), k - 1)
            ran = np.arange(k)[None, :] <= first[:, None]
            beyond_light += int((found & (tj >= 1.0 - ORIGIN_SHIFT)).sum())  # occluded only beyond the light
        tests += int(ran.sum())
        test_hits += int((hit & ran).sum())
        # Curless's order: parallel, t, then the edges v0v1 (v < 0), v1v2 (w < 0), v2v0 (u < 0)
        miss = ran & ~hit
        with np.errstate(invalid="ignore"):
            parallel = miss & ~np.isfinite(t)
            behind = miss & ~parallel & (t <= 0)
            rest = miss & ~parallel & ~behind
            e1 = rest & (v < 0)
            e2 = rest & ~e1 & (w < 0)
            e3 = rest & ~e1 & ~e2  # a finite forward crossing that misses is outside some edge
        for i, mask in enumerate((parallel, behind, e1, e2, e3)):  # MISS_STAGES' first five, in order
            stages[i] += int(mask.sum())
    misses = int(stages.sum())
    return {
        "index": index,
        "t": best,
        "edge_margin": margin,
        "edge_clearance": clearance,
        "figures": {
            "tests": tests,
            "test_hits": test_hits,
            "test_hit_rate": test_hits / tests if tests else math.nan,
            "miss_counts": {s: int(c) for s, c in zip(MISS_STAGES, stages, strict=True)},
            "miss_mix": {s: (int(c) / misses if misses else 0.0) for s, c in zip(MISS_STAGES, stages, strict=True)},
            "tied_hits": ties,
            "rays_on_a_surface": on_surface,
            **({"occluded_beyond_light": beyond_light} if any_hit else {}),
        },
    }


# ---------------------------------------------------------------- generator

#: Consecutive rays per run of the sample: neighbours in the seed's shooting order travel alike, so a kernel's
#: branches are predicted as in the render (docs/decisions.md, "The seed replay's model").
RUN_LENGTH = 64


def sample_runs(n_stream: int, size: int, rng: np.random.Generator) -> np.ndarray:
    """Sorted rows of ``size`` rays of a stream of ``n_stream`` (all if ``size >= n_stream``) in runs of
    :data:`RUN_LENGTH`, each placed at random in its own equal share of the stream: runs never overlap and
    cover the render evenly.

    >>> rows = sample_runs(1000, 130, np.random.default_rng(0))
    >>> len(rows), len(set(rows)), bool(np.all(np.diff(rows) > 0))
    (130, 130, True)
    """
    if size >= n_stream:
        return np.arange(n_stream)
    n_runs = -(-size // RUN_LENGTH)

    def split(total: int) -> np.ndarray:
        return np.diff(np.arange(n_runs + 1) * total // n_runs)

    lengths, spare = split(size), split(n_stream - size)
    stratum_starts = np.concatenate([[0], np.cumsum(lengths + spare)[:-1]])
    starts = stratum_starts + rng.integers(0, spare + 1)
    return np.concatenate([np.arange(a, a + n) for a, n in zip(starts, lengths, strict=True)])


def generate_seed_workload(spec: SeedSpec, workload_id: str) -> Workload:
    """Build the workload of ``spec`` (no caching: see :func:`tribench.workloads.make`).

    >>> w = generate_seed_workload(SeedSpec("scene02", "primary", sample=50, width=12, height=12), "doc")
    >>> w.triangles.shape, len(w.origins), w.achieved["stream_rays"], w.mode
    ((12, 3, 3), 50, 144, 'closest')
    """
    tr = stream_trace(spec)
    tri64 = tr.scene.triangles
    k = len(tri64)
    if k == 0:
        raise UserError(f"scene {spec.scene_label} has no triangles: nothing to replay")
    rows = stream_indices(tr, spec.rays)
    if len(rows) == 0:
        raise EmptyStream(
            f"scene {spec.scene_label} at {spec.width}x{spec.height} shoots no {spec.rays} rays that test its triangles"
        )
    rs = getattr(tr, spec.rays)
    n_stream = len(rows)
    pick = sample_runs(n_stream, spec.sample, np.random.default_rng(spec.rng_seed))

    dt = np.dtype(spec.dtype)
    o_all, d_all = rs.origins[rows], rs.directions[rows]
    if spec.rays != "primary":
        o_all = o_all + ORIGIN_SHIFT * d_all
    o_all, d_all = o_all.astype(dt), d_all.astype(dt)
    tri = np.ascontiguousarray(tri64.astype(dt))
    o, d = np.ascontiguousarray(o_all[pick]), np.ascontiguousarray(d_all[pick])
    if spec.mode == "any":
        per_ray = _any_hit_tests(o_all, d_all, tri)
        stream_tests, sample_tests = int(per_ray.sum()), int(per_ray[pick].sum())
    else:
        stream_tests, sample_tests = n_stream * k, len(pick) * k

    ref = _reference(o.astype(np.float64), d.astype(np.float64), tri.astype(np.float64), spec.mode == "any")
    hits = int((ref["index"] >= 0).sum())
    kernel, precision = STREAM_KERNEL
    achieved = {
        "scene": spec.scene_label,
        "triangles": k,
        "sample_rays": len(pick),
        "stream_rays": n_stream,
        "stream_tests": stream_tests,
        "sample_tests": sample_tests,
        "render_rays": tr.counts,
        "ray_hits": hits,
        "ray_hit_rate": hits / len(pick),
        **ref["figures"],
        "ambiguous_rays": int(ambiguous_rays(ref["edge_margin"], ref["edge_clearance"], spec.dtype).sum()),
        "origin_shift": ORIGIN_SHIFT if spec.rays != "primary" else 0.0,
        "stream_traced_with": f"{kernel} {precision}",
        "generated_with": library_versions("numpy"),
    }
    return Workload(
        workload_id=workload_id,
        spec=spec,
        origins=o,
        directions=d,
        triangles=tri,
        ref_index=ref["index"],
        ref_t=ref["t"],
        ref_edge_margin=ref["edge_margin"],
        ref_edge_clearance=ref["edge_clearance"],
        achieved=achieved,
    )
