"""The seed's Whitted ray tracer, vectorised, with the ray stream it shoots.

:func:`trace` renders a :class:`~tribench.workloads.seed_scene.Scene` as the
seed's renderer does (C. Renaud's teaching ray tracer with Vitse's triangle
tests, ``LR/Src`` of github.com/Weamix/InitiationALaRecherche) and records
every ray it shoots, by kind: ``primary``, ``reflected`` and ``shadow``.
Planes and spheres are intersected here in NumPy float64; triangles through
a C kernel, ``tribench.ext.intersect_closest(kernel, ...)``, at the chosen
precision (or the float64 reference with ``kernel=None``). All rays of one
generation are processed at once; no per-pixel Python loop.

The seed's semantics, and where the seed's code says so
--------------------------------------------------------
Camera (``Camera.cpp``, ``lr.cpp``)
    Eye (0, 0, 2); the image plane z = 0 spans [-1, 1]^2; pixel (i, j), i the
    column from the left and j the row from the top, is aimed at its centre
    (-1 + (i + 1/2) 2/W, 1 - (j + 1/2) 2/H, 0). The direction is normalised.
    512 x 512 (``Image im(512,512)``). The seed loops over columns then rows
    (``for i ... for j``): see :meth:`Trace.seed_order`.
Closest hit (``Scene::intersecte``)
    Every object in file order, brute force; a hit replaces the current one
    only if strictly nearer (ties go to the earlier object).
Planes (``Plan.cpp``)
    ``a x + b y + c z + d = 0``; parallel only when the denominator is exactly
    0; a hit needs ``t >= 1e-4``. ``Plan::coupe`` returns false at once:
    **planes cast no shadows**.
Spheres (``Sphere.cpp``)
    Quadratic with ``a = d.d``; a miss when the discriminant is ``< 1e-4``
    (an absolute epsilon on the discriminant, not on t); ``t`` is the smaller
    root and a hit needs ``t >= 0`` (so a ray starting inside a sphere misses
    it). The shadow test (``coupe``) is the same test.
Triangles (``Triangle.cpp``, final version)
    The kernel: Curless (``t < 1e-4`` rejects, strict edges) or Moller
    (``|det| < 1e-4`` rejects, ``t > 1e-4``), the same test for closest hits
    and for shadows. The normal is ``normalise((v1 - v0) x (v2 - v0))``, never
    flipped toward the viewer.
Shading (``Intersection::getCouleur``, ``Objet::calculerDirect``, ``calculerAmbiant``)
    colour = ambient + direct (+ reflected). Ambient: ``ka * colour * ambient``.
    For each light, in order: **one shadow ray** from the hit point ``p``
    (no offset) with direction ``light - p``, **not normalised** (so ``t = 1``
    at the light), tested against every object in file order until the first
    that cuts it (``Scene::coupe``), with **no upper bound on t**: an object
    beyond the light still shadows. A shadowed light adds nothing. Otherwise,
    with ``l = normalise(light - p)`` and ``n.l = ps``: diffuse
    ``kd * colour * ps * I`` if ``ps > 0``; specular ``ks * (v.r)^shininess * I``
    if ``v.r > 0``, where ``v = normalise(observer - p)`` and
    ``r = normalise(2 ps n - l)`` (computed even when ``ps <= 0``, as the seed does).
Reflection (``Intersection::getCouleur``, ``Objet::getReflechi``)
    If the remaining depth is > 0 and ``ks != 0``: one reflected ray from ``p``
    (no offset), direction ``normalise(2 (n.v) n - v)``; if it hits, the colour
    computed there (with the observer at ``p``, depth - 1) is **added unweighted**
    (not multiplied by ks); if it misses, nothing is added (not the background).
Depth 2 (``#define PROF 2`` in ``lr.cpp``)
    The primary hit is shaded with depth 2, so a pixel shoots at most two
    reflected rays: primary, first bounce, second bounce (whose hit is shaded
    but reflects no further).
Pixels (``Couleur::getRougei``, ``Image::sauver``)
    No clamping while shading; on output a channel ``> 1`` becomes 255, else
    ``int(x * 255)`` (truncation). A primary miss takes the background colour.

Deviations: the seed computes in single precision with non-inlined helpers
(``Vecteur`` holds floats); here planes, spheres, shading and ray set-up are
float64 and only the triangle tests run at the chosen precision. The sphere's
``c`` is computed as ``|o - c|^2 - r^2`` (the seed expands it).

Examples
--------
>>> from tribench.workloads.seed_scene import parse_scene
>>> s = parse_scene("source 0 5 0 1 1 1\\nmateriau 1 0 0 0.1 0.5 0 10\\n"
...                 "tri -1 -1 -1  1 -1 -1  0 1 -1\\n")
>>> tr = trace(s, "moller_seed", "float64", width=4, height=4)
>>> tr.counts
{'primary': 16, 'reflected': 0, 'shadow': 2, 'total': 18}
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import BinaryIO, cast

import numpy as np

from tribench.common import UserError, atomic_write

from .reference import intersect_closest as _reference_closest
from .seed_scene import Scene

__all__ = [
    "DEPTH",
    "EYE",
    "KINDS",
    "RaySet",
    "Trace",
    "camera_rays",
    "difference_mask",
    "edge_margins",
    "pixel_edge_margins",
    "save_mask_png",
    "trace",
]

EYE = np.array([0.0, 0.0, 2.0])
DEPTH = 2  # lr.cpp: #define PROF 2
KINDS = ("primary", "reflected", "shadow")

PLANE_EPS = 1e-4  # Plan.cpp: PL_EPSILON, on t
SPHERE_EPS = 1e-4  # Sphere.cpp: SP_EPSILON, on the discriminant
TRIANGLE_EPS = 1e-4  # Triangle.cpp: TRI_EPSILON (inside the kernels); also the reference's t_min

# hit kinds stored per ray
MISS, PLANE, SPHERE, TRIANGLE = -1, Scene.PLANE, Scene.SPHERE, Scene.TRIANGLE

# Largest rays x triangles product the float64 reference (kernel=None) is asked for.
REFERENCE_LIMIT = 50_000_000


# ---------------------------------------------------------------- ray records


@dataclass(frozen=True, eq=False)
class RaySet:
    """Rays of one kind, as the seed shot them, with what they hit. All arrays length N.

    Attributes
    ----------
    origins, directions : float64 (N, 3)
        Exactly as shot: primary and reflected directions are unit vectors,
        shadow directions are ``light - p`` (not normalised; ``t = 1`` at the light).
    pixel : int64
        Row-major pixel index ``j * width + i`` the ray contributes to.
    depth : int8
        Generation of the ray (primary 0, reflected 1 or 2); for a shadow ray,
        the generation of the ray whose hit point it leaves.
    light : int16
        Light index for a shadow ray, -1 otherwise.
    hit_kind, hit_index : int8, int64
        Primary and reflected rays: the closest object (kind -1 none, 0 plane,
        1 sphere, 2 triangle; index within its kind). Shadow rays: the
        occluder: -1 when the light is visible; a sphere if one cuts the ray
        and comes before the nearest cutting triangle in file order (the
        seed stops at the first occluder in file order; this is exact when the
        spheres precede the triangles, as in both built-in scenes); else the
        nearest cutting triangle.
    triangle, t_triangle : int64, float64
        Closest triangle the kernel hit, whatever else is nearer (-1 and nan
        for none): what the triangle tests of this ray answer.
    """

    origins: np.ndarray
    directions: np.ndarray
    pixel: np.ndarray
    depth: np.ndarray
    light: np.ndarray
    hit_kind: np.ndarray
    hit_index: np.ndarray
    triangle: np.ndarray
    t_triangle: np.ndarray

    def __len__(self) -> int:
        return len(self.origins)

    @property
    def hit(self) -> np.ndarray:
        """Closest rays: hit something; shadow rays: occluded."""
        return self.hit_kind >= 0

    @staticmethod
    def concatenate(parts: list[RaySet]) -> RaySet:
        if not parts:
            return RaySet.empty()
        return RaySet(*(np.concatenate([getattr(p, f) for p in parts]) for f in RaySet.__dataclass_fields__))

    @staticmethod
    def empty() -> RaySet:
        z3 = np.zeros((0, 3))
        i64 = np.zeros(0, np.int64)
        return RaySet(
            z3,
            z3.copy(),
            i64,
            np.zeros(0, np.int8),
            np.zeros(0, np.int16),
            np.zeros(0, np.int8),
            i64.copy(),
            i64.copy(),
            np.zeros(0),
        )


@dataclass(frozen=True, eq=False)
class Trace:
    """One render of a scene with one triangle kernel: the image and the rays shot.

    Attributes
    ----------
    scene : Scene
    kernel : str or None
        ``None``: the float64 reference.
    dtype : str
        Precision of the triangle tests.
    width, height, depth : int
    image : float64 (height, width, 3)
        Colours as the seed computes them, not clamped (see :meth:`to_uint8`).
    primary, reflected, shadow : RaySet
    elapsed_s : float
        Wall time of the whole render; ``triangle_s`` of it in triangle tests.
    """

    scene: Scene
    kernel: str | None
    dtype: str
    width: int
    height: int
    depth: int
    image: np.ndarray
    primary: RaySet
    reflected: RaySet
    shadow: RaySet
    elapsed_s: float
    triangle_s: float
    extra: dict = field(default_factory=dict)

    @property
    def counts(self) -> dict[str, int]:
        """Rays shot per kind, and in total."""
        c = {k: len(getattr(self, k)) for k in KINDS}
        c["total"] = sum(c.values())
        return c

    @property
    def primary_triangle(self) -> np.ndarray:
        """int64 (height, width): triangle seen by each pixel's primary ray, -1 if none."""
        p = self.primary
        seen = np.where(p.hit_kind == TRIANGLE, p.hit_index, -1)
        out = np.full(self.width * self.height, -1, dtype=np.int64)
        out[p.pixel] = seen
        return out.reshape(self.height, self.width)

    @property
    def triangle_tests(self) -> dict[str, int]:
        """Ray-triangle tests a brute-force replay runs per kind (every ray against every triangle).

        The seed's shadow test stops at the first occluder in file order, so
        it runs fewer (see :meth:`RaySet`); this is the closest-hit count.
        """
        k = len(self.scene.triangles)
        return {kind: len(getattr(self, kind)) * k for kind in KINDS}

    def to_uint8(self) -> np.ndarray:
        """The image as the seed writes it: ``> 1`` gives 255, else ``int(x * 255)``."""
        x = self.image
        return np.where(x > 1.0, 255, np.floor(np.maximum(x, 0.0) * 255.0)).astype(np.uint8)

    def to_png(self, path: str | Path) -> Path:
        """Save the image as PNG (matplotlib's ``imsave``); returns the path."""
        import matplotlib

        matplotlib.use("Agg", force=False)
        import matplotlib.pyplot as plt

        path = Path(path)
        with atomic_write(path, "wb") as f:
            plt.imsave(cast(BinaryIO, f), self.to_uint8(), format="png")
        return path

    def seed_order(self) -> tuple[np.ndarray, np.ndarray]:
        """The seed's shooting order: ``(kind, index)`` arrays over all rays.

        The seed renders pixel by pixel, columns outer and rows inner, and
        within a pixel depth first: the primary ray, the shadow rays of its
        hit (lights in order), the reflected ray, its hit's shadow rays, the
        next reflected ray, and so on. ``kind`` indexes :data:`KINDS`;
        ``index`` is the row within that kind's :class:`RaySet`.
        """
        keys, kinds, idx = [], [], []
        for k, name in enumerate(KINDS):
            rs = getattr(self, name)
            keys.append(self._order_key(rs, shadow=(name == "shadow")))
            kinds.append(np.full(len(rs), k, dtype=np.int8))
            idx.append(np.arange(len(rs)))
        key = np.concatenate(keys)
        order = np.argsort(key, kind="stable")
        return np.concatenate(kinds)[order], np.concatenate(idx)[order]

    def replay_rays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """All rays in the seed's order: ``origins, directions`` float64 (N, 3) and ``kind`` int8."""
        kind, idx = self.seed_order()
        o = np.empty((len(kind), 3))
        d = np.empty((len(kind), 3))
        for k, name in enumerate(KINDS):
            rs = getattr(self, name)
            sel = kind == k
            o[sel] = rs.origins[idx[sel]]
            d[sel] = rs.directions[idx[sel]]
        return o, d, kind

    # A per-pixel sequence number: the seed's position of each ray within its pixel.
    def _seq_stride(self) -> int:
        return (self.depth + 1) * (len(self.scene.lights) + 1)

    def _order_key(self, rs: RaySet, shadow: bool) -> np.ndarray:
        n_lights = len(self.scene.lights)
        seq = rs.depth.astype(np.int64) * (n_lights + 1)
        if shadow:
            seq = seq + 1 + rs.light.astype(np.int64)
        i, j = rs.pixel % self.width, rs.pixel // self.width
        column_major = i * self.height + j
        return column_major * self._seq_stride() + seq


# -------------------------------------------------------------------- camera


def camera_rays(width: int, height: int) -> tuple[np.ndarray, np.ndarray]:
    """The seed's primary rays, float64, row-major from the top-left pixel.

    >>> o, d = camera_rays(2, 1)
    >>> d.round(3).tolist()
    [[-0.243, 0.0, -0.97], [0.243, 0.0, -0.97]]
    """
    i, j = np.meshgrid(np.arange(width), np.arange(height))
    x = -1.0 + (2.0 * i.ravel() + 1.0) / width
    y = 1.0 - (2.0 * j.ravel() + 1.0) / height
    d = np.column_stack([x, y, np.zeros_like(x)]) - EYE
    d /= np.sqrt(np.einsum("ij,ij->i", d, d))[:, None]
    return np.repeat(EYE[None], len(x), axis=0), d


# ---------------------------------------------------------- object intersection


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1] + a[..., 2] * b[..., 2]


def _normalise(a: np.ndarray) -> np.ndarray:
    return a / np.sqrt(_dot(a, a))[..., None]


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
    a = _dot(d, d)
    for s, (cx, cy, cz, r) in enumerate(sp):
        oc = o - np.array([cx, cy, cz])
        b = 2.0 * _dot(d, oc)
        c = _dot(oc, oc) - r * r
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
        from tribench import ext

        cast = lambda a: np.ascontiguousarray(a, dtype=dtype)  # noqa: E731
        index, t = ext.intersect_closest(kernel, cast(o), cast(d), cast(scene.triangles))
    clock[0] += time.perf_counter() - start
    t = np.where(index >= 0, t.astype(np.float64), np.inf)
    return index, t


def _closest(scene: Scene, kernel, dtype, o, d, clock):
    """Closest object of every ray in the seed's file order: kind, index, t, and the triangle answer."""
    tri_index, tri_t = _triangles_closest(scene, kernel, dtype, o, d, clock)
    # candidates in file order; the triangles as one group at the first triangle's place
    tp = _plane_t(scene, o, d) if len(scene.planes) else None
    ts = _sphere_t(scene, o, d) if len(scene.spheres) else None
    cands, kinds, idxs = [], [], []
    tri_done = False
    for kind, i in scene.objects.tolist():
        if kind == TRIANGLE:
            if not tri_done:
                cands.append(tri_t)
                kinds.append(TRIANGLE)
                idxs.append(tri_index)
                tri_done = True
            continue
        t_kind = tp if kind == PLANE else ts
        assert t_kind is not None  # the scene has an object of this kind
        cands.append(t_kind[i])
        kinds.append(kind)
        idxs.append(np.full(len(o), i, np.int64))
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
    ts = _sphere_t(scene, o, d) if len(scene.spheres) else np.zeros((0, m))
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


def _normals(scene: Scene, kind: np.ndarray, index: np.ndarray, p: np.ndarray) -> np.ndarray:
    n = np.empty_like(p)
    sel = kind == PLANE
    if sel.any():
        n[sel] = _normalise(scene.planes[index[sel], :3])
    sel = kind == SPHERE
    if sel.any():
        n[sel] = _normalise(p[sel] - scene.spheres[index[sel], :3])
    sel = kind == TRIANGLE
    if sel.any():
        tri = scene.triangles[index[sel]]
        n[sel] = _normalise(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]))
    return n


def _material_arrays(scene: Scene, kind: np.ndarray, index: np.ndarray):
    mat_of = (scene.plane_material, scene.sphere_material, scene.triangle_material)
    m = np.empty(len(kind), np.int64)
    for k in (PLANE, SPHERE, TRIANGLE):
        sel = kind == k
        m[sel] = mat_of[k][index[sel]]
    table = np.array([[*x.colour, x.ka, x.kd, x.ks, x.shininess] for x in scene.materials]).reshape(-1, 7)
    return table[m]


def _rayset(o, d, pixel, depth, light, hit_kind, hit_index, tri_index, tri_t) -> RaySet:
    return RaySet(
        origins=np.ascontiguousarray(o, np.float64),
        directions=np.ascontiguousarray(d, np.float64),
        pixel=np.asarray(pixel, np.int64),
        depth=np.full(len(o), depth, np.int8) if np.isscalar(depth) else np.asarray(depth, np.int8),
        light=np.full(len(o), light, np.int16) if np.isscalar(light) else np.asarray(light, np.int16),
        hit_kind=np.asarray(hit_kind, np.int8),
        hit_index=np.asarray(hit_index, np.int64),
        triangle=np.asarray(tri_index, np.int64),
        t_triangle=np.where(tri_index >= 0, tri_t, np.nan),
    )


# --------------------------------------------------------------------- trace


def trace(
    scene: Scene,
    kernel: str | None = "moller_seed",
    dtype: str = "float32",
    width: int = 512,
    height: int = 512,
    depth: int = DEPTH,
) -> Trace:
    """Render ``scene`` as the seed does, recording every ray shot.

    Parameters
    ----------
    scene : Scene
    kernel : str or None
        A kernel of ``tribench.ext.kernel_names()`` for the triangle tests, or
        ``None`` for the float64 reference (closed triangles, ``t > 1e-4``;
        brute force, so only for small images).
    dtype : {"float32", "float64"}
        Precision of the triangle tests (ignored by the reference).
    width, height : int
        The seed renders 512 x 512.
    depth : int
        Reflection depth (the seed's ``PROF``, 2).

    Returns
    -------
    Trace
    """
    dt = np.dtype(dtype)
    if dt not in (np.dtype(np.float32), np.dtype(np.float64)):
        raise UserError(f"dtype must be float32 or float64, got {dtype!r}")
    if not (isinstance(width, (int, np.integer)) and isinstance(height, (int, np.integer))) or width < 1 or height < 1:
        raise UserError(f"width and height must be positive integers, got {width!r} and {height!r}")
    if depth < 0:
        raise UserError(f"depth must be >= 0, got {depth}")
    if kernel is not None:
        from tribench import ext

        if kernel not in ext.kernel_names():
            raise UserError(f"unknown kernel {kernel!r}; known kernels: {', '.join(ext.kernel_names())}")

    start = time.perf_counter()
    clock = [0.0]
    lights_p = np.array([light.position for light in scene.lights], dtype=np.float64).reshape(-1, 3)
    lights_i = np.array([light.intensity for light in scene.lights], dtype=np.float64).reshape(-1, 3)
    ambient = np.array(scene.ambient)
    colour = np.zeros((width * height, 3))

    o, d = camera_rays(width, height)
    pixel = np.arange(width * height, dtype=np.int64)
    closest_sets: list[RaySet] = []
    shadow_sets: list[RaySet] = []
    for gen in range(depth + 1):
        kind, index, t, tri_index, tri_t = _closest(scene, kernel, dt, o, d, clock)
        closest_sets.append(_rayset(o, d, pixel, gen, -1, kind, index, tri_index, tri_t))
        hit = kind != MISS
        if gen == 0:
            colour[pixel[~hit]] = scene.background
        if not hit.any():
            break
        o, d, pixel, kind, index, t = o[hit], d[hit], pixel[hit], kind[hit], index[hit], t[hit]
        p = o + t[:, None] * d
        n = _normals(scene, kind, index, p)
        mat = _material_arrays(scene, kind, index)
        base, ka, kd, ks, shine = mat[:, :3], mat[:, 3], mat[:, 4], mat[:, 5], mat[:, 6]
        view = _normalise(o - p)  # toward the observer: the eye, or the previous hit point

        shade = ka[:, None] * base * ambient
        for li in range(len(lights_p)):
            sd = lights_p[li] - p  # not normalised, as the seed shoots it
            s_kind, s_index, s_tri, s_tri_t = _occluders(scene, kernel, dt, p, sd, clock)
            shadow_sets.append(_rayset(p, sd, pixel, gen, li, s_kind, s_index, s_tri, s_tri_t))
            lit = s_kind == MISS
            inc = _normalise(sd)
            ps = _dot(n, inc)
            diffuse = np.where(lit & (ps > 0.0), kd * ps, 0.0)
            refl = _normalise(2.0 * ps[:, None] * n - inc)
            vr = _dot(view, refl)
            with np.errstate(invalid="ignore", over="ignore"):
                spec = np.where(lit & (vr > 0.0), ks * np.power(np.maximum(vr, 0.0), shine), 0.0)
            shade += (diffuse[:, None] * base + spec[:, None]) * lights_i[li]
        np.add.at(colour, pixel, shade)

        if gen == depth:
            break
        go = ks != 0.0
        if not go.any():
            break
        nv = _dot(n, view)
        r = _normalise(2.0 * nv[:, None] * n - view)
        o, d, pixel = p[go], r[go], pixel[go]

    primary = closest_sets[0]
    reflected = RaySet.concatenate(closest_sets[1:])
    shadow = RaySet.concatenate(shadow_sets)
    image = colour.reshape(height, width, 3)
    return Trace(
        scene=scene,
        kernel=kernel,
        dtype=str(dt),
        width=int(width),
        height=int(height),
        depth=int(depth),
        image=image,
        primary=primary,
        reflected=reflected,
        shadow=shadow,
        elapsed_s=time.perf_counter() - start,
        triangle_s=clock[0],
    )


# --------------------------------------------------------------- differences


def _hit_codes(tr: Trace) -> np.ndarray:
    """One int64 per ray: (pixel, position in the pixel's ray tree, what it hit)."""
    stride = tr._seq_stride()
    parts = []
    for name in KINDS:
        rs = getattr(tr, name)
        n_lights = len(tr.scene.lights)
        seq = rs.depth.astype(np.int64) * (n_lights + 1)
        if name == "shadow":
            seq = seq + 1 + rs.light.astype(np.int64)
            what = (rs.hit_kind >= 0).astype(np.int64)  # occluded or not: all the seed uses
        else:
            what = (rs.hit_kind.astype(np.int64) + 1) * (1 << 21) + (rs.hit_index + 1)
        key = rs.pixel * stride + seq
        parts.append(key * (1 << 23) + what)
    return np.concatenate(parts)


def difference_mask(a: Trace, b: Trace, by: str = "image") -> tuple[np.ndarray, int]:
    """Pixels where two traces of the same scene and image size differ.

    Parameters
    ----------
    by : {"image", "hits"}
        ``"image"`` (default): the 8-bit pixels differ -- what the seed's
        pictures show. ``"hits"``: the pixel's ray trees differ (an object hit
        by a primary or reflected ray, a shadow ray's occlusion, or a ray
        present in one trace only). Many more pixels differ by hits than by
        image: a last-bit difference in a triangle's ``t`` moves the hit point,
        and the seed's sphere test (``t >= 0``, no epsilon) then flips the
        self-occlusion of shadow rays leaving a sphere toward a light behind
        it, which changes no colour (such a light adds no diffuse term).

    Returns
    -------
    mask : bool (height, width)
    count : int
    """
    if (a.width, a.height) != (b.width, b.height):
        raise UserError(f"traces differ in size: {a.width}x{a.height} and {b.width}x{b.height}")
    if by == "image":
        mask = (a.to_uint8() != b.to_uint8()).any(axis=2)
    elif by == "hits":
        if len(a.scene.lights) != len(b.scene.lights) or a.depth != b.depth:
            raise UserError("traces of different scenes or depths cannot be compared by hits")
        diff = np.setxor1d(_hit_codes(a), _hit_codes(b))
        pixels = (diff >> 23) // a._seq_stride()
        mask = np.zeros(a.width * a.height, bool)
        mask[pixels] = True
        mask = mask.reshape(a.height, a.width)
    else:
        raise UserError(f"by must be 'hits' or 'image', got {by!r}")
    return mask, int(mask.sum())


def save_mask_png(mask: np.ndarray, path: str | Path, background: np.ndarray | None = None) -> Path:
    """Save a difference mask as PNG: differing pixels red, over a dimmed ``background`` image if given."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    h, w = mask.shape
    if background is None:
        rgb = np.full((h, w, 3), 255, np.uint8)
    else:
        rgb = (0.35 * np.asarray(background, np.float64) + 0.65 * 255).astype(np.uint8)
    rgb[mask] = (220, 0, 0)
    path = Path(path)
    with atomic_write(path, "wb") as f:
        plt.imsave(cast(BinaryIO, f), rgb, format="png")  # "wb": a binary file
    return path


def edge_margins(origins: np.ndarray, directions: np.ndarray, triangles: np.ndarray, t_min: float = 0.0) -> np.ndarray:
    """For each ray, how close it passes to the boundary of any triangle, in barycentric units.

    The smallest ``|min(u, v, w)|`` over the triangles whose plane the ray
    crosses at ``t > t_min`` (float64 reference barycentrics); ``inf`` if it
    crosses none. Near 0 means the ray passes next to an edge or a vertex,
    where two correct tests may disagree.
    """
    from .reference import intersect_pairs

    o = np.asarray(origins, np.float64)
    d = np.asarray(directions, np.float64)
    tri = np.asarray(triangles, np.float64)
    m, k = len(o), len(tri)
    out = np.full(m, np.inf)
    if m == 0 or k == 0:
        return out
    step = max(1, (1 << 18) // k)
    for lo in range(0, m, step):
        hi = min(lo + step, m)
        n = hi - lo
        ans = intersect_pairs(np.repeat(o[lo:hi], k, 0), np.repeat(d[lo:hi], k, 0), np.tile(tri, (n, 1, 1)))
        margin = np.abs(ans.edge_margin)
        with np.errstate(invalid="ignore"):
            margin = np.where(ans.t > t_min, margin, np.inf)
        margin = np.where(np.isnan(margin), np.inf, margin).reshape(n, k)
        out[lo:hi] = margin.min(axis=1)
    return out


def pixel_edge_margins(tr: Trace, mask: np.ndarray) -> np.ndarray:
    """For each pixel of ``mask`` (row-major order), the smallest :func:`edge_margins` of its rays."""
    pixels = np.flatnonzero(np.asarray(mask).ravel())
    best = np.full(len(pixels), np.inf)
    for name in KINDS:
        rs = getattr(tr, name)
        sel = np.isin(rs.pixel, pixels)
        if not sel.any():
            continue
        m = edge_margins(rs.origins[sel], rs.directions[sel], tr.scene.triangles)
        where = np.searchsorted(pixels, rs.pixel[sel])
        np.minimum.at(best, where, m)
    return best
