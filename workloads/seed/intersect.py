"""What the seed tracer's rays meet, in file order (:mod:`.trace`): planes and spheres in NumPy, triangles by kernel."""

from __future__ import annotations

import time

import numpy as np

from ...common import UserError
from ..geometry import dot
from ..reference import intersect_closest as _reference_closest
from .records import MISS, PLANE, SPHERE, TRIANGLE
from .scene import Scene

PLANE_EPS = 1e-4  # Plan.cpp: PL_EPSILON, on t
SPHERE_EPS = 1e-4  # Sphere.cpp: SP_EPSILON, on the discriminant
TRIANGLE_EPS = 1e-4  # Triangle.cpp: TRI_EPSILON (inside the kernels); also the reference's t_min

# Largest rays x triangles product the float64 reference (kernel=None) is asked for.
REFERENCE_LIMIT = 50_000_000


def _plane_t(scene: Scene, o: np.ndarray, d: np.ndarray) -> np.ndarray:
    """t (P, M) of every plane, inf for a miss (Plan::intersecte)."""
    pl = scene.planes
    denom = d @ pl[:, :3].T  # (M, P)
    num = o @ pl[:, :3].T + pl[:, 3]
    with np.errstate(divide="ignore", invalid="ignore"):
        t = -num / denom
    return np.where((denom != 0) & (t >= PLANE_EPS), t, np.inf).T


def _sphere_t(scene: Scene, o: np.ndarray, d: np.ndarray) -> np.ndarray:
    """t (S, M) of every sphere, inf for a miss (Sphere::intersecte; coupe is the same test)."""
    sp = scene.spheres
    out = np.full((len(sp), len(o)), np.inf)
    a = dot(d, d)
    for s, (cx, cy, cz, r) in enumerate(sp):
        oc = o - np.array([cx, cy, cz])
        b = 2.0 * dot(d, oc)
        c = dot(oc, oc) - r * r
        disc = b * b - 4.0 * a * c
        ok = disc >= SPHERE_EPS
        t = (-b - np.sqrt(np.where(ok, disc, 0.0))) / (2.0 * a)  # the smaller root
        out[s] = np.where(ok & (t >= 0.0), t, np.inf)
    return out


def _triangles_closest(
    scene: Scene, kernel: str | None, dtype: np.dtype, o: np.ndarray, d: np.ndarray, clock: list[float]
) -> tuple[np.ndarray, np.ndarray]:
    """Closest triangle (index, t as float64; -1 and inf for none) for every ray."""
    m, k = len(o), len(scene.triangles)
    if m == 0 or k == 0:
        return np.full(m, -1, np.int64), np.full(m, np.inf)
    start = time.perf_counter()
    if kernel is None:
        if m * k > REFERENCE_LIMIT:
            raise UserError(
                f"the float64 reference (kernel=None) would solve {m} x {k} ray-triangle systems; "
                f"use a C kernel or a smaller image (limit {REFERENCE_LIMIT:,})"
            )
        index, t = _reference_closest(o, d, scene.triangles, t_min=TRIANGLE_EPS)
    else:
        from ... import ext

        cast = lambda a: np.ascontiguousarray(a, dtype=dtype)  # noqa: E731
        index, t = ext.intersect_closest(kernel, cast(o), cast(d), cast(scene.triangles))
    clock[0] += time.perf_counter() - start
    t = np.where(index >= 0, t.astype(np.float64), np.inf)
    return index, t


def _closest(scene: Scene, kernel, dtype, o, d, clock):
    """Closest object of every ray in the seed's file order: kind, index, t, and the triangle answer."""
    tri_index, tri_t = _triangles_closest(scene, kernel, dtype, o, d, clock)
    t_of = {PLANE: _plane_t(scene, o, d), SPHERE: _sphere_t(scene, o, d)}  # (0, M) for a kind the scene lacks
    cands, kinds, idxs = [], [], []  # in file order
    tri_done = False
    for kind, i in scene.objects.tolist():
        if kind != TRIANGLE:
            cands.append(t_of[kind][i])
            kinds.append(kind)
            idxs.append(np.full(len(o), i, np.int64))
        elif not tri_done:  # the triangles as one group, at the first triangle's place
            cands.append(tri_t)
            kinds.append(TRIANGLE)
            idxs.append(tri_index)
            tri_done = True
    m = len(o)
    if not cands:
        return (np.full(m, MISS, np.int8), np.full(m, -1, np.int64), np.full(m, np.inf), tri_index, tri_t)
    t_all = np.vstack(cands)
    best = np.argmin(t_all, axis=0)  # the first of equal minima: the earlier object wins ties
    t = t_all[best, np.arange(m)]
    found = np.isfinite(t)
    kind = np.where(found, np.array(kinds, np.int8)[best], MISS).astype(np.int8)
    index = np.where(found, np.vstack(idxs)[best, np.arange(m)], -1)
    return kind, index, t, tri_index, tri_t


def _occluders(scene: Scene, kernel, dtype, o, d, clock):
    """Shadow test (Scene::coupe): kind of the first occluder in file order; planes never occlude."""
    m = len(o)
    tri_index, tri_t = _triangles_closest(scene, kernel, dtype, o, d, clock)
    kind = np.full(m, MISS, np.int8)
    index = np.full(m, -1, np.int64)
    sphere_pos = [pos for pos, (k, _) in enumerate(scene.objects.tolist()) if k == SPHERE]
    tri_pos = np.flatnonzero(scene.objects[:, 0] == TRIANGLE)
    ts = _sphere_t(scene, o, d)
    # first sphere (in file order) that cuts each ray
    first_sphere_pos = np.full(m, np.iinfo(np.int64).max)
    first_sphere = np.full(m, -1, np.int64)
    for s in range(len(scene.spheres) - 1, -1, -1):
        cut = np.isfinite(ts[s])
        first_sphere_pos[cut] = sphere_pos[s]
        first_sphere[cut] = s
    # a triangle occluder's file position is at least that of the first triangle
    tri_first_pos = tri_pos[tri_index] if len(tri_pos) else np.zeros(m, np.int64)
    tri_cut = tri_index >= 0
    sphere_cut = first_sphere >= 0
    sphere_first = sphere_cut & (~tri_cut | (first_sphere_pos < np.where(tri_cut, tri_first_pos, 0)))
    # Only the kind is exact for triangles: the seed's first occluding triangle in
    # file order may be another than the nearest one reported by the kernel.
    kind[sphere_first] = SPHERE
    index[sphere_first] = first_sphere[sphere_first]
    by_tri = tri_cut & ~sphere_first
    kind[by_tri] = TRIANGLE
    index[by_tri] = tri_index[by_tri]
    return kind, index, tri_index, tri_t
