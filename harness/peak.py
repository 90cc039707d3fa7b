"""Each kernel's arithmetic bound at the machine's measured FMA peak, and how near it runs.

The bound of a kernel is the time its arithmetic would take if the machine
issued nothing but that arithmetic at its peak rate: ``ops / rate``, where
``ops`` is the kernel's documented operations per test
(:attr:`tribench.ext.KernelInfo.ops`; counting rules in ``ext/kernels.h``)
and ``rate`` the lane operations per nanosecond of the FMA probe
(:func:`tribench.ext.fma_peak`): its GFLOP/s over 2, since an FMA counts two
flops but is one operation. The kernels are built without FMA contraction,
so each of their adds, multiplies and compares is one instruction issued on
the same pipes as an FMA; counting an FMA as one operation is what makes the
bound reachable (counting it as two would cap every kernel at 50% on a core
whose adds and multiplies share the FMA pipes).

The probe runs 8 float lanes; a double vector holds half as many, so the
double rate is half (the same instructions per cycle on every x86 core with
FMA). The bound is the machine's, not the form's: a scalar kernel uses one
lane of eight, so in float its arithmetic alone keeps it near 1/8 or below.

``fraction = bound / measured ns per test``, 1 at the bound. It can exceed 1
where a core has adders beside its FMA pipes (AMD Zen has two). A scalar
early-exit kernel's count is the path of a hit, while most tests exit
earlier, so its fraction overstates how busy it keeps the lane (it can pass
1/8).
"""

from __future__ import annotations

import numpy as np

from tribench import ext

#: probe iterations: about 20 ms at 100 GFLOP/s (12 chains x 16 flops each)
PROBE_ITERATIONS = 10_000_000


def lane_ops_per_ns(peak_gflops: float, dtype, peak_isa: str = "avx2+fma") -> float:
    """Operations per ns the probe's peak allows at ``dtype`` (see the module's note).

    >>> lane_ops_per_ns(100.0, "float32"), lane_ops_per_ns(100.0, "float64")
    (50.0, 25.0)
    >>> lane_ops_per_ns(10.0, "float64", peak_isa="scalar")  # a scalar probe: one lane either way
    5.0
    """
    per_lane = 1.0 if np.dtype(dtype).itemsize == 4 or peak_isa == "scalar" else 0.5
    return peak_gflops / 2 * per_lane


def bound_ns_per_test(kernel: str, dtype, peak_gflops: float, peak_isa: str = "avx2+fma") -> float:
    """The kernel's arithmetic per test at the peak rate, in ns."""
    return ext.kernel_info(kernel).ops / lane_ops_per_ns(peak_gflops, dtype, peak_isa)


def measure_peak(repeats: int = 5) -> ext.Peak:
    """The best of ``repeats`` probes: the peak of this moment, least disturbed by other processes."""
    return max((ext.fma_peak(PROBE_ITERATIONS) for _ in range(repeats)), key=lambda p: p.gflops)


def camera_fractions(dtypes=("float32", "float64"), rounds: int = 5, size: int = 64, seed: int = 0):
    """Every public kernel on the in-cache camera workload, as a fraction of its bound.

    A quick look in this process (``tribench info --peak``), not the sweep's
    protocol: Suzanne at 968 triangles (its records fit in L2) seen by a
    ``size`` x ``size`` pinhole camera, closest hit; ``rounds`` rounds run
    every kernel once in a fresh random order, each batch timed in C and
    about 5 ms long; the probe runs before and after (best of 3 each) and
    their mean is the peak. Returns ``(gflops, isa, table)``: that peak,
    the probe's instruction set, and a DataFrame with ``dtype,
    kernel, form, ops_per_test, bound_ns_per_test, ns_per_test`` (median
    over rounds) and ``fraction``.
    """
    import pandas as pd

    from tribench.workloads import cache
    from tribench.workloads.spec import MeshSpec

    from .worker import calibrate_loops

    rng = np.random.default_rng(seed)
    jobs = {}
    for dtype in dtypes:
        w = cache.make(MeshSpec("suzanne", triangles=968, width=size, height=size, dtype=dtype, result="closest"))
        for kernel in ext.kernel_names():
            job = ext.make_job(kernel, w.origins, w.directions, w.triangles, "closest")
            jobs[dtype, kernel] = (job, calibrate_loops(job, 5e6))
    before = measure_peak(3)
    times: dict[tuple[str, str], list[float]] = {key: [] for key in jobs}
    keys = list(jobs)
    for _ in range(rounds):
        for i in rng.permutation(len(keys)):
            job, loops = jobs[keys[i]]
            times[keys[i]].append(ext.time_batch(job, loops).ns_per_test)
    after = measure_peak(3)
    gflops = (before.gflops + after.gflops) / 2
    rows = []
    for (dtype, kernel), ts in times.items():
        info = ext.kernel_info(kernel)
        bound = bound_ns_per_test(kernel, dtype, gflops, before.isa)
        ns = float(np.median(ts))
        rows.append(
            {
                "dtype": dtype,
                "kernel": kernel,
                "form": "scalar" if info.lanes == 1 else f"{info.lanes} lanes, {info.isa}",
                "ops_per_test": info.ops,
                "bound_ns_per_test": bound,
                "ns_per_test": ns,
                "fraction": bound / ns,
            }
        )
    return gflops, before.isa, pd.DataFrame(rows)
