"""Fuzzing the public kernel API: garbage in any one argument gives an answer
that agrees with the float64 reference, or a UserError naming that argument.

Each example starts from a valid call and replaces one argument with
something drawn from wrong types, shapes, dtypes, byte orders, strides,
subclasses, 0-d and object arrays, empty arrays, NaN/Inf and huge numbers.
Whatever happens must be one of two things: a result that the float64
reference agrees with, or :class:`tribench.common.UserError` whose message
names the replaced argument. Any other exception fails the test (a crash
would end the test process).
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from tribench import ext
from tribench.common import UserError
from tribench.workloads import reference

# hypothesis casts float32-width values into float16 arrays: overflow to inf is what is wanted there
pytestmark = pytest.mark.filterwarnings("ignore:overflow encountered in cast:RuntimeWarning")

BUDGET = settings(
    max_examples=250, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large]
)

# A valid base workload with unambiguous answers: four triangles in the planes
# z = 0 .. 3 and four rays down -z, two through interiors, two far outside.
_TRI = np.array([[[0.0, 0, z], [4, 0, z], [0, 4, z]] for z in range(4)])
_O = np.array([[0.5, 0.5, 10.0], [1.0, 1.0, 2.5], [9.0, 9.0, 10.0], [-5.0, 0.5, 10.0]])
_D = np.tile([0.0, 0.0, -1.0], (4, 1))
KERNELS = tuple(k for k in ext.kernel_names() if not ext.kernel_info(k).seed_replay)  # the seed's keep their epsilons


class _Sub(np.ndarray):
    """An ndarray subclass that does nothing."""


def _unaligned(a: np.ndarray) -> np.ndarray:
    raw = np.zeros(a.nbytes + 1, np.uint8)
    out = np.frombuffer(raw.data, dtype=a.dtype, count=a.size, offset=1).reshape(a.shape)
    out[...] = a
    return out


_TRANSFORMS = {
    "none": lambda a: a,
    "byteswap": lambda a: a.astype(a.dtype.newbyteorder()),
    "strided": lambda a: np.repeat(a, 2, axis=0)[::2] if a.ndim else a,
    "fortran": np.asfortranarray,
    "masked": lambda a: np.ma.masked_array(a, mask=np.zeros(a.shape, bool)),
    "subclass": lambda a: a.view(_Sub),
    "readonly": lambda a: np.frombuffer(a.tobytes(), a.dtype).reshape(a.shape) if a.size else a,
    "unaligned": lambda a: _unaligned(a) if a.size and a.dtype.alignment > 1 else a,
    "object": lambda a: a.astype(object),
}
_DTYPES = st.sampled_from(["float64", "float32", "float16", "int32", "int64", "bool", "complex128", "U2", ">f8"])
_FLOATS = st.floats(allow_nan=True, allow_infinity=True, width=32)


@st.composite
def _bad_array(draw, tail: tuple[int, ...]) -> np.ndarray:
    """Arrays near the expected (N, *tail) shape or far from it, in any dtype and layout."""
    if draw(st.booleans()):
        shape = (draw(st.integers(0, 4)), *tail)
    else:
        shape = draw(hnp.array_shapes(min_dims=0, max_dims=4, min_side=0, max_side=4))
    dtype = np.dtype(draw(_DTYPES))
    if dtype.kind == "f":
        a = draw(hnp.arrays(dtype, shape, elements=st.one_of(_FLOATS, st.floats(-4, 12, width=32))))
    else:
        a = draw(hnp.arrays(dtype, shape))
    return _TRANSFORMS[draw(st.sampled_from(sorted(_TRANSFORMS)))](a)


_SCALARS = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(),
    st.integers(min_value=10**300),
    st.floats(),
    st.complex_numbers(),
    st.text(max_size=6),
    st.binary(max_size=6),
    st.sampled_from(
        [
            np.float32(2.0),
            np.float64(np.nan),
            np.bool_(True),
            np.int64(3),
            np.float16(0.5),
            np.longdouble(2),
            np.complex64(1),
            np.datetime64("2020"),
            object(),
            int,
            "avx2",
            "baseline",
            "avx512",
            "scalar",
            "closest",
            "pairs",
            "moller_trumbore",
            "float32",
        ]
    ),
    st.lists(st.floats(), max_size=3),
    st.tuples(st.integers(), st.integers()),
    st.dictionaries(st.text(max_size=2), st.integers(), max_size=2),
)


def _garbage(tail: tuple[int, ...]):
    return st.one_of(_SCALARS, _bad_array(tail), _bad_array((3,)), _bad_array(()))


def _reference_agrees(r: ext.Hits, o, d, tri, mode: str, t_max) -> None:
    """``r`` agrees with the float64 reference on every ray whose answer is
    unambiguous (no plane crossing within 1e-3 of an edge, of t = 0 or of t_max,
    no near-parallel or degenerate triangle, coordinates of moderate size)."""
    o, d, tri = (np.asarray(x, np.float64) for x in (o, d, tri))
    n, k = len(o), len(tri)
    limit = np.broadcast_to(np.asarray(np.inf if t_max is None else t_max, np.float64), (n,))
    assert r.index.shape == r.t.shape == (n,) and ((r.index >= -1) & (r.index < k)).all()
    assert np.isfinite(r.t[r.hit]).all() and (r.t[r.hit] > 0).all() and (r.t[r.hit] < limit[r.hit]).all()
    if max(np.abs(o).max(), np.abs(d).max(), np.abs(tri).max()) > 1e3:
        return
    pairs_of = (lambda i: [i]) if mode == "pairs" else (lambda i: range(k))
    for i in range(n):
        js = list(pairs_of(i))
        ans = reference.intersect_pairs(
            np.repeat(o[i : i + 1], len(js), 0),
            np.repeat(d[i : i + 1], len(js), 0),
            tri[js],
            t_max=np.full(len(js), limit[i]),
        )
        e1, e2 = tri[js, 1] - tri[js, 0], tri[js, 2] - tri[js, 0]
        area = np.linalg.norm(np.cross(e1, e2), axis=1)
        cos = np.abs(np.einsum("ij,ij->i", np.cross(e1, e2), np.repeat(d[i : i + 1], len(js), 0)))
        with np.errstate(invalid="ignore", divide="ignore"):
            edge = np.minimum(np.minimum(ans.u, ans.v), ans.w)
            clear = (
                (area > 1e-3)
                & (cos > 1e-3 * area * np.linalg.norm(d[i]))
                & np.isfinite(ans.t)
                & (np.abs(edge) > 1e-3)
                & (np.abs(ans.t) > 1e-3)
                & (np.abs(ans.t - limit[i]) > 1e-3)
            )
        if not clear.all():
            continue
        hit_j = [j for j, h in zip(js, ans.hit, strict=True) if h]
        if mode != "any":
            assert r.hit[i] == bool(hit_j), (i, r, ans)
        else:
            assert r.hit[i] == bool(hit_j)
        if hit_j and mode != "any":
            t_ref = min(ans.t[ans.hit])
            assert abs(r.t[i] - t_ref) <= 1e-3 * max(1.0, t_ref)
            assert abs(ans.t[js.index(int(r.index[i]))] - t_ref) <= 1e-3 * max(1.0, t_ref)


def _names(exc: UserError, argument: str) -> bool:
    return argument in str(exc)


_INTERSECT_ARGS = ("kernel", "origins", "directions", "triangles", "mode", "t_max", "isa", "allow_nonfinite")


@BUDGET
@given(
    data=st.data(),
    kernel=st.sampled_from(KERNELS),
    which=st.sampled_from(_INTERSECT_ARGS),
    dtype=st.sampled_from([np.float32, np.float64]),
)
def test_intersect_with_one_bad_argument(data, kernel, which, dtype):
    modes = ext.kernel_info(kernel).modes
    args = {
        "kernel": kernel,
        "origins": _O.astype(dtype),
        "directions": _D.astype(dtype),
        "triangles": _TRI.astype(dtype),
        "mode": data.draw(st.sampled_from(modes)),
        "t_max": None,
        "isa": None,
        "allow_nonfinite": False,
    }
    tail = {"origins": (3,), "directions": (3,), "triangles": (3, 3), "t_max": ()}.get(which, ())
    args[which] = data.draw(_garbage(tail), label=which)
    try:
        r = ext.intersect(**args)
    except UserError as exc:
        assert _names(exc, which), f"{which}={args[which]!r}: {exc}"
        return
    _reference_agrees(r, args["origins"], args["directions"], args["triangles"], args["mode"], args["t_max"])


@BUDGET
@given(data=st.data(), kernel=st.sampled_from(KERNELS), which=st.sampled_from(_INTERSECT_ARGS[:-1]))
def test_make_job_with_one_bad_argument(data, kernel, which):
    args = {
        "kernel": kernel,
        "origins": _O,
        "directions": _D,
        "triangles": _TRI,
        "mode": data.draw(st.sampled_from(ext.kernel_info(kernel).modes)),
        "t_max": None,
        "isa": None,
    }
    tail = {"origins": (3,), "directions": (3,), "triangles": (3, 3), "t_max": ()}.get(which, ())
    args[which] = data.draw(_garbage(tail), label=which)
    try:
        job = ext.make_job(**args)
    except UserError as exc:
        assert _names(exc, which), f"{which}={args[which]!r}: {exc}"
        return
    # the job times what intersect answers: the same hits
    batch = ext.time_batch(job, 1)
    r = ext.intersect(**args)
    _reference_agrees(r, args["origins"], args["directions"], args["triangles"], args["mode"], args["t_max"])
    if args["mode"] != "any":
        assert batch.hits == int(r.hit.sum())


_JOB = ext.make_job("moller_trumbore", _O, _D, _TRI, "closest")


def _not_a_long_valid_count(value) -> bool:
    """False for a valid loop count above 1000: it is accepted, and a batch of 10**11 loops takes minutes."""
    return not (isinstance(value, int) and not isinstance(value, bool) and value > 1000)


@BUDGET
@given(
    job=st.one_of(_SCALARS, st.just(_JOB)),
    loops=st.one_of(_SCALARS.filter(_not_a_long_valid_count), st.integers(1, 3)),
)
def test_time_batch_with_bad_arguments(job, loops):
    try:
        batch = ext.time_batch(job, loops)
    except UserError as exc:
        assert _names(exc, "job") or _names(exc, "loops"), str(exc)
        return
    assert job is _JOB and batch.loops == loops and batch.hits == 2 * loops


@BUDGET
@given(
    kernel=st.one_of(_SCALARS, st.sampled_from(KERNELS)),
    triangles=st.one_of(_garbage((3, 3)), st.just(_TRI)),
    allow_nonfinite=st.one_of(st.booleans(), _SCALARS),
)
def test_prepare_with_bad_arguments(kernel, triangles, allow_nonfinite):
    try:
        p = ext.prepare(kernel, triangles, allow_nonfinite=allow_nonfinite)
    except UserError as exc:
        assert any(_names(exc, a) for a in ("kernel", "triangles", "allow_nonfinite")), str(exc)
        return
    assert p.n_triangles == len(triangles) and p.records.dtype == triangles.dtype


@BUDGET
@given(
    kernel=st.one_of(_SCALARS, st.sampled_from(ext.kernel_names(internal=True))),
    dtype=st.one_of(_SCALARS, st.sampled_from(["float32", "float64", np.float32, ">f4", "f8", "int8", "c16"])),
)
def test_kernel_info_and_bytes_per_triangle_with_bad_arguments(kernel, dtype):
    try:
        info = ext.kernel_info(kernel)
    except UserError as exc:
        assert _names(exc, "kernel"), str(exc)
        return
    try:
        size = ext.bytes_per_triangle(kernel, dtype)
    except UserError as exc:
        assert _names(exc, "dtype"), str(exc)
        return
    assert size == info.stride * np.dtype(dtype).itemsize and np.dtype(dtype) in (np.float32, np.float64)


@pytest.mark.parametrize(
    "t_max, message",
    [
        ("abc", "t_max must be None, a real number"),
        (1 + 2j, "t_max"),
        (True, "t_max"),
        (b"2", "t_max"),
        (np.ma.masked_array([np.nan] * 4, mask=[True] * 4), "t_max is a numpy.ma.MaskedArray"),
    ],
)
def test_issue_examples_of_t_max_are_refused(t_max, message):
    with pytest.raises(UserError, match=message):
        ext.intersect("moller_trumbore", _O, _D, _TRI, "closest", t_max=t_max)


def test_issue_examples_that_are_answers():
    # 10**400 is past float64's range: it means no limit, like inf
    r = ext.intersect("moller_trumbore", _O, _D, _TRI, "closest", t_max=10**400)
    assert r.index.tolist() == [3, 2, -1, -1]
    with pytest.raises(UserError, match="isa must be a str"):
        ext.intersect("moller_trumbore_fma", _O, _D, _TRI, "closest", isa=["avx2"])
    masked = np.ma.masked_array(_O.copy(), mask=np.zeros(_O.shape, bool))
    masked[0, 0] = np.ma.masked
    masked.data[0, 0] = np.nan
    with pytest.raises(UserError, match="origins is a numpy.ma.MaskedArray"):
        ext.intersect("moller_trumbore", masked, _D, _TRI, "closest", allow_nonfinite=False)
