"""The robustness suite's cases, rays aimed at the hard spots of ray-triangle tests with their answers, built
without calling a kernel (``tribench validate`` asks and judges). A test's rays are a pure function of
(rng_seed, test name, size, precision). What each test asks and what fails it: docs/methodology.md, "The
robustness suite"."""

from __future__ import annotations

import functools
import zlib
from collections.abc import Callable

import numpy as np

from ...common import UserError
from ..fields import DTYPES
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


def _rng(rng_seed: int, test: str) -> np.random.Generator:
    # One stream per test, keyed by its name, so adding a test changes no other.
    return np.random.default_rng([rng_seed, zlib.crc32(test.encode())])


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


def build(dtype: str = "float64", quick: bool = False, rng_seed: int = 0, tests=TESTS) -> RaySets:
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
        rng = _rng(rng_seed, "shared")
        built = [_coplanar_mesh(rng, m, size, dtype) for m in range(size.meshes)]
        meshes["shared_edges"] = [edges for edges, _ in built]
        meshes["shared_vertices"] = [vertices for _, vertices in built]
    if "inside_sphere" in tests:
        meshes["inside_sphere"] = _sphere(_rng(rng_seed, "inside_sphere"), size, dtype)
    pairs = {t: make(_rng(rng_seed, t), size, dtype) for t, make in _PAIR_TESTS.items() if t in tests}
    return RaySets(dtype, tuple(t for t in TESTS if t in tests), meshes, pairs)
