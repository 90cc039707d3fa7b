"""Across workloads: where two kernels cross over, and how time scales with size."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from ._core import _check_confidence, _lines, _matrix, _t_interval, _t_quantile, _vector
from .defaults import DEFAULTS


@dataclass(frozen=True)
class Crossover:
    """Hit rate at which a speedup crosses 1 (the ranking flips), from :func:`crossover`.

    ``hit_rate`` is the root of the mean fitted line ``log ratio = intercept + slope * hit_rate``; it and its
    Fieller interval are nan when the root is outside the measured range, the interval also when it is
    unbounded (the slope not clearly non-zero)."""

    hit_rate: float
    ci_low: float
    ci_high: float
    intercept: float
    slope: float
    n: int
    confidence: float


def crossover(
    hit_rates: npt.ArrayLike,
    per_process_log_ratios: npt.ArrayLike,
    confidence: float = DEFAULTS.confidence,
) -> Crossover:
    """Where the speedup of one kernel over another crosses 1, with its interval.

    ``per_process_log_ratios`` (processes, k): each process's log speedup at ``k >= 2`` distinct ``hit_rates``.
    The per-process least-squares lines are averaged, the root is ``-intercept / slope``, and the interval is
    Fieller's over processes (exact for normal coefficients). A line is a local model: use hit rates near the root.

    >>> import math, numpy as np
    >>> h = np.array([0.0, 0.25, 0.5, 0.75, 1.0])
    >>> lines = np.array([[-1.0], [-1.2], [-0.8]]) * (h - 0.4)  # all cross at 0.4
    >>> c = crossover(h, lines)
    >>> round(c.hit_rate, 6), round(c.ci_low, 6), round(c.ci_high, 6)
    (0.4, 0.4, 0.4)
    >>> math.isnan(crossover(h, lines + 2.0).hit_rate)  # always faster: no crossing
    True
    """
    _check_confidence(confidence)
    x = _vector(hit_rates, "hit_rates")
    y = _matrix(per_process_log_ratios, "per_process_log_ratios", x.size)
    if x.size < 2 or np.ptp(x) == 0:
        raise ValueError("need at least two distinct hit rates")
    centre = float(x.mean())
    level, slopes = _lines(x, y)
    a, b = float(level.mean()), float(slopes.mean())
    n = y.shape[0]
    line = dict(intercept=a - b * centre, slope=b, n=n, confidence=confidence)
    root = centre - a / b if b != 0 else math.nan
    if not x.min() <= root <= x.max():  # also false for nan
        return Crossover(math.nan, math.nan, math.nan, **line)
    low = high = math.nan
    if n >= 2:
        # Fieller: centred hit rates u with (a + b u)^2 <= q^2 var(a + b u).
        q2 = _t_quantile(confidence, n - 1) ** 2
        cov = (np.cov(level, slopes) / n).tolist()
        qa = b * b - q2 * cov[1][1]
        qb = 2 * (a * b - q2 * cov[0][1])
        qc = a * a - q2 * cov[0][0]
        if qa > 0:  # bounded only when the slope is significant
            disc = math.sqrt(max(qb * qb - 4 * qa * qc, 0.0))
            low = centre + (-qb - disc) / (2 * qa)
            high = centre + (-qb + disc) / (2 * qa)
    return Crossover(root, low, high, **line)


@dataclass(frozen=True)
class Slope:
    """Log–log slope of cost against size (1: proportional to size, 0: flat), the mean of per-process slopes with
    a t-interval across processes; ``intercept`` is ``log ns/test`` at size 1 of the mean line."""

    slope: float
    ci_low: float
    ci_high: float
    intercept: float
    n: int
    confidence: float


def scaling_slope(
    sizes: npt.ArrayLike,
    ns_per_test_per_process: npt.ArrayLike,
    confidence: float = DEFAULTS.confidence,
) -> Slope:
    """Log–log slope of cost against triangle count or working-set size: ``ns_per_test_per_process`` is
    (processes, k), at the ``k >= 2`` distinct positive ``sizes``.

    One slope per process, then a t-interval across processes (the sizes of one process are not independent).

    >>> import numpy as np
    >>> sizes = np.array([1e3, 1e4, 1e5, 1e6])
    >>> cost = np.array([[2.0], [2.5], [3.0]]) * sizes ** 0.25
    >>> s = scaling_slope(sizes, cost)
    >>> round(s.slope, 9), round(s.ci_low, 9), round(s.ci_high, 9)
    (0.25, 0.25, 0.25)
    """
    _check_confidence(confidence)
    x = np.log(_vector(sizes, "sizes", positive=True))
    y = np.log(_matrix(ns_per_test_per_process, "ns_per_test_per_process", x.size, positive=True))
    if x.size < 2 or np.ptp(x) == 0:
        raise ValueError("need at least two distinct sizes")
    level, slopes = _lines(x, y)
    mean, low, high, _ = _t_interval(slopes, confidence)
    return Slope(mean, low, high, float(level.mean()) - mean * float(x.mean()), y.shape[0], confidence)
