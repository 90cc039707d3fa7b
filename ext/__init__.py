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
  late division, closed triangles).

Internal kernels, for the harness's honesty checks (listed only by
``kernel_names(internal=True)``, accepted everywhere a kernel name is):

* ``moller_trumbore_aa``: an identical copy of ``moller_trumbore`` under
  another name (A/A calibration);
* ``moller_trumbore_twice``: ``moller_trumbore`` doing every test twice (a
  known 2x effect).

``fma_peak()`` measures the core's arithmetic peak with a short loop of
independent 8-lane FMAs.

Results: a miss has ``t = nan`` (and index ``-1`` in closest-hit form).
Conventions of the clean kernels match ``tribench.workloads.reference``.

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

from dataclasses import dataclass
from typing import Literal

import numpy as np

from . import _core

__all__ = [
    "Batch",
    "Job",
    "Peak",
    "Prepared",
    "build_info",
    "bytes_per_triangle",
    "fma_peak",
    "intersect_closest",
    "intersect_pairs",
    "kernel_names",
    "make_job",
    "prepare",
    "time_batch",
]

Mode = Literal["pairs", "closest"]
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
    ['moller_trumbore_aa', 'moller_trumbore_twice']
    """
    return _KERNELS if internal else _PUBLIC


def build_info() -> dict:
    """How the extension was built: compiler, exact flags, FMA and fast-math
    macros, and the resolution of the clock that times batches."""
    return dict(_core.build_info())


def bytes_per_triangle(kernel: str, dtype: np.dtype | type | str) -> int:
    """Bytes of prepared data one triangle occupies for ``kernel`` at ``dtype``.

    >>> bytes_per_triangle("moller_trumbore", "float32")
    36
    """
    _check_kernel(kernel)
    return _core.stride(kernel) * _check_dtype_name(dtype).itemsize


# ----------------------------------------------------------------- validation


def _check_kernel(kernel: object) -> str:
    if not isinstance(kernel, str):
        raise TypeError(f"kernel must be a str, got {type(kernel).__name__}")
    if kernel not in _KERNELS:
        raise ValueError(f"unknown kernel {kernel!r}; known kernels: {', '.join(_PUBLIC)}")
    return kernel


def _check_dtype_name(dtype: object) -> np.dtype:
    try:
        dt = np.dtype(dtype)
    except TypeError as exc:
        raise TypeError(f"not a dtype: {dtype!r}") from exc
    if dt not in _DTYPES:
        raise TypeError(f"precision must be float32 or float64, got {dt}")
    return dt


def _check_array(
    name: str, a: object, tail: tuple[int, ...], allow_nonfinite: bool = False
) -> np.ndarray:
    """Check one input array; return it unchanged (never a copy)."""
    if not isinstance(a, np.ndarray):
        raise TypeError(f"{name} must be a numpy.ndarray, got {type(a).__name__}")
    if a.dtype not in _DTYPES:
        raise TypeError(
            f"{name} must have dtype float32 or float64 (native byte order), got {a.dtype}"
        )
    shape = "(N, " + ", ".join(map(str, tail)) + ")"
    if a.ndim != 1 + len(tail) or a.shape[1:] != tail:
        raise ValueError(f"{name} must have shape {shape}, got {a.shape}")
    if a.shape[0] == 0:
        raise ValueError(f"{name} is empty")
    if not a.flags.c_contiguous:
        raise ValueError(f"{name} must be C-contiguous (use numpy.ascontiguousarray)")
    if not a.flags.aligned:
        raise ValueError(f"{name} is not aligned to its dtype")
    if not allow_nonfinite:
        bad = ~np.isfinite(a.reshape(len(a), -1)).all(axis=1)
        if bad.any():
            raise ValueError(f"{name} contains NaN or Inf (first at row {int(np.argmax(bad))})")
    return a


def _check_same_dtype(**arrays: np.ndarray) -> np.dtype:
    dtypes = {a.dtype for a in arrays.values()}
    if len(dtypes) != 1:
        listed = ", ".join(f"{k}={v.dtype}" for k, v in arrays.items())
        raise TypeError(f"arrays must share one precision, got {listed}")
    return dtypes.pop()


def _check_workload(kernel, origins, directions, triangles, mode: str, allow_nonfinite: bool):
    """Every check of a kernel call on a workload; returns (o, d, triangles, dtype)."""
    _check_kernel(kernel)
    o = _check_array("origins", origins, (3,), allow_nonfinite)
    d = _check_array("directions", directions, (3,), allow_nonfinite)
    if len(o) != len(d):
        raise ValueError(f"origins and directions differ in length: {len(o)} and {len(d)}")
    tris = _check_array("triangles", triangles, (3, 3), allow_nonfinite)
    dtype = _check_same_dtype(origins=o, directions=d, triangles=tris)
    if mode == "pairs" and len(tris) != len(o):
        raise ValueError(f"pairs need one triangle per ray, got {len(tris)} and {len(o)} rays")
    return o, d, tris, dtype


# ------------------------------------------------------------------ prepared


@dataclass(frozen=True)
class Prepared:
    """A kernel's per-triangle records, computed once outside any timed loop.

    Attributes
    ----------
    kernel : str
    records : ndarray, shape (K, stride), read-only
        Raw vertices for kernels that test them directly; vertices plus
        precomputed planes or normals for the others.
    """

    kernel: str
    records: np.ndarray

    @property
    def n_triangles(self) -> int:
        return len(self.records)

    @property
    def dtype(self) -> np.dtype:
        return self.records.dtype


def prepare(kernel: str, triangles: np.ndarray, *, allow_nonfinite: bool = False) -> Prepared:
    """Compute ``kernel``'s records for ``triangles`` of shape (K, 3, 3)."""
    _check_kernel(kernel)
    tris = _check_array("triangles", triangles, (3, 3), allow_nonfinite)
    records = np.empty((len(tris), _core.stride(kernel)), dtype=tris.dtype)
    _core.prepare(kernel, tris.itemsize, tris, len(tris), records)
    records.flags.writeable = False
    return Prepared(kernel, records)


# ------------------------------------------------------------------- results


def intersect_pairs(
    kernel: str,
    origins: np.ndarray,
    directions: np.ndarray,
    triangles: np.ndarray,
    *,
    allow_nonfinite: bool = False,
) -> tuple[np.ndarray, np.ndarray]:
    """Test ray ``i`` against triangle ``i``.

    Parameters
    ----------
    kernel : str
        One of ``kernel_names()``.
    origins, directions : ndarray, shape (N, 3)
    triangles : ndarray, shape (N, 3, 3)
        All three arrays float32, or all float64: the kernel runs at that
        precision.
    allow_nonfinite : bool
        By default NaN or Inf in any input is a ``ValueError``. With True they
        reach the kernel, whose documented behaviour applies (the clean
        kernels report a miss; see each kernel's header).

    Returns
    -------
    hit : bool ndarray, shape (N,)
    t : ndarray, shape (N,), the input precision; nan where ``hit`` is False.
    """
    o, d, tris, dtype = _check_workload(kernel, origins, directions, triangles, "pairs", allow_nonfinite)
    prepared = prepare(kernel, tris, allow_nonfinite=allow_nonfinite)
    hit = np.empty(len(o), dtype=np.uint8)
    t = np.empty(len(o), dtype=dtype)
    _core.run(kernel, dtype.itemsize, False, o, d, len(o), prepared.records, len(tris), hit, t)
    return hit.view(bool), t


def intersect_closest(
    kernel: str,
    origins: np.ndarray,
    directions: np.ndarray,
    triangles: np.ndarray,
    *,
    allow_nonfinite: bool = False,
) -> tuple[np.ndarray, np.ndarray]:
    """Closest hit of every ray against every triangle (brute force).

    Parameters
    ----------
    kernel : str
    origins, directions : ndarray, shape (M, 3)
    triangles : ndarray, shape (K, 3, 3)
        One precision for all three, as in ``intersect_pairs``.
    allow_nonfinite : bool
        As in ``intersect_pairs``.

    Returns
    -------
    triangle_index : int64 ndarray, shape (M,)
        Closest triangle hit, ``-1`` for a miss; ties go to the lowest index.
    t : ndarray, shape (M,), the input precision; nan for a miss.
    """
    o, d, tris, dtype = _check_workload(kernel, origins, directions, triangles, "closest", allow_nonfinite)
    prepared = prepare(kernel, tris, allow_nonfinite=allow_nonfinite)
    index = np.empty(len(o), dtype=np.int64)
    t = np.empty(len(o), dtype=dtype)
    _core.run(kernel, dtype.itemsize, True, o, d, len(o), prepared.records, len(tris), index, t)
    return index, t


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
    prepared: Prepared

    @property
    def tests_per_pass(self) -> int:
        """Ray-triangle tests in one pass over the workload."""
        if self.mode == "pairs":
            return len(self.origins)
        return len(self.origins) * self.prepared.n_triangles


def make_job(
    kernel: str,
    origins: np.ndarray,
    directions: np.ndarray,
    triangles: np.ndarray,
    mode: Mode,
) -> Job:
    """Validate a workload for timing and prepare ``kernel``'s records.

    ``mode`` is ``"pairs"`` (ray i against triangle i) or ``"closest"``
    (every ray against every triangle, closest hit). Inputs must be finite.
    The arrays are kept as read-only views, not copied.
    """
    if mode not in ("pairs", "closest"):
        raise ValueError(f"mode must be 'pairs' or 'closest', got {mode!r}")
    o, d, tris, _ = _check_workload(kernel, origins, directions, triangles, mode, False)
    views = []
    for a in (o, d):
        v = a.view()
        v.flags.writeable = False
        views.append(v)
    return Job(kernel, mode, views[0], views[1], prepare(kernel, tris))


@dataclass(frozen=True)
class Batch:
    """One timed batch: ``loops`` passes of a job, timed inside C.

    ``hits`` and ``t_sum`` are summed over all passes; compare them with
    ``loops`` times the reference's hit count and sum of ``t``.
    """

    elapsed_ns: int
    loops: int
    tests: int
    hits: int
    t_sum: float

    @property
    def ns_per_test(self) -> float:
        return self.elapsed_ns / self.tests


def time_batch(job: Job, loops: int) -> Batch:
    """Run ``job`` ``loops`` times in C with the GIL released; time it.

    The clock is ``CLOCK_MONOTONIC`` read just before and after the loop.
    """
    if not isinstance(job, Job):
        raise TypeError(f"job must be a tribench.ext.Job (see make_job), got {type(job).__name__}")
    if isinstance(loops, bool) or not isinstance(loops, (int, np.integer)):
        raise TypeError(f"loops must be an int, got {type(loops).__name__}")
    if not 1 <= loops <= 2**40:
        raise ValueError(f"loops must be between 1 and 2**40, got {loops}")
    p = job.prepared
    elapsed, hits, t_sum = _core.time(
        job.kernel,
        p.dtype.itemsize,
        job.mode == "closest",
        job.origins,
        job.directions,
        len(job.origins),
        p.records,
        p.n_triangles,
        int(loops),
    )
    return Batch(elapsed, int(loops), int(loops) * job.tests_per_pass, hits, t_sum)


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
        raise TypeError(f"iterations must be an int, got {type(iterations).__name__}")
    if not 1 <= iterations <= 2**40:
        raise ValueError(f"iterations must be between 1 and 2**40, got {iterations}")
    flops, elapsed, isa, _sink = _core.fma_peak(int(iterations), bool(force_scalar))
    return Peak(flops, elapsed, isa)
