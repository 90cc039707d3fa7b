"""The robustness suite's aimed pair tests (docs/methodology.md, "The robustness suite"): safe pairs at extreme
scales, tiny and needle triangles, grazing rays, and non-finite input."""

from __future__ import annotations

import numpy as np

from .. import reference
from ..geometry import (
    normalise,
    random_frames,
    random_in_ball,
    random_perpendicular,
    round_to,
    sample_inside,
    triangle_normals,
)
from ..pairs import generate_pairs
from ..spec import PairSpec
from .sets import PairRays, Size, _as, _dyadic_directions

SCALES = (1e-8, 1e-4, 1.0, 1e4, 1e8)
NEEDLE_ASPECTS = (1e3, 1e4, 1e5, 1e6)
GRAZING_SLOPES = (1e-3, 1e-4, 1e-5, 1e-6)
AIM_MARGIN = 0.2  # barycentric margin the rays of the pair tests aim at
KEEP_MARGIN = 0.05  # ... and the least the reference must still see after rounding


def _equilateral(rng: np.random.Generator, g: int, radius: np.ndarray) -> np.ndarray:
    centre, a, b = random_frames(rng, g)
    cx = np.array([1.0, -0.5, -0.5])
    cy = np.array([0.0, 0.5, -0.5]) * np.sqrt(3.0)
    corners = cx[None, :, None] * a[:, None] + cy[None, :, None] * b[:, None]
    jitter = 0.05 * random_in_ball(rng, 3 * g).reshape(g, 3, 3)
    return centre[:, None] + radius[:, None, None] * (corners + jitter)


def _aimed_pairs(rng, tris, per_triangle, dtype, label, slope=None) -> PairRays:
    """Rays at deep points of each triangle (rounded first, the rays built against them and rounded in turn),
    kept where the reference still sees a deep hit; ``slope`` (one per triangle) makes them graze the plane."""
    tris = round_to(tris, dtype)
    owner = np.repeat(np.arange(len(tris)), per_triangle)
    mine = tris[owner]
    aim = np.einsum("nk,nkj->nj", sample_inside(rng, len(owner), AIM_MARGIN), mine)
    unit_n = normalise(triangle_normals(mine))
    if slope is None:
        d = _dyadic_directions(rng, unit_n)
    else:
        side = rng.choice([-1.0, 1.0], len(owner))
        d = normalise(random_perpendicular(rng, unit_n) + (side * slope[owner])[:, None] * unit_n)
    o = round_to(aim - rng.uniform(1, 3, (len(owner), 1)) * d, dtype)
    d = round_to(d, dtype)
    ans = reference.intersect_pairs(o, d, mine)
    with np.errstate(invalid="ignore"):
        keep = ans.hit & (ans.edge_margin >= KEEP_MARGIN)
    return PairRays(
        *_as(dtype, tris, o[keep], d[keep]),
        owner=owner[keep],
        expect_hit=np.ones(int(keep.sum()), bool),
        label=np.asarray(label)[owner[keep]],
        dropped=int((~keep).sum()),
    )


def _decades(rng, values: tuple[float, ...], g: int) -> tuple[np.ndarray, np.ndarray]:
    """One value per triangle, cycling through the decades, spread over [v, 2v); and its label."""
    k = np.arange(g) % len(values)
    decade = np.array(values)[k]
    return decade * (1.0 + rng.random(g)), np.array([f"{v:.0e}" for v in decade])


def _tiny(rng, size: Size, dtype: str) -> PairRays:
    # down to about 100 ulps of coordinates near 1, where rounding still leaves a triangle
    smallest = int(np.floor(np.log10(100 * np.finfo(dtype).eps)))
    sizes, label = _decades(rng, tuple(10.0**k for k in range(-2, smallest - 1, -1)), size.triangles)
    tris = _equilateral(rng, size.triangles, sizes)
    return _aimed_pairs(rng, tris, size.rays_per_triangle, dtype, label)


def _needles(rng, size: Size, dtype: str) -> PairRays:
    g = size.triangles
    aspect, label = _decades(rng, NEEDLE_ASPECTS, g)
    centre, a, b = random_frames(rng, g)
    apex = rng.uniform(0.05, 0.95, g)
    tris = np.stack([-0.5 * a, 0.5 * a, (apex - 0.5)[:, None] * a + b / aspect[:, None]], axis=1)
    tris += centre[:, None] - tris.mean(axis=1, keepdims=True)
    return _aimed_pairs(rng, tris, size.rays_per_triangle, dtype, label)


def _grazing(rng, size: Size, dtype: str) -> PairRays:
    g = size.triangles
    slope, label = _decades(rng, GRAZING_SLOPES, g)
    tris = _equilateral(rng, g, np.full(g, 0.5))
    return _aimed_pairs(rng, tris, size.rays_per_triangle, dtype, label, slope=slope)


def _nonfinite(rng, size: Size, dtype: str) -> PairRays:
    """Safe hits, each with one NaN, +Inf or -Inf in one coordinate of its origin, direction or a vertex: a bad
    ray shares its finite triangle, as the pair tests do; each bad vertex is its own triangle, every (vertex,
    coordinate, value) ``nonfinite_repeats`` times."""
    values = (np.nan, np.inf, -np.inf)
    g = size.triangles
    rays = _aimed_pairs(rng, _equilateral(rng, g, np.full(g, 0.5)), size.rays_per_triangle, dtype, np.full(g, ""))
    o, d = rays.origins.copy(), rays.directions.copy()
    ray_cases = [(where, k, x) for where in ("origin", "direction") for k in range(3) for x in values]
    labels = []
    for i in range(len(o)):
        where, k, x = ray_cases[i % len(ray_cases)]
        (o if where == "origin" else d)[i, k] = x
        labels.append(f"{where} {x}")

    vertex_cases = [(j, k, x) for j in range(3) for k in range(3) for x in values] * size.nonfinite_repeats
    m = len(vertex_cases)
    own = _aimed_pairs(rng, _equilateral(rng, m, np.full(m, 0.5)), 1, dtype, np.full(m, ""))
    tris = own.triangles[own.owner].copy()  # (rounding may have dropped a few rays)
    for i in range(len(tris)):
        j, k, x = vertex_cases[i]
        tris[i, j, k] = x
        labels.append(f"vertex {x}")
    n = len(o) + len(tris)
    return PairRays(
        np.concatenate([rays.triangles, tris]),
        np.concatenate([o, own.origins]),
        np.concatenate([d, own.directions]),
        owner=np.concatenate([rays.owner, len(rays.triangles) + np.arange(len(tris))]),
        expect_hit=np.zeros(n, bool),
        label=np.array(labels),
    )


def _scales(rng, size: Size, dtype: str) -> PairRays:
    rng_seed = int(rng.integers(2**31))  # the same pairs at every scale
    parts = [
        generate_pairs(
            PairSpec(n=size.pairs_per_scale, hit_rate=0.5, scale=s, dtype=dtype, rng_seed=rng_seed), "validate"
        )
        for s in SCALES
    ]
    n = size.pairs_per_scale
    return PairRays(
        *_as(dtype, *(np.concatenate([getattr(w, f) for w in parts]) for f in ("triangles", "origins", "directions"))),
        owner=np.arange(n * len(SCALES)),
        expect_hit=np.concatenate([w.ref_hit for w in parts]),
        label=np.repeat([f"{s:.0e}" for s in SCALES], n),
    )
