"""How long a sweep will take, said before it starts (``tribench seed``, ``run`` and ``sweep``): per process its
start-up, then per kernel and workload a check, a calibration and its batches, each the target or one pass
(timed here on a strided slice), whichever is longer; the other constants come from finished runs
(docs/decisions.md, "The duration forecast"). The progress lines correct it as batches finish."""

from __future__ import annotations

import math
import sys
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any, cast

import numpy as np

from .plan import Sweep, is_bvh

__all__ = ["Estimate", "estimate", "format_duration", "measure_passes", "model"]

#: A worker's start-up: the interpreter, NumPy, the extension, its workloads from the cache.
START_S = 0.5
#: A check's bookkeeping besides its pass (the reference comparison, the
#: ambiguous rays), read off the main job's batches (docs/decisions.md, "The duration forecast").
CHECK_S = 0.007
#: The runner's time per batch outside the timed loop, the top of what
#: bench/harness_overhead.py measured (docs/decisions.md, "Batches of 8 ms").
BATCH_OVERHEAD_S = 150e-6
#: Tests per measured pass: big enough to be timed, small enough to cost little.
SLICE_TESTS = 1 << 17
#: Rays per measured pass through a BVH (a few hundred tests each).
SLICE_RAYS = 1 << 11


def format_duration(seconds: float) -> str:
    """A duration as people say it: "about" goes before it.

    >>> format_duration(42.4), format_duration(150), format_duration(6000), format_duration(3 * 3600)
    ('40 s', '3 min', '1.7 h', '3 h')
    """
    if seconds < 10:
        return f"{max(1, math.floor(seconds + 0.5))} s"
    if seconds < 90:
        return f"{10 * math.floor(seconds / 10 + 0.5)} s"
    if seconds < 90 * 60:
        return f"{math.floor(seconds / 60 + 0.5)} min"
    hours = seconds / 3600
    return f"{hours:.0f} h" if hours >= 10 else f"{hours:.1f}".removesuffix(".0") + " h"


@dataclass(frozen=True)
class Estimate:
    """A sweep's expected duration and its parts."""

    seconds: float
    processes: int
    batches: int
    #: Per process: start-up, checks and calibrations.
    setup_s: float
    #: Shortest and longest batch (one pass or the target, whichever is longer).
    batch_s: tuple[float, float]

    def line(self, what: str = "") -> str:
        """One line for the log, e.g. ``expected: about 12 min (20 processes x ...)``; ``what`` follows "expected"."""
        lo, hi = (_ms(b) for b in self.batch_s)
        batch = f"{lo} ms" if lo == hi else f"{lo}-{hi} ms"
        head = f"expected {what}" if what else "expected"
        return (
            f"{head}: about {format_duration(self.seconds)} ({self.processes} processes x about "
            f"{format_duration(self.setup_s)} of start-up and checks, then {self.batches:,} batches of {batch})"
        )


def _ms(seconds: float) -> str:
    """Milliseconds to two figures, never in exponent form."""
    ms = 1e3 * seconds
    return f"{ms:.0f}" if ms >= 10 else f"{ms:.2g}"


def model(
    sweep: Sweep,
    tests: Mapping[str, int],
    pass_s: Mapping[tuple[str, str], float],
    twin_s: Mapping[tuple[str, str], float] | None = None,
) -> Estimate:
    """The expected duration of ``sweep`` from each workload's tests per pass and each (kernel,
    workload id) pair's seconds per pass; ``twin_s``: a BVH pair's null-leaf traversal's.

    >>> from tribench.workloads.spec import PairSpec
    >>> s = Sweep(("moller_seed",), (PairSpec(n=4096),), processes=10, rounds=10, warmup=1, target_ms=8.0)
    >>> e = model(s, {s.workload_ids[0]: 4096}, {("moller_seed", s.workload_ids[0]): 2e-5})
    >>> e.batches == s.n_batches, e.batch_s
    (True, (0.008, 0.008))
    >>> e.line()
    'expected: about 6 s (10 processes x about 1 s of start-up and checks, then 110 batches of 8 ms)'
    """
    target = sweep.target_ms / 1e3
    per_pair = sweep.rounds + sweep.warmup
    setup, batches_s, lengths = START_S, 0.0, []
    for spec, wid in zip(sweep.workloads, sweep.workload_ids, strict=True):
        for kernel in sweep.kernels_for(spec):
            one = pass_s[(kernel, wid)]
            batch = max(target, one)
            lengths.append(batch)
            # calibration doubles loops up to a quarter of the target, then times 3 batches
            setup += CHECK_S + one + max(1.25 * target, 4 * one)
            twin = batch * (twin_s or {}).get((kernel, wid), 0.0) / one
            batches_s += per_pair * (batch + twin + BATCH_OVERHEAD_S)
    return Estimate(
        seconds=sweep.processes * (setup + batches_s),
        processes=sweep.processes,
        batches=sweep.n_batches,
        setup_s=setup,
        batch_s=(min(lengths, default=target), max(lengths, default=target)),
    )


Passes = tuple[dict[str, int], dict[tuple[str, str], float], dict[tuple[str, str], float]]


def measure_passes(sweep: Sweep) -> Passes:
    """Tests per pass of every workload and one pass's seconds per (kernel, workload id), BVH twins included, timed
    on a strided slice and scaled; what it builds into the caches the workers would build anyway.

    With kernel files, the passes are timed in a worker of their own: their check never ran this sweep's
    workloads, and a kernel that crashes on one (an ``abort()`` past a size) would end this process without a word."""
    if sweep.kernel_files:
        return _passes_in_a_worker(sweep)
    return _passes(sweep)


def _passes_in_a_worker(sweep: Sweep) -> Passes:
    from .protocol import run_apart

    got: dict[str, Any] = {}
    run_apart(
        "tribench.harness.duration",
        # the files by path, loaded as the sweep's workers load them: the recorded sha256 is of the code
        # compiled, local headers included, which no one file has
        {**sweep.to_dict(), "kernel_files": []},
        sweep.kernel_files,
        {"passes": got.update},
        "the worker timing a pass of each kernel",
        "a kernel file's kernel fails on this sweep's workloads (its check ran others); nothing was timed",
    )
    return (
        got["tests"],
        {(k, w): s for k, w, s in got["seconds"]},
        {(k, w): s for k, w, s in got["twins"]},
    )


def _work(sweep: dict[str, Any]) -> None:
    """The worker of :func:`_passes_in_a_worker`: one ``passes`` line."""
    from .protocol import emit

    tests, seconds, twins = _passes(Sweep.from_dict(sweep), emit)
    emit(
        "passes",
        {
            "tests": tests,
            **{k: [[*key, s] for key, s in d.items()] for k, d in (("seconds", seconds), ("twins", twins))},
        },
    )


def _passes(sweep: Sweep, emit: Callable[[str, dict], None] | None = None) -> Passes:
    """The passes, in this process; in a worker, ``emit`` says how long each step may be silent (protocol)."""
    from .. import ext
    from ..workloads import cache
    from ..workloads.front import front_reference
    from .worker import BVH_RAY_TESTS, unmeasured_limit_s

    tests: dict[str, int] = {}
    seconds: dict[tuple[str, str], float] = {}
    twins: dict[tuple[str, str], float] = {}
    for spec, wid in zip(sweep.workloads, sweep.workload_ids, strict=True):
        if emit:  # no kernel runs while the workload is made, however long that takes
            emit("silence", {"seconds": None, "during": f"making workload {wid}"})
        w = cache.make(spec)
        pairs = w.mode == "pairs"
        if not pairs and any(ext.kernel_info(k).culls_back_faces for k in sweep.kernels_for(spec)):
            front_reference(w)
        rays, tris = len(w.origins), len(w.triangles)
        tests[wid] = rays if pairs else rays * tris
        bvh = is_bvh(spec)  # a ray costs a traversal, not a test of every triangle
        step = math.ceil(rays / SLICE_RAYS) if bvh else math.ceil(tests[wid] / SLICE_TESTS)
        part = slice(None, None, max(1, step))
        silence_s = unmeasured_limit_s(10 * (SLICE_RAYS * BVH_RAY_TESTS if bvh else SLICE_TESTS))

        def cut(a: Any, part: slice = part) -> Any:
            return None if a is None or np.ndim(a) == 0 else np.ascontiguousarray(a[part])

        o, d, tm = cut(w.origins), cut(w.directions), cut(w.t_max)
        for kernel in sweep.kernels_for(spec):
            if emit:  # a BVH's build, then a few passes
                emit("silence", {"seconds": silence_s, "during": f"timing a pass of {kernel} on {wid}"})
            if bvh:
                seconds[(kernel, wid)], twins[(kernel, wid)] = _bvh_passes(kernel, w, o, d, tm)
                continue
            job = ext.make_job(
                kernel, o, d, cut(w.triangles) if pairs else w.triangles, cast(ext.Mode, w.mode), t_max=tm
            )
            best = min(ext.time_batch(job, 1).elapsed_ns for _ in range(2))
            seconds[(kernel, wid)] = best * 1e-9 * tests[wid] / job.tests_per_pass
    return tests, seconds, twins


def _bvh_passes(kernel: str, w: Any, o: np.ndarray, d: np.ndarray, t_max: Any) -> tuple[float, float]:
    """Seconds per pass of ``w``'s rays through ``kernel``'s tree, and of its null-leaf twin."""
    from .. import ext
    from ..workloads import bvh_cache
    from .worker import null_leaf_t_max

    tree, _ = bvh_cache.cached_bvh(kernel, w.triangles, w.spec.max_leaf or ext.DEFAULT_MAX_LEAF)
    scale = 1e-9 * len(w.origins) / len(o)
    mode = cast(ext.Mode, w.mode)
    null_t_max = null_leaf_t_max(tree, o, d, mode, t_max)
    trace = min(tree.time(o, d, mode, 1, t_max=t_max).elapsed_ns for _ in range(2))
    null = min(tree.time(o, d, "closest", 1, t_max=null_t_max, null_leaf=True).elapsed_ns for _ in range(2))
    return trace * scale, null * scale


def estimate(sweep: Sweep) -> Estimate:
    """:func:`model` on :func:`measure_passes`: the line ``tribench seed``, ``run`` and ``sweep`` print first."""
    return model(sweep, *measure_passes(sweep))


if __name__ == "__main__":
    from .protocol import serve_apart

    sys.exit(serve_apart(_work))
