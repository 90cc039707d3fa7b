"""The robustness suite's cases: rays aimed at the hard spots of ray-triangle tests, with their answers.

``tribench validate`` (:mod:`tribench.harness.jobs.validate`) asks every kernel
these questions and judges the answers; this module (with the four it draws
on, listed at the end) only builds them. Each test's rays are a pure
function of (seed, test name, size, precision): one ``numpy``
``default_rng`` stream per test, so a test's rays do not depend on which
other tests are built. :func:`build` returns them for one precision
as :class:`RaySets`: :class:`MeshRays` (closest-mode questions about a small
mesh) and :class:`PairRays` (each ray about one triangle, with the right
answer). Nothing here is timed and no kernel is called; the float64
reference (:mod:`..reference`) decides which rounded rays stay unambiguous.

Tests
-----
``shared_edges``, ``shared_edges_double``, ``shared_vertices``
    Exactly coplanar meshes: an ``n x n`` grid of cells, each split into a
    *lower* and an *upper* triangle along the same diagonal, interior
    vertices moved by multiples of 1/16, mapped onto a plane by a dyadic
    affine map (axis-aligned planes, ``x + y + z = c`` and random planes with
    coefficients in multiples of 1/8), then moved by an integer offset (up to
    1024 cells, half the meshes) and scaled by ``2**k`` (cells of 1/4 to 8
    units). Every coordinate is a dyadic rational that float32 holds exactly
    (checked). A ray aims at a
    point of an interior edge (``A + s (B - A)``, ``s`` in eighths) or at an
    interior vertex; its direction ``D`` is a dyadic vector and its origin
    ``O = P - D``, both exact, so the ray meets the aim at ``t = 1`` exactly:
    it truly passes through the edge or vertex. A **crack** is a ray that
    hits no triangle of the mesh (closest mode). A **double hit** (edges
    only) is a ray that hits both triangles of its edge, each asked alone:
    every interior edge joins a lower and an upper triangle, so the two are
    answered by one closest call on the lower triangles and one on the upper
    ones. Closed-triangle rules (the reference's, Woop's) count an exact
    edge point in both triangles, so for them a double hit is by design; it
    is a defect only where crossings are counted (parity tests of
    inside/outside). At a vertex, all six incident triangles hit is what a
    closed rule gives, so vertices are measured for cracks only.
``inside_sphere``
    Embree's watertightness test (``tests/verify.cpp``, ``WatertightTest``):
    a sphere of radius 2 centred at (148376, 1234, -223423), where float32
    spacing is 1/64; rays start uniformly in the centre's ``[-1, 1]^3`` box,
    directions uniform in ``[-1, 1]^3``; a miss is a failure and Embree fails
    above a 0.002% miss rate. Here the sphere is a trimesh icosphere
    (subdivisions 5: 20480 triangles; Embree's, of 500 segments, is finer).
    Brute force over 20480 triangles is too slow for 50 000 rays, so each ray
    is asked about the triangles around the point where it leaves the
    circumscribed sphere: rays are grouped by the nearest vertex of a coarser
    icosphere and each group meets every triangle whose centre is within
    reach (the group's widest exit angle, the largest centre-to-vertex angle
    of a triangle and 0.03 rad for rounding), a superset of the triangles
    that can hold the exit point.
``scales``
    Safe pairs (:func:`tribench.workloads.pairs.generate_pairs`, hit rate
    0.5, every crossing at least 1e-3 barycentric from an edge) scaled by
    1e-8, 1e-4, 1, 1e4, 1e8: a failure is an answer other than the
    float64 reference's.
``tiny_triangles``, ``needle_triangles``, ``grazing_rays``
    Triangles placed at random in the unit ball: near-equilateral with
    sizes from 1e-2 down to about 100 ulps of the precision; needles with
    base 1 and aspect ratios 1e3 to 1e6; unit triangles met by rays at
    slopes 1e-3 to 1e-6 (about that angle in radians) to the plane. Rays
    aim at points at least 0.2 (barycentric) inside, from 1 to 3 lengths of
    their direction away (tiny and needle: dyadic directions at least 0.2 in
    cosine off the plane);
    once rounded to the precision, rays that the float64 reference does not
    see as hits at least 0.05 inside are dropped (``detail`` counts them). A
    failure is a miss.
``parallel_rays``
    Dyadic triangles on dyadic planes; rays exactly parallel to the plane
    just above the triangle (offsets ``2**-4`` to ``2**-12`` times the
    plane's normal): every one must miss.
``in_plane_rays``
    The same triangles and rays, but exactly in the plane, through the
    triangle. The float64 reference calls them misses (its determinant is
    0), but the exact answer is a segment of contact: a kernel whose
    prepared plane or per-ray transform is rounded (Baldwin-Weber's stored
    rows, Havel-Herout's normalised planes, Woop's shear) sees the ray cross
    a plane turned by a rounding error, and a hit or a miss is that rounding's
    call. Measured for every kernel, never judged.
``degenerate_triangles``
    Zero-area triangles: a point, a segment with a repeated vertex, three
    collinear points (all dyadic, so exactly degenerate), rays aimed exactly at
    them; then, from coordinates that are not dyadic (random, rounded to the
    precision, scaled by ``2**-4`` to ``2**14``), a repeated vertex and three
    exactly collinear vertices (``a + k (b - a)`` for a few k, kept where that
    is exact in the precision, verified in rational arithmetic), rays aimed at
    points of the segment. Every clean kernel must miss every one (flat
    triangles are found exactly at prepare time, ``ext.flat``). The seed
    replays keep the seed's tests, and are measured: ``moller_seed``'s
    ``|det| < 1e-4`` misses the dyadic ones (det is exactly 0) but the rounding
    noise of det reaches 1e-4 on larger non-dyadic ones, which it then hits;
    ``curless_seed`` misses a triangle whose rounded normal is exactly 0 (its
    stored normal is 0) and can hit one whose normal is rounding noise.
``nonfinite``
    Safe hits with one NaN, +Inf or -Inf in one coordinate of the origin,
    the direction or a vertex, every combination (``allow_nonfinite=True``):
    the call must return (no crash) and a hit is a failure, except for the
    seed replays (``ext.kernel_info(k).seed_replay``), faithful copies of
    flawed code, whose hits are reported, not judged.

Sizes: :data:`FULL` (``tribench validate``) and :data:`QUICK` (``--quick``, the tests).

Modules: this one is the suite's public face (every name below, and
:func:`build`); the sizes and ray-set types are in :mod:`.sets`,
the closest-mode tests in :mod:`.meshes`, the aimed pair tests
(scales, tiny, needle, grazing, non-finite) in :mod:`.pairs` and the
exactly constructed ones (parallel, in-plane, degenerate) in
:mod:`.exact`.
"""

from __future__ import annotations

import functools
import zlib
from collections.abc import Callable

import numpy as np

from ...common import UserError
from .exact import _degenerate, _parallel, exactly_collinear
from .meshes import (
    EMBREE_CENTRE,
    EMBREE_MAX_MISS_RATE,
    EMBREE_RADIUS,
    _coplanar_mesh,
    _sphere,
    grid_topology,
    sphere_triangles,
)
from .pairs import (
    AIM_MARGIN,
    GRAZING_SLOPES,
    KEEP_MARGIN,
    NEEDLE_ASPECTS,
    SCALES,
    _grazing,
    _needles,
    _nonfinite,
    _scales,
    _tiny,
)
from .sets import FULL, MIN_COS, QUICK, MeshRays, PairRays, RaySets, Size

__all__ = [
    "AIM_MARGIN",
    "DTYPES",
    "EMBREE_CENTRE",
    "EMBREE_MAX_MISS_RATE",
    "EMBREE_RADIUS",
    "FULL",
    "GRAZING_SLOPES",
    "KEEP_MARGIN",
    "MIN_COS",
    "NEEDLE_ASPECTS",
    "QUICK",
    "SCALES",
    "TESTS",
    "MeshRays",
    "PairRays",
    "RaySets",
    "Size",
    "build",
    "exactly_collinear",
    "grid_topology",
    "sphere_triangles",
]

DTYPES = ("float32", "float64")
TESTS = (
    "shared_edges",
    "shared_edges_double",
    "shared_vertices",
    "inside_sphere",
    "scales",
    "tiny_triangles",
    "needle_triangles",
    "grazing_rays",
    "parallel_rays",
    "in_plane_rays",
    "degenerate_triangles",
    "nonfinite",
)

# ------------------------------------------------------------------ building


def _rng(seed: int, test: str) -> np.random.Generator:
    # One stream per test, keyed by its name, so adding a test changes no other.
    return np.random.default_rng([seed, zlib.crc32(test.encode())])


_PAIR_TESTS: dict[str, Callable[[np.random.Generator, Size, str], PairRays]] = {
    "scales": _scales,
    "tiny_triangles": _tiny,
    "needle_triangles": _needles,
    "grazing_rays": _grazing,
    "parallel_rays": _parallel,
    "in_plane_rays": functools.partial(_parallel, through=True),
    "degenerate_triangles": _degenerate,
    "nonfinite": _nonfinite,
}


def build(dtype: str = "float64", quick: bool = False, seed: int = 0, tests=TESTS) -> RaySets:
    """The rays of ``tests`` at one precision, the same for every kernel.

    Each test draws from its own stream (the seed and the test's name), so
    a test's rays do not depend on which other tests are built.

    Examples
    --------
    >>> sets = build("float32", quick=True, tests=("nonfinite", "shared_edges"))
    >>> sets.tests, sets.meshes["shared_edges"][0].incident.shape
    (('shared_edges', 'nonfinite'), (64, 2))
    """
    if dtype not in DTYPES:
        raise UserError(f"dtype must be float32 or float64, got {dtype!r}")
    unknown = [t for t in tests if t not in TESTS]
    if unknown:
        raise UserError(f"unknown test(s) {', '.join(unknown)}; tests: {', '.join(TESTS)}")
    size = QUICK if quick else FULL
    meshes = {}
    if {"shared_edges", "shared_edges_double", "shared_vertices"} & set(tests):
        rng = _rng(seed, "shared")
        built = [_coplanar_mesh(rng, m, size, dtype) for m in range(size.meshes)]
        meshes["shared_edges"] = [edges for edges, _ in built]
        meshes["shared_vertices"] = [vertices for _, vertices in built]
    if "inside_sphere" in tests:
        meshes["inside_sphere"] = _sphere(_rng(seed, "inside_sphere"), size, dtype)
    pairs = {t: make(_rng(seed, t), size, dtype) for t, make in _PAIR_TESTS.items() if t in tests}
    return RaySets(dtype, tuple(t for t in TESTS if t in tests), meshes, pairs)
