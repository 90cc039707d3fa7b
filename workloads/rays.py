"""Ray sets for meshes (docs/methodology.md, "What is timed"), and their closest-hit reference answers: brute
force's, but solved only for *candidate* (ray, triangle) pairs, a superset of those that hit (exact culling)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..common import UserError
from . import mesh_files, ray_files
from .geometry import (
    dot,
    norm,
    normalise,
    random_in_ball,
    random_perpendicular,
    random_unit_vectors,
    round_to,
    sample_inside,
    triangle_areas,
    triangle_normals,
)
from .meshes import bounding_sphere, build_mesh
from .pairs import BARY_MARGIN
from .reference import intersect_pairs
from .spec import MeshSpec
from .workload import Workload, ambiguous_rays, library_versions

__all__ = [
    "EYE",
    "NEAR_MISS_ROUNDS",
    "ClosestAnswers",
    "camera_rays",
    "camera_candidates",
    "sphere_candidates",
    "closest_hits",
    "hit_rate_rays",
    "BOUNCE_OFFSET",
    "bounce_rays",
    "file_rays",
    "generate_mesh_workload",
]

EYE = np.array([0.0, 0.0, 2.0])
NEAR_MISS_ROUNDS = 8
#: A bounce leaves its hit point this far along the normal, relative to the mesh's scale.
BOUNCE_OFFSET = 1e-4
_MAX_ROUNDS = 40
_CANDIDATE_CHUNK = 1 << 20  # candidate pairs gathered at once (bounds memory)
_CULL_CHUNK = 1 << 22  # ray x triangle pairs examined at once, at most


@dataclass(frozen=True, eq=False)
class ClosestAnswers:
    """Closest-hit reference answers for M rays (a workload's ``ref_*``); ``test_hits`` counts every (ray,
    triangle) pair that hits, closest or not, ``tests`` the candidate pairs solved."""

    index: np.ndarray
    t: np.ndarray
    edge_margin: np.ndarray
    edge_clearance: np.ndarray
    test_hits: int
    tests: int


def camera_rays(width: int, height: int) -> tuple[np.ndarray, np.ndarray]:
    """Origins and unit directions of the seed's camera, float64, row-major from the top left.

    >>> o, d = camera_rays(2, 1)
    >>> o[0].tolist(), d.round(3).tolist()
    ([0.0, 0.0, 2.0], [[-0.243, 0.0, -0.97], [0.243, 0.0, -0.97]])
    """
    i, j = np.meshgrid(np.arange(width), np.arange(height))
    x = (2.0 * i.ravel() + 1.0 - width) / width  # pixel centres on z = 0
    y = (height - 2.0 * j.ravel() - 1.0) / height
    target = np.column_stack([x, y, np.zeros_like(x)])
    return np.repeat(EYE[None], len(x), axis=0), normalise(target - EYE)


def _boxes_to_pairs(i0, i1, j0, j1, width: int) -> tuple[np.ndarray, np.ndarray]:
    """Every (ray, triangle) pair of the inclusive pixel boxes ``[i0, i1] x [j0, j1]`` per triangle."""
    nx = np.maximum(i1 - i0 + 1, 0)
    ny = np.maximum(j1 - j0 + 1, 0)
    count = nx * ny
    tri = np.repeat(np.arange(len(count)), count)
    local = np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count)
    i = i0[tri] + local % nx[tri]
    j = j0[tri] + local // nx[tri]
    return j * width + i, tri


def camera_candidates(triangles: np.ndarray, width: int, height: int) -> tuple[np.ndarray, np.ndarray]:
    """(ray, triangle) index pairs that may hit, for the seed's camera: the pixels of each triangle's projected
    bounding box grown by one pixel.

    >>> tri = np.array([[[-0.1, -0.1, 0], [0.1, -0.1, 0], [0, 0.1, 0]]])
    >>> rays, tris = camera_candidates(tri, 4, 4)
    >>> sorted(rays.tolist())  # the four central pixels, and their neighbours
    [0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15]
    """
    tri = np.asarray(triangles, dtype=np.float64)
    z = tri[:, :, 2]
    ez = EYE[2]
    front = z.max(axis=1) < ez - 1e-9 * max(1.0, ez)
    straddle = ~front & (z.min(axis=1) < ez)  # neither wholly in front nor wholly behind
    s = np.where(front[:, None], ez / np.where(front[:, None], ez - z, 1.0), 0.0)  # projection onto z = 0
    px = (s * tri[:, :, 0] + 1.0) * (width / 2.0) - 0.5  # pixel i has its centre at px = i
    py = (1.0 - s * tri[:, :, 1]) * (height / 2.0) - 0.5
    i0 = np.maximum(np.floor(px.min(axis=1)) - 1, 0).astype(np.int64)
    i1 = np.minimum(np.ceil(px.max(axis=1)) + 1, width - 1).astype(np.int64)
    j0 = np.maximum(np.floor(py.min(axis=1)) - 1, 0).astype(np.int64)
    j1 = np.minimum(np.ceil(py.max(axis=1)) + 1, height - 1).astype(np.int64)
    i1[~front], j1[~front] = -1, -1  # empty boxes; straddlers are added below
    rays, tris = _boxes_to_pairs(i0, i1, j0, j1, width)
    m = width * height
    wide = np.flatnonzero(straddle)
    if len(wide):
        rays = np.concatenate([rays, np.tile(np.arange(m), len(wide))])
        tris = np.concatenate([tris, np.repeat(wide, m)])
    return rays, tris


def _near(w: np.ndarray, d: np.ndarray, radius: np.ndarray) -> np.ndarray:
    """Whether the line ``t d`` (unit d, t >= -radius) passes within ``radius`` of ``w``."""
    along, w2 = dot(w, d), dot(w, w)
    reach = radius + 1e-6 * np.sqrt(w2)  # grown so rounding never drops a hit
    return (w2 - along * along <= reach * reach) & (along >= -reach)


def sphere_candidates(
    origins: np.ndarray, directions: np.ndarray, triangles: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """(ray, triangle) index pairs whose ray line passes through the triangle's bounding sphere (grown by 1e-6 of
    the distance), tested a group of nearby triangles at a time.

    >>> tri = np.array([[[0., 0, 0], [1, 0, 0], [0, 1, 0]], [[5., 5, 0], [6, 5, 0], [5, 6, 0]]])
    >>> sphere_candidates([[0.2, 0.2, 1]], [[0, 0, -1]], tri)
    (array([0]), array([0]))
    """
    o = np.asarray(origins, dtype=np.float64)
    d = normalise(np.asarray(directions, dtype=np.float64))  # the line, whatever |d|
    tri = np.asarray(triangles, dtype=np.float64)
    centre = (tri[:, 0] + tri[:, 1] + tri[:, 2]) / 3.0
    radius = norm(tri - centre[:, None]).max(axis=1)

    # Groups: about 32 triangles per occupied cell of a g x g x g grid.
    g = max(1, int(np.ceil((len(tri) / 32.0) ** (1.0 / 3.0))))
    lo, span = centre.min(axis=0), np.ptp(centre, axis=0) + 1e-300
    cell = np.minimum((g * (centre - lo) / span).astype(np.int64), g - 1)
    key = (cell[:, 0] * g + cell[:, 1]) * g + cell[:, 2]
    members = np.argsort(key, kind="stable")
    starts = np.flatnonzero(np.r_[True, key[members][1:] != key[members][:-1]])
    sizes = np.diff(np.r_[starts, len(members)])
    g_centre = np.add.reduceat(centre[members], starts) / sizes[:, None]
    g_radius = np.maximum.reduceat(norm(centre[members] - np.repeat(g_centre, sizes, axis=0)) + radius[members], starts)

    rays_out, tris_out = [np.zeros(0, np.int64)], [np.zeros(0, np.int64)]
    step = max(1, _CULL_CHUNK // len(tri))  # bounds the expanded pairs, even if every group is near
    for first in range(0, len(o), step):
        r_o, r_d = o[first : first + step], d[first : first + step]
        r, grp = np.nonzero(_near(g_centre[None] - r_o[:, None], r_d[:, None], g_radius[None]))
        # Expand each (ray, group) to the group's triangles, then test their own spheres.
        n = sizes[grp]
        r = np.repeat(r, n)
        k = members[np.repeat(starts[grp], n) + np.arange(n.sum()) - np.repeat(np.cumsum(n) - n, n)]
        keep = _near(centre[k] - r_o[r], r_d[r], radius[k])
        rays_out.append(r[keep] + first)
        tris_out.append(k[keep])
    return np.concatenate(rays_out), np.concatenate(tris_out)


def closest_hits(
    origins, directions, triangles, rays: np.ndarray, tris: np.ndarray, t_max: np.ndarray | None = None
) -> ClosestAnswers:
    """Closest hit per ray among candidate pairs ``(rays[c], tris[c])``, by the float64 reference: brute force's
    when the candidates include every pair that hits. ``t_max`` (per ray; None: no limit) as the kernels apply it.

    >>> tri = np.array([[[0., 0, 0], [1, 0, 0], [0, 1, 0]], [[0., 0, 1], [1, 0, 1], [0, 1, 1]]])
    >>> a = closest_hits([[0.2, 0.2, 3]], [[0, 0, -1]], tri, np.array([0, 0]), np.array([0, 1]))
    >>> a.index.tolist(), a.t.tolist(), a.test_hits
    ([1], [2.0], 2)
    """
    o = np.asarray(origins, dtype=np.float64)
    d = np.asarray(directions, dtype=np.float64)
    tri = np.asarray(triangles, dtype=np.float64)
    m, c = len(o), len(rays)
    limit = np.full(m, np.inf) if t_max is None else np.asarray(t_max, dtype=np.float64)
    t = np.empty(c)
    hit = np.empty(c, dtype=bool)
    margin = np.empty(c)
    clearance = np.empty(c)
    for lo in range(0, c, _CANDIDATE_CHUNK):
        r, k = rays[lo : lo + _CANDIDATE_CHUNK], tris[lo : lo + _CANDIDATE_CHUNK]
        ans = intersect_pairs(o[r], d[r], tri[k], t_max=limit[r])
        part = slice(lo, lo + len(r))
        t[part], hit[part], margin[part], clearance[part] = ans.t, ans.hit, ans.edge_margin, ans.clearance

    # Closest hit: sort hits by (ray, t, triangle) and keep the first of each ray.
    index = np.full(m, -1, dtype=np.int64)
    best = np.full(m, np.inf)
    hr, ht, hk = rays[hit], t[hit], tris[hit]
    order = np.lexsort((hk, ht, hr))
    first = order[np.r_[True, hr[order][1:] != hr[order][:-1]]] if len(order) else order
    index[hr[first]] = hk[first]
    best[hr[first]] = ht[first]

    # Margin: the nearest brush with an edge among crossings that could decide the answer.
    with np.errstate(invalid="ignore"):
        decisive = np.isfinite(t) & (t > 0) & (t <= best[rays])
    nearest, clearest = np.full(m, np.inf), np.full(m, np.inf)
    np.minimum.at(nearest, rays[decisive], np.abs(margin[decisive]))
    np.minimum.at(clearest, rays[decisive], np.abs(clearance[decisive]))
    found = index >= 0
    return ClosestAnswers(
        index=index,
        t=np.where(found, best, np.nan),
        edge_margin=np.where(found, nearest, -nearest),
        edge_clearance=np.where(found, clearest, -clearest),
        test_hits=int(hit.sum()),
        tests=c,
    )


def hit_rate_rays(triangles: np.ndarray, n: int, hit_rate: float, dtype: str, rng: np.random.Generator):
    """The ``hit_rate`` ray set (docs/methodology.md, "What is timed"), misses aimed into the bounding ball (outside
    it after :data:`NEAR_MISS_ROUNDS` tries): origins and directions float64 rounded to ``dtype``, their
    :class:`ClosestAnswers`, and the figures ``misses_outside_bounding_sphere`` and ``redrawn_rays``."""
    tri = np.asarray(triangles, dtype=np.float64)
    centre, radius = bounding_sphere(tri.reshape(-1, 3))
    wants_hit = rng.permutation(np.arange(n) < round(hit_rate * n))
    area_cdf = np.cumsum(triangle_areas(tri))
    o, d = np.empty((n, 3)), np.empty((n, 3))
    far_miss = np.zeros(n, dtype=bool)
    todo, redrawn = np.arange(n), 0
    for attempt in range(_MAX_ROUNDS):
        aim = np.empty((len(todo), 3))
        start = centre + 2.0 * radius * random_unit_vectors(rng, len(todo))
        h = wants_hit[todo]
        # Hits aim at an area-weighted surface point.
        k = np.minimum(np.searchsorted(area_cdf, rng.random(h.sum()) * area_cdf[-1], side="right"), len(tri) - 1)
        b = sample_inside(rng, len(k), 2.0 * BARY_MARGIN)
        aim[h] = b[:, 0:1] * tri[k, 0] + b[:, 1:2] * tri[k, 1] + b[:, 2:3] * tri[k, 2]
        # Misses aim into the bounding ball, or at last pass outside it.
        far = ~h & (attempt >= NEAR_MISS_ROUNDS)
        aim[~h & ~far] = centre + radius * random_in_ball(rng, int((~h & ~far).sum()))
        line = random_unit_vectors(rng, int(far.sum()))
        side = random_perpendicular(rng, line)
        aim[far] = centre + radius * (1.05 + 0.45 * rng.random(len(line)))[:, None] * side
        start[far] = aim[far] - 3.0 * radius * line
        far_miss[todo] = far
        o[todo] = round_to(start, dtype)
        d[todo] = round_to(normalise(aim - start), dtype)
        ans = _closest_culled(o[todo], d[todo], tri)
        clear = np.abs(ans.edge_margin) >= BARY_MARGIN
        good = clear & ((ans.index >= 0) == h)
        todo = todo[~good]
        if not len(todo):
            break
        redrawn += len(todo)
    else:
        raise UserError(f"could not aim {len(todo)} ray(s) clear of every triangle edge; is the mesh degenerate?")
    return (
        o,
        d,
        _closest_culled(o, d, tri),
        {
            "misses_outside_bounding_sphere": int(far_miss.sum()),
            "redrawn_rays": redrawn,
        },
    )


def bounce_rays(triangles: np.ndarray, width: int, height: int, dtype: str, rng: np.random.Generator):
    """One cosine-distributed bounce from each camera ray's reference hit, leaving it on the camera's side
    :data:`BOUNCE_OFFSET` times the mesh's scale (bounding radius plus the centre's distance from the origin: a
    vertex's rounding grows with both): origins and directions float64 rounded to ``dtype``, their
    :class:`ClosestAnswers`, and the figures ``primary_rays``, ``primary_hits`` and ``bounce_offset``."""
    tri = np.asarray(triangles, dtype=np.float64)
    o, d = (round_to(a, dtype) for a in camera_rays(width, height))
    primary = closest_hits(o, d, tri, *camera_candidates(tri, width, height))
    rows = np.flatnonzero(primary.index >= 0)
    k = primary.index[rows]
    point = o[rows] + primary.t[rows, None] * d[rows]
    normal = normalise(triangle_normals(tri[k]))  # a hit triangle is not flat
    normal[dot(normal, d[rows]) > 0] *= -1  # the side the camera saw
    centre, radius = bounding_sphere(tri.reshape(-1, 3))
    offset = BOUNCE_OFFSET * (radius + float(norm(centre)))
    u = rng.random(len(rows))[:, None]
    direction = np.sqrt(u) * random_perpendicular(rng, normal) + np.sqrt(1.0 - u) * normal
    bo, bd = round_to(point + offset * normal, dtype), round_to(normalise(direction), dtype)
    figures = {"primary_rays": len(o), "primary_hits": len(rows), "bounce_offset": offset}
    return bo, bd, _closest_culled(bo, bd, tri), figures


def _closest_culled(o: np.ndarray, d: np.ndarray, tri: np.ndarray, t_max: np.ndarray | None = None) -> ClosestAnswers:
    return closest_hits(o, d, tri, *sphere_candidates(o, d, tri), t_max=t_max)


def file_rays(spec: MeshSpec, triangles: np.ndarray):
    """The rays of ``spec``'s ray file, rounded to its dtype and checked again: origins, directions and ``t_max``
    (or None) as float64, and their :class:`ClosestAnswers`."""
    assert spec.rays_sha256 is not None  # MeshSpec set it
    found = mesh_files.kept(spec.rays, spec.rays_sha256, mesh_files.RAYS_FOLDER)
    rays = ray_files.read_ray_file(found)
    if len(rays.origins) != spec.n_rays:
        raise UserError(f"ray file {found} holds {len(rays.origins)} rays, its spec says {spec.n_rays}")
    o, d, t_max = ray_files.rounded(rays, spec.dtype, f"ray file {found}")
    return o, d, t_max, _closest_culled(o, d, np.asarray(triangles, dtype=np.float64), t_max)


def generate_mesh_workload(spec: MeshSpec, workload_id: str) -> Workload:
    """Build the mesh workload of ``spec`` (no caching: see :func:`tribench.workloads.make`).

    >>> w = generate_mesh_workload(MeshSpec("icosphere", 20, rays="hit_rate", n_rays=10), "doc")
    >>> w.triangles.shape, int(w.hits.sum())
    ((20, 3, 3), 5)
    """
    if spec.is_file:  # the file with the content the spec names, wherever it now is
        assert spec.mesh_sha256 is not None  # MeshSpec set it
        mesh = build_mesh(str(mesh_files.kept(spec.mesh, spec.mesh_sha256)), spec.triangles, spec.rng_seed)
    else:
        mesh = build_mesh(spec.mesh, spec.triangles, spec.rng_seed)
    tri = round_to(mesh.triangles, spec.dtype)
    figures: dict = {}
    t_max = None
    if spec.rays_from_file:
        o, d, t_max, ans = file_rays(spec, tri)
    elif spec.rays == "camera":
        assert spec.width is not None and spec.height is not None  # MeshSpec set them
        o, d = (round_to(a, spec.dtype) for a in camera_rays(spec.width, spec.height))
        ans = closest_hits(o, d, tri, *camera_candidates(tri, spec.width, spec.height))
    elif spec.rays == "bounce":
        assert spec.width is not None and spec.height is not None  # MeshSpec set them
        o, d, ans, figures = bounce_rays(tri, spec.width, spec.height, spec.dtype, np.random.default_rng(spec.rng_seed))
    else:
        rng = np.random.default_rng(spec.rng_seed)
        assert spec.n_rays is not None and spec.hit_rate is not None  # MeshSpec set them
        o, d, ans, figures = hit_rate_rays(tri, spec.n_rays, spec.hit_rate, spec.dtype, rng)
    m, k = len(o), len(tri)
    hits = int((ans.index >= 0).sum())
    centre, radius = bounding_sphere(tri.reshape(-1, 3))
    achieved = {
        "triangles": k,
        "vertices": len(mesh.vertices),
        "count_method": mesh.method,
        "rays": m,
        "ray_hits": hits,
        "ray_hit_rate": hits / m,
        "tests": m * k,
        "test_hits": ans.test_hits,
        "test_hit_rate": ans.test_hits / (m * k),
        "ambiguous_rays": int(ambiguous_rays(ans.edge_margin, ans.edge_clearance, spec.dtype).sum()),
        "reference_tests": ans.tests,
        "bounding_sphere": {"centre": centre.tolist(), "radius": radius},
        **figures,
        "generated_with": library_versions("numpy", "trimesh", "fast-simplification"),
    }
    return Workload(
        workload_id=workload_id,
        spec=spec,
        origins=o.astype(spec.dtype),
        directions=d.astype(spec.dtype),
        triangles=tri.astype(spec.dtype),
        t_max=None if t_max is None else t_max.astype(spec.dtype),
        ref_index=ans.index,
        ref_t=ans.t,
        ref_edge_margin=ans.edge_margin,
        ref_edge_clearance=ans.edge_clearance,
        achieved=achieved,
    )
