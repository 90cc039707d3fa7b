"""The worker: one replicate of a sweep, in a fresh process.

Run as ``python -m tribench.harness.worker`` by :mod:`tribench.harness.runner` in the one worker protocol
(:mod:`.protocol`): a :class:`WorkerJob` on stdin, a ``process``, ``check``, ``batch`` or ``traversal`` row
(:mod:`tribench.harness.runfolder`) out as soon as it is measured. It pins itself, randomises the layout,
probes the FMA peak, checks and calibrates each kernel on each workload, runs the batches with every checksum
verified and probes the peak again (docs/methodology.md, "A sweep", "In a BVH"). A BVH's nodes are not moved
by the layout's random offsets: their start on a cache line is part of the tree, as in any tracer
(``ext/bvh.py``, ``LINE_BYTES``)."""

from __future__ import annotations

import json
import os
import resource
import sys
import time
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass
from typing import Any, cast

import numpy as np

from .. import ext
from ..common import seconds_from_env
from ..workloads import bvh_cache
from . import layout, protocol
from .checks import Checksum, KernelCheckError, check_batch, one_pass_checksum
from .plan import is_bvh
from .runfolder import BatchRow, CheckRow, ProcessRow, TraversalRow

__all__ = [
    "BvhJob",
    "WorkerJob",
    "calibrate_loops",
    "kernel_isa",
    "main",
    "run_job",
]

#: Iterations of the FMA probe: 192 flops each, about 0.4 ms at 100 GFLOP/s.
PEAK_ITERATIONS = 200_000

#: How long a worker may go without a line (protocol ``silence``), so that a kernel that never returns stops the
#: sweep, which keeps its batches: a floor for what runs no kernel (a cache read, a reference; ``$SILENCE_VARIABLE``
#: seconds), then, for a kernel's check, a pass at 10 us a test (a BVH ray: 1,000 tests), 100x the slowest built-in
#: kernel, and from then on ten times the slowest check and batch (docs/decisions.md, "A kernel that never returns").
SILENCE_VARIABLE, SILENCE_FLOOR_S = "TRIBENCH_SILENCE_SECONDS", 60.0
SLOW_TEST_S = 1e-5
BVH_RAY_TESTS = 1000


@dataclass(frozen=True)
class WorkerJob:
    """Everything one worker process needs (sent as JSON on its stdin)."""

    run_id: str
    process: int
    attempt: int
    seed: int
    cpu: int | None
    target_ms: float
    keys: tuple[tuple[int, str, int, int, str], ...]
    workloads: Mapping[str, Mapping[str, Any]]
    kernel_files: tuple[str, ...] = ()  # loaded before anything else: their kernels are in keys
    build: str = ext.INSTALLED  # the build of the kernels (ext.use_build), taken before the kernel files

    @classmethod
    def from_json(cls, text: str) -> WorkerJob:
        d = json.loads(text)
        d["keys"] = tuple(tuple(k) for k in d["keys"])
        d["kernel_files"] = tuple(d.get("kernel_files", ()))
        return cls(**d)

    def to_json(self) -> str:
        return json.dumps(asdict(self))


def kernel_isa(kernel: str) -> str:
    """Form and instruction set a kernel runs with: ``scalar/<baseline>`` (no ``-march``)
    or ``x16/<isa>`` (a native kernel: its block of 16 triangles, the ISA chosen at run time).

    >>> kernel_isa("moller_trumbore").startswith("scalar/")
    True
    >>> kernel_isa("moller_trumbore_fma").startswith("x16/")
    True
    """
    import platform

    info = ext.kernel_info(kernel)
    if info.lanes > 1:
        return f"x{info.lanes}/{info.isa}"
    build = ext.build_info()
    machine = platform.machine()
    baseline = "avx2" if build.get("baseline_avx2") else {"x86_64": "sse2", "AMD64": "sse2"}.get(machine, machine)
    return f"scalar/{baseline}"


@dataclass(frozen=True)
class BvhJob:
    """The inputs of a BVH workload's timed batches: one kernel's BVH, the rays, and ``null_t_max``,
    each ray's limit for the null-leaf traversal (:func:`null_leaf_t_max`; None: the workload's ``t_max``)."""

    bvh: ext.BVH
    origins: np.ndarray
    directions: np.ndarray
    mode: ext.Mode
    t_max: np.ndarray | None
    null_t_max: np.ndarray | None = None

    @property
    def max_loops(self) -> int:
        return ext.MAX_BVH_BATCH_RAYS // len(self.origins)

    def trace(self, loops: int) -> ext.TraceBatch:
        """One timed batch through the tree, with the kernel at the leaves."""
        return self.bvh.time(self.origins, self.directions, self.mode, loops, t_max=self.t_max)

    def trace_null(self, loops: int) -> ext.TraceBatch:
        """The same rays and loops with a null leaf test: the traversal alone."""
        t_max = self.t_max if self.null_t_max is None else self.null_t_max
        return self.bvh.time(self.origins, self.directions, "closest", loops, t_max=t_max, null_leaf=True)


def _as_batch(b: ext.TraceBatch) -> ext.Batch:
    """A BVH batch as a brute-force batch: its ``tests`` are the triangle tests its traversal did."""
    return ext.Batch(b.elapsed_ns, b.loops, b.triangle_tests, b.hits, b.t_sum, b.uv_sum)


def time_job(job: ext.Job | BvhJob, loops: int) -> ext.Batch:
    """One timed batch of a brute-force job or a BVH job."""
    if isinstance(job, BvhJob):
        return _as_batch(job.trace(loops))
    return ext.time_batch(job, loops)


def calibrate_loops(job: ext.Job | BvhJob, target_ns: float) -> int:
    """``loops`` for which one batch of ``job`` takes about ``target_ns``: doubled until a batch
    takes a quarter of the target, then scaled by the median of three batches at that size."""
    most = job.max_loops if isinstance(job, BvhJob) else 2**30
    loops = 1
    while time_job(job, loops).elapsed_ns < target_ns / 4 and loops < most:
        loops = min(2 * loops, most)
    per_loop = float(np.median([time_job(job, loops).elapsed_ns for _ in range(3)])) / loops
    return min(most, max(1, round(target_ns / max(per_loop, 1.0))))


def _peak_row(job: WorkerJob, phase: str, cpu: int, pad: int, dummies: int) -> ProcessRow:
    p = ext.fma_peak(PEAK_ITERATIONS)
    return ProcessRow(
        run_id=job.run_id,
        process=job.process,
        attempt=job.attempt,
        phase=phase,
        pid=os.getpid(),
        cpu=cpu,
        seed=job.seed,
        env_pad_bytes=pad,
        dummy_allocs=dummies,
        peak_gflops=p.gflops,
        peak_flops=p.flops,
        peak_elapsed_ns=p.elapsed_ns,
        peak_isa=p.isa,
        start_ns=time.monotonic_ns(),
    )


class _Meter:
    """What happened around one timed batch: its start, the involuntary context switches during it, and the
    machine's steal time since the previous batch ended (one reading per batch; -1 where unreadable), in clock
    ticks from ``/proc/stat``, which stays open and is re-read with ``pread``, a quarter of the cost of opening it."""

    def __init__(self) -> None:
        try:
            self._fd = os.open("/proc/stat", os.O_RDONLY)
        except OSError:
            self._fd = -1
        self._steal_before: int | None = None
        self._switches_before = 0
        self.start_ns = 0

    def _ticks(self) -> int:
        if self._fd < 0:
            return -1
        try:
            fields = os.pread(self._fd, 256, 0).split(b"\n", 1)[0].split()
            return int(fields[8]) if fields[0] == b"cpu" and len(fields) > 8 else -1
        except (OSError, ValueError, IndexError):
            return -1

    def forget(self) -> None:
        """What ran since the last batch (a check, a calibration, a null trace) is not the next batch's steal."""
        self._steal_before = None

    def start(self) -> None:
        self._switches_before = resource.getrusage(resource.RUSAGE_SELF).ru_nivcsw
        if self._steal_before is None:
            self._steal_before = self._ticks()
        self.start_ns = time.monotonic_ns()

    def stop(self) -> tuple[int, int]:
        """(switches, steal ticks) of the batch since :meth:`start` (ticks are 10 ms; the bookkeeping
        between batches takes ~0.05 ms, so the steal since the previous batch ended is this one's)."""
        switches = resource.getrusage(resource.RUSAGE_SELF).ru_nivcsw - self._switches_before
        after, before = self._ticks(), self._steal_before
        self._steal_before = after
        return switches, (after - before if before is not None and before >= 0 and after >= 0 else -1)

    def close(self) -> None:
        if self._fd >= 0:
            os.close(self._fd)
            self._fd = -1


def _timed(kjob: ext.Job | BvhJob, loops: int, rng: np.random.Generator, meter: _Meter):
    """One batch of a contender: ``(batch, switches, steal ticks, (trace, null, null_first) or None)``. A BVH
    batch's null-leaf twin runs just before or after it at random; its time is not the batch's steal."""
    if not isinstance(kjob, BvhJob):
        meter.start()
        batch = ext.time_batch(kjob, loops)
        return (batch, *meter.stop(), None)
    null_first = bool(rng.integers(2))
    if null_first:
        null = kjob.trace_null(loops)
        meter.forget()
    meter.start()
    trace = kjob.trace(loops)
    switches, steal = meter.stop()
    if not null_first:
        null = kjob.trace_null(loops)
        meter.forget()
    return _as_batch(trace), switches, steal, (trace, null, null_first)


def _load_workloads(job: WorkerJob, rng: np.random.Generator) -> tuple[dict[str, Any], dict[str, tuple]]:
    """The job's workloads from the cache (each checked against its id), copied for this process at random offsets."""
    from ..workloads import cache
    from ..workloads.kinds import spec_from_dict
    from ..workloads.spec import workload_id

    workloads, arrays = {}, {}
    for wid, spec_dict in job.workloads.items():
        spec = spec_from_dict(spec_dict)
        if workload_id(spec) != wid:
            raise ValueError(f"workload {wid}: its spec has id {workload_id(spec)} (generator changed?)")
        workloads[wid] = w = cache.make(spec)
        arrays[wid] = tuple(layout.fresh_copy(a, rng) for a in (w.origins, w.directions, w.triangles))
    return workloads, arrays


def _prepare(job: WorkerJob, process: int, kernel: str, w: Any, arrays: tuple, emit):
    """One kernel on one workload before its first batch: its job (brute force or through its BVH),
    its answers checked against the reference (a ``check`` row), and its batch length calibrated;
    and the seconds its check took."""
    o, d, tris = arrays
    bvh = is_bvh(w.spec)
    tests = len(o) * (BVH_RAY_TESTS if bvh else len(tris) if w.mode != "pairs" else 1)
    during = f"checking {kernel} on {w.workload_id}"
    emit("silence", {"seconds": unmeasured_limit_s(tests), "during": during})
    started = time.monotonic()
    kjob: ext.Job | BvhJob
    if bvh:
        kjob = _bvh_job(kernel, w, o, d, tris)
        expected, counts = one_pass_checksum(kernel, w, kjob.bvh)
    else:
        kjob = ext.make_job(kernel, o, d, tris, cast(ext.Mode, w.mode), t_max=w.t_max)  # the spec checked it
        expected, counts = one_pass_checksum(kernel, w)
    check = CheckRow(
        run_id=job.run_id,
        process=process,
        attempt=job.attempt,
        workload_id=w.workload_id,
        kernel=kernel,
        **counts,
        hits=expected.hits,
        t_sum=expected.t_sum,
    )
    emit("check", check)
    checked_s = time.monotonic() - started
    during = f"calibrating {kernel} on {w.workload_id}"
    emit("silence", {"seconds": measured_limit_s(checked_s + job.target_ms * 1e-3), "during": during})
    return kjob, calibrate_loops(kjob, job.target_ms * 1e6), expected, checked_s


def silence_floor_s() -> float:
    """The least a worker may go without a line: ``$TRIBENCH_SILENCE_SECONDS``, else :data:`SILENCE_FLOOR_S`."""
    return seconds_from_env(SILENCE_VARIABLE, SILENCE_FLOOR_S, "the least seconds a worker may go without a line")


def unmeasured_limit_s(tests: float) -> float:
    """How long a worker may be silent over ``tests`` tests that no pass has timed yet."""
    return silence_floor_s() + SLOW_TEST_S * tests


def measured_limit_s(seconds: float) -> float:
    """How long a worker may be silent over work that takes ``seconds`` by a pass timed (a batch: a pass or the
    target, whichever is longer)."""
    return silence_floor_s() + 10 * seconds


def run_job(job: WorkerJob, emit) -> None:
    """Run one worker job, ``emit(type, record)`` receiving every message; raises KernelCheckError when a kernel's
    answers or a batch's checksum disagree with the reference."""
    layout.pin(job.cpu)
    cpu = job.cpu if job.cpu is not None else -1
    rng = np.random.default_rng([job.seed, job.attempt])
    pad = layout.padding()
    dummies = layout.dummy_allocations(rng)
    workloads, arrays = _load_workloads(job, rng)
    emit("process", _peak_row(job, "start", cpu, pad, len(dummies)))

    isa = {k: kernel_isa(k) for k in {key[4] for key in job.keys}}
    kernels_of: dict[str, dict[str, None]] = {}  # per workload, its kernels in the order they first come
    for _, wid, _, _, kernel in job.keys:
        kernels_of.setdefault(wid, {})[kernel] = None
    prepared: dict[tuple[str, str], tuple[ext.Job | BvhJob, int, Checksum]] = {}
    meter = _Meter()
    slowest_s = 0.0
    for process, wid, rnd, position, kernel in job.keys:
        w = workloads[wid]
        if (kernel, wid) not in prepared:  # a new workload block: check and calibrate all its kernels first
            for k in kernels_of[wid]:
                kjob, loops, expected, checked_s = _prepare(job, process, k, w, arrays[wid], emit)
                prepared[(k, wid)] = (kjob, loops, expected)
                slowest_s = max(slowest_s, checked_s)
            during = f"timing the batches of {', '.join(kernels_of[wid])} on {wid}"
            emit("silence", {"seconds": measured_limit_s(slowest_s + job.target_ms * 1e-3), "during": during})
            meter.forget()
        kjob, loops, expected = prepared[(kernel, wid)]
        batch, switches, steal, bvh_trace = _timed(kjob, loops, rng, meter)
        check_batch(batch, expected, kernel, w)
        emit(
            "batch",
            BatchRow(
                run_id=job.run_id,
                process=process,
                round=rnd,
                position=position,
                kernel=kernel,
                build=job.build,
                workload_id=wid,
                dtype=w.spec.dtype,
                mode=w.mode,
                warmup=rnd < 0,
                loops=batch.loops,
                tests=batch.tests,
                elapsed_ns=batch.elapsed_ns,
                start_ns=meter.start_ns,
                invol_ctx_switches=switches,
                hits=batch.hits,
                t_sum=batch.t_sum,
                cpu=cpu,
                isa=isa[kernel],
                attempt=job.attempt,
                steal_ticks=steal,
            ),
        )
        if bvh_trace is not None:
            emit("traversal", _traversal_row(job, (process, wid, rnd, position, kernel), *bvh_trace))
    meter.close()
    emit("process", _peak_row(job, "end", cpu, pad, len(dummies)))


def _traversal_row(job: WorkerJob, key: tuple[int, str, int, int, str], trace, null, null_first: bool) -> TraversalRow:
    """A BVH batch's traversal counts and its null-leaf twin; ``key`` is the batch's, as in ``job.keys``."""
    process, wid, rnd, position, kernel = key
    return TraversalRow(
        run_id=job.run_id,
        process=process,
        attempt=job.attempt,
        round=rnd,
        position=position,
        kernel=kernel,
        workload_id=wid,
        warmup=rnd < 0,
        rays=trace.loops * trace.rays,
        nodes=trace.nodes,
        box_tests=trace.box_tests,
        leaves=trace.leaves,
        triangle_tests=trace.triangle_tests,
        null_elapsed_ns=null.elapsed_ns,
        null_nodes=null.nodes,
        null_first=null_first,
    )


def null_leaf_t_max(bvh: ext.BVH, o: np.ndarray, d: np.ndarray, mode: ext.Mode, t_max: Any) -> np.ndarray:
    """Each ray's limit for the null-leaf traversal: just above the kernel's own hit (the
    traversal's own 1 + 4 eps, so it still enters the hit's leaf), ``t_max`` where it misses."""
    hits = bvh.intersect(o, d, mode, t_max=t_max).hits
    grow = 1 + 4 * np.finfo(o.dtype).eps
    return np.where(hits.hit, hits.t * grow, np.inf if t_max is None else t_max).astype(o.dtype)


def _bvh_job(kernel: str, w: Any, o: np.ndarray, d: np.ndarray, tris: np.ndarray) -> BvhJob:
    """``kernel``'s BVH over this process's copy of the triangles, and its rays, from the BVH cache."""
    max_leaf = w.spec.max_leaf or ext.DEFAULT_MAX_LEAF
    bvh, _ = bvh_cache.cached_bvh(kernel, tris, max_leaf)
    mode = cast(ext.Mode, w.mode)
    bjob = BvhJob(bvh, o, d, mode, w.t_max, null_leaf_t_max(bvh, o, d, mode, w.t_max))
    if time_job(bjob, 1).tests == 0:  # ns per test needs a test; batches.csv holds positive counts
        raise ValueError(
            f"workload {w.workload_id} ({w.spec.summary()}): no ray reaches a leaf of the BVH, so its "
            f"batches would do no triangle test to time: aim the rays at the mesh, or use accel brute"
        )
    return bjob


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of ``python -m tribench.harness.worker``: job on stdin, JSON lines out."""

    def work(text: str) -> None:
        job = WorkerJob.from_json(text)
        if job.build != ext.INSTALLED:
            ext.use_build(job.build)
        for path in job.kernel_files:
            ext.load_kernels(path)
        run_job(job, protocol.emit)

    return protocol.serve(work, (KernelCheckError,))


if __name__ == "__main__":
    sys.exit(main())
