"""Moller-Trumbore with culling, Baldwin-Weber (12 and 9+k reals), Havel-Herout,
Badouel, Wald, Segura-Feito, Kensler-Shirley and Shevtsov against the float64
reference, in every precision and form (scalar, and the native form on each ISA)."""

from __future__ import annotations

import functools

import numpy as np
import pytest
import trimesh
from conftest import as_dtype, reference_answers, safe_pairs

from tribench import ext
from tribench.workloads import reference

KERNELS = [
    "moller_trumbore_cull",
    "baldwin_weber_12",
    "baldwin_weber_9",
    "havel_herout",
    "badouel",
    "wald",
    "segura_feito",
    "kensler_shirley",
    "shevtsov",
]
STRIDE = {
    "moller_trumbore_cull": 9,
    "baldwin_weber_12": 12,
    "baldwin_weber_9": 10,
    "havel_herout": 12,
    "badouel": 11,
    "wald": 12,  # the thesis's 48 bytes (float32), two pads included
    "wald_fma": 10,  # without the pads (wald_fma.h): a native form whose stride is its own
    "segura_feito": 9,  # the raw vertices (its native form's too)
    "kensler_shirley": 9,  # the raw vertices (its native form's too)
    "shevtsov": 10,  # its native form's too
}
CULLS = {"moller_trumbore_cull"}
# the native form (native.h) of an algorithm that has one: held to the reference, not bit for bit
NATIVE_FORM = {
    "moller_trumbore_cull": "moller_trumbore_cull_fma",
    "havel_herout": "havel_herout_fma",
    "baldwin_weber_12": "baldwin_weber_12_fma",
    "baldwin_weber_9": "baldwin_weber_9_fma",
    "badouel": "badouel_fma",
    "wald": "wald_fma",
    "segura_feito": "segura_feito_fma",
    "kensler_shirley": "kensler_shirley_fma",
    "shevtsov": "shevtsov_fma",
}
DTYPES = [np.float32, np.float64]
T_RTOL = {np.float32: 1e-4, np.float64: 1e-10}
UV_ATOL = {np.float32: 1e-4, np.float64: 1e-9}
# (form, isa): the scalar form, and the native form, held here to its scalar kernel's promises,
# on each ISA of its list
SCALAR = ("scalar", None)
KERNEL_FORMS = [pytest.param(k, SCALAR, id=f"{k}-scalar") for k in KERNELS]
KERNEL_FORMS += [
    pytest.param(k, ("native", isa), id=f"{n}-{isa}") for k, n in NATIVE_FORM.items() for isa in ext.kernel_info(n).isas
]

kernel_param = pytest.mark.parametrize("kernel", KERNELS)
dtype_param = pytest.mark.parametrize("dtype", DTYPES, ids=["f32", "f64"])
kernel_form_param = pytest.mark.parametrize(("kernel", "form"), KERNEL_FORMS)


def _run(kernel, form, o, d, tris, mode, **options):
    which, isa = form
    name = kernel if which == "scalar" else NATIVE_FORM[kernel]
    if isa is not None and not ext.kernel_info(name).isas[isa]:
        pytest.skip(f"{isa} is not available on this CPU")
    return ext.intersect(name, o, d, tris, mode, isa=isa, **options)


def _front(o, d, tris):
    """det = e1 . (d x e2) > 0 in float64: the side moller_trumbore_cull keeps."""
    tris = tris.astype(np.float64)
    e1, e2 = tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0]
    return np.einsum("ij,ij->i", e1, np.cross(d.astype(np.float64), e2)) > 0


def _expected_pairs(kernel, o, d, tris):
    ref = reference_answers(o, d, tris)
    return ref.hit & _front(o, d, tris) if kernel in CULLS else ref.hit, ref


# ------------------------------------------------------------------ storage


@kernel_param
def test_bytes_per_triangle(kernel):
    native = [NATIVE_FORM[kernel]] if kernel in NATIVE_FORM else []
    for name in [kernel, *native]:
        stride = STRIDE.get(name, STRIDE[kernel])
        assert ext.kernel_info(name).stride == stride
        assert ext.kernel_info(name).culls_back_faces == (kernel in CULLS)
        assert ext.bytes_per_triangle(name, np.float32) == 4 * stride
        assert ext.bytes_per_triangle(name, np.float64) == 8 * stride


# -------------------------------------------------------------------- pairs


@dtype_param
@kernel_param
@pytest.mark.parametrize("hit_rate", [0.0, 0.5, 1.0])
def test_pairs_agree_with_reference(kernel, dtype, hit_rate):
    o, d, tris = as_dtype(safe_pairs(2000, seed=11, hit_rate=hit_rate), dtype)
    expected, ref = _expected_pairs(kernel, o, d, tris)
    r = ext.intersect(kernel, o, d, tris, "pairs")
    assert r.t.dtype == dtype
    np.testing.assert_array_equal(r.hit, expected)
    hit = r.hit
    np.testing.assert_allclose(r.t[hit], ref.t[hit], rtol=T_RTOL[dtype])
    np.testing.assert_allclose(r.u[hit], ref.u[hit], atol=UV_ATOL[dtype])
    np.testing.assert_allclose(r.v[hit], ref.v[hit], atol=UV_ATOL[dtype])
    assert np.isnan(r.t[~hit]).all() and (r.index[~hit] == -1).all()
    if kernel in CULLS and hit_rate > 0:
        assert 0 < expected.sum() < ref.hit.sum()  # both faces occur in the data


@dtype_param
@kernel_param
def test_pairs_t_max_is_strict(kernel, dtype):
    o, d, tris = as_dtype(safe_pairs(500, seed=12, hit_rate=1.0), dtype)
    first = ext.intersect(kernel, o, d, tris, "pairs")
    hit = first.hit
    assert hit.sum() > 200
    t_hit = first.t[hit]
    o, d, tris = o[hit], d[hit], tris[hit]
    # the kernel's own t as t_max: t < t_max fails
    assert not ext.intersect(kernel, o, d, tris, "pairs", t_max=t_hit).hit.any()
    below = (t_hit * (1 - 1e-3)).astype(dtype)
    assert not ext.intersect(kernel, o, d, tris, "pairs", t_max=below).hit.any()
    above = (t_hit * (1 + 1e-3)).astype(dtype)
    again = ext.intersect(kernel, o, d, tris, "pairs", t_max=above)
    assert again.hit.all()
    np.testing.assert_array_equal(again.t, t_hit)


@dtype_param
@kernel_param
def test_closed_triangle_edges_and_vertices_hit(kernel, dtype):
    # the unit triangle's edge and vertex points are exact in every kernel's
    # arithmetic (its records hold only 0, 1, -1), so the closed rule shows
    tri = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]])
    on = [[0.5, 0, 1], [0, 0.5, 1], [0.5, 0.5, 1], [0, 0, 1], [1, 0, 1], [0, 1, 1]]
    off = [[0.5, -1e-3, 1], [-1e-3, 0.5, 1], [0.5, 0.501, 1], [1.001, 0, 1]]
    o = np.array(on + off)
    d = np.tile([0.0, 0, -1], (len(o), 1))
    o, d, tris = as_dtype((o, d, np.repeat(tri[None], len(o), 0)), dtype)
    r = ext.intersect(kernel, o, d, tris, "pairs")
    np.testing.assert_array_equal(r.hit, [True] * len(on) + [False] * len(off))
    np.testing.assert_array_equal(r.t[: len(on)], 1.0)
    np.testing.assert_array_equal(r.u[: len(on)], o[: len(on), 0])
    np.testing.assert_array_equal(r.v[: len(on)], o[: len(on), 1])


@dtype_param
@kernel_form_param
def test_origin_on_the_plane_is_not_a_hit(kernel, dtype, form):
    # t = 0 exactly (origin inside the triangle, in its plane): 0 < t fails;
    # a hair above the plane it hits
    tri = np.array([[[0.0, 0, 0], [1, 0, 0], [0, 1, 0]]])
    o = np.array([[0.25, 0.25, 0.0], [0.25, 0.25, 0.0], [0.25, 0.25, 1e-3]])
    d = np.array([[0.0, 0, -1], [0.0, 0.6, -0.8], [0.0, 0, -1]])
    for i in range(len(o)):
        oi, di, ti = as_dtype((o[i : i + 1], d[i : i + 1], tri), dtype)
        assert _run(kernel, form, oi, di, ti, "closest").hit[0] == (i == 2)


@kernel_form_param
def test_which_faces_are_hit(kernel, form):
    # v0 v1 v2 counter-clockwise seen from above: det > 0 for a ray going down
    tri = np.array([[[0.0, 0, 0], [1, 0, 0], [0, 1, 0]]])
    o = np.array([[0.25, 0.25, 2.0], [0.25, 0.25, -2.0]])
    d = np.array([[0.0, 0, -1], [0.0, 0, 1]])
    hit = [_run(kernel, form, o[i : i + 1], d[i : i + 1], tri, "closest").hit[0] for i in range(2)]
    assert hit == [True, kernel not in CULLS]


# -------------------------------------------------------------- mesh modes


@functools.cache
def _mesh_workload():
    """An icosphere, rays from outside (aimed inside) and from inside, kept only
    where every plane crossing is far from every edge and from t = 0; and the
    reference's every (ray, triangle) answer."""
    tris = np.ascontiguousarray(trimesh.creation.icosphere(subdivisions=2).triangles)
    rng = np.random.default_rng(3)
    n_out, n_in = 450, 150
    o = rng.normal(size=(n_out + n_in, 3))
    o /= np.linalg.norm(o, axis=1)[:, None]
    o[:n_out] *= 3
    o[n_out:] *= 0.4
    d = rng.normal(size=o.shape)
    d[:n_out] = rng.normal(size=(n_out, 3)) * 0.7 - o[:n_out]
    d /= np.linalg.norm(d, axis=1)[:, None]
    m, k = len(o), len(tris)
    every = reference.intersect_pairs(np.repeat(o, k, 0), np.repeat(d, k, 0), np.tile(tris, (m, 1, 1)))
    near = (np.abs(every.edge_margin) < 1e-3) | (np.abs(every.t) < 1e-3)
    safe = ~near.reshape(m, k).any(axis=1)
    front = _front(np.repeat(o, k, 0), np.repeat(d, k, 0), np.tile(tris, (m, 1, 1))).reshape(m, k)
    hit = every.hit.reshape(m, k)[safe]
    t, u, v = (x.reshape(m, k)[safe] for x in (every.t, every.u, every.v))
    return o[safe], d[safe], tris, hit, front[safe], t, u, v


def _mesh_expected(kernel, excluded=()):
    """Closest index of every mesh ray (-1: none), the reference's hit matrix."""
    o, d, tris, hit, front, t, u, v = _mesh_workload()
    hit = hit & front if kernel in CULLS else hit.copy()
    hit[:, list(excluded)] = False
    t_hit = np.where(hit, t, np.inf)
    index = np.where(hit.any(axis=1), np.argmin(t_hit, axis=1), -1)
    return index, hit


def test_mesh_workload_has_both_kinds_of_rays():
    o, d, tris, hit, front, *_ = _mesh_workload()
    assert len(o) > 400
    closest_front = _mesh_expected("moller_trumbore_cull")[0] >= 0
    any_hit = hit.any(axis=1)
    assert 0.2 < closest_front.mean() < any_hit.mean()  # inside rays meet back faces only


@dtype_param
@kernel_form_param
def test_closest_uv_on_a_mesh_agrees_with_reference(kernel, dtype, form):
    o64, d64, tris64, _, _, t_ref, u_ref, v_ref = _mesh_workload()
    index_ref, _ = _mesh_expected(kernel)
    o, d, tris = as_dtype((o64, d64, tris64), dtype)
    r = _run(kernel, form, o, d, tris, "closest_uv")
    np.testing.assert_array_equal(r.index, index_ref)
    hit = r.index >= 0
    rows, cols = np.nonzero(hit)[0], r.index[hit]
    np.testing.assert_allclose(r.t[hit], t_ref[rows, cols], rtol=T_RTOL[dtype])
    np.testing.assert_allclose(r.u[hit], u_ref[rows, cols], atol=UV_ATOL[dtype])
    np.testing.assert_allclose(r.v[hit], v_ref[rows, cols], atol=UV_ATOL[dtype])
    assert np.isnan(r.t[~hit]).all() and np.isnan(r.u[~hit]).all()
    closest = _run(kernel, form, o, d, tris, "closest")
    np.testing.assert_array_equal(closest.index, r.index)
    np.testing.assert_array_equal(closest.t, r.t)


@dtype_param
@kernel_form_param
def test_any_on_a_mesh_agrees_with_reference(kernel, dtype, form):
    o, d, tris = as_dtype(_mesh_workload()[:3], dtype)
    index_ref, hit_ref = _mesh_expected(kernel)
    r = _run(kernel, form, o, d, tris, "any")
    np.testing.assert_array_equal(r.hit, index_ref >= 0)
    rows = np.nonzero(r.hit)[0]
    assert hit_ref[rows, r.index[rows]].all()  # some triangle the ray really hits


@dtype_param
@kernel_form_param
def test_t_max_on_a_mesh(kernel, dtype, form):
    o, d, tris = as_dtype(_mesh_workload()[:3], dtype)
    first = _run(kernel, form, o, d, tris, "closest")
    hit = first.hit
    # t_max = the closest t (strict: a miss) on even rays, +inf on odd rays
    t_max = np.where(np.arange(len(o)) % 2 == 0, first.t, np.inf).astype(dtype)
    t_max[~hit] = np.inf
    r = _run(kernel, form, o, d, tris, "closest", t_max=t_max)
    even = np.arange(len(o)) % 2 == 0
    assert not r.hit[even & hit].any()
    np.testing.assert_array_equal(r.index[~even], first.index[~even])
    np.testing.assert_array_equal(r.t[~even], first.t[~even])
    # just above the closest t: the same answers
    above = np.where(hit, first.t * (1 + 1e-3), np.inf).astype(dtype)
    r = _run(kernel, form, o, d, tris, "closest", t_max=above)
    np.testing.assert_array_equal(r.index, first.index)
    np.testing.assert_array_equal(r.t, first.t)


# ------------------------------------------------------------- degenerate


def _degenerate_on_rays(o, d, n_rays):
    """Three zero-area triangles crossing each of the first n_rays rays near
    t = 1, degenerate in any precision (only one coordinate varies, or
    vertices repeat): a segment across the ray along x (collinear), a point,
    and a segment with a repeated vertex."""
    out = []
    along_x = np.array([0.1, 0, 0])
    for i in range(n_rays):
        p = o[i] + d[i]
        out += [
            [p - along_x, p + along_x, p + 0.5 * along_x],
            [p, p, p],
            [p - along_x, p + along_x, p + along_x],
        ]
    return np.array(out)


@dtype_param
@kernel_param
def test_degenerate_triangles_miss_in_pairs(kernel, dtype):
    shapes = [
        [[0.0, 0, 0], [1, 0, 0], [2, 0, 0]],  # collinear, along x
        [[0.0, 0, 0], [1, 1, 1], [2, 2, 2]],  # collinear, diagonal
        [[0.3, 0.3, 0], [0.3, 0.3, 0], [0.3, 0.3, 0]],  # a point
        [[0.0, 0, 0], [1, 1, 0], [1, 1, 0]],  # repeated vertex
        [[0.0, 0, 0], [0, 0, 0], [1, 1, 0]],  # repeated vertex (v0 = v1)
    ]
    rays = [
        ([0.3, 0.3, 1.0], [0.0, 0, -1]),
        ([0.3, 0.3, 1.0], [0.0, 0, 1]),
        ([-1.0, 0.3, 0.3], [1.0, 0, 0]),
        ([0.5, 2.0, 0.5], [0.0, -1, 0]),
        ([0.6, 0.6, 0.6], [-1.0, -1, -1]),
    ]
    tris = np.array([s for s in shapes for _ in rays])
    o = np.array([r[0] for _ in shapes for r in rays])
    d = np.array([r[1] for _ in shapes for r in rays])
    o, d, tris = as_dtype((o, d, tris), dtype)
    r = ext.intersect(kernel, o, d, tris, "pairs")
    assert not r.hit.any() and np.isnan(r.t).all()


@dtype_param
@kernel_form_param
def test_degenerate_triangles_on_the_ray_path_never_hit(kernel, dtype, form):
    o64, d64, tris64 = _mesh_workload()[:3]
    extra = _degenerate_on_rays(o64, d64, 40)
    index_ref, _ = _mesh_expected(kernel)
    o, d, tris = as_dtype((o64, d64, np.concatenate([tris64, extra])), dtype)
    for mode in ("closest", "any"):
        r = _run(kernel, form, o, d, tris, mode)
        assert (r.index < len(tris64)).all(), mode
        np.testing.assert_array_equal(r.hit, index_ref >= 0)
        if mode == "closest":
            np.testing.assert_array_equal(r.index, index_ref)


# --------------------------------------------------------------- non-finite


def _poisoned_pairs(dtype):
    """Front-facing hitting pairs, each copied with one coordinate of the
    origin, direction or a vertex replaced by nan, +inf or -inf."""
    o, d, tris = safe_pairs(60, seed=21, hit_rate=1.0)
    keep = _front(o, d, tris)
    o, d, tris = o[keep][:6], d[keep][:6], tris[keep][:6]
    out_o, out_d, out_t = [], [], []
    for value in (np.nan, np.inf, -np.inf):
        for where, size in (("o", 3), ("d", 3), ("tri", 9)):
            for j in range(size):
                po, pd, pt = o.copy(), d.copy(), tris.copy()
                target = {"o": po, "d": pd, "tri": pt.reshape(len(pt), 9)}[where]
                target[:, j] = value
                out_o.append(po)
                out_d.append(pd)
                out_t.append(pt)
    return as_dtype((np.concatenate(out_o), np.concatenate(out_d), np.concatenate(out_t)), dtype) + as_dtype(
        (o, d, tris), dtype
    )


@dtype_param
@kernel_param
def test_nonfinite_pairs_miss(kernel, dtype):
    o, d, tris, clean_o, clean_d, clean_tris = _poisoned_pairs(dtype)
    assert ext.intersect(kernel, clean_o, clean_d, clean_tris, "pairs").hit.all()
    with pytest.raises(ValueError, match="NaN or Inf"):
        ext.intersect(kernel, o, d, tris, "pairs")
    r = ext.intersect(kernel, o, d, tris, "pairs", allow_nonfinite=True)
    assert not r.hit.any() and np.isnan(r.t).all() and np.isnan(r.u).all()


@dtype_param
@kernel_form_param
def test_nonfinite_rays_and_triangles_miss(kernel, dtype, form):
    o, d, tris, clean_o, clean_d, clean_tris = _poisoned_pairs(dtype)
    finite_ray = np.isfinite(o).all(axis=1) & np.isfinite(d).all(axis=1)
    finite_tri = np.isfinite(tris.reshape(len(tris), 9)).all(axis=1)
    # poisoned rays against clean triangles, clean rays against poisoned triangles
    r = _run(kernel, form, o[~finite_ray], d[~finite_ray], clean_tris, "closest", allow_nonfinite=True)
    assert not r.hit.any()
    r = _run(kernel, form, clean_o, clean_d, tris[~finite_tri], "closest", allow_nonfinite=True)
    assert not r.hit.any()
    # poisoned triangles in the lanes of a mesh: the rest is unaffected
    o64, d64, tris64 = _mesh_workload()[:3]
    bad = [3, 8, 9, 10, 57, 200]
    mesh = tris64.copy()
    for n, i in enumerate(bad):
        mesh[i].flat[n % 9] = (np.nan, np.inf, -np.inf)[n % 3]
    index_ref, _ = _mesh_expected(kernel, excluded=bad)
    o, d, mesh = as_dtype((o64, d64, mesh), dtype)
    r = _run(kernel, form, o, d, mesh, "closest", allow_nonfinite=True)
    np.testing.assert_array_equal(r.index, index_ref)


# -------------------------------------------------------- far from the origin


@functools.cache
def _far_workload(offset: float, n: int = 400):
    """Unit-size triangles around points ~offset from the origin, rounded to
    float32, and one ray per triangle aimed at its centroid from 1-4 units
    away, rounded to float32 too."""
    rng = np.random.default_rng(5)
    centers = rng.uniform(0.5, 1.0, size=(n, 3)) * rng.choice([-1, 1], size=(n, 3)) * offset
    tris = centers[:, None, :] + rng.normal(size=(n, 3, 3))
    tris = tris.astype(np.float32)
    t64 = tris.astype(np.float64)
    normal = np.cross(t64[:, 1] - t64[:, 0], t64[:, 2] - t64[:, 0])
    area2 = np.linalg.norm(normal, axis=1)
    tris, t64, normal, area2 = tris[area2 > 0.5], t64[area2 > 0.5], normal[area2 > 0.5], area2[area2 > 0.5]
    centroid = t64.mean(axis=1)
    unit_n = normal / area2[:, None]
    away = rng.normal(size=centroid.shape)
    away /= np.linalg.norm(away, axis=1)[:, None]
    cos = np.einsum("ij,ij->i", away, unit_n)
    away = np.where(np.abs(cos)[:, None] < 0.3, unit_n * np.sign(cos + 0.5)[:, None], away)
    o = (centroid + rng.uniform(1, 4, size=(len(centroid), 1)) * away).astype(np.float32)
    d = (centroid - o).astype(np.float32)
    d /= np.linalg.norm(d, axis=1)[:, None]
    return o, d, tris


def _bw12_float32_precompute(o, d, tris):
    """Baldwin-Weber with the map computed in float32 (what the kernel must
    not do): the pair hits, per ray."""
    f = np.float32
    v0, v1, v2 = tris[:, 0], tris[:, 1], tris[:, 2]
    e1, e2 = v1 - v0, v2 - v0
    n = np.cross(e1, e2)
    k = np.argmax(np.abs(n), axis=1)
    idx = np.arange(len(tris))
    k1, k2 = (k + 1) % 3, (k + 2) % 3
    nk = n[idx, k]
    cu = (v2[idx, k1] * v0[idx, k2] - v2[idx, k2] * v0[idx, k1]) / nk
    cv = (v0[idx, k1] * v1[idx, k2] - v0[idx, k2] * v1[idx, k1]) / nk
    cw = -np.einsum("ij,ij->i", n, v0) / nk
    w_o = o[idx, k] + n[idx, k1] / nk * o[idx, k1] + n[idx, k2] / nk * o[idx, k2] + cw
    w_d = d[idx, k] + n[idx, k1] / nk * d[idx, k1] + n[idx, k2] / nk * d[idx, k2]
    t = -w_o / w_d
    p1, p2 = o[idx, k1] + t * d[idx, k1], o[idx, k2] + t * d[idx, k2]
    u = e2[idx, k2] / nk * p1 - e2[idx, k1] / nk * p2 + cu
    v = -e1[idx, k2] / nk * p1 + e1[idx, k1] / nk * p2 + cv
    assert u.dtype == f
    return (t > 0) & (u >= 0) & (v >= 0) & (u + v <= 1)


def test_float32_precomputation_would_break_far_from_the_origin():
    # the control for the next test: the same map rounded in float32 at every
    # step loses most rays aimed at centroids near 1e4
    o, d, tris = _far_workload(1e4)
    assert reference_answers(o, d, tris).hit.all()
    assert _bw12_float32_precompute(o, d, tris).mean() < 0.8


@pytest.mark.parametrize(
    ("kernel", "native"),
    [
        ("baldwin_weber_12", "baldwin_weber_12_fma"),
        ("baldwin_weber_9", "baldwin_weber_9_fma"),
        # the projection tests: plane constants (and Wald's line constants) of the same kind, made in double
        ("badouel", "badouel_fma"),
        ("wald", "wald_fma"),
        ("shevtsov", "shevtsov_fma"),
    ],
)
@pytest.mark.parametrize("offset", [1e3, 1e4])
def test_baldwin_weber_float32_far_from_the_origin(kernel, native, offset):
    o, d, tris = _far_workload(offset)
    ref = reference_answers(o, d, tris)
    assert ref.hit.all()
    # every hit is kept; t, u, v carry float32's absolute resolution at the
    # coordinates' scale (W(o) and U(p) sum terms of size ~offset), unlike
    # moller_trumbore, whose o - v0 is exact
    atol = 16 * offset * np.finfo(np.float32).eps
    r = ext.intersect(kernel, o, d, tris, "pairs")
    assert r.hit.all()
    np.testing.assert_allclose(r.t, ref.t, atol=atol, rtol=0)
    np.testing.assert_allclose(r.u, ref.u, atol=atol, rtol=0)
    np.testing.assert_allclose(r.v, ref.v, atol=atol, rtol=0)
    index_ref, t_ref = reference.intersect_closest(o, d, tris)
    closest = ext.intersect(kernel, o, d, tris, "closest_uv")
    np.testing.assert_array_equal(closest.index, index_ref)
    np.testing.assert_allclose(closest.t, t_ref, atol=atol, rtol=0)
    # the native FMA form (u, v from the transformed ray, not the hit point): the same resolution
    for isa, runnable in ext.kernel_info(native).isas.items():
        if runnable:
            fused = ext.intersect(native, o, d, tris, "closest_uv", isa=isa)
            np.testing.assert_array_equal(fused.index, index_ref, err_msg=isa)
            np.testing.assert_allclose(fused.t, t_ref, atol=atol, rtol=0, err_msg=isa)
