"""The robustness suite's sizes and ray-set types (the tests: docs/methodology.md, "The robustness suite"), and
the dyadic constructions, exact in float32, its builders share."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..geometry import dot, round_to

MIN_COS = 0.2  # |cos| between a ray and the plane's normal, away from grazing


@dataclass(frozen=True)
class Size:
    """How many of everything: ``FULL`` for the command, ``QUICK`` for tests."""

    meshes: int  # coplanar meshes
    cells: int  # grid cells per side of a mesh
    edge_rays: int  # per mesh
    vertex_rays: int  # per mesh
    sphere_rays: int
    pairs_per_scale: int
    triangles: int  # per pair test
    rays_per_triangle: int
    nonfinite_repeats: int  # triangles per (vertex, coordinate, value) with a bad vertex


FULL = Size(
    meshes=12,
    cells=8,
    edge_rays=512,
    vertex_rays=128,
    sphere_rays=50_000,
    pairs_per_scale=100,
    triangles=48,
    rays_per_triangle=16,
    nonfinite_repeats=4,
)
QUICK = Size(
    meshes=3,
    cells=4,
    edge_rays=64,
    vertex_rays=16,
    sphere_rays=2_000,
    pairs_per_scale=20,
    triangles=8,
    rays_per_triangle=4,
    nonfinite_repeats=1,
)


@dataclass(frozen=True)
class MeshRays:
    """Rays against one small mesh, answered in closest mode, all arrays in the set's dtype.

    ``label``: the kind of mesh, for the ``detail`` breakdown. ``incident``: for aimed rays, the triangles
    whose closure holds the aim (an edge's lower then upper triangle, or a vertex's six). ``back``: whether the
    ray meets the back of the mesh (``d . n > 0``), which culling kernels ask of the mesh wound the other way.
    ``aims``: the aimed points, ``origins + directions`` exactly."""

    triangles: np.ndarray
    origins: np.ndarray
    directions: np.ndarray
    back: np.ndarray
    label: str = ""
    incident: np.ndarray | None = None
    aims: np.ndarray | None = None


@dataclass(frozen=True)
class PairRays:
    """Rays each asked about one triangle, ray ``i`` against ``triangles[owner[i]]``: ``expect_hit`` is its
    right answer, ``label`` its group in the ``detail`` breakdown; ``dropped`` counts the rays left out because
    rounding made them ambiguous."""

    triangles: np.ndarray
    origins: np.ndarray
    directions: np.ndarray
    owner: np.ndarray
    expect_hit: np.ndarray
    label: np.ndarray
    dropped: int = 0


@dataclass(frozen=True)
class RaySets:
    """The rays of some tests at one precision (:func:`build`): ``meshes`` holds the closest-mode tests
    (``shared_edges``, which ``shared_edges_double`` uses too, ``shared_vertices``, ``inside_sphere``),
    ``pairs`` the others."""

    dtype: str
    tests: tuple[str, ...]
    meshes: dict[str, list[MeshRays]]
    pairs: dict[str, PairRays]


# ------------------------------------------------ exact (dyadic) constructions


def _exact(*arrays: np.ndarray) -> None:
    """The dyadic constructions must survive rounding to float32 unchanged."""
    for a in arrays:
        if not np.array_equal(round_to(a, "float32"), a):
            raise RuntimeError("a dyadic construction is not exact in float32 (a bug in workloads.robustness)")


def _as(dtype: str, *arrays: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:  # triangles, origins, directions
    triangles, origins, directions = (np.ascontiguousarray(a, dtype=dtype) for a in arrays)
    return triangles, origins, directions


def _dyadic_directions(rng: np.random.Generator, normals: np.ndarray, min_cos: float = MIN_COS) -> np.ndarray:
    """Directions with components in multiples of 1/8, length >= 1/2, at least ``min_cos`` off each plane."""
    out = np.empty_like(normals)
    todo = np.arange(len(normals))
    while len(todo):
        d = rng.integers(-8, 9, (len(todo), 3)) / 8
        length = np.sqrt(dot(d, d))
        with np.errstate(invalid="ignore", divide="ignore"):
            cos = np.abs(dot(d, normals[todo])) / (length * np.sqrt(dot(normals[todo], normals[todo])))
        ok = (length >= 0.5) & (cos >= min_cos)
        out[todo[ok]] = d[ok]
        todo = todo[~ok]
    return out


def _dyadic_plane(rng: np.random.Generator, kind: int) -> np.ndarray:
    """A 3x2 map from plane parameters (a, b) to space, exact on dyadic input."""
    if kind == 0:  # an axis-aligned plane
        return np.eye(3)[:, :2][rng.permutation(3)]
    if kind == 1:  # x + y + z = c
        return np.array([[1.0, 0], [0, 1], [-1, -1]])[rng.permutation(3)]
    while True:  # a random plane, coefficients in eighths
        basis = rng.integers(-8, 9, (3, 2)) / 8
        if np.linalg.norm(np.cross(basis[:, 0], basis[:, 1])) >= 0.5:
            return basis
