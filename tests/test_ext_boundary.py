"""The C/Python boundary: every malformed input is a clear error, never a crash."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from tribench import ext
from tribench.ext import _core

O = np.array([[0.25, 0.25, 1.0]])
D = np.array([[0.0, 0, -1]])
TRI = np.array([[[0.0, 0, 0], [1, 0, 0], [0, 1, 0]]])


@pytest.mark.parametrize(
    "call, error, message",
    [
        (lambda: ext.intersect_pairs("nope", O, D, TRI), ValueError, "unknown kernel 'nope'"),
        (lambda: ext.intersect_pairs(3, O, D, TRI), TypeError, "kernel must be a str"),
        (lambda: ext.intersect_pairs("curless", O.tolist(), D, TRI), TypeError, "origins must be a numpy.ndarray"),
        (lambda: ext.intersect_pairs("curless", O.astype(np.int64), D, TRI), TypeError, "origins must have dtype"),
        (lambda: ext.intersect_pairs("curless", O, D.astype(">f8"), TRI), TypeError, "directions must have dtype"),
        (lambda: ext.intersect_pairs("curless", O, D.astype(np.float32), TRI), TypeError, "one precision"),
        (lambda: ext.intersect_pairs("curless", O[0], D, TRI), ValueError, r"origins must have shape \(N, 3\)"),
        (lambda: ext.intersect_pairs("curless", O, D, TRI[0]), ValueError, r"triangles must have shape \(N, 3, 3\)"),
        (lambda: ext.intersect_pairs("curless", O[:0], D[:0], TRI[:0]), ValueError, "origins is empty"),
        (lambda: ext.intersect_pairs("curless", np.repeat(O, 2, 0), D, TRI), ValueError, "differ in length"),
        (lambda: ext.intersect_pairs("curless", np.repeat(O, 2, 0), np.repeat(D, 2, 0), TRI), ValueError, "one triangle per ray"),
        (lambda: ext.intersect_pairs("curless", np.repeat(O, 4, 0)[::2], np.repeat(D, 2, 0), np.repeat(TRI, 2, 0)), ValueError, "C-contiguous"),
        (lambda: ext.intersect_pairs("curless", np.asfortranarray(np.repeat(O, 2, 0)), np.repeat(D, 2, 0), np.repeat(TRI, 2, 0)), ValueError, "C-contiguous"),
        (lambda: ext.intersect_closest("curless", O, D, np.full_like(TRI, np.nan)), ValueError, r"triangles contains NaN or Inf \(first at row 0\)"),
        (lambda: ext.make_job("curless", O, D, TRI, "sideways"), ValueError, "mode must be"),
        (lambda: ext.time_batch("job", 1), TypeError, "make_job"),
        (lambda: ext.time_batch(ext.make_job("curless", O, D, TRI, "pairs"), 0), ValueError, "loops must be between"),
        (lambda: ext.time_batch(ext.make_job("curless", O, D, TRI, "pairs"), 1.5), TypeError, "loops must be an int"),
        (lambda: ext.bytes_per_triangle("curless", "int8"), TypeError, "float32 or float64"),
    ],
)
def test_bad_input_is_a_clear_error(call, error, message):
    with pytest.raises(error, match=message):
        call()


def test_unaligned_array_is_rejected():
    raw = np.zeros(3 * 8 + 1, dtype=np.uint8)
    unaligned = np.frombuffer(raw.data, dtype=np.float64, count=3, offset=1).reshape(1, 3)
    assert not unaligned.flags.aligned
    with pytest.raises(ValueError, match="not aligned"):
        ext.intersect_pairs("curless", unaligned, D, TRI)


def test_private_module_checks_buffer_sizes_itself():
    # a direct call that lies about counts must raise, not read out of bounds
    records = ext.prepare("moller_trumbore", TRI).records
    hit, t = np.empty(5, np.uint8), np.empty(5)
    with pytest.raises(ValueError, match="origins: buffer has"):
        _core.run("moller_trumbore", 8, False, O, D, 5, records, 5, hit, t)
    with pytest.raises(ValueError, match="records: buffer has"):
        _core.time("moller_trumbore", 8, True, O, D, 1, records, 1000, 10)
    with pytest.raises(ValueError, match="itemsize"):
        _core.time("moller_trumbore", 2, True, O, D, 1, records, 1, 10)
    with pytest.raises(ValueError, match="unknown kernel"):
        _core.stride("nope")
    with pytest.raises(ValueError, match="at least 1"):
        _core.time("moller_trumbore", 8, True, O, D, -1, records, 1, 10)


def test_results_do_not_alias_inputs_and_inputs_are_untouched():
    o, d, tri = O.copy(), D.copy(), TRI.copy()
    ext.intersect_pairs("curless_seed", o, d, tri)
    np.testing.assert_array_equal(o, O)
    np.testing.assert_array_equal(tri, TRI)
    job = ext.make_job("curless", o, d, tri, "pairs")
    assert not job.origins.flags.writeable and not job.prepared.records.flags.writeable


def test_bytes_per_triangle_reports_prepared_storage():
    assert ext.bytes_per_triangle("moller_trumbore", np.float64) == 72
    assert ext.bytes_per_triangle("curless_seed", "float32") == 48


_dtypes = st.sampled_from([np.float32, np.float64, np.float16, np.int32, np.int64, np.bool_, np.complex64])
_shapes = hnp.array_shapes(min_dims=0, max_dims=4, min_side=0, max_side=4)


@st.composite
def _arrays(draw):
    a = draw(hnp.arrays(draw(_dtypes), draw(_shapes)))
    if a.ndim >= 1 and a.shape[0] >= 2 and draw(st.booleans()):
        a = a[::2]  # sometimes non-contiguous
    return a


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    kernel=st.one_of(st.sampled_from(ext.kernel_names()), st.text(max_size=5), st.integers()),
    o=_arrays(),
    d=_arrays(),
    tri=_arrays(),
    closest=st.booleans(),
    allow_nonfinite=st.booleans(),
)
def test_random_inputs_give_results_or_clear_errors(kernel, o, d, tri, closest, allow_nonfinite):
    fn = ext.intersect_closest if closest else ext.intersect_pairs
    try:
        first, t = fn(kernel, o, d, tri, allow_nonfinite=allow_nonfinite)
    except (TypeError, ValueError):
        return
    assert first.shape == t.shape == (len(o),)
    hit = first >= 0 if closest else first
    if kernel != "curless_seed":
        # every hit has a finite, positive t (the seed's Curless may report NaN)
        assert (t[hit] > 0).all() and np.isfinite(t[hit]).all()


@settings(max_examples=200, deadline=None)
@given(
    values=hnp.arrays(np.float64, (4, 15), elements=st.floats(allow_nan=True, allow_infinity=True, width=64)),
    kernel=st.sampled_from(ext.kernel_names()),
    dtype=st.sampled_from([np.float32, np.float64]),
)
def test_any_float_values_reach_the_kernels_safely(values, kernel, dtype):
    # extreme magnitudes, subnormals, NaN and Inf anywhere: a defined result
    with np.errstate(over="ignore"):
        v = values.astype(dtype)
    o, d, tri = v[:, :3].copy(), v[:, 3:6].copy(), v[:, 6:].reshape(4, 3, 3).copy()
    hit, t = ext.intersect_pairs(kernel, o, d, tri, allow_nonfinite=True)
    index, tc = ext.intersect_closest(kernel, o, d, tri, allow_nonfinite=True)
    assert ((index >= -1) & (index < 4)).all()
    if kernel != "curless_seed":
        assert np.isfinite(t[hit]).all() and (t[hit] > 0).all()
        assert np.isfinite(tc[index >= 0]).all()
