"""Float64 reference answers for ray-triangle tests: the ground truth every kernel and generator is checked
against, written from the geometry, not from any kernel.

``o + t d = v0 + u e1 + v e2`` is solved with ``numpy.linalg.solve`` (LU), never with the kernels'
scalar triple products, so a shared algebra slip cannot hide in both. Conventions, shared with the clean
kernels: the triangle is closed (an edge or a vertex is inside); a singular system (parallel ray, degenerate
triangle) is a miss; a hit needs ``t_min < t < t_max`` (``t_max`` per ray; None: no limit); a miss has
``t = nan`` in :func:`intersect_closest` (:func:`intersect_pairs` keeps its plane crossing's ``t``)."""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

from ..common import UserError

__all__ = ["PairAnswers", "edge_clearance", "intersect_pairs", "intersect_closest"]

# Pairs solved per call of numpy.linalg.solve: bounds the temporary memory.
_CHUNK = 1 << 16


@dataclass(frozen=True)
class PairAnswers:
    """Reference answers for N pairs, float64: ``t``, ``u``, ``v`` of the plane crossing (``u``, ``v`` the
    weights of ``v1``, ``v2``), nan where the system is singular and kept for misses, so that generators see
    *why* a pair misses; ``clearance``: :func:`edge_clearance`."""

    hit: np.ndarray
    t: np.ndarray
    u: np.ndarray
    v: np.ndarray
    clearance: np.ndarray

    @property
    def w(self) -> np.ndarray:
        """Weight of ``v0``: ``1 - u - v``."""
        return 1.0 - self.u - self.v

    @property
    def edge_margin(self) -> np.ndarray:
        """Smallest barycentric, ``min(u, v, w)``: negative outside, 0 on an edge."""
        return np.minimum(np.minimum(self.u, self.v), self.w)


def _as_f64(name: str, a: np.ndarray, shape_tail: tuple[int, ...]) -> np.ndarray:
    a = np.asarray(a, dtype=np.float64)
    if a.ndim != 1 + len(shape_tail) or a.shape[1:] != shape_tail:
        want = "(N, " + ", ".join(map(str, shape_tail)) + ")"
        raise UserError(f"{name} must have shape {want}, got {a.shape}")
    return a


def _solve(origins: np.ndarray, directions: np.ndarray, triangles: np.ndarray):
    """Solve the crossing system for each row; singular rows give nan."""
    v0, v1, v2 = triangles[:, 0], triangles[:, 1], triangles[:, 2]
    a = np.stack([-directions, v1 - v0, v2 - v0], axis=-1)  # columns: -d, e1, e2
    b = origins - v0
    # Singular (or numerically singular) systems are misses: detect them by the
    # scale-free determinant so a tiny but valid triangle is not rejected.
    scale = np.prod(np.linalg.norm(a, axis=1), axis=-1)
    det = np.linalg.det(a)
    with np.errstate(invalid="ignore", divide="ignore"):
        regular = np.abs(det) > 1e-14 * scale
    x = np.full(b.shape, np.nan)
    if regular.any():
        x[regular] = np.linalg.solve(a[regular], b[regular][..., None])[..., 0]
    return x[:, 0], x[:, 1], x[:, 2]


def _as_t_max(t_max, n: int) -> np.ndarray:
    """Per-ray limit as float64 (N,); None means +inf."""
    if t_max is None:
        return np.full(n, np.inf)
    t_max = np.asarray(t_max, dtype=np.float64)
    if t_max.shape != (n,):
        raise UserError(f"t_max must have shape ({n},), one per ray, got {t_max.shape}")
    return t_max


def intersect_pairs(
    origins: np.ndarray,
    directions: np.ndarray,
    triangles: np.ndarray,
    t_min: float = 0.0,
    t_max: np.ndarray | None = None,
    front_only: bool = False,
) -> PairAnswers:
    """Test ray ``i`` against triangle ``i`` (``triangles[i, j]`` its vertex ``j``) in float64.

    A crossing counts where ``t_min < t < t_max`` (past ``t_max``: a miss keeping its ``t``) and, with
    ``front_only``, on the front face, ``d . ((v1 - v0) x (v2 - v0)) < 0`` (counter-clockwise from the origin).

    >>> tri = np.array([[[0., 0, 0], [1, 0, 0], [0, 1, 0]]])
    >>> r = intersect_pairs([[0.25, 0.25, 1]], [[0., 0, -1]], tri)
    >>> bool(r.hit[0]), float(r.t[0])
    (True, 1.0)
    >>> r = intersect_pairs([[0.25, 0.25, 1]] * 2, [[0., 0, -1]] * 2, np.vstack([tri, tri]), t_max=[1.5, 0.5])
    >>> r.hit.tolist(), r.t.tolist()
    ([True, False], [1.0, 1.0])
    >>> bool(intersect_pairs([[0.25, 0.25, -1]], [[0., 0, 1]], tri, front_only=True).hit[0])
    False
    """
    o = _as_f64("origins", origins, (3,))
    d = _as_f64("directions", directions, (3,))
    tri = _as_f64("triangles", triangles, (3, 3))
    if not (len(o) == len(d) == len(tri)):
        raise UserError(
            f"origins, directions and triangles need one row each per pair, got {len(o)}, {len(d)} and {len(tri)}"
        )
    limit = _as_t_max(t_max, len(o))
    t = np.empty(len(o))
    u = np.empty(len(o))
    v = np.empty(len(o))
    for lo in range(0, len(o), _CHUNK):
        hi = lo + _CHUNK
        t[lo:hi], u[lo:hi], v[lo:hi] = _solve(o[lo:hi], d[lo:hi], tri[lo:hi])
    with np.errstate(invalid="ignore"):
        hit = (u >= 0) & (v >= 0) & (u + v <= 1) & (t > t_min) & (t < limit)
    if front_only:
        normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        hit &= np.einsum("ij,ij->i", d, normal) < 0
    return PairAnswers(hit=hit, t=t, u=u, v=v, clearance=edge_clearance(o, d, tri, t, u, v))


def all_pairs(
    o: np.ndarray, d: np.ndarray, tri: np.ndarray, budget: int = _CHUNK, t_max=None, **kwargs
) -> Iterator[tuple[int, int, PairAnswers]]:
    """Every ray against every triangle by :func:`intersect_pairs`, ``budget // K`` rays at a time (bounding the
    memory): ``(lo, hi, answers)`` per chunk, the answers of rays ``lo:hi`` in row-major (ray, triangle) order."""
    k = len(tri)
    step = max(1, budget // max(k, 1))
    for lo in range(0, len(o), step):
        hi = min(lo + step, len(o))
        o_k, d_k = np.repeat(o[lo:hi], k, axis=0), np.repeat(d[lo:hi], k, axis=0)
        limit = None if t_max is None else np.repeat(t_max[lo:hi], k)
        yield lo, hi, intersect_pairs(o_k, d_k, np.tile(tri, (hi - lo, 1, 1)), t_max=limit, **kwargs)


def edge_clearance(o: np.ndarray, d: np.ndarray, tri: np.ndarray, t: np.ndarray, u: np.ndarray, v: np.ndarray):
    """The crossings' distance from their triangle's nearest edge line (negative outside), in units of a kernel's
    rounding there: over ``(|o| + max |v_i| + |t d|) / |cos|``, so ``|clearance|`` under a few epsilons of a
    precision means a correct kernel in it may decide either way (docs/decisions.md, "Ambiguous rays").

    >>> tri = np.array([[[0., 0, 0], [1, 0, 0], [0, 1, 0]]])
    >>> a = intersect_pairs([[0.25, 0.5, 1]], [[0., 0, -1]], tri)  # 0.25 / sqrt(2) from x + y = 1
    >>> bool(np.isclose(a.clearance[0], 0.25 / np.sqrt(2) / (np.sqrt(1.3125) + 1 + 1)))
    True
    """
    v0, v1, v2 = tri[:, 0], tri[:, 1], tri[:, 2]
    length = np.linalg.norm
    normal_d = np.abs(np.einsum("ij,ij->i", np.cross(v1 - v0, v2 - v0), d))
    scale = length(o, axis=1) + np.max(length(tri, axis=2), axis=1) + np.abs(t) * length(d, axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        # weights of v0 (w), v1 (u), v2 (v) over the edge each faces
        per_edge = np.minimum(
            np.minimum((1 - u - v) / length(v2 - v1, axis=1), u / length(v0 - v2, axis=1)), v / length(v1 - v0, axis=1)
        )
        return per_edge * normal_d / (length(d, axis=1) * scale)


def intersect_closest(
    origins: np.ndarray,
    directions: np.ndarray,
    triangles: np.ndarray,
    t_min: float = 0.0,
    t_max: np.ndarray | None = None,
    front_only: bool = False,
) -> tuple[np.ndarray, np.ndarray]:
    """Closest hit of every ray against every triangle (brute force, float64): the triangle's index (``-1`` for a
    miss, ties to the lowest) and its ``t`` (nan for a miss); the other arguments as :func:`intersect_pairs`'s.

    >>> tris = np.array([[[0., 0, 0], [1, 0, 0], [0, 1, 0]],
    ...                  [[0., 0, 1], [1, 0, 1], [0, 1, 1]]])
    >>> intersect_closest([[0.2, 0.2, 3]], [[0., 0, -1]], tris)
    (array([1]), array([2.]))
    >>> intersect_closest([[0.2, 0.2, 3]] * 2, [[0., 0, -1]] * 2, tris, t_max=[2.5, 1.5])
    (array([ 1, -1]), array([ 2., nan]))
    """
    o = _as_f64("origins", origins, (3,))
    d = _as_f64("directions", directions, (3,))
    tri = _as_f64("triangles", triangles, (3, 3))
    m, k = len(o), len(tri)
    index = np.full(m, -1, dtype=np.int64)
    best = np.full(m, np.inf)
    pairs = all_pairs(o, d, tri, t_min=t_min, t_max=_as_t_max(t_max, m), front_only=front_only) if k else ()
    for lo, hi, ans in pairs:  # no triangle: every ray misses
        n = hi - lo
        t = np.where(ans.hit, ans.t, np.inf).reshape(n, k)
        j = np.argmin(t, axis=1)  # argmin returns the first of equal minima
        tj = t[np.arange(n), j]
        found = np.isfinite(tj)
        index[lo:hi] = np.where(found, j, -1)
        best[lo:hi] = tj
    return index, np.where(index >= 0, best, np.nan)
