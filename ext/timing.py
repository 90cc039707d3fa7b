"""Timed batches: a job checked and prepared once (:func:`make_job`), so a batch adds nothing to the timed
region but the call, run ``loops`` times in C with the GIL released (:func:`time_batch`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..common import UserError, UserTypeError
from . import _core
from .intersection import Prepared, check_workload, prepare
from .registry import MODES, Mode, core_of


@dataclass(frozen=True)
class Job:
    """Validated inputs of timed batches, one kernel on one workload (:func:`make_job`)."""

    kernel: str
    mode: Mode
    origins: np.ndarray
    directions: np.ndarray
    t_max: np.ndarray
    prepared: Prepared
    isa: str

    @property
    def tests_per_pass(self) -> int:
        """Tests in one pass over the workload; for ``any`` the most there can be (a batch counts those it did)."""
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
    """Validate a workload for timing (finite inputs; ``mode``, ``t_max`` and ``isa`` as in ``intersect``) and
    prepare ``kernel``'s records; the arrays are kept as read-only views, not copied."""
    o, d, tris, tm, isa = check_workload(kernel, origins, directions, triangles, mode, t_max, isa, False)
    o, d, tm = (a.view() for a in (o, d, tm))
    for a in (o, d, tm):
        a.flags.writeable = False
    return Job(kernel, mode, o, d, tm, prepare(kernel, tris), isa)


@dataclass(frozen=True)
class Batch:
    """One timed batch: ``loops`` passes of a job, timed inside C; ``hits`` and ``t_sum`` (and ``uv_sum``, of
    ``u + v`` in mode ``closest_uv``) are summed over the passes, to compare with ``loops`` times the reference's."""

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
    """Run ``job`` ``loops`` times in C with the GIL released, timed by ``CLOCK_MONOTONIC`` read around the loop;
    ``loops * job.tests_per_pass`` is at most :data:`MAX_BATCH_TESTS`. The loop looks for signals about every
    0.1 s, so Ctrl-C stops a long batch with ``KeyboardInterrupt``."""
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
    elapsed, hits, tests, t_sum, uv_sum = core_of(job.kernel).time(
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
