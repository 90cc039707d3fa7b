"""Each kernel's bound on the machine's measured pipes, and how near it runs.

The rates. :func:`tribench.ext.op_throughput` probes, on the widest vector
the core has (AVX-512, else AVX2 with FMA, else SSE2), the lane-operations
per ns of each operation class: ``fma, mul, add, cmp, logic, div, load``,
and two mixes, ``fma_add`` and ``fma_mul`` (an FMA and an add, or a
multiply, 1:1). The counts.
:attr:`tribench.ext.KernelInfo.mix`: a kernel's operations per test and lane
by class (``tb_<name>_mix`` beside its code; a wide form's counted in its
compiled loop).

The port model: the bound is the largest of these lower bounds on time,
each a count over a measured rate (lane-ops per ns, so ns per test):

1. each class alone: ``n_c / r_c`` (no class runs faster than its probe);
2. the pools of the mixes: for each mix ``a_b``, ``(n_a + n_b) / max(r_a,
   r_b, r_a_b)``, and the FP arithmetic pool ``(n_fma + n_mul + n_add)``
   over the fastest FP probe, alone or mixed. Whether two classes share
   pipes is measured, not assumed: where they do, the 1:1 mix runs at the
   rate of either alone and the pool is their sum over it; where they do
   not, the mix runs faster and its rate caps the pool instead. Multiplies
   share the FMA pipes on Intel and AMD alike (``fma_mul`` runs at ``fma``'s
   rate). Adds share them on Intel's AVX-512 (ports 0 and 5) and have pipes
   of their own on AMD Zen (FADD) and on Golden Cove's 256-bit adders (ports
   1 and 5). Without the ``fma_mul`` pool a Zen core's bound let multiplies
   and FMAs each use the adders' share of the FP pipes: up to twice too fast
   for a kernel of multiplies and FMAs (docs/decisions.md, "How near the
   bound");
3. the vector-ALU pool: every class but loads issues on the same vector
   pipes, so ``sum of those counts / the fastest rate of any ALU probe``
   (valid where the fastest class uses every vector pipe, as bitwise logic
   does on Intel and AMD);
4. loads alone are rule 1's ``n_load / r_load`` (load ports are separate).

It is the tightest bound the probes support for the kernel's operations as
compiled, at the widest FMA-capable width: a form that runs narrower, or
without FMA, or a scalar form on one lane, shows that as a small fraction.
Not modelled: the front end's issue width, latency chains, branches and
cache misses (the in-cache workload keeps misses out).

``fraction = bound / measured ns per test``, 1 at the bound. A scalar
early-exit kernel's counts are the path of a hit, while most tests exit
earlier, so its fraction overstates how busy it keeps the lane.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from .. import ext

#: probe iterations: about 20 ms at 100 GFLOP/s (12 chains x 16 flops each)
PROBE_ITERATIONS = 10_000_000


#: classes that issue on the vector pipes (all but loads), and the FP arithmetic among them
ALU_CLASSES = ("fma", "mul", "add", "cmp", "logic", "div")
FP_CLASSES = ("fma", "mul", "add")


def bound_from_mix(mix: Mapping[str, float], rates: Mapping[str, float]) -> float:
    """ns per test at the port model's bound (rules in the module's note).

    ``mix``: operations per test by class; ``rates``: lane-ops per ns by class
    (the ``float32`` or ``float64`` field of :class:`tribench.ext.OpThroughput`).

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


def measure_rates(repeats: int = 3, isa: str | None = None) -> ext.OpThroughput:
    """The probes on ``isa`` (default: the widest), best of ``repeats`` each (about 0.2 s)."""
    return ext.op_throughput(isa, repeats=repeats)


def throughput_record() -> dict:
    """The probes' rates and the 8-lane FMA peak of the same moment, as ``run.json``
    keeps them (key ``throughput``): ``isa, peak_gflops, float32, float64``. The
    analysis scales the rates to each process's own moment by the ratio of its FMA
    peak to this one (a clock speed factor), so every process is held to its own bound."""
    peak, rates = measure_peak(3), measure_rates()
    return {"isa": rates.isa, "peak_gflops": peak.gflops, "float32": rates.float32, "float64": rates.float64}


def measure_peak(repeats: int = 5) -> ext.Peak:
    """The best of ``repeats`` probes: the peak of this moment, least disturbed by other processes."""
    return max((ext.fma_peak(PROBE_ITERATIONS) for _ in range(repeats)), key=lambda p: p.gflops)


def camera_fractions(dtypes=("float32", "float64"), rounds: int = 5, size: int = 64, seed: int = 0, isa=None):
    """Every public kernel on the in-cache camera workload, as a fraction of its bound.

    A quick look in this process (``tribench info --peak``), not the sweep's
    protocol: Suzanne at 968 triangles (its records, 35-83 KiB in float32, fit in L2;
    L1d holds some of them, and the port model counts no L2 traffic) seen by a
    ``size`` x ``size`` pinhole camera, closest hit; ``rounds`` rounds run
    every kernel once in a fresh random order, each batch timed in C and
    about 5 ms long; the probe runs before and after (best of 3 each) and
    their mean is the peak, and so do the throughput probes (their mean
    the rates). Returns ``(gflops, isa, rate_isa, rates, table)``: the FMA
    peak and its ISA, the probes' ISA and rates per dtype, and a DataFrame
    with ``dtype, kernel, form, ops_per_test, records_bytes`` (the prepared
    triangles a ray streams), ``bound_ns_per_test`` (the port
    model's), ``ns_per_test`` (median over rounds) and ``fraction``. ``isa`` (a probe
    ISA of :func:`tribench.ext.probe_isas`) holds every wide form to it and
    probes the pipes on it, so that an AVX-512 core answers for AVX2 too.
    """
    import pandas as pd

    from ..workloads import cache
    from ..workloads.spec import MeshSpec
    from .worker import calibrate_loops

    rng = np.random.default_rng(seed)
    jobs = {}
    for dtype in dtypes:
        w = cache.make(MeshSpec("suzanne", triangles=968, width=size, height=size, dtype=dtype, result="closest"))
        for kernel in ext.kernel_names():
            held = isa if isa in ext.kernel_info(kernel).isas else None  # scalar forms have one
            job = ext.make_job(kernel, w.origins, w.directions, w.triangles, "closest", isa=held)
            jobs[dtype, kernel] = (job, calibrate_loops(job, 5e6))
    before, rates_before = measure_peak(3), measure_rates(isa=isa)
    times: dict[tuple[str, str], list[float]] = {key: [] for key in jobs}
    keys = list(jobs)
    for _ in range(rounds):
        for i in rng.permutation(len(keys)):
            job, loops = jobs[keys[i]]
            times[keys[i]].append(ext.time_batch(job, loops).ns_per_test)
    after, rates_after = measure_peak(3), measure_rates(isa=isa)
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
