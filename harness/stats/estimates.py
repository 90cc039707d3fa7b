"""Per process, per kernel: the per-process reduction, estimates and speedups with intervals."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
import pandas as pd

from ._core import _GROUP, _bca_interval, _check_confidence, _exp, _log_interval, _t_interval, _timed, _vector
from .defaults import DEFAULTS


def per_process(batches: pd.DataFrame) -> pd.DataFrame:
    """One row per kernel, workload and process: the median ns/test of its non-warm-up batches and their count.

    >>> import pandas as pd
    >>> batches = pd.DataFrame({
    ...     "process": [0, 0, 0, 0], "kernel": ["mt"] * 4, "workload_id": ["w"] * 4,
    ...     "warmup": [True, False, False, False], "tests": [100] * 4,
    ...     "elapsed_ns": [900, 200, 300, 250]})
    >>> per_process(batches)
      kernel workload_id  process  ns_per_test  n_rounds
    0     mt           w        0          2.5         3
    """
    timed = _timed(batches)
    return timed.groupby(_GROUP, sort=True)["ns_per_test"].agg(ns_per_test="median", n_rounds="size").reset_index()


@dataclass(frozen=True)
class Estimate:
    """Mean of per-process values with its intervals.

    ``ci_low, ci_high``: Student-t on the log scale, always positive as a time is (the primary interval);
    ``bootstrap_low, bootstrap_high``: BCa over processes, a cross-check, nan under 3 values or all equal;
    ``minimum``: a robust secondary figure, since noise only ever adds time (Chen & Revels 2016)."""

    mean: float
    ci_low: float
    ci_high: float
    bootstrap_low: float
    bootstrap_high: float
    minimum: float
    sd: float
    n: int
    confidence: float


def estimate(
    values: npt.ArrayLike,
    confidence: float = DEFAULTS.confidence,
    n_resamples: int = DEFAULTS.n_resamples,
    rng_seed: int = DEFAULTS.rng_seed,
) -> Estimate:
    """A kernel's cost from one value per process; the bootstrap is seeded, so a re-analysis repeats it.

    >>> e = estimate([1.0, 2.0, 3.0, 4.0, 5.0])
    >>> e.mean, round(e.ci_low, 4), round(e.ci_high, 4), e.minimum, e.n
    (3.0, 1.5592, 5.772, 1.0, 5)
    >>> e.bootstrap_low < 3.0 < e.bootstrap_high
    True
    >>> estimate([2.0, 2.0, 2.0]).bootstrap_low  # degenerate: no interval
    nan
    """
    _check_confidence(confidence)
    x = _vector(values, "values")
    mean, low, high = _log_interval(x, confidence)
    boot_low, boot_high = _bca_interval(x, confidence, n_resamples, rng_seed)
    sd = float(np.std(x, ddof=1)) if x.size > 1 else math.nan
    return Estimate(mean, low, high, boot_low, boot_high, float(x.min()), sd, x.size, confidence)


@dataclass(frozen=True)
class Speedup:
    """Speedup ``time_baseline / time_kernel`` (above 1: the kernel is faster) over ``n`` paired processes.

    ``ratio = exp(mean d)``, ``d_p = log baseline_p - log kernel_p``; the interval is
    ``exp(mean d -/+ t_{n-1} sd(d) / sqrt(n))``, nan for one process;
    ``p_value`` is the two-sided t-test of ``d`` against 0."""

    ratio: float
    ci_low: float
    ci_high: float
    p_value: float
    n: int
    confidence: float


def speedup(
    baseline_values: npt.ArrayLike,
    kernel_values: npt.ArrayLike,
    confidence: float = DEFAULTS.confidence,
) -> Speedup:
    """Speedup from paired per-process values: element ``p`` of both from one process, which removes its effect.

    >>> s = speedup([2.0, 2.2, 1.8], [1.0, 1.1, 0.9])
    >>> round(s.ratio, 6), round(s.ci_low, 6), round(s.ci_high, 6)
    (2.0, 2.0, 2.0)
    >>> back = speedup([1.0, 1.1, 0.9], [2.0, 2.2, 1.8])  # the inverse
    >>> round(back.ratio, 6)
    0.5
    """
    _check_confidence(confidence)
    base = _vector(baseline_values, "baseline_values", positive=True)
    kern = _vector(kernel_values, "kernel_values", positive=True)
    if base.size != kern.size:
        raise ValueError(f"paired values differ in length: {base.size} != {kern.size}")
    d = np.log(base) - np.log(kern)
    mean, low, high, p = _t_interval(d, confidence)
    return Speedup(_exp(mean), _exp(low), _exp(high), p, d.size, confidence)


@dataclass(frozen=True)
class GeometricMean:
    """Geometric mean of positive values with the t interval of their mean log."""

    mean: float
    ci_low: float
    ci_high: float
    n: int
    confidence: float


def geometric_mean(values: npt.ArrayLike, confidence: float = DEFAULTS.confidence) -> GeometricMean:
    """Geometric mean of rates or ratios (one per replicate) with its interval: multiplicative values, so the
    Student-t interval is taken on their logs and mapped back (nan for one value).

    >>> g = geometric_mean([1.0, 4.0])
    >>> round(g.mean, 6), g.ci_low < 2.0 < g.ci_high
    (2.0, True)
    """
    _check_confidence(confidence)
    logs = np.log(_vector(values, "values", positive=True))
    mean, low, high, _ = _t_interval(logs, confidence)
    return GeometricMean(_exp(mean), _exp(low), _exp(high), logs.size, confidence)
