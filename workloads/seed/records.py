"""The seed tracer's records: the rays of one kind (:class:`RaySet`) and one render (:class:`Trace`), and
the kinds of rays (:data:`KINDS`) and of hits (``MISS``, ``PLANE``, ``SPHERE``, ``TRIANGLE``) they store."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ...common import atomic_write
from .scene import Scene

KINDS = ("primary", "reflected", "shadow")

# hit kinds stored per ray
MISS, PLANE, SPHERE, TRIANGLE = -1, Scene.PLANE, Scene.SPHERE, Scene.TRIANGLE


@dataclass(frozen=True, eq=False)
class RaySet:
    """Rays of one kind as the seed shot them, with what they hit; every array has length N.

    ``origins``, ``directions``: float64, exactly as shot. ``pixel``: the row-major pixel the ray adds to;
    ``depth``: its generation (a shadow ray's is its parent's); ``light``: a shadow ray's light, else -1.
    ``hit_kind``, ``hit_index``: the closest object (kind -1 none, 0 plane, 1 sphere, 2 triangle), for a shadow
    ray the occluder (-1: the light is visible; a sphere if one cuts it before the first cutting triangle, exact
    when the spheres precede the triangles, as in both built-in scenes). ``triangle``, ``t_triangle``: the
    closest triangle the kernel hit, whatever else is nearer (-1, nan: none): what its triangle tests answer."""

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
        none = np.zeros(0, np.int64)
        return _rayset(np.zeros((0, 3)), np.zeros((0, 3)), none, 0, -1, none, none, none, np.zeros(0))


@dataclass(frozen=True, eq=False)
class Trace:
    """One render of a scene with one triangle kernel (None: the float64 reference): the image, as the seed
    computes it before clamping (:meth:`to_uint8`), and the rays shot; ``elapsed_s`` is the render's wall
    time, ``triangle_s`` the part of it in triangle tests."""

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

    @property
    def counts(self) -> dict[str, int]:
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

    def to_uint8(self) -> np.ndarray:
        """The image as the seed writes it: ``> 1`` gives 255, else ``int(x * 255)``."""
        x = self.image
        return np.where(x > 1.0, 255, np.floor(np.maximum(x, 0.0) * 255.0)).astype(np.uint8)

    def to_png(self, path: str | Path) -> Path:
        return save_png(path, self.to_uint8())

    def seed_order(self) -> tuple[np.ndarray, np.ndarray]:
        """The seed's shooting order, ``(kind, index)`` arrays over all rays (``kind`` indexes :data:`KINDS`,
        ``index`` the row in its :class:`RaySet`): pixel by pixel, columns outer and rows inner, and within a
        pixel depth first (the primary ray, its hit's shadow rays by light, the reflected ray, its shadow rays...)."""
        per_pixel = len(self.scene.lights) + 1  # a ray's place in its pixel: depth, then its light if a shadow ray
        keys, kinds, idx = [], [], []
        for k, name in enumerate(KINDS):
            rs = getattr(self, name)
            seq = rs.depth.astype(np.int64) * per_pixel
            if name == "shadow":
                seq += 1 + rs.light.astype(np.int64)
            column_major = (rs.pixel % self.width) * self.height + rs.pixel // self.width
            keys.append(column_major * (self.depth + 1) * per_pixel + seq)
            kinds.append(np.full(len(rs), k, dtype=np.int8))
            idx.append(np.arange(len(rs)))
        order = np.argsort(np.concatenate(keys), kind="stable")
        return np.concatenate(kinds)[order], np.concatenate(idx)[order]


def save_png(path: str | Path, rgb: np.ndarray) -> Path:
    """Save an 8-bit RGB image as a PNG file, atomically; returns the path."""
    from PIL import Image

    path = Path(path)
    with atomic_write(path, "wb") as f:
        Image.fromarray(rgb).save(f, format="PNG")
    return path


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
