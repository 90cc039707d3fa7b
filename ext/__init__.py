"""Ray-triangle intersection kernels in C, behind a validated Python API.

Every array is checked here (type, dtype, shape, contiguity, alignment,
finiteness, emptiness) before the compiled module sees it, and the compiled
module checks buffer sizes again, so no input from Python can crash the
process. Precision follows the arrays: all float32 or all float64.

Kernels (see ``kernel_names()``; each C file's header cites its paper):

* ``curless_seed``, ``moller_seed``: the seed paper's two tests, as its code
  wrote them (absolute epsilons 1e-4, divide-first Moller, stored unit normal
  and strict edges for Curless);
* ``curless``, ``moller_trumbore``: clean versions (no absolute epsilon,
  late division, closed triangles);
* ``moller_trumbore_cull`` (back faces culled), ``baldwin_weber_12`` and
  ``baldwin_weber_9`` (Baldwin & Weber 2016, 12- and 9-float storage),
  ``havel_herout`` (Havel & Herout 2010), ``woop`` (Woop, Benthin & Wald
  2013, watertight), ``plucker`` (origin-shifted Pluecker tests);
* ``<name>_x8``: the wide form of a kernel (branchless, one ray against
  blocks of 8 triangles stored structure of arrays), compiled for several
  instruction sets and run with the best one this CPU has (see
  ``kernel_info``; ``TRIBENCH_ISA=baseline`` forces the build's baseline);
* ``moller_trumbore_fma`` and ``moller_trumbore_fma_exit``: native wide
  kernels (no scalar form): Moller-Trumbore at the widest vector the CPU
  has (16 float lanes with AVX-512, 8 with AVX2 + FMA), fused
  multiply-adds, stored edges, blocks of 16 triangles; held to the
  reference with an error bound, not bit for bit to ``moller_trumbore``;
* ``woop_fma``: ``woop`` as a native wide kernel, watertight as ``woop``
  (the shear and the scaled t fused, the edge functions not, a 0 edge
  function recomputed exactly), leaving a vector when no lane is inside all
  three edges; held to the reference with the same error bound;
* ``baldwin_weber_12_fma`` and ``baldwin_weber_9_fma``: Baldwin & Weber
  as native wide kernels, fused, on the scalar forms' records, with the
  early exit after the u test; held to the reference with their own bound;
* ``havel_herout_fma`` and ``plucker_fma``: the same treatment of Havel &
  Herout (its 12-real planes, early exit after u) and of the Plucker test
  (vertices, edges and normal stored, early exit after the edge tests).

Internal kernels, for the harness's honesty checks (listed only by
``kernel_names(internal=True)``, accepted everywhere a kernel name is):

* ``moller_trumbore_aa``: an identical copy of ``moller_trumbore`` under
  another name (A/A calibration);
* ``moller_trumbore_twice``: ``moller_trumbore`` doing every test twice (a
  known 2x effect);
* ``moller_trumbore_yardstick``: a plain AVX2 intrinsics Moller-Trumbore
  (AVX2 only), the yardstick of ``bench/yardstick.py``.

``fma_peak()`` measures the core's arithmetic peak with a short loop of
independent 8-lane FMAs.

Modes (what a call answers per ray): ``pairs`` (ray i against triangle i),
``any`` (some hit, as shadow rays ask), ``closest`` (the closest hit's t),
``closest_uv`` (its t, u, v). Every ray may carry a ``t_max``: only hits
with ``0 < t < t_max`` count. A miss has index ``-1`` and ``t = u = v =
nan``. Conventions of the clean kernels match ``tribench.workloads.reference``.

``tribench.ext`` owns the kernels, their registration and the checked C
boundary. It may import ``tribench.common`` only: it knows nothing of
workloads, statistics or files.

Examples
--------
>>> import numpy as np
>>> tri = np.array([[[0., 0, 0], [1, 0, 0], [0, 1, 0]]])
>>> hit, t = intersect_pairs("moller_trumbore", np.array([[0.25, 0.25, 1.0]]),
...                          np.array([[0.0, 0, -1]]), tri)
>>> bool(hit[0]), float(t[0])
(True, 1.0)
"""

from __future__ import annotations

import functools
import hashlib
import os
from dataclasses import dataclass
from fractions import Fraction
from typing import Any, Literal, NamedTuple

import numpy as np

from tribench.common import UserError, UserTypeError

from . import _core

__all__ = [
    "MAX_BATCH_TESTS",
    "MAX_PEAK_ITERATIONS",
    "MODES",
    "Batch",
    "Hits",
    "Job",
    "KernelInfo",
    "Peak",
    "Prepared",
    "UserError",
    "UserTypeError",
    "build_info",
    "extension_sha256",
    "BVH",
    "COUNT_NAMES",
    "MAX_BVH_BATCH_RAYS",
    "MAX_BVH_TRIANGLES",
    "BVH_BUILD_VERSION",
    "Trace",
    "TraceBatch",
    "adopt_bvh",
    "build_bvh",
    "DEFAULT_MAX_LEAF",
    "bvh_kernel_names",
    "bytes_per_triangle",
    "flat",
    "fma_peak",
    "OP_CLASSES",
    "OpThroughput",
    "op_throughput",
    "probe_isas",
    "intersect",
    "intersect_closest",
    "intersect_pairs",
    "kernel_info",
    "kernel_names",
    "make_job",
    "prepare",
    "time_batch",
]

Mode = Literal["pairs", "any", "closest", "closest_uv"]
MODES: tuple[str, ...] = ("pairs", "any", "closest", "closest_uv")  # the C enum's order
_DTYPES = (np.dtype(np.float32), np.dtype(np.float64))
_PUBLIC: tuple[str, ...] = _core.kernel_names(False)
_KERNELS: tuple[str, ...] = _core.kernel_names(True)  # every name a call accepts


def kernel_names(internal: bool = False) -> tuple[str, ...]:
    """Names of the registered kernels, in registry order.

    Parameters
    ----------
    internal : bool
        Also list the internal kernels (the harness's A/A copy and
        double-work kernel), after the others.

    >>> "moller_trumbore" in kernel_names()
    True
    >>> [k for k in kernel_names(internal=True) if k not in kernel_names()]
    ['moller_trumbore_aa', 'moller_trumbore_twice', 'moller_trumbore_yardstick']
    """
    return _KERNELS if internal else _PUBLIC


@dataclass(frozen=True)
class KernelInfo:
    """What the registry says of one kernel.

    Every property is declared once, on the kernel's registration line in
    ``ext/kernels/list.h`` (or, for stride, ops and flat, beside the code in
    its file), and read here from the extension: no property is inferred
    from a kernel's name.

    Attributes
    ----------
    name : str
    lanes : int
        Triangles per record block: 1 for a scalar early-exit kernel, 8 for
        an ``_x8`` wide form, 16 for a native wide kernel (one vector of 16
        float lanes with AVX-512, two of 8 with AVX2).
    stride : int
        Reals of prepared data per triangle.
    ops : int
        Arithmetic operations per test (per lane for a wide form; a scalar
        kernel's count is the path of a hit). Documented per kernel in its
        header, with the counting rules in ``ext/kernels.h``.
    internal : bool
        One of the harness's honesty-check kernels (the A/A copy and the
        double-work kernel), left out of ``kernel_names()``.
    isas : dict[str, bool]
        Instruction sets the kernel is compiled for (best first), and whether
        this CPU can run each. Scalar kernels have one, ``"scalar"``.
    isa : str
        The ISA calls use by default: ``TRIBENCH_ISA`` if set and runnable,
        else the best runnable one.
    scalar_form : str or None
        For a wide form, the scalar kernel it is the wide form of (same
        algorithm, properties and answers); None for a scalar kernel.
    wide_form : str or None
        For a scalar kernel that has one, the name of its wide form.
    algorithm : str
        The clean scalar kernel whose algorithm this kernel is a form of:
        itself for a scalar kernel (a seed replay is its own), the scalar form
        for an ``_x8`` form, the one a native kernel declares
        (``tb_<name>_algorithm`` in its file). Rankings by algorithm group by it.
    culls_back_faces : bool
        Only front faces count: ``det = e1 . (d x e2) > 0``, the vertices
        counter-clockwise seen from the ray's origin.
    watertight : str
        ``"none"``, or ``"edges_and_vertices"``: the kernel's paper promises
        no crack on shared edges and vertices (``tribench validate`` holds it
        to that, and to Embree's threshold inside a sphere).
    watertight_source : str
        The paper that makes the watertight promise (``""`` if none).
    seed_replay : bool
        A faithful copy of the seed's code, flaws included: its differences
        from the reference are measured and recorded, never judged.
    flat : str
        What becomes of an exactly flat triangle: ``"miss"`` (every ray
        misses it) or ``"as_is"`` (the kernel's own test decides, as the
        seed's code did).
    precisions : tuple[str, ...]
        The dtypes the kernel is compiled for.
    """

    name: str
    lanes: int
    stride: int
    ops: int
    internal: bool
    isas: dict
    isa: str
    scalar_form: str | None
    wide_form: str | None
    algorithm: str
    culls_back_faces: bool
    watertight: str
    watertight_source: str
    seed_replay: bool
    flat: str
    precisions: tuple[str, ...]

    @property
    def mix(self) -> dict[str, int]:
        """Operations per test (and lane) by class: ``fma, mul, add, cmp, div`` (summing
        to :attr:`ops`), ``logic`` (mask and select work, outside ``ops``) and ``load``
        (reals read per test: the stride). Declared as ``tb_<name>_mix`` in the kernel's
        file; a wide form's is its compiled loop's (tests/test_ext_build.py)."""
        counts = dict(zip(("fma", "mul", "add", "cmp", "div", "logic"), _core.kernel_mix(self.name), strict=True))
        return {**counts, "load": self.stride}

    @property
    def modes(self) -> tuple[str, ...]:
        """Modes the kernel runs (wide forms have no pairs mode)."""
        return MODES if self.lanes == 1 else MODES[1:]

    @property
    def bytes_per_triangle(self) -> dict[str, int]:
        """Bytes of prepared data per triangle, per precision (stride x itemsize)."""
        return {p: self.stride * np.dtype(p).itemsize for p in self.precisions}


# Scalar kernel -> its wide form, from each wide form's declared scalar form.
_WIDE_FORMS: dict[str, str] = {s: k for k in _KERNELS if (s := _core.kernel_info(k)["scalar_form"])}


def kernel_info(kernel: str) -> KernelInfo:
    """Lanes, storage, instruction sets and declared properties of ``kernel``.

    >>> kernel_info("moller_trumbore").isa
    'scalar'
    >>> info = kernel_info("moller_trumbore_x8")
    >>> info.lanes, info.isas["baseline"], info.scalar_form
    (8, True, 'moller_trumbore')
    >>> kernel_info("woop").watertight, kernel_info("moller_trumbore_cull").culls_back_faces
    ('edges_and_vertices', True)
    """
    _check_kernel(kernel)
    declared = dict(_core.kernel_info(kernel))  # afresh: which ISAs run can be asked again
    isas = declared.pop("isas")
    runnable = dict(isas)
    wanted = os.environ.get("TRIBENCH_ISA")
    if declared["lanes"] > 1 and wanted:
        if not runnable.get(wanted):
            raise UserError(
                f"TRIBENCH_ISA={wanted!r} cannot run {kernel}: runnable here: {', '.join(i for i, ok in isas if ok)}"
            )
        isa = wanted
    else:
        isa = next(i for i, ok in isas if ok)
    return KernelInfo(name=kernel, isas=runnable, isa=isa, wide_form=_WIDE_FORMS.get(kernel), **declared)


def build_info() -> dict:
    """How the extension was built: compiler, exact flags, FMA and fast-math
    macros, and the resolution of the clock that times batches."""
    return dict(_core.build_info())


@functools.cache
def extension_sha256() -> str:
    """The sha256 of the compiled extension's file: which build of the C code
    this is (any change to a kernel, its records or the BVH build changes it)."""
    with open(_core.__file__, "rb") as f:
        return hashlib.file_digest(f, "sha256").hexdigest()


def bytes_per_triangle(kernel: str, dtype: np.dtype | type | str) -> int:
    """Bytes of prepared data one triangle occupies for ``kernel`` at ``dtype``.

    >>> bytes_per_triangle("moller_trumbore", "float32")
    36
    """
    info, dt = kernel_info(kernel), _check_dtype_name(dtype)
    if dt.name not in info.precisions:
        raise UserError(f"{kernel} is compiled for {', '.join(info.precisions)}, not {dt.name}")
    return info.bytes_per_triangle[dt.name]


# ----------------------------------------------------------------- validation


def _check_kernel(kernel: object) -> str:
    if not isinstance(kernel, str):
        raise UserTypeError(f"kernel must be a str, got {type(kernel).__name__}")
    if kernel not in _KERNELS:
        raise UserError(f"unknown kernel {kernel!r}; known kernels: {', '.join(_PUBLIC)}")
    return kernel


def _check_dtype_name(dtype: Any) -> np.dtype:
    if dtype is None:  # numpy reads None as float64: a precision must be named
        raise UserTypeError("dtype must be float32 or float64, got None")
    try:
        dt = np.dtype(dtype)
    except Exception as exc:  # numpy raises TypeError, ValueError or SyntaxError for a bad spec
        raise UserTypeError(f"dtype must be float32 or float64, got {dtype!r:.80}") from exc
    if dt not in _DTYPES:
        raise UserTypeError(f"dtype must be float32 or float64 (native byte order), got {dt}")
    return dt


def _check_name(name: str, value: object, choices: tuple[str, ...]) -> str:
    """``value`` is one of ``choices`` (a str: a list or an array is not a name)."""
    if not isinstance(value, str):
        raise UserTypeError(f"{name} must be a str, one of {', '.join(choices)}; got {type(value).__name__}")
    if value not in choices:
        raise UserError(f"{name} must be one of {', '.join(choices)}; got {value!r:.80}")
    return value


def _check_flag(name: str, value: object) -> bool:
    if not isinstance(value, (bool, np.bool_)):
        raise UserTypeError(f"{name} must be True or False, got {type(value).__name__}")
    return bool(value)


def _plain(name: str, a: np.ndarray) -> np.ndarray:
    """``a`` as a plain ndarray view (never a copy). A masked array is refused:
    the kernels read every value, masked or not, so its mask would be ignored
    silently (and a NaN under the mask would pass the finiteness check)."""
    if isinstance(a, np.ma.MaskedArray):
        raise UserTypeError(
            f"{name} is a numpy.ma.MaskedArray: the kernels would read the masked values "
            f"too; pass {name}.filled(...) or only the unmasked rows"
        )
    return a if type(a) is np.ndarray else a.view(np.ndarray)


def _check_array(name: str, a: object, tail: tuple[int, ...], allow_nonfinite: bool = False) -> np.ndarray:
    """Check one input array; return it as a plain ndarray (a view, never a copy)."""
    allow_nonfinite = _check_flag("allow_nonfinite", allow_nonfinite)
    if not isinstance(a, np.ndarray):
        raise UserTypeError(f"{name} must be a numpy.ndarray, got {type(a).__name__}")
    a = _plain(name, a)
    if a.dtype not in _DTYPES:
        raise UserTypeError(f"{name} must have dtype float32 or float64 (native byte order), got {a.dtype}")
    shape = "(N, " + ", ".join(map(str, tail)) + ")"
    if a.ndim != 1 + len(tail) or a.shape[1:] != tail:
        raise UserError(f"{name} must have shape {shape}, got {a.shape}")
    if a.shape[0] == 0:
        raise UserError(f"{name} is empty")
    if not a.flags.c_contiguous:
        raise UserError(f"{name} must be C-contiguous (use numpy.ascontiguousarray)")
    if not a.flags.aligned:
        raise UserError(f"{name} is not aligned to its dtype")
    if not allow_nonfinite:
        bad = ~np.isfinite(a.reshape(len(a), -1)).all(axis=1)
        if bad.any():
            raise UserError(f"{name} contains NaN or Inf (first at row {int(np.argmax(bad))})")
    return a


def _check_same_dtype(**arrays: np.ndarray) -> np.dtype:
    dtypes = {a.dtype for a in arrays.values()}
    if len(dtypes) != 1:
        listed = ", ".join(f"{k}={v.dtype}" for k, v in arrays.items())
        raise UserTypeError(f"arrays must share one precision, got {listed}")
    return dtypes.pop()


def _check_workload(kernel, origins, directions, triangles, mode, t_max, isa, allow_nonfinite):
    """Every check of a kernel call on a workload.

    Returns (o, d, triangles, t_max, isa): t_max as an array of the
    workload's precision (a new array when given None or a scalar), isa the
    checked ISA name."""
    info = kernel_info(kernel)
    _check_name("mode", mode, MODES)
    if mode not in info.modes:
        raise UserError(f"{kernel} has no {mode!r} mode (its modes: {', '.join(info.modes)})")
    if isa is None:
        isa = info.isa
    else:
        _check_name("isa", isa, tuple(info.isas))
        if not info.isas[isa]:
            raise UserError(f"{kernel}: isa {isa!r} is not available on this CPU")
    o = _check_array("origins", origins, (3,), allow_nonfinite)
    d = _check_array("directions", directions, (3,), allow_nonfinite)
    if len(o) != len(d):
        raise UserError(f"origins and directions differ in length: {len(o)} and {len(d)}")
    tris = _check_array("triangles", triangles, (3, 3), allow_nonfinite)
    dtype = _check_same_dtype(origins=o, directions=d, triangles=tris)
    if mode == "pairs" and len(tris) != len(o):
        raise UserError(f"triangles: pairs need one triangle per ray, got {len(tris)} for {len(o)} rays")
    return o, d, tris, _check_t_max(t_max, len(o), dtype), isa


def _check_t_max(t_max, n: int, dtype: np.dtype) -> np.ndarray:
    """t_max per ray: None means +inf; a real number applies to every ray.
    NaN and values <= 0 are errors (no hit could ever count). A number past
    the dtype's range rounds to inf, which is what it means: no limit."""
    if t_max is None:
        return np.full(n, np.inf, dtype=dtype)
    if isinstance(t_max, (int, float, np.integer, np.floating)) and not isinstance(t_max, (bool, np.bool_)):
        try:
            value = float(t_max)
        except OverflowError:  # an int past float64's range: no limit either way
            value = np.inf if t_max > 0 else -np.inf
        with np.errstate(over="ignore"):
            t_max = np.full(n, value, dtype=dtype)
    elif not isinstance(t_max, np.ndarray):
        raise UserTypeError(f"t_max must be None, a real number or a numpy.ndarray, got {type(t_max).__name__}")
    t_max = _plain("t_max", t_max)
    if t_max.shape != (n,):
        raise UserError(f"t_max must have shape ({n},), one per ray, got {t_max.shape}")
    if t_max.dtype != dtype:
        raise UserTypeError(f"t_max must have the rays' dtype {dtype}, got {t_max.dtype}")
    if not (t_max > 0).all():
        raise UserError(f"t_max must be > 0 (inf allowed), got {t_max[~(t_max > 0)][0]!r}")
    return np.ascontiguousarray(t_max)


# ------------------------------------------------------------------ prepared


@dataclass(frozen=True)
class Prepared:
    """A kernel's per-triangle records, computed once outside any timed loop.

    Attributes
    ----------
    kernel : str
    records : ndarray, read-only
        Shape (K, stride) for a scalar kernel: raw vertices for kernels that
        test them directly; vertices plus precomputed planes or normals for
        the others. A wide kernel's are the same records in blocks of
        L = ``kernel_info(kernel).lanes`` triangles (8 or 16), structure of
        arrays: shape (ceil(K / L), stride, L), lanes past the last triangle
        zero. An exactly flat triangle's record is all
        NaN (every ray misses it), except for the seed replays, which keep
        the seed's behaviour (see each kernel's header and :func:`flat`).
    n_triangles : int
    """

    kernel: str
    records: np.ndarray
    n_triangles: int

    @property
    def dtype(self) -> np.dtype:
        return self.records.dtype


def prepare(kernel: str, triangles: np.ndarray, *, allow_nonfinite: bool = False) -> Prepared:
    """Compute ``kernel``'s records for ``triangles`` of shape (K, 3, 3).

    Exactly flat triangles (:func:`flat`) are found here, once, and every
    kernel but the seed replays gets a record no ray can hit: the promise
    that zero-area triangles are misses costs no time per test.
    """
    info = kernel_info(kernel)
    tris = _check_array("triangles", triangles, (3, 3), allow_nonfinite)
    n = len(tris)
    shape = (n, info.stride) if info.lanes == 1 else (-(-n // info.lanes), info.stride, info.lanes)
    records = np.empty(shape, dtype=tris.dtype)
    _core.prepare(kernel, tris.itemsize, tris, n, records, flat(tris).view(np.uint8))
    records.flags.writeable = False
    return Prepared(kernel, records, n)


# The float filter of flat(): |computed cross component| above this fraction of
# |left| + |right| (its two products) cannot come from an exact zero. Rounding
# the two differences, the two products and their difference moves the result by
# at most about 5 units of 2**-53 of |left| + |right|; 2**-48 is 32 of them.
# The absolute term covers products that underflow (errors of 2**-1075 each).
_FILTER_RELATIVE = 2.0**-48
_FILTER_ABSOLUTE = 2.0**-1000


def flat(triangles: np.ndarray) -> np.ndarray:
    """Which triangles have exactly zero area: a point, a repeated vertex, or
    three vertices on one line, in exact arithmetic on the stored values.

    ``cross(v1 - v0, v2 - v0) == 0`` decided exactly: the cross product in
    float64 with an error bound settles every triangle it is clearly not zero
    for; the few others (flat or within rounding of it) are decided in rational
    arithmetic (``fractions.Fraction`` holds a float exactly). A triangle with
    a non-finite vertex is not flat. Returns a bool array, one per triangle.

    >>> import numpy as np
    >>> a = np.array([0.1, 0.2, 0.3])  # not dyadic
    >>> line = np.array([a, 2 * a, 4 * a])  # exactly on the line through 0 and a
    >>> flat(np.stack([line, line + [[0, 0, 0], [0, 0, 0], [0, 0, 1e-15]], [a, a, a]])).tolist()
    [True, False, True]
    """
    v = np.asarray(triangles, dtype=np.float64).reshape(-1, 3, 3)
    with np.errstate(all="ignore"):  # overflow and NaN only leave a triangle undecided
        e, f = v[:, 1] - v[:, 0], v[:, 2] - v[:, 0]
        left = e[:, [1, 2, 0]] * f[:, [2, 0, 1]]
        right = e[:, [2, 0, 1]] * f[:, [1, 2, 0]]
        clearly_not = (np.abs(left - right) > _FILTER_RELATIVE * (np.abs(left) + np.abs(right)) + _FILTER_ABSOLUTE).any(
            axis=1
        )
    out = np.zeros(len(v), dtype=bool)
    for i in np.flatnonzero(~clearly_not & np.isfinite(v).all(axis=(1, 2))):
        a, b, c = ([Fraction(float(x)) for x in vertex] for vertex in v[i])
        e_i, f_i = [q - p for p, q in zip(a, b, strict=True)], [q - p for p, q in zip(a, c, strict=True)]
        out[i] = all(e_i[j] * f_i[k] == e_i[k] * f_i[j] for j, k in ((1, 2), (2, 0), (0, 1)))
    return out


# ------------------------------------------------------------------- results


class Hits(NamedTuple):
    """Per-ray answers of ``intersect``.

    index : int64 ndarray, shape (N,)
        Triangle hit (``-1`` for a miss). Closest modes: ties go to the
        lowest index. ``any``: some hit triangle, not necessarily the
        closest. ``pairs``: ``i`` or ``-1``.
    t, u, v : ndarray, shape (N,), the input precision
        Distance and barycentrics of that hit (the point is
        ``(1-u-v) v0 + u v1 + v v2``); nan for a miss.
    """

    index: np.ndarray  # type: ignore[assignment]  # the field hides tuple.index, as meant
    t: np.ndarray
    u: np.ndarray
    v: np.ndarray

    @property
    def hit(self) -> np.ndarray:
        return self.index >= 0


def intersect(
    kernel: str,
    origins: np.ndarray,
    directions: np.ndarray,
    triangles: np.ndarray,
    mode: Mode = "closest",
    *,
    t_max: np.ndarray | float | None = None,
    isa: str | None = None,
    allow_nonfinite: bool = False,
) -> Hits:
    """Run ``kernel`` on a workload (untimed) and return every ray's answer.

    Parameters
    ----------
    kernel : str
        One of ``kernel_names()``.
    origins, directions : ndarray, shape (N, 3)
    triangles : ndarray, shape (K, 3, 3)
        All three float32, or all float64: the kernel runs at that precision.
        ``pairs`` needs K == N.
    mode : str
        ``pairs``, ``any``, ``closest`` or ``closest_uv`` (``closest`` and
        ``closest_uv`` both return u and v here; they differ when timed).
    t_max : None, number or ndarray (N,)
        Only hits with ``t < t_max`` count (default: +inf).
    isa : str, optional
        Instruction set of a wide kernel (default: ``kernel_info(kernel).isa``).
    allow_nonfinite : bool
        By default NaN or Inf in any input is a ``ValueError``. With True they
        reach the kernel, whose documented behaviour applies (the clean
        kernels report a miss; see each kernel's header).

    >>> import numpy as np
    >>> tri = np.array([[[0., 0, 0], [1, 0, 0], [0, 1, 0]]])
    >>> r = intersect("moller_trumbore_x8", np.array([[0.25, 0.5, 1.0]]),
    ...               np.array([[0.0, 0, -1]]), tri)
    >>> int(r.index[0]), float(r.t[0]), float(r.u[0]), float(r.v[0])
    (0, 1.0, 0.25, 0.5)
    """
    o, d, tris, tm, isa = _check_workload(kernel, origins, directions, triangles, mode, t_max, isa, allow_nonfinite)
    prepared = prepare(kernel, tris, allow_nonfinite=allow_nonfinite)
    n, dtype = len(o), tris.dtype
    out = Hits(np.empty(n, np.int64), np.empty(n, dtype), np.empty(n, dtype), np.empty(n, dtype))
    _core.run(kernel, dtype.itemsize, MODES.index(mode), isa, o, d, n, tm, prepared.records, len(tris), *out)
    return out


def intersect_pairs(kernel, origins, directions, triangles, **options) -> tuple[np.ndarray, np.ndarray]:
    """Ray ``i`` against triangle ``i``: ``(hit, t)`` (see ``intersect``)."""
    r = intersect(kernel, origins, directions, triangles, "pairs", **options)
    return r.hit, r.t


def intersect_closest(kernel, origins, directions, triangles, **options) -> tuple[np.ndarray, np.ndarray]:
    """Closest hit of every ray against every triangle: ``(index, t)``
    (see ``intersect``)."""
    r = intersect(kernel, origins, directions, triangles, "closest", **options)
    return r.index, r.t


# --------------------------------------------------------------------- timing


@dataclass(frozen=True)
class Job:
    """Validated inputs of timed batches: one kernel on one workload.

    Build with ``make_job``; checking happens there once, so ``time_batch``
    adds nothing but the call to the timed region's surroundings.
    """

    kernel: str
    mode: Mode
    origins: np.ndarray
    directions: np.ndarray
    t_max: np.ndarray
    prepared: Prepared
    isa: str

    @property
    def tests_per_pass(self) -> int:
        """Ray-triangle tests in one pass over the workload; for ``any`` the
        most there can be (a batch counts the tests it did, up to each ray's
        first hit)."""
        if self.mode == "pairs":
            return len(self.origins)
        return len(self.origins) * self.prepared.n_triangles


def make_job(
    kernel: str,
    origins: np.ndarray,
    directions: np.ndarray,
    triangles: np.ndarray,
    mode: Mode,
    *,
    t_max: np.ndarray | float | None = None,
    isa: str | None = None,
) -> Job:
    """Validate a workload for timing and prepare ``kernel``'s records.

    ``mode``, ``t_max`` and ``isa`` are as in ``intersect``. Inputs must be
    finite. The arrays are kept as read-only views, not copied.
    """
    o, d, tris, tm, isa = _check_workload(kernel, origins, directions, triangles, mode, t_max, isa, False)
    views = []
    for a in (o, d, tm):
        v = a.view()
        v.flags.writeable = False
        views.append(v)
    return Job(kernel, mode, views[0], views[1], views[2], prepare(kernel, tris), isa)


@dataclass(frozen=True)
class Batch:
    """One timed batch: ``loops`` passes of a job, timed inside C.

    ``hits`` and ``t_sum`` are summed over all passes; compare them with
    ``loops`` times the reference's hit count and sum of ``t``. ``uv_sum``
    is the sum of ``u + v`` in mode ``closest_uv``, else 0.
    """

    elapsed_ns: int
    loops: int
    tests: int
    hits: int
    t_sum: float
    uv_sum: float = 0.0

    @property
    def ns_per_test(self) -> float:
        return self.elapsed_ns / self.tests


#: The most tests one timed batch may do: a minute even at 0.1 ns per test
#: (the fastest kernels here take about 1 ns); a harness batch is about 8 ms.
MAX_BATCH_TESTS: int = _core.MAX_BATCH_TESTS


def time_batch(job: Job, loops: int) -> Batch:
    """Run ``job`` ``loops`` times in C with the GIL released; time it.

    The clock is ``CLOCK_MONOTONIC`` read just before and after the loop.
    ``loops * job.tests_per_pass`` may be at most :data:`MAX_BATCH_TESTS`.
    The loop looks for signals about every 0.1 s, so Ctrl-C stops a long
    batch with ``KeyboardInterrupt`` (a short one never takes the GIL).
    """
    if not isinstance(job, Job):
        raise UserTypeError(f"job must be a tribench.ext.Job (see make_job), got {type(job).__name__}")
    if isinstance(loops, bool) or not isinstance(loops, (int, np.integer)):
        raise UserTypeError(f"loops must be an int, got {type(loops).__name__}")
    if loops < 1:
        raise UserError(f"loops must be at least 1, got {loops}")
    if loops > MAX_BATCH_TESTS // job.tests_per_pass:
        raise UserError(
            f"loops={loops} x {job.tests_per_pass} tests per pass is more than {MAX_BATCH_TESTS:.0e} "
            f"tests, a minute even at 0.1 ns per test; use at most "
            f"{MAX_BATCH_TESTS // job.tests_per_pass} loops (the harness's batches take about 8 ms)"
        )
    p = job.prepared
    elapsed, hits, tests, t_sum, uv_sum = _core.time(
        job.kernel,
        p.dtype.itemsize,
        MODES.index(job.mode),
        job.isa,
        job.origins,
        job.directions,
        len(job.origins),
        job.t_max,
        p.records,
        p.n_triangles,
        int(loops),
    )
    return Batch(elapsed, int(loops), tests, hits, t_sum, uv_sum)


# ------------------------------------------------------------------ FMA peak


@dataclass(frozen=True)
class Peak:
    """One run of the FMA peak probe.

    Attributes
    ----------
    flops : float
        Floating-point operations done (one FMA counts as two).
    elapsed_ns : int
    isa : str
        ``"avx2+fma"`` (8 float lanes, fused) or ``"scalar"`` (the portable
        fallback: separate multiply and add on one lane).
    """

    flops: float
    elapsed_ns: int
    isa: str

    @property
    def gflops(self) -> float:
        """Flops per nanosecond, i.e. GFLOP/s."""
        return self.flops / self.elapsed_ns if self.elapsed_ns > 0 else float("nan")


#: Operation classes of the throughput probes (``ext/probes.h``).
OP_CLASSES: tuple[str, ...] = _core.op_classes()


@dataclass(frozen=True)
class OpThroughput:
    """Lane-operations per ns of each operation class on one ISA's widest vector.

    Attributes
    ----------
    isa : str
        ``"avx512"``, ``"avx2"`` (with FMA) or ``"baseline"`` (SSE2 on x86-64).
    float32, float64 : dict[str, float]
        Per class of :data:`OP_CLASSES` (``fma, mul, add, cmp, logic, div, load,
        fma_add``), the best rate of the probe's repeats.
    """

    isa: str
    float32: dict[str, float]
    float64: dict[str, float]

    def rates(self, dtype) -> dict[str, float]:
        """The rates of one precision."""
        return self.float32 if np.dtype(dtype).itemsize == 4 else self.float64


def probe_isas() -> tuple[str, ...]:
    """ISAs the throughput probes can run on this CPU, widest first."""
    return tuple(name for name, runnable in _core.probe_isas() if runnable)


def op_throughput(isa: str | None = None, *, target_ns: float = 2e6, repeats: int = 3) -> OpThroughput:
    """Probe every operation class on ``isa`` (default: the widest runnable) in both precisions.

    Each probe runs 12 independent chains of one class (ext/probes.h) for about
    ``target_ns`` (scaled from a short first run), timed in C with the GIL
    released; the best of ``repeats`` is kept. About 0.1 s in all.
    """
    runnable = probe_isas()
    isa = runnable[0] if isa is None else isa
    if isa not in runnable:
        raise UserError(f"isa must be one of this CPU's probe ISAs {', '.join(runnable)}; got {isa!r}")
    out: dict[int, dict[str, float]] = {4: {}, 8: {}}
    for itemsize, rates in out.items():
        for op in OP_CLASSES:
            _ops, ns, _ = _core.op_probe(isa, itemsize, op, 1000)
            steps = int(min(MAX_PEAK_ITERATIONS, max(1000, 1000 * target_ns / max(ns, 1))))
            best = 0.0
            for _ in range(repeats):
                lane_ops, ns, _ = _core.op_probe(isa, itemsize, op, steps)
                best = max(best, lane_ops / ns if ns > 0 else 0.0)
            rates[op] = best
    return OpThroughput(isa, out[4], out[8])


#: The most iterations of :func:`fma_peak`: about 4 s of work on a current core.
MAX_PEAK_ITERATIONS: int = _core.MAX_PEAK_ITERATIONS


def fma_peak(iterations: int = 200_000, *, force_scalar: bool = False) -> Peak:
    """Measure this core's arithmetic peak with independent FMA chains.

    Each iteration updates 12 independent 8-lane accumulators with one FMA
    (192 flops); the AVX2+FMA loop is chosen at run time when the CPU has
    both, else a scalar loop runs. 200 000 iterations take about 1-2 ms on a
    current x86 core. The GIL is released.

    >>> p = fma_peak(1000)
    >>> p.flops > 0 and p.elapsed_ns >= 0
    True
    """
    if isinstance(iterations, bool) or not isinstance(iterations, (int, np.integer)):
        raise UserTypeError(f"iterations must be an int, got {type(iterations).__name__}")
    if not 1 <= iterations <= MAX_PEAK_ITERATIONS:
        raise UserError(
            f"iterations must be between 1 and {MAX_PEAK_ITERATIONS} (2**28, about a second of work), got {iterations}"
        )
    flops, elapsed, isa, _sink = _core.fma_peak(int(iterations), bool(force_scalar))
    return Peak(flops, elapsed, isa)


# ----------------------------------------------------------------------- BVH


def bvh_kernel_names() -> tuple[str, ...]:
    """Kernels a :class:`BVH` can take as its leaf test: the native kernels
    (blocks of 16 triangles, one block test per leaf block).

    >>> "moller_trumbore_fma" in bvh_kernel_names()
    True
    """
    return _core.bvh_kernels()


#: Columns of :attr:`Trace.counts`: per ray, nodes entered (inner nodes and
#: leaves), ray-box tests, leaves entered, and triangles tested in them.
COUNT_NAMES: tuple[str, ...] = ("nodes", "box_tests", "leaves", "triangle_tests")
#: The most triangles one BVH takes; the most rays x loops one timed BVH batch traces.
MAX_BVH_TRIANGLES: int = _core.MAX_BVH_TRIANGLES
MAX_BVH_BATCH_RAYS: int = _core.MAX_BVH_BATCH_RAYS
#: The version of the tree ext/bvh.h builds (bumped when it changes; the BVH cache names files by it).
BVH_BUILD_VERSION: int = _core.BVH_BUILD_VERSION


class Trace(NamedTuple):
    """Answers of :meth:`BVH.intersect`, with the work each ray took.

    hits : Hits
        As :func:`intersect` answers (indices are the caller's triangle indices).
    counts : int64 ndarray, shape (N, 4)
        Per ray, the columns of :data:`COUNT_NAMES`.
    """

    hits: Hits
    counts: np.ndarray


@dataclass(frozen=True)
class TraceBatch:
    """One timed BVH batch: ``loops`` passes over the rays, timed inside C.

    ``hits``, ``t_sum`` and ``uv_sum`` as in :class:`Batch`; the counts are
    summed over every ray of every pass (:data:`COUNT_NAMES`).
    """

    elapsed_ns: int
    loops: int
    rays: int
    hits: int
    t_sum: float
    uv_sum: float
    nodes: int
    box_tests: int
    leaves: int
    triangle_tests: int

    @property
    def rays_per_s(self) -> float:
        return self.loops * self.rays / self.elapsed_ns * 1e9 if self.elapsed_ns > 0 else float("nan")


@dataclass(frozen=True, eq=False)
class BVH:
    """A bounding volume hierarchy over a triangle array, with one native
    kernel's records at its leaves. Build with :func:`build_bvh`.

    The tree is ``ext/bvh.h``'s: binned SAH, deterministic, nodes depth first
    (left child next), leaves of at most ``max_leaf`` triangles, each leaf on
    whole blocks of 16 slots. Answers are always in the caller's triangle
    indices; a traversal never sees the caller's array again.

    Attributes
    ----------
    kernel : str
    triangles : ndarray (K, 3, 3), read-only
        The triangles as given (kept for validation and for reference checks).
    nodes : ndarray (n_nodes, 8), read-only, the triangles' precision
        Box corners (6 reals), then two uint32 per node (``nodes.view(np.uint32)``
        columns 6-7 in float32; the first two uint32 of column 6 in float64):
        inner ``(right child, 0)``, leaf ``(first slot, triangles)``.
    perm : int64 ndarray (n_slots,), read-only
        Slot -> caller's triangle index; ``-1`` for the padding of a leaf's last block.
    prepared : Prepared
        The kernel's records in slot order (``n_triangles`` = n_slots).
    max_leaf : int
    """

    kernel: str
    triangles: np.ndarray
    nodes: np.ndarray
    perm: np.ndarray
    prepared: Prepared
    max_leaf: int

    @property
    def dtype(self) -> np.dtype:
        return self.triangles.dtype

    @property
    def n_nodes(self) -> int:
        return len(self.nodes)

    @property
    def n_slots(self) -> int:
        return len(self.perm)

    @property
    def leaves(self) -> np.ndarray:
        """(first slot, triangles) of every leaf, in slot order: int64 (L, 2)."""
        return _leaves(self.nodes)

    def _rays(self, origins, directions, mode, t_max, isa, allow_nonfinite):
        if self.kernel not in bvh_kernel_names():  # a BVH made by hand
            raise UserError(f"{self.kernel} cannot be a BVH's leaf test; these can: {', '.join(bvh_kernel_names())}")
        # one row stands for the triangles (checked finite at the build): dtype and kernel checks only
        return _check_workload(self.kernel, origins, directions, self.triangles[:1], mode, t_max, isa, allow_nonfinite)

    def intersect(
        self,
        origins: np.ndarray,
        directions: np.ndarray,
        mode: Mode = "closest",
        *,
        t_max: np.ndarray | float | None = None,
        isa: str | None = None,
        allow_nonfinite: bool = False,
    ) -> Trace:
        """Trace every ray (untimed); the arguments as :func:`intersect`'s.

        ``closest`` finds the same triangle as brute force with the same
        kernel (ties in ``t`` to the lowest index), up to rounding where two
        triangles' hits are within a few ulps; ``any`` stops at the first hit.
        With ``allow_nonfinite``, a ray with NaN or Inf in its origin or
        direction is a miss (it is not traversed).

        >>> import numpy as np
        >>> tri = np.array([[[0., 0, 0], [1, 0, 0], [0, 1, 0]], [[0., 0, 1], [1, 0, 1], [0, 1, 1]]])
        >>> bvh = build_bvh("moller_trumbore_fma", tri)
        >>> tr = bvh.intersect(np.array([[0.25, 0.25, 3.0]]), np.array([[0.0, 0, -1]]))
        >>> int(tr.hits.index[0]), float(tr.hits.t[0])
        (1, 2.0)
        """
        o, d, _, tm, isa = self._rays(origins, directions, mode, t_max, isa, allow_nonfinite)
        n, dtype = len(o), self.dtype
        hits = Hits(np.empty(n, np.int64), np.empty(n, dtype), np.empty(n, dtype), np.empty(n, dtype))
        counts = np.empty((n, len(COUNT_NAMES)), np.int64)
        _core.bvh_run(self.kernel, dtype.itemsize, MODES.index(mode), isa, o, d, n, tm, *self._tree(), *hits, counts)
        return Trace(hits, counts)

    def time(
        self,
        origins: np.ndarray,
        directions: np.ndarray,
        mode: Mode,
        loops: int,
        *,
        t_max: np.ndarray | float | None = None,
        isa: str | None = None,
        null_leaf: bool = False,
    ) -> TraceBatch:
        """Trace the rays ``loops`` times in C with the GIL released; time it.

        ``null_leaf``: the same traversal with the leaf test replaced by a
        compiler barrier (nothing is hit, so no interval shrinks; give each
        ray's closest-hit ``t`` as ``t_max`` to traverse as if every ray found
        its hit at once). Inputs must be finite; ``loops * len(origins)`` at
        most :data:`MAX_BVH_BATCH_RAYS`.
        """
        o, d, _, tm, isa = self._rays(origins, directions, mode, t_max, isa, False)
        if isinstance(loops, bool) or not isinstance(loops, (int, np.integer)):
            raise UserTypeError(f"loops must be an int, got {type(loops).__name__}")
        if not 1 <= loops <= MAX_BVH_BATCH_RAYS // len(o):
            raise UserError(
                f"loops must be between 1 and {MAX_BVH_BATCH_RAYS // len(o)} for {len(o)} rays, got {loops}"
            )
        null_leaf = _check_flag("null_leaf", null_leaf)
        elapsed, hits, tris, t_sum, uv_sum, nodes, boxes, leaves = _core.bvh_time(
            self.kernel,
            self.dtype.itemsize,
            MODES.index(mode),
            isa,
            o,
            d,
            len(o),
            tm,
            *self._tree(),
            int(loops),
            null_leaf,
        )
        return TraceBatch(elapsed, int(loops), len(o), hits, t_sum, uv_sum, nodes, boxes, leaves, tris)

    def _tree(self) -> tuple[np.ndarray, int, np.ndarray, int, np.ndarray]:
        return self.nodes, self.n_nodes, self.perm, self.n_slots, self.prepared.records


def _leaves(nodes: np.ndarray) -> np.ndarray:
    """(first slot, triangles) of every leaf of a node array, in node order (= slot order)."""
    pair = nodes.view(np.uint32)[:, [6, 7] if nodes.itemsize == 4 else [12, 13]].astype(np.int64)
    return pair[pair[:, 1] > 0]


#: Leaves of at most 32 triangles (two native blocks), measured on every lane width:
#: ``flock /tmp/tribench-timing.lock python bench/bvh_leaf.py`` (Suzanne, 250,000
#: triangles, float32, 128x128 camera rays and their 2,750 bounces, every native
#: kernel, one core of the shared 2-core Xeon). Rays/s over max_leaf 16's, geometric
#: mean over the 9 kernels, at max_leaf 4 / 8 / 32 / 64:
#:   AVX-512 (16 lanes) camera 0.582 / 0.697 / 1.073 / 1.077, bounces 0.563 / 0.668 / 1.065 / 1.037;
#:   AVX2 (8 lanes)     camera 0.603 / 0.778 / 1.037 / 1.067, bounces 0.543 / 0.683 / 1.024 / 1.022;
#:   SSE (4 lanes)      camera 0.629 / 0.799 / 1.049 / 1.016, bounces 0.636 / 0.750 / 1.055 / 1.057.
#: Small leaves lose everywhere (a 4-triangle leaf still costs a whole block test, and
#: the tree has more nodes); 32 is ahead of 16 on every width and ray set, 64 not
#: consistently ahead of 32: one default for every width. Single kernels move by up to
#: about 10-30% between neighbouring sizes (one process, 5 rounds, no CIs).
DEFAULT_MAX_LEAF: int = 32


def build_bvh(kernel: str, triangles: np.ndarray, *, max_leaf: int = DEFAULT_MAX_LEAF) -> BVH:
    """Build a BVH over ``triangles`` (K, 3, 3), float32 or float64, finite,
    with ``kernel``'s records at its leaves (one of :func:`bvh_kernel_names`).

    ``max_leaf`` (1..1024): the most triangles in one leaf (default :data:`DEFAULT_MAX_LEAF`). Exactly
    flat triangles become records no ray hits, as
    :func:`prepare` makes them. The same input gives the same tree, bit for bit.

    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> bvh = build_bvh("moller_trumbore_fma", rng.normal(size=(1000, 3, 3)))
    >>> sorted(bvh.perm[bvh.perm >= 0].tolist()) == list(range(1000))
    True
    """
    _check_kernel(kernel)
    if kernel not in bvh_kernel_names():
        raise UserError(f"{kernel} cannot be a BVH's leaf test; these can: {', '.join(bvh_kernel_names())}")
    if isinstance(max_leaf, bool) or not isinstance(max_leaf, (int, np.integer)):
        raise UserTypeError(f"max_leaf must be an int, got {type(max_leaf).__name__}")
    if not 1 <= max_leaf <= 1024:
        raise UserError(f"max_leaf must be between 1 and 1024, got {max_leaf}")
    tris = _check_array("triangles", triangles, (3, 3))
    n = len(tris)
    if n > MAX_BVH_TRIANGLES:
        raise UserError(f"a BVH takes at most {MAX_BVH_TRIANGLES} triangles, got {n}")
    nodes = np.empty((2 * n - 1, 8), dtype=tris.dtype)
    order = np.empty(n, dtype=np.int64)
    n_nodes, n_slots = _core.bvh_build(tris.itemsize, tris, n, int(max_leaf), nodes, order)
    nodes = nodes[:n_nodes].copy()
    # slot of each triangle in leaf order: its leaf's first slot + its place in the leaf
    first, count = _leaves(nodes).T
    slots = np.repeat(first, count) + np.arange(n) - np.repeat(np.cumsum(count) - count, count)
    perm = np.full(n_slots, -1, dtype=np.int64)
    perm[slots] = order
    in_slots = np.zeros((n_slots, 3, 3), dtype=tris.dtype)
    in_slots[slots] = tris[order]
    is_flat = np.ones(n_slots, dtype=np.uint8)  # padding: flat, so a miss for kernels that miss flat triangles
    is_flat[slots] = flat(tris)[order]
    info = kernel_info(kernel)
    records = np.empty((n_slots // info.lanes, info.stride, info.lanes), dtype=tris.dtype)
    _core.prepare(kernel, tris.itemsize, in_slots, n_slots, records, is_flat)
    return _frozen_bvh(kernel, tris, nodes, perm, records, int(max_leaf))


def _frozen_bvh(kernel: str, tris: np.ndarray, nodes: np.ndarray, perm: np.ndarray, records: np.ndarray, max_leaf: int):
    view = tris.view()
    for a in (view, nodes, perm, records):
        a.flags.writeable = False
    return BVH(kernel, view, nodes, perm, Prepared(kernel, records, len(perm)), max_leaf)


def adopt_bvh(
    kernel: str, triangles: np.ndarray, nodes: np.ndarray, perm: np.ndarray, records: np.ndarray, max_leaf: int
) -> BVH:
    """A :class:`BVH` from arrays made elsewhere (a cache file): the
    ``nodes``, ``perm`` and ``prepared.records`` of a :func:`build_bvh` over
    the same ``triangles`` with the same ``kernel`` and ``max_leaf``.

    Nothing is trusted. The C layer checks every structural invariant of the
    tree before it can be traversed (node order and indices, depth, boxes
    inside their parents and around their triangles, leaves on whole blocks
    of 16 slots, ``perm`` a permutation of the triangles plus padding), and
    the records must be, bit for bit, what the kernel prepares for the
    triangles ``perm`` names (flat triangles aside, whose records no ray
    hits). Raises :class:`~tribench.common.UserError` naming the first fault.

    >>> import numpy as np
    >>> tri = np.random.default_rng(0).normal(size=(100, 3, 3))
    >>> b = build_bvh("moller_trumbore_fma", tri)
    >>> adopt_bvh(b.kernel, tri, b.nodes, b.perm, b.prepared.records, b.max_leaf).n_nodes == b.n_nodes
    True
    """
    _check_kernel(kernel)
    if kernel not in bvh_kernel_names():
        raise UserError(f"{kernel} cannot be a BVH's leaf test; these can: {', '.join(bvh_kernel_names())}")
    if isinstance(max_leaf, bool) or not isinstance(max_leaf, (int, np.integer)) or not 1 <= max_leaf <= 1024:
        raise UserError(f"max_leaf must be an int between 1 and 1024, got {max_leaf!r}")
    tris = _check_array("triangles", triangles, (3, 3))
    info = kernel_info(kernel)
    for name, a, dtype, ndim in (("nodes", nodes, tris.dtype, 2), ("perm", perm, np.dtype(np.int64), 1)):
        if not isinstance(a, np.ndarray) or a.dtype != dtype or a.ndim != ndim:
            raise UserError(f"malformed BVH: {name} must be a {ndim}-d {dtype} array")
    if nodes.shape[1:] != (8,) or not len(nodes) or not len(perm) or len(perm) % 16:
        raise UserError(
            f"malformed BVH: nodes must be (N, 8) and perm a multiple of 16 slots, got {nodes.shape}, {perm.shape}"
        )
    shape = (len(perm) // info.lanes, info.stride, info.lanes)
    if not isinstance(records, np.ndarray) or records.dtype != tris.dtype or records.shape != shape:
        raise UserError(f"malformed BVH: {kernel}'s records for {len(perm)} slots must be {tris.dtype} {shape}")
    nodes, perm, records = (np.ascontiguousarray(a) for a in (nodes, perm, records))
    try:
        _core.bvh_check(tris.itemsize, nodes, len(nodes), perm, len(perm), tris, len(tris), int(max_leaf))
    except ValueError as e:
        raise UserError(str(e)) from None
    # the records: prepared again from the triangles perm names, with the same
    # slots marked flat as the stored records say, which must be flat indeed
    slot_flat = np.isnan(records).all(axis=1).ravel()
    used = perm >= 0
    if not flat(tris[perm[used & slot_flat]]).all():
        raise UserError(f"malformed BVH: {kernel}'s records make a triangle that is not flat a miss")
    in_slots = np.zeros((len(perm), 3, 3), dtype=tris.dtype)
    in_slots[used] = tris[perm[used]]
    expected = np.empty_like(records)
    _core.prepare(kernel, tris.itemsize, in_slots, len(perm), expected, (slot_flat | ~used).view(np.uint8))
    if not np.array_equal(expected.view(np.uint8), records.view(np.uint8)):
        raise UserError(f"malformed BVH: the records are not {kernel}'s records of the triangles its perm names")
    return _frozen_bvh(kernel, tris, nodes.copy(), perm.copy(), records.copy(), int(max_leaf))
