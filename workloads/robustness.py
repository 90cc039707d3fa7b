"""The robustness suite's cases: rays aimed at the hard spots of ray-triangle tests, with their answers.

``tribench validate`` (:mod:`tribench.studies.validate`) asks every kernel
these questions and judges the answers; this module only builds them. Each
test's rays are a pure function of (seed, test name, size, precision): one
``numpy`` ``default_rng`` stream per test, so a test's rays do not depend on
which other tests are built. :func:`build` returns them for one precision
as :class:`RaySets`: :class:`MeshRays` (closest-mode questions about a small
mesh) and :class:`PairRays` (each ray about one triangle, with the right
answer). Nothing here is timed and no kernel is called; the float64
reference (:mod:`.reference`) decides which rounded rays stay unambiguous.

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
"""

from __future__ import annotations

import functools
import zlib
from collections.abc import Callable
from dataclasses import dataclass
from fractions import Fraction
from typing import Any

import numpy as np

from tribench.common import UserError

from . import reference
from .geometry import (
    dot,
    normalise,
    random_in_ball,
    random_perpendicular,
    random_unit_vectors,
    round_to,
    sample_inside,
    triangle_normals,
)
from .pairs import generate_pairs
from .spec import PairSpec

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

EMBREE_CENTRE = (148376.0, 1234.0, -223423.0)
EMBREE_RADIUS = 2.0
EMBREE_MAX_MISS_RATE = 2e-5  # 0.002%

SCALES = (1e-8, 1e-4, 1.0, 1e4, 1e8)
NEEDLE_ASPECTS = (1e3, 1e4, 1e5, 1e6)
GRAZING_SLOPES = (1e-3, 1e-4, 1e-5, 1e-6)
AIM_MARGIN = 0.2  # barycentric margin the rays of the pair tests aim at
KEEP_MARGIN = 0.05  # ... and the least the reference must still see after rounding
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
    """Rays against one small mesh, answered in closest mode.

    Attributes
    ----------
    triangles : ndarray (K, 3, 3)
    origins, directions : ndarray (M, 3)
        All three in the set's dtype.
    label : str
        What kind of mesh, for the ``detail`` breakdown.
    incident : ndarray (M, J) or None
        For aimed rays, the triangles whose closure holds the aim: an edge's
        lower then upper triangle (J = 2), or a vertex's six triangles.
    back : ndarray (M,) of bool
        Whether the ray meets the back of the mesh (``d . n > 0``, ``n = (v1 -
        v0) x (v2 - v0)``): culling kernels ask such rays about the mesh wound
        the other way.
    aims : ndarray (M, 3) or None
        The aimed points, ``origins + directions`` exactly.
    """

    triangles: np.ndarray
    origins: np.ndarray
    directions: np.ndarray
    back: np.ndarray
    label: str = ""
    incident: np.ndarray | None = None
    aims: np.ndarray | None = None


@dataclass(frozen=True)
class PairRays:
    """Rays each asked about one triangle: ray ``i`` against ``triangles[owner[i]]``.

    ``expect_hit`` is the right answer of each ray, ``label`` its group in
    the ``detail`` breakdown, ``dropped`` the rays left out because rounding
    made them ambiguous.
    """

    triangles: np.ndarray
    origins: np.ndarray
    directions: np.ndarray
    owner: np.ndarray
    expect_hit: np.ndarray
    label: np.ndarray
    dropped: int = 0


@dataclass(frozen=True)
class RaySets:
    """The rays of some tests at one precision (see :func:`build`).

    ``meshes`` holds the closest-mode tests (``shared_edges``, which
    ``shared_edges_double`` uses too, ``shared_vertices``,
    ``inside_sphere``), ``pairs`` the others.
    """

    dtype: str
    tests: tuple[str, ...]
    meshes: dict[str, list[MeshRays]]
    pairs: dict[str, PairRays]


# ------------------------------------------------------------------ building


def _rng(seed: int, test: str) -> np.random.Generator:
    # One stream per test, keyed by its name, so adding a test changes no other.
    return np.random.default_rng([seed, zlib.crc32(test.encode())])


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


_PLANE_NAMES = ("axis plane", "x+y+z=c", "dyadic plane")


def grid_topology(n: int) -> tuple[np.ndarray, list, list]:
    """Faces, interior edges and interior vertices of an ``n x n`` grid split along one diagonal.

    Vertex ``(i, j)`` is ``i (n + 1) + j``; cell ``(i, j)`` has corners
    ``v00 v10 v11 v01`` and two triangles, lower ``(v00, v10, v11)`` =
    ``2 (i n + j)`` and upper ``(v00, v11, v01)`` = lower + 1. Returns the
    faces (vertex indices), the edges as ``(vertex, vertex, lower triangle,
    upper triangle)`` (every interior edge joins one lower and one upper
    triangle) and the interior vertices as ``(vertex, six incident triangles)``.

    Examples
    --------
    >>> faces, edges, vertices = grid_topology(2)
    >>> faces[:2].tolist(), len(edges), vertices
    ([[0, 3, 4], [0, 4, 1]], 8, [(4, (6, 7, 0, 1, 2, 5))])
    """

    def vertex(i, j):
        return i * (n + 1) + j

    def lower(i, j):
        return 2 * (i * n + j)

    faces, edges, vertices = [], [], []
    for i in range(n):
        for j in range(n):
            v00, v10, v11, v01 = vertex(i, j), vertex(i + 1, j), vertex(i + 1, j + 1), vertex(i, j + 1)
            faces += [(v00, v10, v11), (v00, v11, v01)]
            edges.append((vertex(i, j), vertex(i + 1, j + 1), lower(i, j), lower(i, j) + 1))
            if i > 0:  # the edge x = i between cells (i-1, j) and (i, j)
                edges.append((vertex(i, j), vertex(i, j + 1), lower(i - 1, j), lower(i, j) + 1))
            if j > 0:  # the edge y = j between cells (i, j-1) and (i, j)
                edges.append((vertex(i, j), vertex(i + 1, j), lower(i, j), lower(i, j - 1) + 1))
            if i > 0 and j > 0:
                around = (
                    lower(i, j),
                    lower(i, j) + 1,
                    lower(i - 1, j - 1),
                    lower(i - 1, j - 1) + 1,
                    lower(i - 1, j),
                    lower(i, j - 1) + 1,
                )
                vertices.append((vertex(i, j), around))
    return np.array(faces), edges, vertices


def _coplanar_mesh(rng: np.random.Generator, m: int, size: Size, dtype: str) -> tuple[MeshRays, MeshRays]:
    """Mesh ``m``: its edge rays and its vertex rays (see the module docstring)."""
    n = size.cells
    basis = _dyadic_plane(rng, m % 3)
    offset = rng.integers(-1024, 1025, 3).astype(float) * (m % 2)
    scale = 2.0 ** int(rng.integers(-2, 4))  # cells 1/4 to 8 units: the scales test varies size
    i, j = np.meshgrid(np.arange(n + 1), np.arange(n + 1), indexing="ij")
    params = np.stack([i, j], axis=-1).reshape(-1, 2).astype(float)
    inner = ((i > 0) & (i < n) & (j > 0) & (j < n)).ravel()
    params[inner] += rng.integers(-2, 3, (int(inner.sum()), 2)) / 16

    def space(p):
        return (offset + p @ basis.T) * scale

    faces, edges, vertices = grid_topology(n)
    tris = space(params)[faces]
    normal = np.cross(basis[:, 0], basis[:, 1])

    def aimed(aim_params, incident, label):
        aims = space(aim_params)
        d = _dyadic_directions(rng, np.tile(normal, (len(aims), 1))) * rng.integers(1, 5, (len(aims), 1)) * scale
        o = aims - d
        _exact(tris, aims, o, d)
        return MeshRays(
            *_as(dtype, tris, o, d), back=dot(d, normal) > 0, label=label, incident=np.asarray(incident), aims=aims
        )

    e = np.array([edges[k] for k in rng.integers(len(edges), size=size.edge_rays)])
    s = rng.integers(1, 8, (len(e), 1)) / 8
    edge_aims = params[e[:, 0]] + s * (params[e[:, 1]] - params[e[:, 0]])
    picked = [vertices[k] for k in rng.integers(len(vertices), size=size.vertex_rays)]
    vertex_aims = params[[v for v, _ in picked]]
    label = _PLANE_NAMES[m % 3]
    return (aimed(edge_aims, e[:, 2:], label), aimed(vertex_aims, [around for _, around in picked], label))


def sphere_triangles(dtype: str) -> np.ndarray:
    """The closed sphere of ``inside_sphere``: a trimesh icosphere (subdivisions 5,
    20480 triangles) of radius 2 centred at :data:`EMBREE_CENTRE`, rounded to ``dtype``."""
    import trimesh  # lazy: slow to import

    fine = trimesh.creation.icosphere(subdivisions=5, radius=EMBREE_RADIUS)
    return round_to(np.asarray(fine.vertices) + np.array(EMBREE_CENTRE), dtype)[fine.faces]


def _sphere(rng: np.random.Generator, size: Size, dtype: str) -> list[MeshRays]:
    """Embree's sphere test, rays grouped by exit region (see the module docstring)."""
    import trimesh

    centre = np.array(EMBREE_CENTRE)
    tris = sphere_triangles(dtype)
    n = size.sphere_rays
    o = round_to(centre + rng.uniform(-1, 1, (n, 3)), dtype)
    d = rng.uniform(-1, 1, (n, 3))
    while (short := dot(d, d) < 1e-4).any():  # a direction needs a length
        d[short] = rng.uniform(-1, 1, (int(short.sum()), 3))
    d = round_to(d, dtype)

    # where each ray leaves the circumscribed sphere, as a direction from the centre
    oc = o - centre
    a, b, c = dot(d, d), dot(oc, d), dot(oc, oc) - EMBREE_RADIUS**2
    t = (-b + np.sqrt(b * b - a * c)) / a
    exit_dir = normalise(oc + t[:, None] * d)
    patches = np.asarray(trimesh.creation.icosphere(subdivisions=3).vertices)
    patch = np.argmax(exit_dir @ patches.T, axis=1)
    face_dir = normalise(tris.mean(axis=1) - centre)
    ideal = sphere_triangles("float64") - centre
    corner_cos = np.einsum("fj,fkj->fk", normalise(ideal.mean(axis=1)), normalise(ideal))
    face_reach = np.arccos(np.clip(corner_cos, -1, 1)).max()
    groups = []
    for p in np.unique(patch):
        rays = patch == p
        widest = np.arccos(np.clip(exit_dir[rays] @ patches[p], -1, 1)).max()
        near = face_dir @ patches[p] >= np.cos(widest + face_reach + 0.03)
        # trimesh winds the sphere outwards: from inside, every ray meets a back face
        groups.append(
            MeshRays(*_as(dtype, tris[near], o[rays], d[rays]), back=np.ones(int(rays.sum()), bool), label="sphere")
        )
    return groups


def _frames(rng: np.random.Generator, g: int):
    """Random placements: centres in the ball of radius 1/2 and orthonormal frames (a, b, normal)."""
    centre = 0.5 * random_in_ball(rng, g)
    normal = random_unit_vectors(rng, g)
    a = random_perpendicular(rng, normal)
    return centre, a, np.cross(normal, a)


def _equilateral(rng: np.random.Generator, g: int, radius: np.ndarray) -> np.ndarray:
    centre, a, b = _frames(rng, g)
    cx = np.array([1.0, -0.5, -0.5])
    cy = np.array([0.0, 0.5, -0.5]) * np.sqrt(3.0)
    corners = cx[None, :, None] * a[:, None] + cy[None, :, None] * b[:, None]
    jitter = 0.05 * random_in_ball(rng, 3 * g).reshape(g, 3, 3)
    return centre[:, None] + radius[:, None, None] * (corners + jitter)


def _aimed_pairs(rng, tris, per_triangle, dtype, label, slope=None) -> PairRays:
    """Rays at deep points of each triangle, kept where the reference still sees a deep hit.

    The triangles are rounded first and the rays built against them, then
    rounded in turn; ``slope`` (one per triangle) makes the rays graze the
    plane at that slope instead of meeting it at least MIN_COS off it.
    """
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
    centre, a, b = _frames(rng, g)
    apex = rng.uniform(0.05, 0.95, g)
    tris = np.stack([-0.5 * a, 0.5 * a, (apex - 0.5)[:, None] * a + b / aspect[:, None]], axis=1)
    tris += centre[:, None] - tris.mean(axis=1, keepdims=True)
    return _aimed_pairs(rng, tris, size.rays_per_triangle, dtype, label)


def _grazing(rng, size: Size, dtype: str) -> PairRays:
    g = size.triangles
    slope, label = _decades(rng, GRAZING_SLOPES, g)
    tris = _equilateral(rng, g, np.full(g, 0.5))
    return _aimed_pairs(rng, tris, size.rays_per_triangle, dtype, label, slope=slope)


def _parallel(rng, size: Size, dtype: str, through: bool = False) -> PairRays:
    """Dyadic triangles; rays parallel to their plane just above them, or (``through``) in the plane through them."""
    g, per = size.triangles, size.rays_per_triangle
    tris, origins, directions, labels = [], [], [], []
    for k in range(g):
        basis = _dyadic_plane(rng, k % 3)
        while True:
            params = rng.integers(-16, 17, (3, 2)) / 8
            e1, e2 = params[1] - params[0], params[2] - params[0]
            if abs(e1[0] * e2[1] - e1[1] * e2[0]) >= 1:
                break
        base = rng.integers(-8, 9, 3) / 8
        scale = 2.0 ** int(rng.integers(-10, 11))
        i = rng.integers(1, 7, per)
        j = rng.integers(1, 8 - i)  # barycentrics in eighths, every one >= 1/8
        bary = np.column_stack([8 - i - j, i, j]) / 8
        aims = base + (bary @ params) @ basis.T
        while True:
            in_plane = rng.integers(-8, 9, (per, 2)) / 8
            if (np.abs(in_plane).sum(axis=1) > 0).all():
                break
        d = in_plane @ basis.T
        o = aims - rng.integers(1, 4, (per, 1)) * d
        above = np.full(per, not through)
        height = rng.choice([-1.0, 1.0], per) * 2.0 ** -rng.integers(4, 13, per).astype(float)
        o[above] += height[above, None] * np.cross(basis[:, 0], basis[:, 1])
        tri = (base + params @ basis.T) * scale
        o, d = o * scale, d * scale
        _exact(tri, o, d)
        tris.append(tri)
        origins.append(o)
        directions.append(d)
        labels += ["above" if a else "in plane" for a in above]
    n = g * per
    return PairRays(
        *_as(dtype, np.array(tris), np.concatenate(origins), np.concatenate(directions)),
        owner=np.repeat(np.arange(g), per),
        expect_hit=np.zeros(n, bool),
        label=np.array(labels),
    )


_DEGENERATE = ("point", "repeated vertex", "collinear")
_NON_DYADIC = ("repeated vertex, non-dyadic", "collinear, non-dyadic")
# c = a + k (b - a): the k tried for exactly collinear non-dyadic vertices
_COLLINEAR_K = (2.0, -1.0, 0.5, 3.0, 1.5, -0.5)


def exactly_collinear(tri: np.ndarray) -> bool:
    """Whether the three vertices of ``tri`` (3, 3) lie exactly on one line (or coincide),
    in rational arithmetic on the stored values (independent of ``ext.flat``'s filter).

    >>> exactly_collinear(np.array([[0.1, 0.2, 0.3], [0.2, 0.4, 0.6], [0.3, 0.6, 0.9]]))
    False
    """
    a, b, c = ([Fraction(float(x)) for x in v] for v in tri)
    e, f = [q - p for p, q in zip(a, b, strict=True)], [q - p for p, q in zip(a, c, strict=True)]
    return all(e[j] * f[k] == e[k] * f[j] for j, k in ((1, 2), (2, 0), (0, 1)))


def _non_dyadic_flat(rng, g: int, per: int, dtype: str) -> PairRays:
    """Repeated vertices (a, b, b) and exactly collinear vertices (a, b, a + k (b - a), kept only
    where that is exact in ``dtype``) from random coordinates that are not dyadic, scaled by
    2**-4 to 2**14 (exact), in any vertex order; rays aimed at points between a and b from
    random directions."""
    tris: Any = []  # a list, then the array of it
    ends: Any = []
    while len(tris) < g:
        scale = 2.0 ** int(rng.integers(-4, 15))
        a = round_to(scale * rng.uniform(-2, 2, 3), dtype)
        b = round_to(a + scale * rng.uniform(-1, 1, 3), dtype)
        if len(tris) % 2 == 0:
            tri = np.array([a, b, b])
        else:
            tri = np.array([a, b, round_to(a + rng.choice(_COLLINEAR_K) * (b - a), dtype)])
            if not exactly_collinear(tri):
                continue
        tris.append(tri[rng.permutation(3)])
        ends.append((a, b))
    if not all(exactly_collinear(t) for t in tris):
        raise RuntimeError("a flat triangle is not exactly flat (a bug in workloads.robustness)")
    tris, ends = np.array(tris), np.array(ends)
    owner = np.repeat(np.arange(g), per)
    a, b = ends[owner, 0], ends[owner, 1]
    aims = a + rng.uniform(0, 1, (len(owner), 1)) * (b - a)
    d = round_to(rng.normal(size=(len(owner), 3)), dtype)
    length = np.abs(b - a).max(axis=1, keepdims=True)  # origins a few segment lengths away
    o = round_to(aims - rng.uniform(1, 3, (len(owner), 1)) * length * d, dtype)
    return PairRays(
        *_as(dtype, tris, o, d),
        owner=owner,
        expect_hit=np.zeros(len(owner), bool),
        label=np.array(_NON_DYADIC)[owner % 2],
    )


def _degenerate(rng, size: Size, dtype: str) -> PairRays:
    """A point, a segment with a repeated vertex, three collinear points, all dyadic, with rays
    aimed exactly at them; then repeated and collinear vertices that are not dyadic."""
    g, per = size.triangles, size.rays_per_triangle
    kind = (np.arange(g) % 3)[:, None]
    a = rng.integers(-16, 17, (g, 3)) / 8
    b = a + _dyadic_directions(rng, np.ones((g, 3)), min_cos=0.0)  # b != a
    # point (a, a, a), repeated vertex (a, a, b), collinear (a, b, 2b - a); then a random rotation of the order
    tris = np.stack([a, np.where(kind == 2, b, a), np.select([kind == 0, kind == 1], [a, b], 2 * b - a)], axis=1)
    kind = kind[:, 0]
    tris = np.take_along_axis(tris, ((np.arange(3) + rng.integers(0, 3, (g, 1))) % 3)[:, :, None], axis=1)
    owner = np.repeat(np.arange(g), per)
    s = np.where(kind[owner] == 0, 0, rng.integers(0, 9, len(owner)))[:, None] / 8
    aims = a[owner] + s * (b[owner] - a[owner])
    d = _dyadic_directions(rng, np.ones((len(owner), 3)), min_cos=0.0) * rng.integers(1, 4, (len(owner), 1))
    o = aims - d
    _exact(tris, o, d)
    rest = _non_dyadic_flat(rng, g, per, dtype)
    dyadic = _as(dtype, tris, o, d)
    return PairRays(
        *_as(
            dtype,
            *(
                np.concatenate([x, y])
                for x, y in zip(dyadic, (rest.triangles, rest.origins, rest.directions), strict=True)
            ),
        ),
        owner=np.concatenate([owner, g + rest.owner]),
        expect_hit=np.zeros(len(owner) + len(rest.owner), bool),
        label=np.concatenate([np.array(_DEGENERATE)[kind[owner]], rest.label]),
    )


def _nonfinite(rng, size: Size, dtype: str) -> PairRays:
    """Safe hits, each with one NaN, +Inf or -Inf in one coordinate of its origin, direction or a vertex.

    Rays with a bad origin or direction share their (finite) triangles, as
    the pair tests do; each bad vertex is its own triangle, every (vertex,
    coordinate, value) combination ``nonfinite_repeats`` times.
    """
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
    seed = int(rng.integers(2**31))  # the same pairs at every scale
    parts = [
        generate_pairs(PairSpec(n=size.pairs_per_scale, hit_rate=0.5, scale=s, dtype=dtype, seed=seed), "validate")
        for s in SCALES
    ]
    n = size.pairs_per_scale
    return PairRays(
        *_as(dtype, *(np.concatenate([getattr(w, f) for w in parts]) for f in ("triangles", "origins", "directions"))),
        owner=np.arange(n * len(SCALES)),
        expect_hit=np.concatenate([w.ref_hit for w in parts]),
        label=np.repeat([f"{s:.0e}" for s in SCALES], n),
    )


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
