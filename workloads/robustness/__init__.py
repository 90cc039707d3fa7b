"""The robustness suite's cases: rays aimed at the hard spots of ray-triangle tests, with their answers.

``tribench validate`` (:mod:`tribench.harness.jobs.validate`) asks every kernel these questions and judges
the answers; this package only builds them, calling no kernel. :func:`build` returns one precision's
:class:`RaySets`: :class:`MeshRays` (closest-mode questions about a small mesh) and :class:`PairRays` (each
ray about one triangle, with the right answer). A test's rays are a pure function of (seed, test name,
size, precision), so no test depends on which others are built. Sizes: :data:`FULL` and :data:`QUICK`
(``--quick``). Builders: :mod:`.meshes`, :mod:`.pairs`, :mod:`.exact`; types: :mod:`.sets`.

Tests
-----
``shared_edges``, ``shared_edges_double``, ``shared_vertices``
    Exactly coplanar ``n x n`` grids, each cell split along one diagonal into a *lower* and an *upper*
    triangle, on axis-aligned, ``x + y + z = c`` and random planes, moved and scaled by powers of 2: every
    coordinate is dyadic, exact in float32 (checked). A ray aims at a point of an interior edge, or at an
    interior vertex, from ``O = P - D``, both exact, so it truly meets it at ``t = 1``. A **crack** is a
    ray that hits no triangle (closest mode). A **double hit** (edges only) hits both triangles of its
    edge, each asked alone: by design under closed-triangle rules (the reference's, Woop's), a defect only
    where crossings are counted (parity tests). Vertices are measured for cracks only.
``inside_sphere``
    Embree's watertightness test (``tests/verify.cpp``, ``WatertightTest``): a sphere of radius 2 at
    (148376, 1234, -223423), where float32 spacing is 1/64, here an icosphere of 20480 triangles; rays
    start uniform in the centre's ``[-1, 1]^3`` box, directions uniform in it; a miss is a failure (Embree
    fails above 0.002%). Each ray is asked only about the triangles near where it leaves the circumscribed
    sphere (grouped by the nearest vertex of a coarser icosphere, with room for rounding), a superset of
    those that can hold the exit point: brute force over 50 000 rays would be too slow.
``scales``
    Safe pairs (:func:`tribench.workloads.pairs.generate_pairs`, hit rate 0.5) scaled by 1e-8 to 1e8: a
    failure is an answer other than the float64 reference's.
``tiny_triangles``, ``needle_triangles``, ``grazing_rays``
    Triangles from 1e-2 down to about 100 ulps of the precision, needles of aspect 1e3 to 1e6, and unit
    triangles met at slopes 1e-3 to 1e-6, with rays aimed at least 0.2 (barycentric) inside; those the
    reference no longer sees as hits 0.05 inside once rounded are dropped (``detail`` counts them). A
    failure is a miss.
``parallel_rays``, ``in_plane_rays``
    Dyadic triangles, and rays exactly parallel to the plane just above them: every one must miss. Rays in
    the plane, through the triangle, touch it along a segment: a kernel whose prepared plane or per-ray
    transform is rounded (Baldwin-Weber, Havel-Herout, Woop) sees a plane turned by rounding, so these are
    measured for every kernel, never judged.
``degenerate_triangles``
    Zero-area triangles (a point, a repeated vertex, three collinear vertices; dyadic, then from random
    coordinates, verified in rational arithmetic) with rays aimed at them: every clean kernel must miss
    (``ext.flat``). The seed replays keep the seed's tests and are measured: ``moller_seed``'s
    ``|det| < 1e-4`` misses the dyadic ones, but rounding noise reaches 1e-4 on larger others;
    ``curless_seed`` misses a triangle whose rounded normal is exactly 0 and can hit one whose is noise.
``nonfinite``
    Safe hits with one NaN, +Inf or -Inf in one coordinate of the origin, the direction or a vertex
    (``allow_nonfinite=True``): the call must return, and a hit is a failure, but for the seed replays
    (faithful copies of flawed code), whose hits are reported, not judged."""

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
