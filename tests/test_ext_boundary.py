"""The C/Python boundary: every malformed input is a clear error, never a crash."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from tribench import ext
from tribench.ext import _core

ORIGIN = np.array([[0.25, 0.25, 1.0]])
D = np.array([[0.0, 0, -1]])
TRI = np.array([[[0.0, 0, 0], [1, 0, 0], [0, 1, 0]]])


@pytest.mark.parametrize(
    "call, error, message",
    [
        (lambda: ext.intersect_pairs("nope", ORIGIN, D, TRI), ValueError, "unknown kernel 'nope'"),
        (lambda: ext.intersect_pairs(3, ORIGIN, D, TRI), TypeError, "kernel must be a str"),
        (lambda: ext.intersect_pairs("curless", ORIGIN.tolist(), D, TRI), TypeError, "origins must be a numpy.ndarray"),
        (lambda: ext.intersect_pairs("curless", ORIGIN.astype(np.int64), D, TRI), TypeError, "origins must have dtype"),
        (lambda: ext.intersect_pairs("curless", ORIGIN, D.astype(">f8"), TRI), TypeError, "directions must have dtype"),
        (lambda: ext.intersect_pairs("curless", ORIGIN, D.astype(np.float32), TRI), TypeError, "one precision"),
        (lambda: ext.intersect_pairs("curless", ORIGIN[0], D, TRI), ValueError, r"origins must have shape \(N, 3\)"),
        (
            lambda: ext.intersect_pairs("curless", ORIGIN, D, TRI[0]),
            ValueError,
            r"triangles must have shape \(N, 3, 3\)",
        ),
        (lambda: ext.intersect_pairs("curless", ORIGIN[:0], D[:0], TRI[:0]), ValueError, "origins is empty"),
        (lambda: ext.intersect_pairs("curless", np.repeat(ORIGIN, 2, 0), D, TRI), ValueError, "differ in length"),
        (
            lambda: ext.intersect_pairs("curless", np.repeat(ORIGIN, 2, 0), np.repeat(D, 2, 0), TRI),
            ValueError,
            "one triangle per ray",
        ),
        (
            lambda: ext.intersect_pairs(
                "curless", np.repeat(ORIGIN, 4, 0)[::2], np.repeat(D, 2, 0), np.repeat(TRI, 2, 0)
            ),
            ValueError,
            "C-contiguous",
        ),
        (
            lambda: ext.intersect_pairs(
                "curless", np.asfortranarray(np.repeat(ORIGIN, 2, 0)), np.repeat(D, 2, 0), np.repeat(TRI, 2, 0)
            ),
            ValueError,
            "C-contiguous",
        ),
        (
            lambda: ext.intersect_closest("curless", ORIGIN, D, np.full_like(TRI, np.nan)),
            ValueError,
            r"triangles contains NaN or Inf \(first at row 0\)",
        ),
        (lambda: ext.make_job("curless", ORIGIN, D, TRI, "sideways"), ValueError, "mode must be"),
        (lambda: ext.time_batch("job", 1), TypeError, "make_job"),
        (
            lambda: ext.time_batch(ext.make_job("curless", ORIGIN, D, TRI, "pairs"), 0),
            ValueError,
            "loops must be at least 1, got 0",
        ),
        (
            lambda: ext.time_batch(ext.make_job("curless", ORIGIN, D, TRI, "pairs"), 1.5),
            TypeError,
            "loops must be an int",
        ),
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
    t_max = np.full(1, np.inf)
    index, t, u, v = np.empty(5, np.int64), np.empty(5), np.empty(5), np.empty(5)
    with pytest.raises(ValueError, match="origins: buffer has"):
        _core.run("moller_trumbore", 8, 0, "scalar", ORIGIN, D, 5, t_max, records, 5, index, t, u, v)
    with pytest.raises(ValueError, match="t_max: buffer has"):
        _core.run(
            "moller_trumbore", 8, 2, "scalar", ORIGIN, D, 1, np.full(3, 1.0), records, 1, index[:1], t[:1], u[:1], v[:1]
        )
    with pytest.raises(ValueError, match="records: buffer has"):
        _core.time("moller_trumbore", 8, 2, "scalar", ORIGIN, D, 1, t_max, records, 1000, 10)
    with pytest.raises(ValueError, match="itemsize"):
        _core.time("moller_trumbore", 2, 2, "scalar", ORIGIN, D, 1, t_max, records, 1, 10)
    with pytest.raises(ValueError, match="mode must be"):
        _core.time("moller_trumbore", 8, 7, "scalar", ORIGIN, D, 1, t_max, records, 1, 10)
    with pytest.raises(ValueError, match="no ISA"):
        _core.time("moller_trumbore", 8, 2, "avx2", ORIGIN, D, 1, t_max, records, 1, 10)
    with pytest.raises(ValueError, match="no 'pairs' mode"):
        wide = ext.prepare("moller_trumbore_fma", TRI).records
        _core.time("moller_trumbore_fma", 8, 0, "baseline", ORIGIN, D, 1, t_max, wide, 1, 10)
    with pytest.raises(ValueError, match="records: buffer has"):
        # a native kernel's records are whole blocks of 16
        _core.time("moller_trumbore_fma", 8, 2, "baseline", ORIGIN, D, 1, t_max, records, 1, 10)
    with pytest.raises(ValueError, match="unknown kernel"):
        _core.kernel_info("nope")
    with pytest.raises(ValueError, match="at least 1"):
        _core.time("moller_trumbore", 8, 2, "scalar", ORIGIN, D, -1, t_max, records, 1, 10)


def test_t_max_is_checked():
    for bad, err in [
        (np.zeros(1), ValueError),
        (np.full(1, np.nan), ValueError),
        (np.ones(2), ValueError),
        (np.ones(1, np.float32), TypeError),
        ([1.0], TypeError),
    ]:
        with pytest.raises(err, match="t_max"):
            ext.intersect("moller_trumbore", ORIGIN, D, TRI, "pairs", t_max=bad)
    assert not ext.intersect("moller_trumbore", ORIGIN, D, TRI, "pairs", t_max=0.5).hit[0]


def test_results_do_not_alias_inputs_and_inputs_are_untouched():
    o, d, tri = ORIGIN.copy(), D.copy(), TRI.copy()
    ext.intersect_pairs("curless_seed", o, d, tri)
    np.testing.assert_array_equal(o, ORIGIN)
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
    mode=st.sampled_from(ext.MODES + ("nope",)),
    allow_nonfinite=st.booleans(),
)
def test_random_inputs_give_results_or_clear_errors(kernel, o, d, tri, mode, allow_nonfinite):
    try:
        r = ext.intersect(kernel, o, d, tri, mode, allow_nonfinite=allow_nonfinite)
    except (TypeError, ValueError):
        return
    assert r.index.shape == r.t.shape == r.u.shape == (len(o),)
    # every hit has a finite, positive t
    assert (r.t[r.hit] > 0).all() and np.isfinite(r.t[r.hit]).all()


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
    if "pairs" in ext.kernel_info(kernel).modes:
        hit, t = ext.intersect_pairs(kernel, o, d, tri, allow_nonfinite=True)
        assert np.isfinite(t[hit]).all() and (t[hit] > 0).all()
    for mode in ("any", "closest_uv"):
        index, tc, _, _ = ext.intersect(kernel, o, d, tri, mode, allow_nonfinite=True)
        assert ((index >= -1) & (index < 4)).all()
        assert np.isfinite(tc[index >= 0]).all() and (tc[index >= 0] > 0).all()


# ------------------------------------------------------------ unbounded work


def test_a_batch_is_bounded_up_front_with_the_bound_and_why():
    job = ext.make_job("moller_trumbore", ORIGIN, D, TRI, "pairs")
    with pytest.raises(
        ext.UserError,
        match=r"more than 6e\+11 tests, a minute even at 0\.1 ns per test; "
        r"use at most 600000000000 loops",
    ):
        ext.time_batch(job, 2**40)
    many = ext.make_job(
        "moller_trumbore_fma", np.repeat(ORIGIN, 100, 0), np.repeat(D, 100, 0), np.repeat(TRI, 10, 0), "closest"
    )
    assert many.tests_per_pass == 1000
    with pytest.raises(ext.UserError, match="use at most 600000000 loops"):
        ext.time_batch(many, ext.MAX_BATCH_TESTS // 1000 + 1)
    # the C glue refuses it too, on a direct call
    with pytest.raises(ValueError, match="at most 600000000000"):
        _core.time("moller_trumbore", 8, 2, "scalar", ORIGIN, D, 1, np.full(1, np.inf), job.prepared.records, 1, 2**40)
    with pytest.raises(ext.UserError, match=r"iterations must be between 1 and 268435456 \(2\*\*28"):
        ext.fma_peak(2**31)
    with pytest.raises(ValueError, match="iterations must be between 1 and 268435456"):
        _core.fma_peak(2**31)


LONG_CALLS = {
    # one ray, one triangle, as many loops as the bound allows: hours of work
    "time_batch": "job = ext.make_job('moller_trumbore', ORIGIN, D, T, 'pairs')\n"
    "go(); ext.time_batch(job, ext.MAX_BATCH_TESTS)",
    "time_batch_native": "job = ext.make_job('moller_trumbore_fma', ORIGIN, D, np.repeat(T, 64, 0), 'closest')\n"
    "go(); ext.time_batch(job, ext.MAX_BATCH_TESTS // 64)",
    # an untimed call of 10**10 tests (about a minute)
    "intersect": "o = np.repeat(ORIGIN, 200_000, 0); d = np.repeat(D, 200_000, 0); t = np.repeat(T, 50_000, 0)\n"
    "go(); ext.intersect('moller_trumbore', o, d, t, 'closest')",
}


@pytest.mark.parametrize("call", list(LONG_CALLS))
def test_ctrl_c_stops_a_long_kernel_call_within_a_second(call):
    import signal
    import subprocess
    import sys
    import time

    # Python turns SIGINT into KeyboardInterrupt only if it was not ignored at start: a suite launched in the
    # background by a script (`bash .ci/run &`) hands its children an ignored SIGINT, so the child asks for it
    script = (
        "import signal, sys, numpy as np\nfrom tribench import ext\n"
        "signal.signal(signal.SIGINT, signal.default_int_handler)\n"
        "ORIGIN = np.array([[0.25, 0.25, 1.0]], np.float32); D = np.array([[0.0, 0, -1]], np.float32)\n"
        "T = np.array([[[0.0, 0, 0], [1, 0, 0], [0, 1, 0]]], np.float32)\n"
        "def go(): print('started', flush=True)\n" + LONG_CALLS[call] + "\nprint('finished')\n"
    )
    proc = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert proc.stdout.readline().strip() == "started"
        time.sleep(0.5)  # well inside the C loop
        assert proc.poll() is None
        sent = time.monotonic()
        proc.send_signal(signal.SIGINT)
        proc.wait(timeout=10)
        took = time.monotonic() - sent
    finally:
        proc.kill()
    out, err = proc.communicate()
    assert "finished" not in out
    assert proc.returncode != 0 and "KeyboardInterrupt" in err, err
    assert took < 2.0, took


@pytest.mark.parametrize(
    "triangles, error, words",
    [
        (np.zeros((2, 2)), ext.UserError, "must have shape (N, 3, 3), got (2, 2)"),
        (np.zeros(9), ext.UserError, "got (9,)"),
        ("abc", ext.UserTypeError, "array of real numbers, got str"),
    ],
)
def test_flat_refuses_what_is_no_triangle_array_in_one_line(triangles, error, words):
    with pytest.raises(error) as refused:
        ext.flat(triangles)
    assert words in str(refused.value)


def test_flat_takes_one_triangle_a_list_and_none_at_all():
    assert ext.flat([[0, 0, 0], [1, 0, 0], [2, 0, 0]]).tolist() == [True]
    assert ext.flat(np.zeros((0, 3, 3))).tolist() == []


def test_kernel_names_refuses_a_truthy_string_as_its_flag():
    with pytest.raises(ext.UserTypeError, match="internal must be True or False, got str"):
        ext.kernel_names(internal="yes")


def test_a_t_max_off_its_alignment_is_refused_before_c():
    # hypothesis found it: the rays' arrays are checked for alignment, t_max was not, and C said
    # "buffer is not aligned to 8 bytes" as a plain ValueError
    o = np.zeros((2, 3))
    d = np.tile([0.0, 0.0, 1.0], (2, 1))
    tri = np.array([[[-1.0, -1, 1], [1, -1, 1], [0, 1, 1]]])
    t_max = np.frombuffer(np.full(17, 2, np.uint8).tobytes(), np.uint8)[1:].view(np.float64)
    assert not t_max.flags.aligned
    for call in (ext.intersect, ext.make_job):
        with pytest.raises(ext.UserError, match="t_max is not aligned to its dtype"):
            call("moller_trumbore", o, d, tri, "closest", t_max=t_max)
