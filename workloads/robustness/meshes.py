"""The robustness suite's closest-mode tests (docs/methodology.md): coplanar grids and Embree's sphere."""

from __future__ import annotations

import numpy as np

from ..geometry import dot, normalise, round_to
from .sets import MeshRays, Size, _as, _dyadic_directions, _dyadic_plane, _exact

EMBREE_CENTRE = (148376.0, 1234.0, -223423.0)
EMBREE_RADIUS = 2.0
EMBREE_MAX_MISS_RATE = 2e-5  # 0.002%

_PLANE_NAMES = ("axis plane", "x+y+z=c", "dyadic plane")


def grid_topology(n: int) -> tuple[np.ndarray, list, list]:
    """Faces, interior edges and interior vertices of an ``n x n`` grid split along one diagonal.

    Vertex ``(i, j)`` is ``i (n + 1) + j``; cell ``(i, j)``, corners ``v00 v10 v11 v01``, has a lower
    triangle ``(v00, v10, v11)``, number ``2 (i n + j)``, and an upper one ``(v00, v11, v01)``, the next.
    Edges are ``(vertex, vertex, lower, upper)`` (every interior edge joins one of each), interior vertices
    ``(vertex, six incident triangles)``.

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
    """Mesh ``m``: its edge rays and its vertex rays (see :mod:`tribench.workloads.robustness`)."""
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
    """``inside_sphere``'s sphere: an icosphere of 20480 triangles, radius 2, at :data:`EMBREE_CENTRE`, in ``dtype``."""
    import trimesh  # lazy: slow to import

    fine = trimesh.creation.icosphere(subdivisions=5, radius=EMBREE_RADIUS)
    return round_to(np.asarray(fine.vertices) + np.array(EMBREE_CENTRE), dtype)[fine.faces]


#: The icosphere whose vertices group the sphere's rays: 162 patches of about 300 triangles each (at 3, the
#: kernel calls' fixed cost ruled: docs/decisions.md, "The robustness suite's time").
_PATCH_SUBDIVISIONS = 2


def _sphere(rng: np.random.Generator, size: Size, dtype: str) -> list[MeshRays]:
    """Embree's sphere test, rays grouped by exit region (see :mod:`tribench.workloads.robustness`)."""
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
    patches = np.asarray(trimesh.creation.icosphere(subdivisions=_PATCH_SUBDIVISIONS).vertices)
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
