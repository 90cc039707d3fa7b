"""The measured files' rows: one dataclass per file, each field a column, the one schema they are written from
and read back with: a field's type is the column's (readers check every value), its ``doc`` the column's
meaning (docs/run-folder.md is made from it), the fields' order the columns'. Rows are built with keywords."""

from __future__ import annotations

from dataclasses import dataclass, field, fields
from typing import Any

__all__ = ["BatchRow", "CheckRow", "PeerRow", "ProcessRow", "TraversalRow", "column_docs"]


def _col(doc: str) -> Any:
    """A required field whose metadata holds the column's meaning."""
    return field(metadata={"doc": doc})


def column_docs(row_type: type) -> dict[str, str]:
    """Column -> meaning of a row dataclass, in file order."""
    return {f.name: f.metadata["doc"] for f in fields(row_type)}


_RUN_ID = "identifier of the run (as in run.json)"
_PROCESS = "index of the worker process, the replicate (0-based)"
_ATTEMPT = "worker attempt of this process index (above 0 only after a resume)"
_ROUND = "round inside the process; negative for warm-up rounds"
_CPU = "CPU the worker was pinned to"


@dataclass(frozen=True)
class BatchRow:
    """One timed batch: a row of ``batches.csv``."""

    run_id: str = _col(_RUN_ID)
    process: int = _col(_PROCESS)
    round: int = _col(_ROUND)
    position: int = _col("position of the kernel inside its round (random order, 0-based)")
    kernel: str = _col("kernel name, as registered in the C extension")
    build: str = _col("build of the kernels: installed (pip's), or a --builds spec, a compiler and its flags")
    workload_id: str = _col("workload identifier (hash of its spec; see run.json sweep.workloads)")
    dtype: str = _col("precision of the workload's arrays: float32 or float64")
    mode: str = _col("pairs (ray i against triangle i) or closest (every ray against every triangle)")
    warmup: bool = _col("True for a warm-up batch (kept, left out of every estimate)")
    loops: int = _col("passes over the whole workload in this batch")
    tests: int = _col("ray-triangle tests in this batch (loops x tests per pass)")
    elapsed_ns: int = _col("wall time of the batch in nanoseconds (CLOCK_MONOTONIC, inside C)")
    start_ns: int = _col("CLOCK_MONOTONIC time at the start of the batch, in nanoseconds")
    invol_ctx_switches: int = _col("involuntary context switches during the batch (getrusage)")
    hits: int = _col("hits counted in the batch (checksum; loops x hits per pass)")
    t_sum: float = _col("sum of t over the hits of the batch (checksum)")
    cpu: int = _col(_CPU)
    isa: str = _col("instruction set the kernel variant ran with")
    attempt: int = _col(_ATTEMPT)
    steal_ticks: int = _col("steal time during the batch in clock ticks from /proc/stat (-1: unreadable)")


@dataclass(frozen=True)
class ProcessRow:
    """One FMA peak probe of a worker process, at its start and its end, with its layout: a row of ``processes.csv``."""

    run_id: str = _col(_RUN_ID)
    process: int = _col(_PROCESS)
    attempt: int = _col(_ATTEMPT)
    phase: str = _col("start or end of the process")
    pid: int = _col("operating-system process id")
    cpu: int = _col(_CPU)
    seed: int = _col("seed of the process's random choices (kernel orders, layout)")
    env_pad_bytes: int = _col("bytes of environment padding (layout randomisation)")
    dummy_allocs: int = _col("small allocations made before the arrays (layout randomisation)")
    peak_gflops: float = _col("measured FMA peak, GFLOP/s")
    peak_flops: float = _col("flops of the probe")
    peak_elapsed_ns: int = _col("duration of the probe in nanoseconds")
    peak_isa: str = _col("instruction set of the probe")
    start_ns: int = _col("CLOCK_MONOTONIC time of the probe, in nanoseconds")


@dataclass(frozen=True)
class CheckRow:
    """A row of ``checks.csv``: one kernel's answers on one workload against the reference, per process."""

    run_id: str = _col(_RUN_ID)
    process: int = _col(_PROCESS)
    attempt: int = _col(_ATTEMPT)
    workload_id: str = _col("workload identifier")
    kernel: str = _col("kernel name")
    rays: int = _col("rays of the workload (count)")
    ambiguous_rays: int = _col(
        "rays near an edge (1e-5 barycentric, or 8 epsilons of rounding): "
        "a correct kernel may answer either way (count)"
    )
    disagreements: int = _col("rays the kernel answered differently from the float64 reference (count)")
    ambiguous_disagreements: int = _col("of those, how many are ambiguous rays (count)")
    hits: int = _col("hits of the kernel in one pass (its checksum)")
    t_sum: float = _col("sum of t over the kernel's hits in one pass (its checksum)")


@dataclass(frozen=True)
class TraversalRow:
    """A row of ``traversals.csv``: what one BVH batch and its null-leaf twin did inside the tree, keyed as its
    batch, summed over every ray and loop (``1 - null_elapsed_ns / elapsed_ns`` is the leaf tests' share)."""

    run_id: str = _col(_RUN_ID)
    process: int = _col("index of the worker process (with workload_id, round, position and kernel, a batch's key)")
    attempt: int = _col(_ATTEMPT)
    round: int = _col(_ROUND)
    position: int = _col("position of the kernel inside its round")
    kernel: str = _col("kernel name (the BVH's leaf test)")
    workload_id: str = _col("workload identifier (a BVH workload)")
    warmup: bool = _col("True for a warm-up batch")
    rays: int = _col("rays traced in the batch (loops x rays of the workload)")
    nodes: int = _col("nodes the batch's traversal entered, inner nodes and leaves (count, over all its rays)")
    box_tests: int = _col("ray-box tests of the batch (count)")
    leaves: int = _col("leaves the batch's traversal entered (count)")
    triangle_tests: int = _col("triangle tests in those leaves (count; batches.csv's tests)")
    null_elapsed_ns: int = _col(
        "the same batch traced again with a null leaf test (no triangle tested; each ray's t_max at the "
        "kernel's own closest hit, so it enters the nodes a ray that found its hit at once would), "
        "timed inside C, ns"
    )
    null_nodes: int = _col("nodes that null traversal entered (count; at most nodes in closest mode)")
    null_first: bool = _col("True when the null traversal ran just before the real batch, False just after (random)")


@dataclass(frozen=True)
class PeerRow:
    """One timed call of tribench or a peer: a row of ``peers.csv``."""

    process: int = _col(_PROCESS)
    rep: int = _col("repetition inside the process (0-based)")
    position: int = _col("position of the contender inside its repetition (random order, 0-based)")
    contender: str = _col(
        "tribench (kernel loop timed in C), tribench_call (ext.intersect), tribench_packets (the BVH walked by "
        "packets of 16 rays), embree, embree_16, embree_robust, embree_robust_16 (native Embree, loop timed in C), "
        "embreex (Embree from Python) or trimesh"
    )
    implementation: str = _col("what ran, with its version (and the kernel's form and ISA for tribench)")
    kernel: str = _col("the tribench kernel of the run (the fastest closest-mode kernel on this workload)")
    workload_id: str = _col("workload identifier (the camera workload; see tribench workloads show)")
    workload: str = _col("the workload's spec in one line")
    rays: int = _col("rays in the call (count; trimesh runs a fixed random subset)")
    elapsed_ns: int = _col(
        "time the rate is computed from, ns: the C-timed loop for tribench and native Embree, else wall_ns"
    )
    wall_ns: int = _col("wall time of the call from Python, in nanoseconds")
    cpu_ns: int = _col("CPU time of the process during the call, in nanoseconds")
    rays_per_s: float = _col("rays / elapsed_ns, per second")
    setup_ns: int = _col("one-off set-up before the timing, ns (Embree's BVH, trimesh's rtree, tribench's job)")
    differ: int = _col("rays whose closest triangle differs from the float64 reference's (count)")
    differ_ambiguous: int = _col("of those, ambiguous rays (near an edge: see `ambiguous_rays`) (count)")
    cpu: int = _col("CPU the process was pinned to")
