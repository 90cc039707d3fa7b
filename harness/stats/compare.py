"""Two independent runs (``tribench compare``): the ratio of their speedups."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy.typing as npt

from ._core import _check_confidence, _exp, _scipy_stats, _t_quantile, _vector


@dataclass(frozen=True)
class LogRatio:
    """``exp(mean(b) - mean(a))`` of two independent samples, with a Welch interval."""

    ratio: float
    ci_low: float
    ci_high: float
    se: float
    df: float
    p_value: float
    n_a: int
    n_b: int
    confidence: float


def unpaired_ratio(log_a: npt.ArrayLike, log_b: npt.ArrayLike, confidence: float = 0.95) -> LogRatio:
    """Ratio ``exp(mean(log_b) - mean(log_a))`` of two independent samples (one log value per process: log speedups,
    or log ns/test), with a Welch interval ``exp(diff -/+ t_df se)``, ``se = sqrt(s_a^2/n_a + s_b^2/n_b)``. Swapping
    the samples inverts ratio and interval exactly; under two values in either sample the interval is nan.

    >>> import numpy as np
    >>> r = unpaired_ratio(np.log([1.0, 1.1, 0.9]), np.log([2.0, 2.2, 1.8]))
    >>> round(r.ratio, 6), r.ci_low < 2.0 < r.ci_high
    (2.0, True)
    >>> back = unpaired_ratio(np.log([2.0, 2.2, 1.8]), np.log([1.0, 1.1, 0.9]))
    >>> round(back.ratio * r.ratio, 12), round(back.ci_low * r.ci_high, 12)
    (1.0, 1.0)
    """
    a, b = _vector(log_a, "log_a"), _vector(log_b, "log_b")
    _check_confidence(confidence)
    diff = float(b.mean() - a.mean())
    ratio = _exp(diff)
    if a.size < 2 or b.size < 2:
        return LogRatio(ratio, math.nan, math.nan, math.nan, math.nan, math.nan, a.size, b.size, confidence)
    va, vb = float(a.var(ddof=1)) / a.size, float(b.var(ddof=1)) / b.size
    se = math.sqrt(va + vb)
    if se == 0:
        return LogRatio(ratio, ratio, ratio, 0.0, math.inf, 0.0 if diff else 1.0, a.size, b.size, confidence)
    df = (va + vb) ** 2 / (va**2 / (a.size - 1) + vb**2 / (b.size - 1))
    q = _t_quantile(confidence, df)
    p = float(2 * _scipy_stats().t.sf(abs(diff) / se, df))
    return LogRatio(ratio, _exp(diff - q * se), _exp(diff + q * se), se, df, p, a.size, b.size, confidence)
