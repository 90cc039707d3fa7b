"""Each kernel's bound on the machine's measured pipes, and how near it runs.

The bound is a port model (docs/kernels.md, "How near the machine's limit"): the largest lower bound on time that
the probed rates (:func:`tribench.ext.op_throughput`, lane-ops per ns by class) and the kernel's counts
(:attr:`tribench.ext.KernelInfo.mix`) support. Whether two classes share pipes is measured by a 1:1 mix, never
assumed: without the ``fma_mul`` pool a Zen core's bound was up to twice too fast (docs/decisions.md, "How near the
bound"). ``fraction = bound / measured ns per test``, 1 at the bound."""

from __future__ import annotations

import sys
from collections.abc import Mapping

import numpy as np

from .. import ext
from .protocol import emit, run_apart

#: probe iterations: about 20 ms at 100 GFLOP/s (12 chains x 16 flops each)
PROBE_ITERATIONS = 10_000_000


#: classes that issue on the vector pipes (all but loads), and the FP arithmetic among them
ALU_CLASSES = ("fma", "mul", "add", "cmp", "logic", "div")
FP_CLASSES = ("fma", "mul", "add")


def bound_from_mix(mix: Mapping[str, float], rates: Mapping[str, float]) -> float:
    """ns per test at the port model's bound: ``mix`` is operations per test by class,
    ``rates`` lane-ops per ns by class (a field of :class:`tribench.ext.OpThroughput`).

    >>> rates = {"fma": 2, "mul": 2, "add": 2, "cmp": 1, "logic": 2, "div": 0.25, "load": 2, "fma_add": 2}
    >>> bound_from_mix({"mul": 4, "add": 4}, rates)  # adds share the FMA pipes: (4 + 4) / 2
    4.0
    >>> bound_from_mix({"mul": 4, "add": 4}, {**rates, "fma_add": 4})  # adders of their own: 8 / 4, but mul 4 / 2
    2.0
    >>> bound_from_mix({"cmp": 6, "add": 1}, rates)  # compares on one pipe: 6 / 1
    6.0
    >>> bound_from_mix({"add": 3, "cmp": 1, "logic": 4, "load": 20}, rates)  # loads bind: 20 / 2
    10.0
    >>> zen = {**rates, "fma_add": 4, "fma_mul": 2}  # adders of their own; multiplies on the FMA pipes
    >>> bound_from_mix({"fma": 4, "mul": 4, "add": 4}, zen)  # fma + mul: 8 / 2; all three: 12 / 4
    4.0
    """
    n = {c: float(mix.get(c, 0)) for c in (*ALU_CLASSES, "load")}
    alone = max(n[c] / rates[c] for c in n)
    mixes = [name.split("_") for name in rates if "_" in name]
    pairs = max((n[a] + n[b]) / max(rates[a], rates[b], rates[f"{a}_{b}"]) for a, b in mixes) if mixes else 0.0
    fp_pool = sum(n[c] for c in FP_CLASSES) / max(r for c, r in rates.items() if set(c.split("_")) <= set(FP_CLASSES))
    alu_pool = sum(n[c] for c in ALU_CLASSES) / max(r for c, r in rates.items() if c != "load")
    return max(alone, pairs, fp_pool, alu_pool)


def throughput_record() -> dict:
    """The probes' rates and the FMA peak of the same moment, as ``run.json``'s ``throughput``.

    The analysis scales the rates to each process's moment by the ratio of its FMA
    peak to this one (a clock factor), so every process is held to its own bound."""
    peak, rates = measure_peak(), ext.op_throughput()
    return {"isa": rates.isa, "peak_gflops": peak.gflops, "float32": rates.float32, "float64": rates.float64}


def measure_peak() -> ext.Peak:
    """The best of three probes: the peak of this moment, least disturbed by other processes."""
    return max((ext.fma_peak(PROBE_ITERATIONS) for _ in range(3)), key=lambda p: p.gflops)


def camera_fractions(dtypes=("float32", "float64"), rounds: int = 5, size: int = 64, isa=None):
    """Every public kernel on the in-cache camera workload, as a fraction of its bound (``tribench info --peak``).

    A quick look in one process, not the sweep's protocol: Suzanne at 968 triangles (in L2, which the port model
    does not count), every kernel once per round in a fresh order, the probes' mean before and after as the peak
    and rates. Returns ``(gflops, isa, rate_isa, rates, table)``; ``isa`` holds every native kernel and the
    probes to that ISA, so an AVX-512 core answers for AVX2 too. With kernel files loaded, that process is a
    worker of the protocol: their check ran other triangles, and a kernel that crashes on these ends the worker
    (UserError), not this process."""
    import pandas as pd

    args = {"dtypes": list(dtypes), "rounds": rounds, "size": size, "isa": isa}
    files = sorted({f.path for k in ext.kernel_names() if (f := ext.kernel_file_of(k)) is not None})
    if not files:
        return _camera_fractions(**args)
    got: dict = {}
    run_apart(
        "tribench.harness.peak",
        args,
        files,
        {"fractions": got.update},
        "the worker timing every kernel",
        "a kernel file's kernel fails on the camera workload (its check ran others)",
    )
    return got["gflops"], got["isa"], got["rate_isa"], got["rates"], pd.DataFrame(got["table"])


def _work(args: dict) -> None:
    """The worker of :func:`camera_fractions`: one ``fractions`` line."""
    gflops, isa, rate_isa, rates, table = _camera_fractions(**args, emit=emit)
    fractions = {"gflops": gflops, "isa": isa, "rate_isa": rate_isa, "rates": rates}
    emit("fractions", {**fractions, "table": table.to_dict("records")})


def _camera_fractions(dtypes, rounds: int, size: int, isa, emit=None):
    """:func:`camera_fractions` in this process; in a worker, ``emit`` says how long each step may be silent."""
    import pandas as pd

    from ..workloads import cache
    from ..workloads.spec import MeshSpec
    from .worker import calibrate_loops, measured_limit_s, unmeasured_limit_s

    rng = np.random.default_rng(0)  # the kernels' orders: the same every time
    jobs = {}
    for dtype in dtypes:
        if emit:
            emit("silence", {"seconds": None, "during": f"making the camera workload ({dtype})"})
        w = cache.make(MeshSpec("suzanne", triangles=968, width=size, height=size, dtype=dtype, result="closest"))
        for kernel in ext.kernel_names():
            held = isa if isa in ext.kernel_info(kernel).isas else None  # scalar forms have one
            if emit:  # a calibration is at most four passes
                silence_s = unmeasured_limit_s(4 * len(w.origins) * len(w.triangles))
                emit("silence", {"seconds": silence_s, "during": f"calibrating {kernel} ({dtype})"})
            job = ext.make_job(kernel, w.origins, w.directions, w.triangles, "closest", isa=held)
            jobs[dtype, kernel] = (job, calibrate_loops(job, 5e6))
    if emit:  # batches of 5 ms, and the probes
        silence_s = measured_limit_s(rounds * len(jobs) * 5e-3)
        emit("silence", {"seconds": silence_s, "during": "timing every kernel"})
    before, rates_before = measure_peak(), ext.op_throughput(isa)
    times: dict[tuple[str, str], list[float]] = {key: [] for key in jobs}
    keys = list(jobs)
    for _ in range(rounds):
        for i in rng.permutation(len(keys)):
            job, loops = jobs[keys[i]]
            times[keys[i]].append(ext.time_batch(job, loops).ns_per_test)
    after, rates_after = measure_peak(), ext.op_throughput(isa)
    gflops = (before.gflops + after.gflops) / 2
    rates = {
        d: {c: (rates_before.rates(d)[c] + rates_after.rates(d)[c]) / 2 for c in rates_before.rates(d)} for d in dtypes
    }
    rows = []
    for (dtype, kernel), ts in times.items():
        info = ext.kernel_info(kernel)
        bound = bound_from_mix(info.mix, rates[dtype])
        ns = float(np.median(ts))
        rows.append(
            {
                "dtype": dtype,
                "kernel": kernel,
                "form": "scalar" if info.lanes == 1 else f"blocks of {info.lanes}, {jobs[dtype, kernel][0].isa}",
                "ops_per_test": info.ops,
                "records_bytes": jobs[dtype, kernel][0].prepared.records.nbytes,
                "bound_ns_per_test": bound,
                "ns_per_test": ns,
                "fraction": bound / ns,
            }
        )
    return gflops, before.isa, rates_before.isa, rates, pd.DataFrame(rows)


if __name__ == "__main__":
    from .protocol import serve_apart

    sys.exit(serve_apart(_work))
