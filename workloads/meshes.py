"""Meshes at controlled triangle counts: a base mesh (:data:`BASE_COUNTS`) or any mesh file trimesh reads, brought
to the exact count by :func:`with_triangle_count` and placed where the seed's camera sees it (:func:`place`)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..common import UserError
from .geometry import MAX_COORDINATE, norm, random_unit_vectors, triangle_areas

__all__ = [
    "SUZANNE_PATH",
    "BASE_COUNTS",
    "Mesh",
    "read_mesh_file",
    "base_mesh",
    "soup",
    "heightfield",
    "place",
    "bounding_sphere",
    "with_triangle_count",
    "build_mesh",
]

SUZANNE_PATH = Path(__file__).parent / "data" / "suzanne.obj"
BASE_COUNTS = {"suzanne": 968, "icosphere": 1280, "uvsphere": 896, "heightfield": 1152, "soup": 1000}

SUZANNE_OFFSET = np.array([0.0, 0.5, -2.0])
VIEW_CENTRE = np.array([0.0, 0.0, -2.0])
VIEW_RADIUS = 1.5

# fast-simplification's aggressiveness values to try, default first.
_AGGS = (7.0, 8.0, 9.0, 10.0, 6.0, 5.0)


@dataclass(frozen=True, eq=False)
class Mesh:
    """An indexed triangle mesh and how its triangle count was reached."""

    vertices: np.ndarray  # float64 (V, 3)
    faces: np.ndarray  # int64 (F, 3)
    method: str = "base"

    @property
    def triangles(self) -> np.ndarray:
        """Vertex coordinates per face, float64 (F, 3, 3)."""
        return self.vertices[self.faces]


def _compact(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Drop unreferenced vertices, keeping the order of the rest."""
    used, inverse = np.unique(faces, return_inverse=True)  # faces renumbered over the used vertices
    return np.ascontiguousarray(vertices[used], dtype=np.float64), inverse.reshape(faces.shape).astype(np.int64)


def read_mesh_file(path: str | Path, dtype: str = "float64") -> tuple[np.ndarray, np.ndarray]:
    """Vertices and faces of a mesh file as trimesh reads it with ``process=False``; a UserError when it cannot be
    read as a mesh or has a non-finite coordinate, one too large for ``dtype``, or no triangle of non-zero area."""
    import trimesh  # lazy: slow to import

    try:
        mesh = trimesh.load(str(path), force="mesh", process=False)
        assert isinstance(mesh, trimesh.Trimesh)  # force="mesh" gives one
        vertices = np.asarray(mesh.vertices, dtype=np.float64)
        faces = np.asarray(mesh.faces, dtype=np.int64).reshape(-1, 3)
    except ImportError:  # trimesh guesses a garbled file's text encoding with an optional module
        raise UserError(f"cannot read mesh file {str(path)!r}: not a mesh file trimesh reads") from None
    except Exception as e:  # trimesh raises many types for malformed files
        raise UserError(f"cannot read mesh file {str(path)!r}: {type(e).__name__}: {e}") from None
    if len(faces) == 0:
        raise UserError(f"mesh file {str(path)!r} holds no triangles")
    outside = faces[(faces < 0) | (faces >= len(vertices))]  # trimesh checks an OBJ's, not a PLY's
    if outside.size:
        raise UserError(
            f"mesh file {str(path)!r} has a face naming vertex {outside[0]}, which it does not have "
            f"(its vertices are 0 to {len(vertices) - 1})"
        )
    if not np.isfinite(vertices).all():
        raise UserError(f"mesh file {str(path)!r} has non-finite vertex coordinates")
    largest, limit = float(np.abs(vertices).max()), MAX_COORDINATE[dtype]
    if largest > limit:
        other = " or time it in float64" if dtype == "float32" and largest <= MAX_COORDINATE["float64"] else ""
        raise UserError(
            f"mesh file {str(path)!r} has coordinates up to {largest:.3g}: in {dtype} their squares overflow "
            f"(edge products and distances to place it), so scale it to at most {limit:.0e}{other}"
        )
    if not (triangle_areas(vertices[faces]) > 0).any():
        raise UserError(f"mesh file {str(path)!r} has no triangle of non-zero area")
    return _compact(vertices, faces)


def soup(n: int, rng_seed: int) -> tuple[np.ndarray, np.ndarray]:
    """``n`` random triangles in the cube [-1, 1]^3, unconnected, on spheres of radius ``0.25 * sqrt(1000 / n)``
    around uniform centres: the soup keeps about the same look at any count.

    >>> v, f = soup(5, rng_seed=0)
    >>> v.shape, f.shape
    ((15, 3), (5, 3))
    """
    rng = np.random.default_rng(rng_seed)
    size = 0.25 * np.sqrt(1000.0 / n)
    centres = rng.random((n, 3)) * 2.0 - 1.0
    verts = centres[:, None] + size * random_unit_vectors(rng, 3 * n).reshape(n, 3, 3)
    return verts.reshape(-1, 3), np.arange(3 * n, dtype=np.int64).reshape(n, 3)


def heightfield(cells: int, rng_seed: int) -> tuple[np.ndarray, np.ndarray]:
    """A ``cells`` x ``cells`` grid over [-1, 1]^2 with six smooth bumps, normals toward +z; the bumps are
    ``a / (1 + r^2 / s^2)``, rational, so the heights need no transcendental function.

    >>> v, f = heightfield(2, rng_seed=0)
    >>> v.shape, f.shape
    ((9, 3), (8, 3))
    """
    rng = np.random.default_rng(rng_seed)
    g = np.linspace(-1.0, 1.0, cells + 1)
    x, y = np.meshgrid(g, g)  # row j, column i
    z = np.zeros_like(x)
    bumps = zip(
        rng.random(6) * 2 - 1, rng.random(6) * 2 - 1, rng.random(6) * 0.6 - 0.3, 0.2 + 0.4 * rng.random(6), strict=True
    )
    for cx, cy, a, s in bumps:
        z += a / (1.0 + ((x - cx) ** 2 + (y - cy) ** 2) / (s * s))
    vertices = np.column_stack([x.ravel(), y.ravel(), z.ravel()])
    i, j = np.meshgrid(np.arange(cells), np.arange(cells))
    v00 = (j * (cells + 1) + i).ravel()
    v10, v01 = v00 + 1, v00 + cells + 1
    faces = np.concatenate([np.column_stack([v00, v10, v01 + 1]), np.column_stack([v00, v01 + 1, v01])])
    return vertices, faces.astype(np.int64)


def base_mesh(name: str, rng_seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Vertices and faces of a base mesh by name or of a mesh file by path.

    >>> v, f = base_mesh("suzanne")
    >>> v.shape, f.shape
    ((507, 3), (968, 3))
    """
    if name == "suzanne":
        return read_mesh_file(SUZANNE_PATH)
    if name == "soup":
        return soup(BASE_COUNTS["soup"], rng_seed)
    if name == "heightfield":
        return heightfield(24, rng_seed)
    if name in ("icosphere", "uvsphere"):
        import trimesh  # lazy: slow to import

        if name == "icosphere":
            m = trimesh.creation.icosphere(subdivisions=3)
        else:
            m = trimesh.creation.uv_sphere(count=[16, 16])
        return np.asarray(m.vertices, dtype=np.float64), np.asarray(m.faces, dtype=np.int64)
    return read_mesh_file(name)


def bounding_sphere(vertices: np.ndarray) -> tuple[np.ndarray, float]:
    """Centre of the bounding box and the largest distance from it to a vertex."""
    centre = 0.5 * (vertices.min(axis=0) + vertices.max(axis=0))
    return centre, float(norm(vertices - centre).max())


def place(name: str, vertices: np.ndarray, like: np.ndarray | None = None) -> np.ndarray:
    """Vertices moved where the seed's camera sees them: Suzanne as in scene03, any other mesh with its bounding
    sphere of radius 1.5 at (0, 0, -2) (``like``'s, so a finer version is placed exactly as the base mesh).

    >>> place("suzanne", np.array([[1.0, 2.0, 3.0]]))
    array([[ 1. ,  3.5, -4. ]])
    """
    if name == "suzanne":
        x, y, z = vertices.T
        return np.column_stack([x, z, -y]) + SUZANNE_OFFSET
    centre, radius = bounding_sphere(vertices if like is None else like)
    return (vertices - centre) * (VIEW_RADIUS / radius) + VIEW_CENTRE


def _split_longest_edges(vertices: np.ndarray, faces: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
    """Add exactly ``k`` triangles, splitting ``k`` times the triangle with the longest edge at its midpoint:
    winding and surface unchanged, the neighbour across that edge left whole (a T-junction)."""
    v, f = vertices, faces.copy()
    for _ in range(k):
        edge_vec = v[f[:, [1, 2, 0]]] - v[f]  # edge j runs from corner j to corner j+1
        length2 = (edge_vec**2).sum(axis=2)
        face, j = np.unravel_index(np.argmax(length2), length2.shape)  # first maximum: deterministic
        a, b, c = f[face, j], f[face, (j + 1) % 3], f[face, (j + 2) % 3]
        m = len(v)
        v = np.vstack([v, 0.5 * (v[a] + v[b])])
        f = np.vstack([f, [[m, b, c]]])
        f[face] = [a, m, c]
    return v, f


def _drop_smallest(vertices: np.ndarray, faces: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
    """Remove the ``k`` triangles of smallest area (stable: ties keep the lower index)."""
    order = np.argsort(triangle_areas(vertices[faces]), kind="stable")
    keep = np.sort(order[k:])
    return _compact(vertices, faces[keep])


def with_triangle_count(vertices: np.ndarray, faces: np.ndarray, n: int) -> Mesh:
    """The mesh with exactly ``n`` triangles; ``Mesh.method`` says how it was reached.

    Fewer than ``n``: loop subdivision to at least ``n``. More: fast-simplification, trying several aggressiveness
    values for an exact result, the closest below ``n`` topped up by :func:`_split_longest_edges` (an edge collapse
    removes two triangles, so the parity can miss by one); if none works (a count too small for the topology), the
    smallest triangles are dropped: exact, no longer closed.

    >>> v, f = base_mesh("icosphere")
    >>> m = with_triangle_count(v, f, 501)
    >>> len(m.faces), m.method
    (501, 'simplified (agg=7) + 1 split(s)')
    """
    import fast_simplification  # lazy: heavy compiled modules
    import trimesh

    if len(faces) == n:
        return Mesh(vertices, faces, "base")
    steps = []
    iterations = 0
    while len(faces) * 4**iterations < n:
        iterations += 1
    if iterations:
        try:
            vertices, faces = trimesh.remesh.subdivide_loop(vertices, faces, iterations=iterations)
        except Exception as e:  # a mesh loop subdivision cannot handle (non-manifold, say)
            raise UserError(f"cannot subdivide this mesh to reach {n} triangles: {e}") from None
        faces = np.asarray(faces, dtype=np.int64)
        steps.append(f"subdivided x{iterations}")
        if len(faces) == n:
            return Mesh(np.asarray(vertices, dtype=np.float64), faces, steps[0])

    results = []
    for agg in _AGGS:
        v, f = fast_simplification.simplify(vertices, faces, target_count=n, agg=agg)
        v, f = _compact(np.asarray(v, dtype=np.float64), np.asarray(f, dtype=np.int64))
        if len(f) == n:
            return Mesh(v, f, ", ".join([*steps, f"simplified (agg={agg:g})"]))
        results.append((agg, v, f))
    below = [r for r in results if 0 < len(r[2]) < n]
    if below:
        agg, v, f = max(below, key=lambda r: len(r[2]))  # first of the closest: deterministic
        missing = n - len(f)
        v, f = _split_longest_edges(v, f, missing)
        return Mesh(v, f, ", ".join([*steps, f"simplified (agg={agg:g}) + {missing} split(s)"]))
    # Every result is above n, or empty: trim the smallest result above n (or the input).
    above = [r for r in results if len(r[2]) > n]
    if above:
        agg, v, f = min(above, key=lambda r: len(r[2]))
        steps.append(f"simplified (agg={agg:g})")
    else:
        v, f = np.asarray(vertices, dtype=np.float64), faces
    extra = len(f) - n
    v, f = _drop_smallest(v, f, extra)
    return Mesh(v, f, ", ".join([*steps, f"{extra} smallest dropped"]))


def build_mesh(mesh: str, triangles: int | None, rng_seed: int) -> Mesh:
    """The placed mesh of a spec's ``mesh``, ``triangles`` and ``rng_seed``. The soup is made at the count directly,
    and so is the heightfield above its base count: sampled on the finest grid it needs, then simplified (a
    finer grid of the same function is its exact subdivision; loop subdivision moves a grid's corners).

    >>> len(build_mesh("suzanne", 100, rng_seed=0).faces)
    100
    """
    if mesh == "soup":
        n = BASE_COUNTS["soup"] if triangles is None else triangles
        v, f = soup(n, rng_seed)
        return Mesh(place(mesh, v), f, "generated")
    v, f = base_mesh(mesh, rng_seed)
    if triangles is None:
        return Mesh(place(mesh, v), f, "base")
    if mesh == "heightfield" and triangles > len(f):
        cells = math.isqrt(-(-triangles // 2))
        cells += 2 * cells * cells < triangles
        fine_v, fine_f = heightfield(cells, rng_seed)
        m = with_triangle_count(place(mesh, fine_v, like=v), fine_f, triangles)
        return Mesh(m.vertices, m.faces, f"grid {cells}x{cells}" + ("" if m.method == "base" else f", {m.method}"))
    return with_triangle_count(place(mesh, v), f, triangles)
