"""The seed's Whitted ray tracer, vectorised a generation of rays at a time, recording every ray it shoots:
planes and spheres in NumPy float64, triangles by a C kernel at the chosen precision or by the float64
reference. The seed's rules and the deviations from them: docs/methodology.md, "The seed's replay".

>>> from tribench.workloads.seed.scene import parse_scene
>>> s = parse_scene("source 0 5 0 1 1 1\\nmateriau 1 0 0 0.1 0.5 0 10\\n"
...                 "tri -1 -1 -1  1 -1 -1  0 1 -1\\n")
>>> tr = trace(s, "moller_seed", "float64", width=4, height=4)
>>> tr.counts
{'primary': 16, 'reflected': 0, 'shadow': 2, 'total': 18}
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from ...common import UserError
from ..geometry import normalise
from .differences import difference_mask, edge_margins, pixel_edge_margins, save_mask_png
from .intersect import _closest, _occluders
from .records import KINDS, MISS, RaySet, Trace, _rayset
from .scene import Scene
from .shading import EYE, _direct, _material_arrays, _normals, _reflect, camera_rays

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

DEPTH = 2  # lr.cpp: #define PROF 2


@dataclass
class _Render:
    """One render under way: what its generations share, the image they add to and the rays they shot."""

    scene: Scene
    kernel: str | None
    dtype: np.dtype
    colour: np.ndarray  # (pixels, 3), row-major, not clamped
    clock: list[float] = field(default_factory=lambda: [0.0])  # seconds spent in triangle tests
    closest: list[RaySet] = field(default_factory=list)  # the primary rays, then each reflected generation
    shadow: list[RaySet] = field(default_factory=list)


def _check_arguments(kernel: str | None, dtype: str, width: int, height: int, depth: int) -> np.dtype:
    """The triangle tests' dtype, once every argument of :func:`trace` is one it can take."""
    dt = np.dtype(dtype)
    if dt not in (np.dtype(np.float32), np.dtype(np.float64)):
        raise UserError(f"dtype must be float32 or float64, got {dtype!r}")
    if not (isinstance(width, (int, np.integer)) and isinstance(height, (int, np.integer))) or width < 1 or height < 1:
        raise UserError(f"width and height must be positive integers, got {width!r} and {height!r}")
    if depth < 0:
        raise UserError(f"depth must be >= 0, got {depth}")
    if kernel is not None:
        from ... import ext

        if kernel not in ext.kernel_names():
            raise UserError(f"unknown kernel {kernel!r}; known kernels: {', '.join(ext.kernel_names())}")
    return dt


def _shade(
    r: _Render, gen: int, pixel: np.ndarray, p: np.ndarray, n: np.ndarray, view: np.ndarray, mat: np.ndarray
) -> np.ndarray:
    """Each hit's colour: ambient, then every light its shadow ray reaches (the shadow rays are recorded)."""
    base, ka = mat[:, :3], mat[:, 3]
    shade = ka[:, None] * base * np.array(r.scene.ambient, np.float64)
    for li, light in enumerate(r.scene.lights):
        sd = np.array(light.position, np.float64) - p  # not normalised, as the seed shoots it
        s_kind, s_index, s_tri, s_tri_t = _occluders(r.scene, r.kernel, r.dtype, p, sd, r.clock)
        r.shadow.append(_rayset(p, sd, pixel, gen, li, s_kind, s_index, s_tri, s_tri_t))
        shade += _direct(n, view, sd, s_kind == MISS, mat) * np.array(light.intensity, np.float64)
    return shade


def _generation(
    r: _Render, gen: int, depth: int, o: np.ndarray, d: np.ndarray, pixel: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """Shoot one generation of rays and add the colour of what they hit; the reflected rays to shoot next, if any."""
    kind, index, t, tri_index, tri_t = _closest(r.scene, r.kernel, r.dtype, o, d, r.clock)
    r.closest.append(_rayset(o, d, pixel, gen, -1, kind, index, tri_index, tri_t))
    hit = kind != MISS
    if gen == 0:
        r.colour[pixel[~hit]] = r.scene.background
    if not hit.any():
        return None
    o, d, pixel, kind, index, t = o[hit], d[hit], pixel[hit], kind[hit], index[hit], t[hit]
    p = o + t[:, None] * d
    n = _normals(r.scene, kind, index, p)
    mat = _material_arrays(r.scene, kind, index)
    view = normalise(o - p)  # toward the observer: the eye, or the previous hit point
    np.add.at(r.colour, pixel, _shade(r, gen, pixel, p, n, view, mat))
    if gen == depth:
        return None
    go = mat[:, 5] != 0.0  # only a surface with ks != 0 reflects
    if not go.any():
        return None
    return p[go], _reflect(n, view)[go], pixel[go]


def trace(
    scene: Scene,
    kernel: str | None = "moller_seed",
    dtype: str = "float32",
    width: int = 512,
    height: int = 512,
    depth: int = DEPTH,
) -> Trace:
    """Render ``scene`` as the seed does, recording every ray shot. ``kernel`` tests the triangles at ``dtype``;
    None is the float64 reference (closed triangles, ``t > 1e-4``; brute force, so small images only).
    ``depth`` is the seed's ``PROF``."""
    dt = _check_arguments(kernel, dtype, width, height, depth)
    start = time.perf_counter()
    render = _Render(scene, kernel, dt, colour=np.zeros((width * height, 3)))
    o, d = camera_rays(width, height)
    rays = o, d, np.arange(width * height, dtype=np.int64)
    for gen in range(depth + 1):
        shot = _generation(render, gen, depth, *rays)
        if shot is None:
            break
        rays = shot
    return Trace(
        scene=scene,
        kernel=kernel,
        dtype=str(dt),
        width=int(width),
        height=int(height),
        depth=int(depth),
        image=render.colour.reshape(height, width, 3),
        primary=render.closest[0],
        reflected=RaySet.concatenate(render.closest[1:]),
        shadow=RaySet.concatenate(render.shadow),
        elapsed_s=time.perf_counter() - start,
        triangle_s=render.clock[0],
    )
