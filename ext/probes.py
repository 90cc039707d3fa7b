"""The core's own limits, measured: the FMA peak (:func:`fma_peak`) and the
throughput of each operation class the kernels use (:func:`op_throughput`).

The probes are C loops (``ext/fma_peak.h``, ``ext/probes.h``) timed with the
GIL released; the harness states estimates as fractions of the peak of the
moment, and the port model reads the per-class rates.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..common import UserError, UserTypeError
from . import _core


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


#: The most iterations of :func:`fma_peak`: about 4 s of work on a current core.
MAX_PEAK_ITERATIONS: int = _core.MAX_PEAK_ITERATIONS


#: Operation classes of the throughput probes (``ext/probes.h``).
OP_CLASSES: tuple[str, ...] = _core.op_classes()


@dataclass(frozen=True)
class OpThroughput:
    """Lane-operations per ns of each operation class on one ISA's widest vector.

    Attributes
    ----------
    isa : str
        ``"avx512"``, ``"avx2"`` (with FMA) or ``"baseline"`` (SSE2 on x86-64).
    float32, float64 : dict[str, float]
        Per class of :data:`OP_CLASSES` (``fma, mul, add, cmp, logic, div, load,
        fma_add, fma_mul``), the best rate of the probe's repeats.
    """

    isa: str
    float32: dict[str, float]
    float64: dict[str, float]

    def rates(self, dtype) -> dict[str, float]:
        """The rates of one precision."""
        return self.float32 if np.dtype(dtype).itemsize == 4 else self.float64


def probe_isas() -> tuple[str, ...]:
    """ISAs the throughput probes can run on this CPU, widest first."""
    return tuple(name for name, runnable in _core.probe_isas() if runnable)


def op_throughput(isa: str | None = None, *, target_ns: float = 2e6, repeats: int = 3) -> OpThroughput:
    """Probe every operation class on ``isa`` (default: the widest runnable) in both precisions.

    Each probe runs 12 independent chains of one class (ext/probes.h) for about
    ``target_ns`` (scaled from a short first run), timed in C with the GIL
    released; the best of ``repeats`` is kept. About 0.1 s in all.
    """
    runnable = probe_isas()
    isa = runnable[0] if isa is None else isa
    if isa not in runnable:
        raise UserError(f"isa must be one of this CPU's probe ISAs {', '.join(runnable)}; got {isa!r}")
    out: dict[int, dict[str, float]] = {4: {}, 8: {}}
    for itemsize, rates in out.items():
        for op in OP_CLASSES:
            _ops, ns, _ = _core.op_probe(isa, itemsize, op, 1000)
            steps = int(min(MAX_PEAK_ITERATIONS, max(1000, 1000 * target_ns / max(ns, 1))))
            best = 0.0
            for _ in range(repeats):
                lane_ops, ns, _ = _core.op_probe(isa, itemsize, op, steps)
                best = max(best, lane_ops / ns if ns > 0 else 0.0)
            rates[op] = best
    return OpThroughput(isa, out[4], out[8])


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
        raise UserTypeError(f"iterations must be an int, got {type(iterations).__name__}")
    if not 1 <= iterations <= MAX_PEAK_ITERATIONS:
        raise UserError(
            f"iterations must be between 1 and {MAX_PEAK_ITERATIONS} (2**28, about a second of work), got {iterations}"
        )
    flops, elapsed, isa, _sink = _core.fma_peak(int(iterations), bool(force_scalar))
    return Peak(flops, elapsed, isa)
