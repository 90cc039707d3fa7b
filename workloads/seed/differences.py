"""Where two renders of the seed tracer differ (:func:`difference_mask`, drawn by :func:`save_mask_png`), and how
near an edge their rays pass (:func:`edge_margins`): a difference near an edge is one two correct tests may make."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ...common import UserError
from .records import KINDS, Trace, save_png


def _hit_codes(tr: Trace) -> np.ndarray:
    """One int64 per ray: (pixel, position in the pixel's ray tree, what it hit)."""
    stride = tr._seq_stride()
    parts = []
    for name in KINDS:
        rs = getattr(tr, name)
        if name == "shadow":
            what = (rs.hit_kind >= 0).astype(np.int64)  # occluded or not: all the seed uses
        else:
            what = (rs.hit_kind.astype(np.int64) + 1) * (1 << 21) + (rs.hit_index + 1)
        key = rs.pixel * stride + tr._seq(rs, name == "shadow")
        parts.append(key * (1 << 23) + what)
    return np.concatenate(parts)


def difference_mask(a: Trace, b: Trace, by: str = "image") -> tuple[np.ndarray, int]:
    """Pixels where two traces of the same scene and size differ, and their count: ``by="image"``, their 8-bit
    pixels; ``by="hits"``, their ray trees (an object hit, a shadow ray's occlusion, a ray in one trace only),
    which differ far more often (a shadow ray leaving a sphere flips on a last-bit change, with no colour)."""
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
    h, w = mask.shape
    if background is None:
        rgb = np.full((h, w, 3), 255, np.uint8)
    else:
        rgb = (0.35 * np.asarray(background, np.float64) + 0.65 * 255).astype(np.uint8)
    rgb[mask] = (220, 0, 0)
    return save_png(path, rgb)


def edge_margins(origins: np.ndarray, directions: np.ndarray, triangles: np.ndarray, t_min: float = 0.0) -> np.ndarray:
    """How close each ray passes to the boundary of any triangle: the smallest ``|min(u, v, w)|`` over the
    triangles whose plane it crosses at ``t > t_min`` (float64 reference barycentrics), ``inf`` if none. Near
    0: next to an edge or a vertex, where two correct tests may disagree."""
    from ..reference import all_pairs

    o = np.asarray(origins, np.float64)
    d = np.asarray(directions, np.float64)
    tri = np.asarray(triangles, np.float64)
    m, k = len(o), len(tri)
    out = np.full(m, np.inf)
    if m == 0 or k == 0:
        return out
    for lo, hi, ans in all_pairs(o, d, tri, budget=1 << 18):
        margin = np.abs(ans.edge_margin)
        with np.errstate(invalid="ignore"):
            margin = np.where(ans.t > t_min, margin, np.inf)
        margin = np.where(np.isnan(margin), np.inf, margin).reshape(hi - lo, k)
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
