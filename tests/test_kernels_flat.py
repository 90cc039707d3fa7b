"""Flat (zero-area) triangles: ``ext.flat`` decides them exactly, every clean kernel misses
them in every precision, form and ISA this CPU runs, the seed replays keep the seed's
behaviour, and nearly flat triangles are still triangles."""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tribench import ext
from tribench.workloads import reference

DTYPES = [np.float32, np.float64]
CLEAN = [k for k in ext.kernel_names(internal=True) if not ext.kernel_info(k).seed_replay]
# (kernel, isa) for every form and every ISA this CPU runs
FORMS = [(k, isa) for k in CLEAN for isa, ok in ext.kernel_info(k).isas.items() if ok]
FORM_IDS = [f"{k}-{isa}" for k, isa in FORMS]


def exactly_flat(tri) -> bool:
    a, b, c = ([Fraction(float(x)) for x in v] for v in tri)
    e, f = [q - p for p, q in zip(a, b, strict=True)], [q - p for p, q in zip(a, c, strict=True)]
    return all(e[j] * f[k] == e[k] * f[j] for j, k in ((1, 2), (2, 0), (0, 1)))


def flat_set(seed: int, dtype, n: int = 24, scale_exp: tuple[int, int] = (-6, 16)):
    """n exactly flat triangles from coordinates that are not dyadic (a point, a repeated vertex,
    collinear vertices a + k (b - a) kept where exact), each scaled by a power of two, in a random
    vertex order, and one ray per triangle aimed at a point between a and b."""
    rng = np.random.default_rng(seed)
    tris, o, d = [], [], []
    while len(tris) < n:
        scale = 2.0 ** int(rng.integers(*scale_exp))
        a = (scale * rng.uniform(-3, 3, 3)).astype(dtype)
        b = (a + scale * rng.uniform(-2, 2, 3)).astype(dtype)
        kind = len(tris) % 3
        if kind == 0:
            tri = np.array([a, a, a])
        elif kind == 1:
            tri = np.array([a, b, b])
        else:
            k = rng.choice([2.0, -1.0, 0.5, 3.0, 1.5, -0.5, 5.0, 0.25])
            tri = np.array([a, b, (a.astype(np.float64) + k * (b.astype(np.float64) - a)).astype(dtype)])
            if not exactly_flat(tri):
                continue
        tris.append(tri[rng.permutation(3)])
        aim = a + rng.uniform(0, 1) * (b.astype(np.float64) - a)
        di = rng.normal(size=3)
        o.append(aim - rng.uniform(1, 3) * scale * di)
        d.append(di)
    return tuple(np.ascontiguousarray(x, dtype=dtype) for x in (o, d, tris))


def test_the_issue_repro_is_a_miss():
    hits = ext.intersect(
        "moller_trumbore",
        np.array([[-1.0865, 0.1745000000000001, 3.3760000000000003]]),
        np.array([[0.724, 0.697, -1.312]]),
        np.array([[[-0.192, 1.11, 1.44], [-0.533, 0.633, 2.688], [-0.533, 0.633, 2.688]]]),
        "pairs",
    )
    assert hits.index[0] == -1 and np.isnan(hits.t[0])


# ----------------------------------------------------------------- ext.flat


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), dtype=st.sampled_from(DTYPES))
def test_flat_finds_every_exactly_flat_triangle(seed, dtype):
    _, _, tris = flat_set(seed, dtype, n=12)
    assert ext.flat(tris).all()


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), dtype=st.sampled_from(DTYPES), ulps=st.integers(1, 4))
def test_flat_spares_triangles_one_ulp_from_flat(seed, dtype, ulps):
    # one coordinate of a flat triangle moved by a few ulps: exactly not flat (checked in
    # rational arithmetic), though its float cross product may round to 0
    _, _, tris = flat_set(seed, dtype, n=6)
    rng = np.random.default_rng(seed)
    moved = tris.copy()
    for tri in moved:
        j, k = rng.integers(3), rng.integers(3)
        toward = np.inf if rng.random() < 0.5 else -np.inf
        for _ in range(ulps):
            tri[j, k] = np.nextafter(tri[j, k], toward)
    expected = [exactly_flat(t) for t in moved]
    assert ext.flat(moved).tolist() == expected
    assert not all(expected)  # most moves leave the line


def test_flat_on_extreme_and_nonfinite_coordinates():
    big, tiny = 1e300, 1e-300
    tris = np.array(
        [
            [[big, big, 0], [-big, -big, 0], [0, 0, 0]],  # collinear, differences overflow in float64
            [[big, big, 0], [-big, -big, 0], [0, tiny, 0]],  # not flat: a tiny offset
            [[tiny, 0, 0], [0, tiny, 0], [0, 0, tiny]],  # not flat: products underflow
            [[tiny, tiny, tiny], [2 * tiny, 2 * tiny, 2 * tiny], [3 * tiny, 3 * tiny, 3 * tiny]],  # flat
            [[np.nan, 0, 0], [0, 0, 0], [0, 0, 0]],  # non-finite: not flat
            [[np.inf, 0, 0], [np.inf, 0, 0], [np.inf, 0, 0]],
        ]
    )
    assert ext.flat(tris).tolist() == [True, False, False, True, False, False]


@pytest.mark.parametrize("dtype", DTYPES, ids=["f32", "f64"])
def test_prepare_poisons_flat_records_of_clean_kernels_only(dtype):
    o, d, tris = flat_set(5, dtype, n=9)
    both = np.ascontiguousarray(np.concatenate([tris, [[[0, 0, 0], [1, 0, 0], [0, 1, 0]]]]), dtype=dtype)
    for kernel in ext.kernel_names(internal=True):
        records = ext.prepare(kernel, both).records
        if ext.kernel_info(kernel).lanes > 1:  # blocks of 16, structure of arrays: back to one row per triangle
            records = records.transpose(0, 2, 1).reshape(-1, records.shape[1])[: len(both)]
        poisoned = np.isnan(records).all(axis=1)
        assert poisoned.tolist() == ([not ext.kernel_info(kernel).seed_replay] * len(tris) + [False]), kernel


@pytest.mark.parametrize("dtype", DTYPES, ids=["f32", "f64"])
def test_a_blocks_lanes_past_the_last_triangle_hold_the_flat_record(dtype):
    """Padding is NaN, which every kernel's tests fail on their common path; zeros (a triangle at the
    origin, edge functions exactly 0) sent woop_fma to its exact fallback on every vector holding them."""
    tris = np.ascontiguousarray(np.random.default_rng(3).normal(size=(12, 3, 3)), dtype=dtype)
    for kernel in ext.kernel_names(internal=True):
        lanes = ext.kernel_info(kernel).lanes
        if lanes == 1:
            continue
        records = ext.prepare(kernel, tris).records  # a block of 16: 12 triangles, then padding
        rows = records.transpose(0, 2, 1).reshape(-1, records.shape[1])  # one row per lane
        assert len(rows) == 16 and np.isfinite(rows[:12]).all() and np.isnan(rows[12:]).all(), kernel
    o, d = np.zeros((1, 3), dtype), np.array([[0, 0, 1]], dtype)  # through the origin, where zeros lay
    expected = reference.intersect_closest(o.astype(np.float64), d.astype(np.float64), tris.astype(np.float64))
    for kernel in (
        k for k in ext.kernel_names() if ext.kernel_info(k).lanes > 1 and not ext.kernel_info(k).culls_back_faces
    ):
        assert ext.intersect(kernel, o, d, tris, "closest").index[0] == expected[0][0], kernel


# ------------------------------------------------------------- the kernels


@pytest.mark.parametrize("kernel,isa", FORMS, ids=FORM_IDS)
@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), dtype=st.sampled_from(DTYPES))
def test_clean_kernels_miss_every_flat_triangle(kernel, isa, seed, dtype):
    o, d, tris = flat_set(seed, dtype)
    for mode in ext.kernel_info(kernel).modes:
        assert not ext.intersect(kernel, o, d, tris, mode, isa=isa).hit.any(), mode


def test_moller_seed_keeps_the_seeds_det_test_on_flat_triangles():
    # collinear float32 vertices some 100 units out: det is rounding noise above the seed's
    # 1e-4, so the seed's code hits the segment (documented in moller_seed.h and docs/kernels.md)
    o = np.array([[0.9213621616363525, -168.2555389404297, -372.24993896484375]], np.float32)
    d = np.array([[-55.93600082397461, 12.543999671936035, 83.96800231933594]], np.float32)
    tri = np.array(
        [
            [
                [-89.08799743652344, -184.83200073242188, -174.20799255371094],
                [-57.855995178222656, -244.3520050048828, -131.19998168945312],
                [-120.31999969482422, -125.31199645996094, -217.21600341796875],
            ]
        ],
        np.float32,
    )
    assert exactly_flat(tri[0]) and ext.flat(tri)[0]
    assert ext.intersect("moller_seed", o, d, tri, "pairs").hit[0]
    assert not ext.intersect("moller_trumbore", o, d, tri, "pairs").hit[0]


def nearly_flat(seed: int, dtype, n: int = 32):
    """Needles: c = a + k (b - a) + w, w perpendicular to b - a and 1e-3 to 1e-2 (float32) or
    1e-6 to 1e-3 (float64) of |b - a|; one ray per triangle at its centroid."""
    rng = np.random.default_rng(seed)
    a = rng.uniform(-2, 2, (n, 3))
    e = rng.uniform(-1, 1, (n, 3))
    w = np.cross(e, rng.normal(size=(n, 3)))
    width = 10.0 ** rng.uniform(-3, -2, n) if dtype == np.float32 else 10.0 ** rng.uniform(-6, -3, n)
    w *= (width * np.linalg.norm(e, axis=1) / np.linalg.norm(w, axis=1))[:, None]
    k = rng.uniform(0.2, 0.8, (n, 1))
    tris = np.stack([a, a + e, a + k * e + w], axis=1).astype(dtype).astype(np.float64)
    normal = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
    d = normal / np.linalg.norm(normal, axis=1)[:, None] + 0.3 * rng.normal(size=(n, 3))
    o = tris.mean(axis=1) - rng.uniform(1, 3, (n, 1)) * d
    return tuple(np.ascontiguousarray(x, dtype=dtype) for x in (o, d, tris))


@pytest.mark.parametrize("kernel,isa", FORMS, ids=FORM_IDS)
@pytest.mark.parametrize("dtype", DTYPES, ids=["f32", "f64"])
def test_nearly_flat_triangles_still_hit_where_the_reference_does(kernel, isa, dtype):
    o, d, tris = nearly_flat(7, dtype)
    assert not ext.flat(tris).any()
    ref = reference.intersect_pairs(o.astype(np.float64), d.astype(np.float64), tris.astype(np.float64))
    sure = ref.hit & (ref.edge_margin >= 0.2)
    assert sure.sum() >= len(o) // 2
    if ext.kernel_info(kernel).culls_back_faces:  # front faces only: turn each triangle to face its ray
        t64 = tris.astype(np.float64)
        back = np.einsum("ij,ij->i", d.astype(np.float64), np.cross(t64[:, 1] - t64[:, 0], t64[:, 2] - t64[:, 0])) > 0
        tris = np.ascontiguousarray(np.where(back[:, None, None], tris[:, [0, 2, 1]], tris))
    for i in np.flatnonzero(sure):
        r = ext.intersect(kernel, o[i : i + 1], d[i : i + 1], tris[i : i + 1], "closest", isa=isa)
        assert r.hit[0], (i, kernel)
