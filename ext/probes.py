"""The core's own limits, measured by C loops (``ext/fma_peak.h``, ``ext/probes.h``) with the GIL released:
the FMA peak, which estimates are stated as fractions of, and each operation class's throughput, which the
port model reads."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..common import UserError, UserTypeError
from . import _core


@dataclass(frozen=True)
class Peak:
    """One run of the FMA peak probe: ``flops`` (an FMA counts two) on ``isa``, ``"avx2+fma"``, ``"neon+fma"``
    (aarch64) or ``"scalar"`` (the portable fallback: a separate multiply and add on one lane)."""

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
    """Lane-operations per ns of each class of :data:`OP_CLASSES` on one ISA's widest vector (``"avx512"``,
    ``"avx2"`` with FMA, ``"neon"`` (aarch64), or ``"baseline"``), per precision: the best of the probe's repeats."""

    isa: str
    float32: dict[str, float]
    float64: dict[str, float]

    def rates(self, dtype) -> dict[str, float]:
        return self.float32 if np.dtype(dtype).itemsize == 4 else self.float64


def probe_isas() -> tuple[str, ...]:
    """ISAs the throughput probes can run on this CPU, widest first."""
    return tuple(name for name, runnable in _core.probe_isas() if runnable)


def op_throughput(isa: str | None = None, *, target_ns: float = 2e6, repeats: int = 3) -> OpThroughput:
    """Probe every operation class on ``isa`` (default: the widest runnable) in both precisions: 12 independent
    chains of one class for about ``target_ns`` each, the best of ``repeats`` kept; about 0.1 s in all."""
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
    """This core's arithmetic peak: 12 independent 8-lane FMA chains (192 flops an iteration), AVX2+FMA where the
    CPU has both, else a scalar loop; 200 000 iterations take 1-2 ms on a current x86 core.

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
