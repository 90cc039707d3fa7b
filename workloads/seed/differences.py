"""Where two renders of the seed tracer differ (:func:`difference_mask`, drawn by :func:`save_mask_png`), and how
near an edge their rays pass (:func:`edge_margins`): a difference near an edge is one two correct tests may make."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ...common import UserError
from .records import KINDS, Trace, save_png


def difference_mask(a: Trace, b: Trace) -> tuple[np.ndarray, int]:
    """Pixels where two traces of the same scene and size differ in their 8-bit image, and their count."""
    if (a.width, a.height) != (b.width, b.height):
        raise UserError(f"traces differ in size: {a.width}x{a.height} and {b.width}x{b.height}")
    mask = (a.to_uint8() != b.to_uint8()).any(axis=2)
    return mask, int(mask.sum())


def save_mask_png(mask: np.ndarray, path: str | Path, background: np.ndarray) -> Path:
    """Save a difference mask as PNG: differing pixels red, over the ``background`` image dimmed."""
    rgb = (0.35 * np.asarray(background, np.float64) + 0.65 * 255).astype(np.uint8)
    rgb[mask] = (220, 0, 0)
    return save_png(path, rgb)


def edge_margins(origins: np.ndarray, directions: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """How close each ray passes to the boundary of any triangle: the smallest ``|min(u, v, w)|`` over the
    triangles whose plane it crosses at ``t > 0`` (float64 reference barycentrics), ``inf`` if none. Near
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
            margin = np.where(ans.t > 0, margin, np.inf)
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
