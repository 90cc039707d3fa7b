"""The harness's overhead per batch, against a bare C loop of the same kernel (goal: under 2%).

(a) Harness: a real short sweep through ``runner.start`` (fresh pinned worker
processes, checks, calibration, one JSON line per batch) of moller_trumbore
and curless on a pairs workload and a Suzanne camera workload. From
``batches.csv``, for consecutive batches of one process in the same round,
the gap ``start_ns[i+1] - start_ns[i] - elapsed_ns[i]`` is time the harness
spent outside the C-timed loop between two batches; it is printed relative to
``elapsed_ns[i]`` (median and 90th percentile, in percent).

(w) Worker alone: the worker's loop (``worker.run_job``) run in this process
with its messages dropped: its per-batch bookkeeping (rusage, steal ticks
from /proc/stat, checksum check, the row) without the pipe and the runner.

(b) Bare: this process, pinned to the workers' CPU, calls ``ext.time_batch``
back to back on the same jobs with the same calibrated ``loops``; the same
gap between call starts (``time.perf_counter_ns``) relative to
``elapsed_ns`` is the floor any harness pays for calling C from Python.

All three at several batch lengths (``target_ms``), with, for each, the
batch length at which the harness's median gap would be 2% of the batch.
The workers (and so the bare loop) run on the last CPU: on a shared machine
other processes' time slices land in batches and gaps alike (the sweep's
involuntary context switches per batch are printed).

    python bench/harness_overhead.py [--target-ms 0.5,2,8] [--processes 4] [--rounds 10] [--bare-batches 60] [--cpu N]
"""

from __future__ import annotations

import argparse
import os
import shutil
import tempfile
import time
from dataclasses import asdict

import numpy as np

from tribench import ext
from tribench.harness import runfolder, runner
from tribench.harness.machine import describe
from tribench.harness.plan import Sweep, plan, process_seed
from tribench.harness.worker import WorkerJob, calibrate_loops, run_job
from tribench.workloads import cache
from tribench.workloads.spec import MeshSpec, PairSpec

KERNELS = ("moller_trumbore", "curless")
GOAL = 2.0  # percent


def workloads() -> tuple:
    # a pairs workload in L2 and a small mesh through a small camera (one pass well
    # under 0.5 ms, so every target_ms is reachable): both kinds of workload the harness runs
    return (
        PairSpec(n=4096, hit_rate=0.5, dtype="float32"),
        MeshSpec("suzanne", triangles=100, width=16, height=16, dtype="float32"),
    )


def consecutive_gaps(frame):
    """Overheads (percent), gaps (ns) and batch lengths (ns) of consecutive batches
    of one process in the same workload block and round (the first batch of a block
    follows the checks and calibration, which are not per-batch costs)."""
    gaps, lengths = [], []
    for _, group in frame.sort_values(["process", "attempt", "start_ns"]).groupby(["process", "attempt"]):
        start, elapsed = group["start_ns"].to_numpy(), group["elapsed_ns"].to_numpy()
        rnd, wid = group["round"].to_numpy(), group["workload_id"].to_numpy()
        same = (rnd[1:] == rnd[:-1]) & (wid[1:] == wid[:-1])
        gaps.append((start[1:] - start[:-1] - elapsed[:-1])[same])
        lengths.append(elapsed[:-1][same])
    gaps, lengths = np.concatenate(gaps), np.concatenate(lengths)
    return 100 * gaps / lengths, gaps, lengths


def harness_gaps(target_ms: float, processes: int, rounds: int, root: str, cpu):
    """Gaps from one real sweep: worker processes, JSON lines to the runner, batches.csv."""
    sweep = Sweep(KERNELS, workloads(), processes=processes, rounds=rounds, warmup=1, target_ms=target_ms)
    result = runner.start(sweep, f"{root}/run-{target_ms:g}ms", cpu=cpu, progress=False)
    frame = runfolder.read_batches(result.run_dir)
    return (*consecutive_gaps(frame), (result, frame["invol_ctx_switches"].mean()))


def in_process_gaps(target_ms: float, rounds: int, cpu):
    """The worker's own loop run in this process with its messages dropped: the
    worker's per-batch bookkeeping without the pipe and the runner."""
    import pandas as pd

    sweep = Sweep(KERNELS, workloads(), processes=1, rounds=rounds, warmup=1, target_ms=target_ms)
    job = WorkerJob(
        "in-process",
        0,
        0,
        process_seed(sweep.rng_seed, 0),
        cpu,
        target_ms,
        tuple(tuple(k.to_list()) for k in plan(sweep)),
        {wid: sweep.spec_of(wid).to_dict() for wid in sweep.workload_ids},
    )
    rows = []
    run_job(job, lambda kind, record: rows.append(record) if kind == "batch" else None)
    return consecutive_gaps(pd.DataFrame([asdict(r) for r in rows]))


def bare_gaps(target_ms: float, n_batches: int, jobs: list):
    """The same gap for ``time_batch`` called back to back on each job in this process."""
    gaps, lengths = [], []
    for job in jobs:
        loops = calibrate_loops(job, target_ms * 1e6)  # the worker's own calibration
        starts, elapsed = [], []
        for _ in range(n_batches):
            starts.append(time.perf_counter_ns())
            elapsed.append(ext.time_batch(job, loops).elapsed_ns)
        starts.append(time.perf_counter_ns())
        wall = np.diff(starts)  # wall time per batch, call to call
        gaps.append(wall - elapsed)
        lengths.append(np.array(elapsed))
    gaps, lengths = np.concatenate(gaps), np.concatenate(lengths)
    return 100 * gaps / lengths, gaps, lengths


def row(name: str, target: float, pct, gaps, lengths) -> str:
    med, p90 = np.median(pct), np.percentile(pct, 90)
    return (
        f"{name:<9}{target:>8g}{len(pct):>7}{np.median(lengths) / 1e6:>10.3f}{np.median(gaps) / 1e3:>10.1f}"
        f"{np.percentile(gaps, 90) / 1e3:>10.1f}{med:>9.3f}{p90:>9.3f}   {'yes' if med < GOAL else 'NO'}"
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--target-ms", default="0.5,2,8", help="batch lengths to try, comma-separated")
    ap.add_argument("--processes", type=int, default=4)
    ap.add_argument("--rounds", type=int, default=10)
    ap.add_argument("--cpu", type=int, help="CPU for the workers and the bare loop (default: the harness's, the last)")
    ap.add_argument("--bare-batches", type=int, default=60, help="bare gaps per job and target")
    ap.add_argument("--keep", metavar="DIR", help="keep the sweeps' run folders under DIR (default: deleted)")
    args = ap.parse_args()
    print(describe())
    targets = [float(t) for t in args.target_ms.split(",")]

    # the bare loop's jobs: the same kernels and workloads, pinned where the workers run
    specs = workloads()
    jobs = []
    for spec in specs:
        w = cache.make(spec)
        jobs += [ext.make_job(k, w.origins, w.directions, w.triangles, w.mode) for k in KERNELS]
    cpu = runner.default_cpu() if args.cpu is None else args.cpu
    print(f"kernels: {', '.join(KERNELS)}; workloads: " + "; ".join(s.summary() for s in specs))
    print(
        f"workers and the bare loop pinned to CPU {cpu}; gap = start[i+1] - start[i] - elapsed[i], "
        f"overhead = gap / elapsed[i]; load average {os.getloadavg()[0]:.2f}"
    )

    root = args.keep or tempfile.mkdtemp(prefix="tribench-overhead-")
    results = []
    for target in targets:
        pct, gaps, lengths, result = harness_gaps(target, args.processes, args.rounds, root, cpu)
        allowed = os.sched_getaffinity(0)
        if cpu is not None:
            os.sched_setaffinity(0, {cpu})
        try:
            worker = in_process_gaps(target, args.rounds, cpu)  # pins itself to cpu too
            bare = bare_gaps(target, args.bare_batches, jobs)
        finally:
            os.sched_setaffinity(0, allowed)  # the next sweep's runner runs unpinned, as usual
        results.append((target, (pct, gaps, lengths), worker, bare, result))

    print(
        f"\n{'':<9}{'target':>8}{'gaps':>7}{'batch':>10}{'gap':>10}{'gap p90':>10}{'median':>9}{'p90':>9}"
        f"   median < {GOAL:g}%"
    )
    print(f"{'':<9}{'ms':>8}{'':>7}{'ms':>10}{'us':>10}{'us':>10}{'%':>9}{'%':>9}")
    for target, harness, worker, bare, (result, switches) in results:
        print(row("harness", target, *harness))
        print(row("worker", target, *worker))
        print(row("bare", target, *bare))
        gap = np.median(harness[1])
        print(
            f"{'':<9}harness - bare: {(gap - np.median(bare[1])) / 1e3:.1f} us per batch; this gap is "
            f"{GOAL:g}% of a {gap / (GOAL / 100) / 1e6:.1f} ms batch; sweep: {result.batches_run} batches "
            f"in {result.elapsed_s:.1f} s, {switches:.2f} involuntary context switches per batch"
        )
    if args.keep:
        print(f"run folders: {root}")
    else:
        shutil.rmtree(root)


if __name__ == "__main__":
    main()
