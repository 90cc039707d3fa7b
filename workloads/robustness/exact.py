"""The robustness suite's exact pair tests (docs/methodology.md): parallel and in-plane rays, degenerate triangles."""

from __future__ import annotations

from fractions import Fraction
from typing import Any

import numpy as np

from ..geometry import round_to
from .sets import PairRays, Size, _as, _dyadic_directions, _dyadic_plane, _exact


def _parallel(rng, size: Size, dtype: str, through: bool = False) -> PairRays:
    """Dyadic triangles; rays parallel to their plane just above them, or (``through``) in the plane through them."""
    g, per = size.triangles, size.rays_per_triangle
    tris, origins, directions, labels = [], [], [], []
    for k in range(g):
        basis = _dyadic_plane(rng, k % 3)
        while True:
            params = rng.integers(-16, 17, (3, 2)) / 8
            e1, e2 = params[1] - params[0], params[2] - params[0]
            if abs(e1[0] * e2[1] - e1[1] * e2[0]) >= 1:
                break
        base = rng.integers(-8, 9, 3) / 8
        scale = 2.0 ** int(rng.integers(-10, 11))
        i = rng.integers(1, 7, per)
        j = rng.integers(1, 8 - i)  # barycentrics in eighths, every one >= 1/8
        bary = np.column_stack([8 - i - j, i, j]) / 8
        aims = base + (bary @ params) @ basis.T
        while True:
            in_plane = rng.integers(-8, 9, (per, 2)) / 8
            if (np.abs(in_plane).sum(axis=1) > 0).all():
                break
        d = in_plane @ basis.T
        o = aims - rng.integers(1, 4, (per, 1)) * d
        above = np.full(per, not through)
        height = rng.choice([-1.0, 1.0], per) * 2.0 ** -rng.integers(4, 13, per).astype(float)
        o[above] += height[above, None] * np.cross(basis[:, 0], basis[:, 1])
        tri = (base + params @ basis.T) * scale
        o, d = o * scale, d * scale
        _exact(tri, o, d)
        tris.append(tri)
        origins.append(o)
        directions.append(d)
        labels += ["above" if a else "in plane" for a in above]
    n = g * per
    return PairRays(
        *_as(dtype, np.array(tris), np.concatenate(origins), np.concatenate(directions)),
        owner=np.repeat(np.arange(g), per),
        expect_hit=np.zeros(n, bool),
        label=np.array(labels),
    )


_DEGENERATE = ("point", "repeated vertex", "collinear")
_NON_DYADIC = ("repeated vertex, non-dyadic", "collinear, non-dyadic")
# c = a + k (b - a): the k tried for exactly collinear non-dyadic vertices
_COLLINEAR_K = (2.0, -1.0, 0.5, 3.0, 1.5, -0.5)


def exactly_collinear(tri: np.ndarray) -> bool:
    """Whether the three vertices of ``tri`` (3, 3) lie exactly on one line (or coincide),
    in rational arithmetic on the stored values (independent of ``ext.flat``'s filter).

    >>> exactly_collinear(np.array([[0.1, 0.2, 0.3], [0.2, 0.4, 0.6], [0.3, 0.6, 0.9]]))
    False
    """
    a, b, c = ([Fraction(float(x)) for x in v] for v in tri)
    e, f = [q - p for p, q in zip(a, b, strict=True)], [q - p for p, q in zip(a, c, strict=True)]
    return all(e[j] * f[k] == e[k] * f[j] for j, k in ((1, 2), (2, 0), (0, 1)))


def _non_dyadic_flat(rng, g: int, per: int, dtype: str) -> PairRays:
    """Repeated vertices (a, b, b) and exactly collinear ones (a, b, a + k (b - a), kept where exact in ``dtype``)
    from random non-dyadic coordinates scaled by 2**-4 to 2**14, in any vertex order; rays aimed between a
    and b from random directions."""
    tris: Any = []  # a list, then the array of it
    ends: Any = []
    while len(tris) < g:
        scale = 2.0 ** int(rng.integers(-4, 15))
        a = round_to(scale * rng.uniform(-2, 2, 3), dtype)
        b = round_to(a + scale * rng.uniform(-1, 1, 3), dtype)
        if len(tris) % 2 == 0:
            tri = np.array([a, b, b])
        else:
            tri = np.array([a, b, round_to(a + rng.choice(_COLLINEAR_K) * (b - a), dtype)])
            if not exactly_collinear(tri):
                continue
        tris.append(tri[rng.permutation(3)])
        ends.append((a, b))
    if not all(exactly_collinear(t) for t in tris):
        raise RuntimeError("a flat triangle is not exactly flat (a bug in workloads.robustness)")
    tris, ends = np.array(tris), np.array(ends)
    owner = np.repeat(np.arange(g), per)
    a, b = ends[owner, 0], ends[owner, 1]
    aims = a + rng.uniform(0, 1, (len(owner), 1)) * (b - a)
    d = round_to(rng.normal(size=(len(owner), 3)), dtype)
    length = np.abs(b - a).max(axis=1, keepdims=True)  # origins a few segment lengths away
    o = round_to(aims - rng.uniform(1, 3, (len(owner), 1)) * length * d, dtype)
    return PairRays(
        *_as(dtype, tris, o, d),
        owner=owner,
        expect_hit=np.zeros(len(owner), bool),
        label=np.array(_NON_DYADIC)[owner % 2],
    )


def _degenerate(rng, size: Size, dtype: str) -> PairRays:
    """A point, a segment with a repeated vertex, three collinear points, all dyadic, with rays
    aimed exactly at them; then repeated and collinear vertices that are not dyadic."""
    g, per = size.triangles, size.rays_per_triangle
    kind = (np.arange(g) % 3)[:, None]
    a = rng.integers(-16, 17, (g, 3)) / 8
    b = a + _dyadic_directions(rng, np.ones((g, 3)), min_cos=0.0)  # b != a
    # point (a, a, a), repeated vertex (a, a, b), collinear (a, b, 2b - a); then a random rotation of the order
    tris = np.stack([a, np.where(kind == 2, b, a), np.select([kind == 0, kind == 1], [a, b], 2 * b - a)], axis=1)
    kind = kind[:, 0]
    tris = np.take_along_axis(tris, ((np.arange(3) + rng.integers(0, 3, (g, 1))) % 3)[:, :, None], axis=1)
    owner = np.repeat(np.arange(g), per)
    s = np.where(kind[owner] == 0, 0, rng.integers(0, 9, len(owner)))[:, None] / 8
    aims = a[owner] + s * (b[owner] - a[owner])
    d = _dyadic_directions(rng, np.ones((len(owner), 3)), min_cos=0.0) * rng.integers(1, 4, (len(owner), 1))
    o = aims - d
    _exact(tris, o, d)
    rest = _non_dyadic_flat(rng, g, per, dtype)
    both = [np.concatenate(pair) for pair in ((tris, rest.triangles), (o, rest.origins), (d, rest.directions))]
    return PairRays(
        *_as(dtype, *both),
        owner=np.concatenate([owner, g + rest.owner]),
        expect_hit=np.zeros(len(owner) + len(rest.owner), bool),
        label=np.concatenate([np.array(_DEGENERATE)[kind[owner]], rest.label]),
    )
