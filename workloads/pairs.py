"""Pair workloads: N (ray, triangle) pairs with an exact per-test hit rate and miss-stage mix.

Each pair is built for one outcome, its *kind* (the misses shared among the stages by :func:`apportion`): a
triangle (``sphere``: vertices uniform on the unit sphere, Loefstedt & Akenine-Moeller 2005; ``equilateral``;
``sliver``), then a point of its plane by barycentric weights ``(w, u, v)`` inside it or outside one edge, then
a ray through it (in the plane for ``parallel``). Every pair keeps the safe margins :data:`BARY_MARGIN`,
:data:`T_MARGIN`, :data:`PLANE_MARGIN` and :data:`PARALLEL_COS` (lengths times ``scale``) after rounding to
the dtype, so that all kernels agree; a pair that lost one is drawn again."""

from __future__ import annotations

import numpy as np

from ..common import UserError
from .geometry import (
    MAX_COORDINATE,
    aspect_ratios,
    dot,
    normalise,
    random_frames,
    random_in_ball,
    random_perpendicular,
    random_unit_vectors,
    round_to,
    sample_inside,
    triangle_normals,
)
from .reference import PairAnswers, intersect_pairs
from .spec import MISS_STAGES, PairSpec
from .workload import Workload, library_versions

__all__ = [
    "BARY_MARGIN",
    "T_MARGIN",
    "SCALE_RANGE",
    "PLANE_MARGIN",
    "PARALLEL_COS",
    "MAX_ASPECT",
    "HIT",
    "OTHER",
    "apportion",
    "classify_misses",
    "stage_counts",
    "generate_pairs",
]

BARY_MARGIN = 1e-3
T_MARGIN = 1e-3
PLANE_MARGIN = 0.05
PARALLEL_COS = 1e-6
MAX_ASPECT = 1e3
MIN_COS = 0.1

#: Codes returned by :func:`classify_misses`: a stage's index in MISS_STAGES,
#: or HIT, or OTHER for a miss of no single stage (outside two edges, say).
HIT = -1
OTHER = len(MISS_STAGES)
_PARALLEL, _BEHIND = MISS_STAGES.index("parallel"), MISS_STAGES.index("behind_origin")
_BEYOND = MISS_STAGES.index("beyond_t_max")

_MAX_ROUNDS = 50

#: The pair scales each precision holds. A kernel's t is a triple product of edges and offsets (scale**3),
#: Curless's edge tests a fourfold one, the generator's normals a squared cross product (scale**4): past these
#: one of them leaves the precision's range. MAX_COORDINATE (squares) let float32 through at 1e13, where 90% of
#: the hits of moller_trumbore, plucker and woop were misses, and float64 at 1e80, where generating never ended;
#: at 1e-10 a float32 sliver's Curless tests underflowed. Inside, every clean kernel agrees with the reference.
SCALE_RANGE = {"float32": (1e-8, 1e11), "float64": (1e-70, 1e70)}
_OFFSET_AXIS = np.full(3, 1.0) / np.sqrt(3.0)


def _edge_stage(e: int) -> int:
    return MISS_STAGES.index(f"outside_edge_{e}")


def _opposite(e: int) -> int:
    """Column in ``(w, u, v)`` of the weight that is negative outside edge ``e``."""
    return (e + 1) % 3


def apportion(fractions: list[float], total: int) -> list[int]:
    """Split ``total`` by ``fractions`` with largest-remainder rounding (ties to the first).

    >>> apportion([1/3, 1/3, 1/3], 10)
    [4, 3, 3]
    >>> apportion([0.5, 0.0, 0.5], 3)
    [2, 0, 1]
    """
    s = sum(fractions)
    exact = [f / s * total for f in fractions] if s > 0 else [0.0] * len(fractions)
    counts = [int(x) for x in exact]
    by_remainder = sorted(range(len(exact)), key=lambda i: (-(exact[i] - counts[i]), i))
    for i in by_remainder[: total - sum(counts)]:
        counts[i] += 1
    return counts


def _classify(ans: PairAnswers, directions: np.ndarray, triangles: np.ndarray, t_max=None) -> np.ndarray:
    """Codes of ``ans``, which must have been computed with the same ``t_max``."""
    cos = np.abs(dot(normalise(directions), normalise(triangle_normals(triangles))))
    b = np.column_stack([ans.w, ans.u, ans.v])
    t = ans.t
    limit = np.inf if t_max is None else np.asarray(t_max, dtype=np.float64)
    codes = np.full(len(t), OTHER, dtype=np.int8)
    with np.errstate(invalid="ignore"):
        parallel = ~np.isfinite(t) | (cos < PARALLEL_COS)
        crossing = ~ans.hit & ~parallel
        inside = b.min(axis=1) >= 0
        codes[crossing & inside & (t <= 0)] = _BEHIND
        codes[crossing & inside & (t > 0) & (t >= limit)] = _BEYOND
        ahead = (t > 0) & (t < limit)  # outside an edge and past t_max too: two stages, OTHER
        for e in (1, 2, 3):
            j = _opposite(e)
            others = np.delete(b, j, axis=1)
            only_e = (b[:, j] < 0) & (others.min(axis=1) >= 0)
            codes[crossing & only_e & ahead] = _edge_stage(e)
    codes[~ans.hit & parallel] = _PARALLEL
    codes[ans.hit] = HIT
    return codes


def classify_misses(
    origins: np.ndarray, directions: np.ndarray, triangles: np.ndarray, t_max: np.ndarray | None = None
) -> np.ndarray:
    """Which stage rejects each (ray, triangle) pair by the float64 reference, as int8 codes: :data:`HIT`, a
    stage's index in ``MISS_STAGES``, or :data:`OTHER` (outside two edges, or outside an edge and behind the
    origin or past ``t_max``); without the workload's ``t_max``, a beyond_t_max pair is a hit.

    >>> tri = np.array([[[0., 0, 0], [1, 0, 0], [0, 1, 0]]] * 3)
    >>> o = np.array([[0.2, 0.2, 1], [0.2, -0.5, 1], [0.2, 0.2, -1]])
    >>> d = np.array([[0., 0, -1], [0, 0, -1], [0, 0, -1]])
    >>> [MISS_STAGES[c] if 0 <= c < OTHER else int(c) for c in classify_misses(o, d, tri)]
    [-1, 'outside_edge_1', 'behind_origin']
    >>> int(classify_misses(o, d, tri, t_max=[0.5, np.inf, np.inf])[0]) == MISS_STAGES.index("beyond_t_max")
    True
    """
    o = np.asarray(origins, dtype=np.float64)
    d = np.asarray(directions, dtype=np.float64)
    tri = np.asarray(triangles, dtype=np.float64)
    return _classify(intersect_pairs(o, d, tri, t_max=t_max), d, tri, t_max)


def stage_counts(codes: np.ndarray) -> dict[str, int]:
    """Misses per stage (``"other"`` only when present).

    >>> stage_counts(np.array([-1, 2, 2, 0], dtype=np.int8))["outside_edge_1"]
    2
    """
    counts = np.bincount(codes[codes != HIT], minlength=OTHER + 1)
    out = {s: int(counts[i]) for i, s in enumerate(MISS_STAGES)}
    if counts[OTHER]:
        out["other"] = int(counts[OTHER])
    return out


def _kinds(spec: PairSpec, rng: np.random.Generator) -> np.ndarray:
    hits = round(spec.hit_rate * spec.n)
    misses = apportion(list(spec.miss_fractions().values()), spec.n - hits)
    kinds = np.repeat(np.arange(HIT, OTHER, dtype=np.int8), [hits, *misses])
    return rng.permutation(kinds) if spec.order == "shuffled" else kinds


def _triangles(shape: str, k: int, rng: np.random.Generator) -> np.ndarray:
    """``k`` triangles of the given shape, within the unit ball (unit scale, at the origin)."""
    if shape == "sphere":
        out = np.empty((k, 3, 3))
        todo = np.arange(k)
        while len(todo):
            t = random_unit_vectors(rng, 3 * len(todo)).reshape(-1, 3, 3)
            ok = aspect_ratios(t) <= MAX_ASPECT
            out[todo[ok]] = t[ok]
            todo = todo[~ok]
        return out
    centre, a, b = random_frames(rng, k)
    if shape == "equilateral":
        radius = 0.5
        cx = np.array([1.0, -0.5, -0.5])
        cy = np.array([0.0, 0.5, -0.5]) * np.sqrt(3.0)
        jitter = 0.05 * radius * random_in_ball(rng, 3 * k).reshape(k, 3, 3)
        return centre[:, None] + radius * (cx[:, None] * a[:, None] + cy[:, None] * b[:, None]) + jitter
    # Sliver: base of length 1 along a, apex above a point of the base at height 1/aspect.
    aspect = np.where(rng.random(k) < 0.5, 10.0, 100.0) * (1.0 + 9.0 * rng.random(k))
    s = 0.05 + 0.9 * rng.random(k)
    verts = np.stack([-0.5 * a, 0.5 * a, (s - 0.5)[:, None] * a + b / aspect[:, None]], axis=1)
    verts = verts - (verts[:, 0] + verts[:, 1] + verts[:, 2])[:, None] / 3.0 + centre[:, None]
    roll = (np.arange(3) + rng.integers(0, 3, k)[:, None]) % 3  # cyclic: keeps the winding
    return np.take_along_axis(verts, roll[:, :, None], axis=1)


def _sample_outside(rng: np.random.Generator, n: int, j: int, margin: float) -> np.ndarray:
    """Weights ``(w, u, v)`` with column ``j`` in ``[-1, -margin]`` and the other two >= margin."""
    neg = -(margin + (1.0 - margin) * rng.random(n))
    a = margin + (1.0 - neg - 2.0 * margin) * rng.random(n)
    b = np.empty((n, 3))
    b[:, j] = neg
    b[:, (j + 1) % 3] = a
    b[:, (j + 2) % 3] = 1.0 - neg - a
    return b


def _oblique(rng: np.random.Generator, normal: np.ndarray) -> np.ndarray:
    """Random unit directions at least MIN_COS off each plane (either side)."""
    out = np.empty_like(normal)
    todo = np.arange(len(normal))
    while len(todo):
        d = random_unit_vectors(rng, len(todo))
        ok = np.abs(dot(d, normal[todo])) >= MIN_COS
        out[todo[ok]] = d[ok]
        todo = todo[~ok]
    return out


def _rays(kinds: np.ndarray, tri: np.ndarray, scale: float, rng: np.random.Generator, facing: bool):
    """Origins, directions and t_max realising each kind against its (already rounded) triangle, and the
    triangles, rewound (v1 and v2 swapped) where ``facing`` asks each ray to meet the front face."""
    k = len(kinds)
    normal = normalise(triangle_normals(tri))
    margin = 2.0 * BARY_MARGIN  # twice the checked margin: rounding rarely costs a redraw
    bary = np.empty((k, 3))
    inside = (kinds <= _BEHIND) | (kinds == _BEYOND)
    bary[inside] = sample_inside(rng, int(inside.sum()), margin)
    for e in (1, 2, 3):
        sel = kinds == _edge_stage(e)
        bary[sel] = _sample_outside(rng, int(sel.sum()), _opposite(e), margin)

    parallel = kinds == _PARALLEL
    d = np.empty((k, 3))
    d[~parallel] = _oblique(rng, normal[~parallel])
    d[parallel] = random_perpendicular(rng, normal[parallel])
    if facing:
        # Rewound before the point is placed: the weights name vertex slots, so each pair keeps its kind
        # (an edge miss stays outside the same edge) and its ray its direction. |cos| >= MIN_COS keeps
        # the sign exact through rounding.
        back = ~parallel & (dot(d, normal) > 0)
        tri = tri.copy()
        tri[back] = tri[back][:, [0, 2, 1]]
        normal[back] = -normal[back]
    point = bary[:, 0:1] * tri[:, 0] + bary[:, 1:2] * tri[:, 1] + bary[:, 2:3] * tri[:, 2]
    dist = scale * (1.0 + 2.0 * rng.random(k))
    away = np.where(kinds == _BEHIND, -1.0, 1.0)  # behind: start past the point, look away
    o = point - (away * dist)[:, None] * d
    height = scale * (0.1 + 0.9 * rng.random(int(parallel.sum())))
    height *= np.where(rng.random(len(height)) < 0.5, -1.0, 1.0)
    o[parallel] += height[:, None] * normal[parallel]
    # Drawn last: without beyond_t_max pairs no draw, so the other arrays are unchanged.
    beyond = kinds == _BEYOND
    t_max = np.full(k, np.inf)
    t_max[beyond] = (0.2 + 0.6 * rng.random(int(beyond.sum()))) * dist[beyond]  # d is unit: t = dist
    return o, d, t_max, tri


def _keeps_margins(kinds, ans: PairAnswers, o, d, tri, t_max, scale: float) -> np.ndarray:
    """Whether each pair is its kind with every safe margin, on the rounded arrays; ``ans`` is without ``t_max``
    (a beyond_t_max pair must be a deep hit without it)."""
    b = np.column_stack([ans.w, ans.u, ans.v])
    t = ans.t
    t_tol = T_MARGIN * scale
    normal = normalise(triangle_normals(tri))
    ok = np.zeros(len(kinds), dtype=bool)
    with np.errstate(invalid="ignore"):
        deep = b.min(axis=1) >= BARY_MARGIN
        sel = kinds == HIT
        ok[sel] = (ans.hit & deep & (t >= t_tol))[sel]
        sel = kinds == _BEHIND
        ok[sel] = (deep & (t <= -t_tol))[sel]
        sel = kinds == _BEYOND
        ok[sel] = (ans.hit & deep & (t_max >= t_tol) & (t - t_max >= t_tol))[sel]
        for e in (1, 2, 3):
            j = _opposite(e)
            sel = kinds == _edge_stage(e)
            outside = (b[:, j] <= -BARY_MARGIN) & (np.delete(b, j, axis=1).min(axis=1) >= BARY_MARGIN)
            ok[sel] = (outside & (t >= t_tol))[sel]
        sel = kinds == _PARALLEL
        flat = ~np.isfinite(t) | (np.abs(dot(normalise(d), normal)) < PARALLEL_COS)
        off_plane = np.abs(dot(o - tri[:, 0], normal)) >= PLANE_MARGIN * scale
        ok[sel] = (flat & off_plane & ~ans.hit)[sel]
    return ok


def _figures(spec: PairSpec, ans: PairAnswers, codes, d, tri, t_max, redrawn: int) -> dict:
    hits = ans.hit
    n_hits, n_misses = int(hits.sum()), int((~hits).sum())
    counts = stage_counts(codes)
    b = np.column_stack([ans.w, ans.u, ans.v])
    front = dot(d, triangle_normals(tri)) < 0

    def smallest(x):
        return float(x.min()) if len(x) else None

    edge_miss = np.zeros(len(codes), dtype=bool)
    outside_by = np.full(len(codes), np.inf)
    for e in (1, 2, 3):
        sel = codes == _edge_stage(e)
        edge_miss |= sel
        outside_by[sel] = -b[sel, _opposite(e)]
    inside_kinds = (codes == HIT) | (codes == _BEHIND) | (codes == _BEYOND)
    beyond = codes == _BEYOND
    aspect = aspect_ratios(tri)
    return {
        "pairs": spec.n,
        "hits": n_hits,
        "hit_rate": n_hits / spec.n,
        "miss_counts": counts,
        "miss_mix": {s: (c / n_misses if n_misses else 0.0) for s, c in counts.items()},
        "hits_front_facing": float(front[hits].mean()) if n_hits else None,
        "redrawn_pairs": redrawn,
        "min_inside_margin": smallest(b[inside_kinds].min(axis=1)),
        "min_outside_margin": smallest(outside_by[edge_miss]),
        "min_abs_t_over_scale": smallest(np.abs(ans.t[codes != _PARALLEL]) / spec.scale),
        "min_t_past_t_max_over_scale": smallest((ans.t[beyond] - t_max[beyond]) / spec.scale),
        "aspect_ratio": {
            "min": float(aspect.min()),
            "median": float(np.median(aspect)),
            "max": float(aspect.max()),
        },
        "generated_with": library_versions("numpy"),
    }


def generate_pairs(spec: PairSpec, workload_id: str) -> Workload:
    """Build the pair workload of ``spec`` (no caching: see :func:`tribench.workloads.make`).

    >>> w = generate_pairs(PairSpec(n=20, hit_rate=0.25), "doc")
    >>> w.expected_checksum()[0], w.achieved["miss_counts"]["outside_edge_1"]
    (5, 5)
    """
    rng = np.random.default_rng(spec.rng_seed)
    kinds = _kinds(spec, rng)
    n, dtype, scale = spec.n, spec.dtype, spec.scale
    low, high = SCALE_RANGE[dtype]
    if not low <= scale <= high:  # refused now, not after every redraw has failed or every kernel missed
        raise UserError(
            f"scale = {scale:.3g} is outside what {dtype} holds with its products (they overflow or underflow): "
            f"a pair's scale may be {low:.0e} to {high:.0e} in {dtype}"
        )
    if scale + abs(spec.offset) > MAX_COORDINATE[dtype]:  # refused now, not after every redraw has failed
        raise UserError(
            f"scale = {scale:.3g} is outside what {dtype} holds with its products (they overflow): "
            f"scale and offset may reach {MAX_COORDINATE[dtype]:.0e} together"
        )
    shift = spec.offset * _OFFSET_AXIS
    tri, o, d = np.empty((n, 3, 3)), np.empty((n, 3)), np.empty((n, 3))
    t_max = np.full(n, np.inf)
    todo, redrawn = np.arange(n), 0
    for _ in range(_MAX_ROUNDS):
        # Rays are built against the triangle as rounded, then rounded in turn.
        tri[todo] = round_to(scale * _triangles(spec.shape, len(todo), rng) + shift, dtype)
        ok = np.zeros(len(todo), dtype=bool)
        sound = np.flatnonzero(aspect_ratios(tri[todo]) <= 2.0 * MAX_ASPECT)  # rounding can flatten one
        slots = todo[sound]
        o_new, d_new, t_max_new, tri[slots] = _rays(kinds[slots], tri[slots], scale, rng, spec.winding == "facing")
        o[slots], d[slots] = round_to(o_new, dtype), round_to(d_new, dtype)
        t_max[slots] = round_to(t_max_new, dtype)
        ans = intersect_pairs(o[slots], d[slots], tri[slots])
        ok[sound] = _keeps_margins(kinds[slots], ans, o[slots], d[slots], tri[slots], t_max[slots], scale)
        todo = todo[~ok]
        if not len(todo):
            break
        redrawn += len(todo)
    else:
        cause = (
            f"offset/scale = {abs(spec.offset) / scale:.3g} is too large for this precision"
            if spec.offset
            else f"scale = {scale:.3g} is outside what {dtype} holds with its products (they overflow or underflow)"
        )
        raise UserError(f"{len(todo)} pair(s) kept losing their safe margins when rounded to {dtype}: {cause}")
    ans = intersect_pairs(o, d, tri, t_max=t_max)
    codes = _classify(ans, d, tri, t_max)
    if not np.array_equal(codes, kinds):  # construction and classification disagree: a bug
        raise RuntimeError(f"{int((codes != kinds).sum())} pairs are not of the kind they were built as")
    return Workload(
        workload_id=workload_id,
        spec=spec,
        origins=o.astype(dtype),
        directions=d.astype(dtype),
        triangles=tri.astype(dtype),
        ref_hit=ans.hit,
        ref_t=np.where(ans.hit, ans.t, np.nan),
        ref_edge_margin=ans.edge_margin,
        ref_edge_clearance=ans.clearance,
        t_max=t_max.astype(dtype) if spec.miss_fractions()["beyond_t_max"] > 0 else None,
        achieved=_figures(spec, ans, codes, d, tri, t_max, redrawn),
    )
