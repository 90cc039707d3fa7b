"""Baldwin-Weber on tiny triangles far from the origin: why the paper's
precomputation misses them even in float64, and that the kernels' does not.

The map's constants U_c = (v2 x v0)_k / n_k and V_c = (v0 x v1)_k / n_k
(the paper's formulas) subtract two products of size |v0|^2 that cancel down
to size |v0| s (s the triangle's size); the rounding of the products stays,
about eps |v0|^2, and the division by n_k ~ s^2 makes it an error of about
eps |v0|^2 / |n_k| in u and v: above 1 for s below about 1e-9 at |v0| ~ 0.5,
so every ray misses (validate's tiny triangles in float64 lost 37.5%, every
triangle of 1e-10 and below). The kernels compute the equal (e2 x v0)_k and
(v0 x e1)_k, products of size |v0| s: error about eps |v0| / s, the order of
the per-test rounding of u = U . p + U_c itself.
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tribench import ext

EPS = 2.0**-53
KERNELS = ["baldwin_weber_12", "baldwin_weber_9"]
# every form of each: scalar and the native FMA form (the same map, prepared by the same code)
FORMS = {k: [k, f] for k, f in zip(KERNELS, ["baldwin_weber_12_fma", "baldwin_weber_9_fma"], strict=True)}


def _triangle(size: float, distance: float, seed: int = 0) -> np.ndarray:
    """A near-equilateral triangle of circumradius ``size`` centred ``distance`` from the origin."""
    rng = np.random.default_rng(seed)
    centre, a, b = rng.normal(size=(3, 3))
    centre *= distance / np.linalg.norm(centre)
    a /= np.linalg.norm(a)
    b -= (b @ a) * a
    b /= np.linalg.norm(b)
    angles = np.array([0.1, 2.2, 4.3])
    return centre + size * (np.cos(angles)[:, None] * a + np.sin(angles)[:, None] * b)


def _exact_constants(tri: np.ndarray, k: int) -> tuple[Fraction, Fraction, Fraction]:
    """n_k and the constants U_c, V_c of the map, in exact arithmetic on the stored vertices."""
    v0, v1, v2 = ([Fraction(float(x)) for x in v] for v in tri)
    k1, k2 = (k + 1) % 3, (k + 2) % 3
    e1 = [v1[i] - v0[i] for i in range(3)]
    e2 = [v2[i] - v0[i] for i in range(3)]
    nk = e1[k1] * e2[k2] - e1[k2] * e2[k1]
    return nk, (v2[k1] * v0[k2] - v2[k2] * v0[k1]) / nk, (v0[k1] * v1[k2] - v0[k2] * v1[k1]) / nk


def _paper_constants(tri: np.ndarray, k: int) -> tuple[float, float]:
    """U_c and V_c as the paper writes them, (v2 x v0)_k / n_k and (v0 x v1)_k / n_k, in double."""
    v0, v1, v2 = tri
    k1, k2 = (k + 1) % 3, (k + 2) % 3
    e1, e2 = v1 - v0, v2 - v0
    nk = e1[k1] * e2[k2] - e1[k2] * e2[k1]
    return (v2[k1] * v0[k2] - v2[k2] * v0[k1]) / nk, (v0[k1] * v1[k2] - v0[k2] * v1[k1]) / nk


def _record(tri: np.ndarray) -> tuple[int, float, float]:
    """The dropped axis k and the constants U_c, V_c of baldwin_weber_12's record."""
    m = ext.prepare("baldwin_weber_12", tri[None]).records[0]
    k = int(np.flatnonzero(m[8:11] == 1)[0])  # W's k column holds exactly 1
    return k, float(m[3]), float(m[7])


def _rays_at_centroid(tri: np.ndarray, n: int = 16) -> tuple[np.ndarray, np.ndarray]:
    """n rays through points well inside the triangle (barycentrics >= 0.2), 1 to 3 units away."""
    rng = np.random.default_rng(1)
    bary = 0.2 + 0.4 * rng.dirichlet([2, 2, 2], n)
    aim = bary @ tri
    normal = np.cross(tri[1] - tri[0], tri[2] - tri[0])
    d = normal / np.linalg.norm(normal) + 0.5 * rng.uniform(-1, 1, (n, 3))
    d /= np.linalg.norm(d, axis=1)[:, None]
    return aim - rng.uniform(1, 3, (n, 1)) * d, d


def _paper_error(tri: np.ndarray) -> float:
    """The paper form's predicted error in u and v: eps |v0|^2 / |n_k|."""
    n = np.cross(tri[1] - tri[0], tri[2] - tri[0])
    return EPS * float(np.abs(tri[0]).max()) ** 2 / float(np.abs(n).max())


@pytest.mark.parametrize(
    ("distance", "paper_misses"),
    [(0.6, True), (1e-4, False)],
    ids=["far-from-origin", "near-origin"],
)
def test_tiny_triangle_known_answers(distance, paper_misses):
    # a 1e-10 triangle: at 0.6 from the origin the paper's constants are off by
    # far more than 1 (every ray would miss); at 1e-4 by far less than the 0.2
    # margin of the rays. The kernels' constants are right at both.
    tri = _triangle(1e-10, distance)
    predicted = _paper_error(tri)
    assert (predicted > 10) if paper_misses else (predicted < 1e-3)
    k, u_c, v_c = _record(tri)
    _, exact_u, exact_v = _exact_constants(tri, k)
    paper_u, paper_v = _paper_constants(tri, k)
    paper_off = max(abs(Fraction(paper_u) - exact_u), abs(Fraction(paper_v) - exact_v))
    assert (paper_off > 1) if paper_misses else (paper_off < 0.01)  # what the bound predicts
    assert max(abs(Fraction(u_c) - exact_u), abs(Fraction(v_c) - exact_v)) < 1e-4

    o, d = _rays_at_centroid(tri)
    tris = np.repeat(tri[None], len(o), axis=0)
    for kernel in KERNELS:
        for name in FORMS[kernel]:
            for isa, runnable in ext.kernel_info(name).isas.items():
                if runnable:
                    options = {} if ext.kernel_info(name).lanes == 1 else {"isa": isa}
                    assert ext.intersect(name, o, d, tris, "closest", **options).hit.all(), (name, isa)


@settings(max_examples=40, deadline=None)
@given(
    size_exp=st.floats(-14, -2),
    distance_exp=st.floats(-3, 2),
    seed=st.integers(0, 2**32 - 1),
)
def test_constants_have_the_error_of_the_e2_form(size_exp, distance_exp, seed):
    # the record's U_c and V_c are within a few eps |v0| |e| / |n_k| of the exact
    # constants (the (e2 x v0)_k form), not eps |v0|^2 / |n_k| (the paper's)
    tri = _triangle(10.0**size_exp, 10.0**distance_exp, seed)
    k, u_c, v_c = _record(tri)
    nk, exact_u, exact_v = _exact_constants(tri, k)
    edge = float(np.abs(tri[1:] - tri[0]).max())
    bound = 8 * EPS * float(np.abs(tri[0]).max()) * edge / abs(float(nk))
    assert abs(float(Fraction(u_c) - exact_u)) <= bound + 4 * EPS * abs(float(exact_u))
    assert abs(float(Fraction(v_c) - exact_v)) <= bound + 4 * EPS * abs(float(exact_v))


@settings(max_examples=30, deadline=None)
@given(size_exp=st.floats(-14, -2), distance_exp=st.floats(-3, 0), seed=st.integers(0, 2**32 - 1))
def test_tiny_triangles_are_hit_in_float64(size_exp, distance_exp, seed):
    # validate's tiny triangles: sizes 1e-2 to 1e-14 within a unit of the origin
    tri = _triangle(10.0**size_exp, 10.0**distance_exp, seed)
    o, d = _rays_at_centroid(tri, 8)
    tris = np.repeat(tri[None], len(o), axis=0)
    for kernel in KERNELS:
        assert ext.intersect(kernel, o, d, tris, "pairs").hit.all(), kernel
        for name in FORMS[kernel][1:]:  # no pairs mode: one triangle repeated, every ray hits one
            assert ext.intersect(name, o, d, tris, "closest").hit.all(), name
