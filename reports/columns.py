"""The documented, stable columns of the CSVs next to ``report.html``.

Every CSV of a run folder is tidy: one row per observation, snake_case
column names, raw units (nanoseconds, counts, fractions; never scaled for
printing). The order below is the order in the file; tests check that the
files a run writes match these lists exactly, so a change here is a change
of the format and must be deliberate.

``batches.csv``, ``processes.csv`` and ``checks.csv`` are written by the
harness while it measures; ``estimates.csv`` and ``speedups.csv`` by ``tribench stats`` (or by
``tribench report`` when they are missing); ``validate.csv`` by ``tribench run`` or
``tribench validate --out RUN_DIR`` (or by ``tribench report`` when it is missing); ``peers.csv`` by
``tribench run`` or ``tribench peers --out RUN_DIR`` when a peer is installed. The report never
changes them.
"""

from __future__ import annotations

__all__ = ["BATCHES", "CHECKS", "ESTIMATES", "SPEEDUPS", "PROCESSES", "VALIDATE", "PEERS", "FILES", "OPTIONAL",
           "describe"]

#: ``batches.csv``: one row per timed batch, warm-up batches included.
BATCHES: dict[str, str] = {
    "run_id": "identifier of the run (as in run.json)",
    "process": "index of the worker process, the replicate (0-based)",
    "round": "round inside the process; negative for warm-up rounds",
    "position": "position of the kernel inside its round (random order, 0-based)",
    "kernel": "kernel name, as registered in the C extension",
    "workload_id": "workload identifier (hash of its spec; see run.json sweep.workloads)",
    "dtype": "precision of the workload's arrays: float32 or float64",
    "mode": "pairs (ray i against triangle i) or closest (every ray against every triangle)",
    "warmup": "True for a warm-up batch (kept, left out of every estimate)",
    "loops": "passes over the whole workload in this batch",
    "tests": "ray-triangle tests in this batch (loops x tests per pass)",
    "elapsed_ns": "wall time of the batch in nanoseconds (CLOCK_MONOTONIC, inside C)",
    "start_ns": "CLOCK_MONOTONIC time at the start of the batch, in nanoseconds",
    "invol_ctx_switches": "involuntary context switches during the batch (getrusage)",
    "hits": "hits counted in the batch (checksum; loops x hits per pass)",
    "t_sum": "sum of t over the hits of the batch (checksum)",
    "cpu": "CPU the worker was pinned to",
    "isa": "instruction set the kernel variant ran with",
    "attempt": "worker attempt of this process index (above 0 only after a resume)",
    "steal_ticks": "steal time during the batch in clock ticks from /proc/stat (-1: unreadable)",
}

#: ``estimates.csv``: one row per kernel and workload; times in ns per ray-triangle test.
ESTIMATES: dict[str, str] = {
    "kernel": "kernel name",
    "workload_id": "workload identifier",
    "ns_per_test": "ns per ray-triangle test: mean over processes of each process's median",
    "ns_per_test_ci_low": "lower end of the Student-t confidence interval of ns_per_test",
    "ns_per_test_ci_high": "upper end of the Student-t confidence interval of ns_per_test",
    "ns_per_test_bootstrap_low": "lower end of the BCa bootstrap interval over processes (cross-check), ns",
    "ns_per_test_bootstrap_high": "upper end of the BCa bootstrap interval over processes, ns",
    "ns_per_test_min": "smallest per-process median, ns (robust secondary figure)",
    "ns_per_test_sd": "standard deviation of the per-process medians, ns",
    "n_processes": "number of processes (replicates) behind the estimate",
    "confidence": "two-sided confidence level of both intervals (0.95)",
    "workload": "the workload's spec in one line",
    "peak_gflops": "mean measured FMA peak of the processes, GFLOP/s",
    "ops_per_test": "the kernel's arithmetic operations per test (documented in its header)",
    "bound_ns_per_test": "those operations at the measured FMA peak, ns (the arithmetic bound)",
    "peak_fraction": "bound / measured time (1 = at the bound), each process against its own peak",
    "peak_fraction_ci_low": "lower end of its 95% confidence interval",
    "peak_fraction_ci_high": "upper end of its 95% confidence interval",
}

#: ``speedups.csv``: one row per kernel (other than the baseline) and workload.
SPEEDUPS: dict[str, str] = {
    "workload_id": "workload identifier",
    "kernel": "kernel compared with the baseline",
    "baseline": "baseline kernel",
    "ratio": "speedup, time_baseline / time_kernel (above 1: the kernel is faster); unitless",
    "ratio_ci_low": "lower end of the simultaneous (Bonferroni) confidence interval of the ratio",
    "ratio_ci_high": "upper end of that interval",
    "p_value": "two-sided paired t-test of the per-process log ratios against 0",
    "p_holm": "Holm-adjusted p-value over the kernels compared on this workload",
    "n_processes": "number of paired processes",
    "confidence": "per-comparison confidence level actually used (Bonferroni-adjusted)",
    "margin": "relative equivalence margin of the verdict (0.01 = 1 %)",
    "verdict": "faster, slower, equivalent or inconclusive (stats.verdict)",
    "workload": "the workload's spec in one line",
    "margin_source": "where the margin came from (A/A calibration or default)",
}

#: ``processes.csv``: one row per FMA peak probe of a worker process.
PROCESSES: dict[str, str] = {
    "run_id": "identifier of the run",
    "process": "index of the worker process",
    "attempt": "worker attempt of this process index",
    "phase": "start or end of the process",
    "pid": "operating-system process id",
    "cpu": "CPU the worker was pinned to",
    "seed": "seed of the process's random choices (kernel orders, layout)",
    "env_pad_bytes": "bytes of environment padding (layout randomisation)",
    "dummy_allocs": "small allocations made before the arrays (layout randomisation)",
    "peak_gflops": "measured FMA peak, GFLOP/s",
    "peak_flops": "flops of the probe",
    "peak_elapsed_ns": "duration of the probe in nanoseconds",
    "peak_isa": "instruction set of the probe",
    "start_ns": "CLOCK_MONOTONIC time of the probe, in nanoseconds",
}

#: ``checks.csv``: one row per kernel, workload and process, written before its first batch.
CHECKS: dict[str, str] = {
    "run_id": "identifier of the run",
    "process": "index of the worker process",
    "attempt": "worker attempt of this process index",
    "workload_id": "workload identifier",
    "kernel": "kernel name",
    "rays": "rays of the workload (count)",
    "ambiguous_rays": "rays within 1e-5 barycentric of an edge, which rounding may answer either way (count)",
    "disagreements": "rays the kernel answered differently from the float64 reference (count)",
    "ambiguous_disagreements": "of those, how many are ambiguous rays (count)",
    "hits": "hits of the kernel in one pass (its checksum)",
    "t_sum": "sum of t over the kernel's hits in one pass (its checksum)",
}

#: ``validate.csv``: one row per kernel, precision and robustness test (tribench.harness.validate).
VALIDATE: dict[str, str] = {
    "kernel": "kernel name, as registered in the C extension",
    "dtype": "precision of every array: float32 or float64",
    "isa": "instruction set the kernel ran with (scalar kernels: scalar)",
    "test": "robustness test (see tribench.harness.validate)",
    "rays": "rays asked (count, after dropping rays rounding made ambiguous)",
    "failures": "cracks, double hits, misses, wrong answers or hits, as the test defines (count)",
    "rate": "failures / rays (fraction)",
    "expected": "what the papers promise for this kernel, or 'measured'",
    "verdict": "pass or fail against the promise; 'measured' where there is none",
    "detail": "a short breakdown of the failures",
}

#: ``peers.csv``: one row per timed call of a contender (tribench.harness.peers; only when a peer is installed).
PEERS: dict[str, str] = {
    "process": "index of the worker process, the replicate (0-based)",
    "rep": "repetition inside the process (0-based)",
    "position": "position of the contender inside its repetition (random order, 0-based)",
    "contender": "tribench (kernel loop timed in C), tribench_call (ext.intersect), trimesh or embree",
    "implementation": "what ran, with its version (and the kernel's form and ISA for tribench)",
    "kernel": "the tribench kernel of the run (the fastest closest-mode kernel on this workload)",
    "workload_id": "workload identifier (the camera workload; see tribench workloads show)",
    "workload": "the workload's spec in one line",
    "rays": "rays in the call (count; trimesh runs a fixed random subset)",
    "elapsed_ns": "time the rate is computed from, ns: the C-timed loop for tribench, else wall_ns",
    "wall_ns": "wall time of the call from Python, in nanoseconds",
    "cpu_ns": "CPU time of the process during the call, in nanoseconds",
    "rays_per_s": "rays / elapsed_ns, per second",
    "setup_ns": "one-off set-up before the timing, ns (Embree's BVH, trimesh's rtree, tribench's job)",
    "differ": "rays whose closest triangle differs from the float64 reference's (count)",
    "differ_ambiguous": "of those, rays within 1e-5 barycentric of an edge (count)",
    "cpu": "CPU the process was pinned to",
}

#: File name -> its columns.
FILES: dict[str, dict[str, str]] = {
    "batches.csv": BATCHES,
    "processes.csv": PROCESSES,
    "checks.csv": CHECKS,
    "estimates.csv": ESTIMATES,
    "speedups.csv": SPEEDUPS,
    "validate.csv": VALIDATE,
    "peers.csv": PEERS,
}

#: Files a run folder has only sometimes (``peers.csv`` needs an installed peer).
OPTIONAL = frozenset({"peers.csv"})


def describe(name: str) -> str:
    """The column documentation of one CSV as plain text.

    Examples
    --------
    >>> print(describe("speedups.csv").splitlines()[0])
    speedups.csv
    >>> "elapsed_ns" in describe("batches.csv")
    True
    """
    columns = FILES[name]
    width = max(len(c) for c in columns)
    return "\n".join([name] + [f"  {c:<{width}}  {d}" for c, d in columns.items()])
