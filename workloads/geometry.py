"""Small vector helpers of the workload generators: only ``+ - * /`` and ``sqrt`` (correctly rounded in IEEE
754) on numpy's PCG64 stream, never ``sin``, ``exp`` or ``log``, whose last bit may differ between
machines and numpy builds; so a generated workload is the same bytes everywhere."""

from __future__ import annotations

import numpy as np

__all__ = [
    "MAX_COORDINATE",
    "dot",
    "norm",
    "normalise",
    "random_in_ball",
    "random_unit_vectors",
    "random_perpendicular",
    "random_frames",
    "sample_inside",
    "triangle_normals",
    "triangle_areas",
    "aspect_ratios",
    "round_to",
]

#: The largest coordinate a workload may have per precision: squares and cross products of coordinates above it
#: overflow (a mesh at 1e300 became a point of radius 0 in float64, and every ray missed; one at 5e38 is infinite
#: in float32), with a margin of about 1e4 below the square root of the precision's largest number.
MAX_COORDINATE = {"float64": 1e150, "float32": 1e15}


def dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise dot product of (..., 3) arrays, summed in a fixed order.

    >>> dot(np.array([[1., 2, 3]]), np.array([[4., 5, 6]]))
    array([32.])
    """
    return a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1] + a[..., 2] * b[..., 2]


def norm(a: np.ndarray) -> np.ndarray:
    """Row-wise Euclidean length of a (..., 3) array."""
    return np.sqrt(dot(a, a))


def normalise(a: np.ndarray) -> np.ndarray:
    """Rows of ``a`` scaled to unit length (rows must be non-zero).

    >>> normalise(np.array([[3., 0, 4]]))
    array([[0.6, 0. , 0.8]])
    """
    return a / norm(a)[..., None]


def random_in_ball(rng: np.random.Generator, n: int, min_radius: float = 0.0) -> np.ndarray:
    """``n`` points uniform in the unit ball outside ``min_radius``, by rejection: a pure function of the generator."""
    out = np.empty((n, 3))
    have = 0
    while have < n:
        want = n - have
        p = rng.random((2 * want + 16, 3)) * 2.0 - 1.0
        r2 = dot(p, p)
        p = p[(r2 <= 1.0) & (r2 > min_radius * min_radius)][:want]
        out[have : have + len(p)] = p
        have += len(p)
    return out


def random_unit_vectors(rng: np.random.Generator, n: int) -> np.ndarray:
    """``n`` directions uniform on the unit sphere.

    >>> v = random_unit_vectors(np.random.default_rng(0), 4)
    >>> bool(np.allclose(norm(v), 1.0))
    True
    """
    # Points too near the centre are dropped: their direction is badly rounded.
    return normalise(random_in_ball(rng, n, min_radius=0.1))


def random_perpendicular(rng: np.random.Generator, axis: np.ndarray) -> np.ndarray:
    """A random unit vector perpendicular to each unit row of ``axis``."""
    out = np.empty_like(axis)
    todo = np.arange(len(axis))
    while len(todo):
        r = random_unit_vectors(rng, len(todo))
        p = r - dot(r, axis[todo])[:, None] * axis[todo]
        ok = norm(p) > 0.1  # far from parallel to the axis: a well-defined direction
        out[todo[ok]] = normalise(p[ok])
        todo = todo[~ok]
    return out


def random_frames(rng: np.random.Generator, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``n`` random placements: centres uniform in the ball of radius 1/2, and unit ``a``, ``b`` spanning a
    random plane (``a x b`` its normal)."""
    centre = 0.5 * random_in_ball(rng, n)
    normal = random_unit_vectors(rng, n)
    a = random_perpendicular(rng, normal)
    return centre, a, np.cross(normal, a)


def sample_inside(rng: np.random.Generator, n: int, margin: float = 0.0) -> np.ndarray:
    """Barycentric weights ``(w, u, v)`` uniform over the inner triangle ``min(w, u, v) >= margin`` (a scaled
    copy), so a point is uniform in area whatever the triangle's shape.

    >>> b = sample_inside(np.random.default_rng(1), 1000, margin=0.01)
    >>> bool(np.allclose(b.sum(axis=1), 1.0)), bool(b.min() >= 0.01)
    (True, True)
    """
    r = rng.random((n, 2))
    folded = r[:, 0] + r[:, 1] > 1.0  # fold the unit square onto the simplex
    r[folded] = 1.0 - r[folded]
    b = np.column_stack([1.0 - r[:, 0] - r[:, 1], r[:, 0], r[:, 1]])
    return margin + (1.0 - 3.0 * margin) * b


def triangle_normals(tris: np.ndarray) -> np.ndarray:
    """Unnormalised normals ``(v1 - v0) x (v2 - v0)`` of (K, 3, 3) triangles."""
    return np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])


def triangle_areas(tris: np.ndarray) -> np.ndarray:
    """Areas of (K, 3, 3) triangles.

    >>> triangle_areas(np.array([[[0., 0, 0], [2, 0, 0], [0, 1, 0]]]))
    array([1.])
    """
    return 0.5 * norm(triangle_normals(tris))


def aspect_ratios(tris: np.ndarray) -> np.ndarray:
    """Longest edge over the altitude onto it (``2/sqrt(3)`` for equilateral, ``inf`` if flat).

    >>> aspect_ratios(np.array([[[0., 0, 0], [10, 0, 0], [3, 1, 0]]]))
    array([10.])
    """
    edges = tris[:, [1, 2, 0]] - tris
    longest2 = dot(edges, edges).max(axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):  # flat: inf; a single point: nan
        return longest2 / (2.0 * triangle_areas(tris))


def round_to(a: np.ndarray, dtype: str) -> np.ndarray:
    """``a`` rounded to ``dtype`` and returned as float64 (what the reference sees)."""
    return np.asarray(a, dtype=dtype).astype(np.float64)
