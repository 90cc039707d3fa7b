"""The seed tracer's camera and shading (the seed's rules: docs/methodology.md, "The seed's replay"): primary
rays, a hit's normal and material, the light it gets from the lights its shadow rays reach."""

from __future__ import annotations

import numpy as np

from ..geometry import dot, normalise
from .records import PLANE, SPHERE, TRIANGLE
from .scene import Scene

EYE = np.array([0.0, 0.0, 2.0])


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


def _normals(scene: Scene, kind: np.ndarray, index: np.ndarray, p: np.ndarray) -> np.ndarray:
    n = np.empty_like(p)
    sel = kind == PLANE
    if sel.any():
        n[sel] = normalise(scene.planes[index[sel], :3])
    sel = kind == SPHERE
    if sel.any():
        n[sel] = normalise(p[sel] - scene.spheres[index[sel], :3])
    sel = kind == TRIANGLE
    if sel.any():
        tri = scene.triangles[index[sel]]
        n[sel] = normalise(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]))
    return n


def _material_arrays(scene: Scene, kind: np.ndarray, index: np.ndarray):
    mat_of = (scene.plane_material, scene.sphere_material, scene.triangle_material)
    m = np.empty(len(kind), np.int64)
    for k in (PLANE, SPHERE, TRIANGLE):
        sel = kind == k
        m[sel] = mat_of[k][index[sel]]
    table = np.array([[*x.colour, x.ka, x.kd, x.ks, x.shininess] for x in scene.materials]).reshape(-1, 7)
    return table[m]


def _direct(
    n: np.ndarray,
    view: np.ndarray,
    to_light: np.ndarray,
    lit: np.ndarray,
    material: np.ndarray,
) -> np.ndarray:
    """One light's diffuse plus specular colour at each hit, before its intensity (0 where not ``lit``);
    ``to_light`` is ``light - p``, ``view`` the unit vector toward the observer."""
    base, kd, ks, shine = material[:, :3], material[:, 4], material[:, 5], material[:, 6]
    inc = normalise(to_light)
    ps = dot(n, inc)
    diffuse = np.where(lit & (ps > 0.0), kd * ps, 0.0)
    refl = normalise(2.0 * ps[:, None] * n - inc)
    vr = dot(view, refl)
    with np.errstate(invalid="ignore", over="ignore"):
        spec = np.where(lit & (vr > 0.0), ks * np.power(np.maximum(vr, 0.0), shine), 0.0)
    return diffuse[:, None] * base + spec[:, None]


def _reflect(n: np.ndarray, view: np.ndarray) -> np.ndarray:
    """The mirror direction of ``view`` about ``n``, normalised (``Objet::getReflechi``)."""
    nv = dot(n, view)
    return normalise(2.0 * nv[:, None] * n - view)
