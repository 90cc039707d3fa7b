"""The native FMA forms (Moller-Trumbore's, Woop's, and the yardstick): held to the
float64 reference with a documented error bound, on every ISA; blocks of 16
masked at the tail; the ISA that runs is the one asked for.

The bound (ext/kernels/moller_trumbore_fma.h, woop_fma.h): where the reference's
edge margin is at least 1e-3, the hit/miss decision is the reference's and
|t - t_ref| <= 4 eps K t_ref, K = |e1| |e2| (|d| + |o - v0| / t_ref) / |det|,
all in float64 on the inputs as the kernel sees them (after rounding). The
plain moller_trumbore and woop meet the same bound (checked here too, so the
bound is no weaker for the FMA forms than for the forms they replace).
Measured on the cases below (300 pairs, seeds 0-3, every scale, shift and
grazing, every ISA), largest error in eps K: moller_trumbore 0.92 (float32) /
0.98 (float64), moller_trumbore_fma 0.93 / 1.27; woop 0.97 / 1.27, woop_fma
0.98 / 1.27 (the float64 figures are one pair, shared by both Woop forms).
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import run_pairs, safe_pairs
from hypothesis import given, settings
from hypothesis import strategies as st

from tribench import ext
from tribench.workloads import reference

NATIVE = [k for k in ext.kernel_names(internal=True) if ext.kernel_info(k).lanes == 16]
FMA = [k for k in NATIVE if not ext.kernel_info(k).internal]  # the yardstick is the internal one
BOUND = 4.0  # in units of eps K (measured: at most about 1.3 on the cases below)
SCALAR = ["moller_trumbore", "woop"]  # the plain forms the native ones replace, held to the same bound
BYTES = {"float32": 36, "float64": 72}  # every native kernel's record: 9 reals
BYTES_PER_TRIANGLE = {
    "moller_trumbore_fma": BYTES,  # v0, e1, e2
    "moller_trumbore_fma_exit": BYTES,
    "moller_trumbore_yardstick": BYTES,  # the raw vertices
    "woop_fma": BYTES,  # the raw vertices (the transform is per ray)
}


def _condition(o: np.ndarray, d: np.ndarray, tris: np.ndarray, t: np.ndarray) -> np.ndarray:
    """K of the bound, per pair, in float64."""
    e1, e2 = tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0]
    det = np.abs(np.einsum("ij,ij->i", e1, np.cross(d, e2)))
    n = np.linalg.norm
    return n(e1, axis=1) * n(e2, axis=1) * (n(d, axis=1) + n(o - tris[:, 0], axis=1) / t) / det


def _cases(n: int, seed: int, dtype: type, scale: float, shift: float, grazing: float):
    """Safe-margin pairs, all aimed inside, scaled, shifted away from the origin,
    and tilted toward grazing (grazing = fraction of the normal component removed)."""
    o, d, tris = safe_pairs(n, seed=seed, hit_rate=1.0)
    normal = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
    normal /= np.linalg.norm(normal, axis=1)[:, None]
    target = o + reference.intersect_pairs(o, d, tris).t[:, None] * d  # the point each ray aims at
    d = d - grazing * np.einsum("ij,ij->i", d, normal)[:, None] * normal
    o = target - 2 * d
    return tuple(np.ascontiguousarray(a, dtype) for a in (o * scale + shift, d, tris * scale + shift))


def _check_bound(kernel: str, o: np.ndarray, d: np.ndarray, tris: np.ndarray, isa: str | None = None) -> float:
    """Asserts the bound on every safe pair; returns the largest error in units of eps K."""
    f64 = [a.astype(np.float64) for a in (o, d, tris)]
    ref = reference.intersect_pairs(*f64)
    options = {} if isa is None or ext.kernel_info(kernel).lanes == 1 else {"isa": isa}
    hit, t = run_pairs(kernel, o, d, tris, **options)
    safe = np.abs(ref.edge_margin) >= 1e-3
    np.testing.assert_array_equal(hit[safe], ref.hit[safe], err_msg=kernel)
    both = safe & hit & ref.hit
    assert both.sum() > len(o) // 2
    error = np.abs(t[both] - ref.t[both]) / ref.t[both] / (np.finfo(o.dtype).eps * _condition(*f64, ref.t)[both])
    assert error.max() <= BOUND, (kernel, isa, float(error.max()))
    return float(error.max())


def test_the_native_kernels_are_registered_as_such():
    assert set(FMA) == {"moller_trumbore_fma", "moller_trumbore_fma_exit", "woop_fma"}
    assert set(NATIVE) == set(BYTES_PER_TRIANGLE)
    for k in NATIVE:
        info = ext.kernel_info(k)
        assert info.scalar_form is None and info.wide_form is None and info.modes == ext.MODES[1:]
        assert info.bytes_per_triangle == BYTES_PER_TRIANGLE[k], k
    assert ext.kernel_info("moller_trumbore_yardstick").internal
    assert list(ext.kernel_info("moller_trumbore_yardstick").isas) == ["avx2"]
    for k in FMA:
        isas = ext.kernel_info(k).isas
        assert isas["baseline"] and list(isas) == list(ext.kernel_info("moller_trumbore_x8").isas)
    # woop_fma makes woop's promises
    woop, woop_fma = ext.kernel_info("woop"), ext.kernel_info("woop_fma")
    assert (woop_fma.watertight, woop_fma.watertight_source) == (woop.watertight, woop.watertight_source)
    assert (woop_fma.culls_back_faces, woop_fma.flat, woop_fma.seed_replay) == (False, woop.flat, False)


@pytest.mark.parametrize("dtype", [np.float32, np.float64], ids=["f32", "f64"])
@pytest.mark.parametrize("kernel", NATIVE + SCALAR)
def test_random_pairs_meet_the_bound_on_every_isa(kernel, dtype):
    o, d, tris = _cases(300, seed=21, dtype=dtype, scale=1.0, shift=0.0, grazing=0.0)
    for isa, runnable in ext.kernel_info(kernel).isas.items():
        if runnable:
            _check_bound(kernel, o, d, tris, isa)


@settings(max_examples=12, deadline=None)
@given(
    dtype=st.sampled_from([np.float32, np.float64]),
    scale=st.sampled_from([1e-3, 1.0, 1e3]),
    shift=st.sampled_from([0.0, 10.0, 1e3]),
    grazing=st.sampled_from([0.0, 0.9, 0.97]),
    seed=st.integers(0, 1000),
)
def test_adversarial_pairs_meet_the_bound(dtype, scale, shift, grazing, seed):
    o, d, tris = _cases(60, seed=seed, dtype=dtype, scale=scale, shift=shift, grazing=grazing)
    for kernel in FMA + SCALAR:
        _check_bound(kernel, o, d, tris)


@pytest.mark.parametrize("dtype", [np.float32, np.float64], ids=["f32", "f64"])
def test_the_early_exit_changes_the_work_not_the_answers(dtype):
    rng = np.random.default_rng(4)
    tris = rng.normal(size=(100, 3, 3)).astype(dtype)
    o = (rng.normal(size=(400, 3)) * 0.5 + [0, 0, -4]).astype(dtype)
    d = (rng.normal(size=(400, 3)) * 0.3 + [0, 0, 1]).astype(dtype)
    for isa, runnable in ext.kernel_info("moller_trumbore_fma").isas.items():
        if runnable:
            want = ext.intersect("moller_trumbore_fma", o, d, tris, "closest_uv", isa=isa)
            got = ext.intersect("moller_trumbore_fma_exit", o, d, tris, "closest_uv", isa=isa)
            assert (want.index >= 0).sum() > 50
            for w, g in zip(want, got, strict=True):
                np.testing.assert_array_equal(g, w, err_msg=isa)


@pytest.mark.parametrize("n", [1, 15, 16, 17, 33])
def test_the_lanes_past_the_last_triangle_never_hit(n):
    # a stack of n triangles below the ray: the closest is the first, the last
    # block's empty lanes (zero records) must never answer
    unit = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], float)
    tris = np.tile(unit, (n, 1, 1)) + np.arange(n)[:, None, None] * np.array([0, 0, -1.0])
    o, d = np.array([[0.25, 0.25, 1.0], [0.0, 0.0, -1e9]]), np.array([[0, 0, -1.0], [0, 0, 1.0]])
    for kernel in NATIVE:
        for isa, runnable in ext.kernel_info(kernel).isas.items():
            if not runnable:
                continue
            r = ext.intersect(kernel, o, d, tris, "closest", isa=isa)
            assert list(r.index) == [0, n - 1] and r.t[0] == 1.0, (kernel, isa)
            last = ext.intersect(kernel, o[:1], d[:1], np.ascontiguousarray(tris[n - 1 :]), "any", isa=isa)
            assert last.index[0] == 0 and last.t[0] == n


def test_the_isa_that_runs_is_the_one_asked_for(monkeypatch):
    info = ext.kernel_info("moller_trumbore_fma")
    assert info.isa == next(i for i, ok in info.isas.items() if ok)
    monkeypatch.setenv("TRIBENCH_ISA", "baseline")
    assert ext.kernel_info("moller_trumbore_fma").isa == "baseline"
    job = ext.make_job("moller_trumbore_fma", np.zeros((1, 3)), np.ones((1, 3)), np.eye(3)[None], "closest")
    assert job.isa == "baseline"
    with pytest.raises(ValueError, match="TRIBENCH_ISA='baseline' cannot run moller_trumbore_yardstick"):
        ext.kernel_info("moller_trumbore_yardstick")
