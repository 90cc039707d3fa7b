"""Per process, per kernel: the per-process reduction, estimates and speedups with intervals."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
import pandas as pd

from ._core import _GROUP, _bca_interval, _check_confidence, _log_interval, _t_interval, _timed, _vector
from .defaults import DEFAULTS


def per_process(batches: pd.DataFrame) -> pd.DataFrame:
    """Reduce timed batches to one value per kernel, workload and process.

    Parameters
    ----------
    batches : DataFrame
        One row per batch (see the module docstring). Warm-up batches are
        ignored here, not removed from ``batches``.

    Returns
    -------
    DataFrame
        Columns ``kernel, workload_id, process, ns_per_test, n_rounds``:
        the median ns/test of the process's non-warm-up batches and how many
        there were, sorted by kernel, workload and process.

    Examples
    --------
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

    Attributes
    ----------
    mean : float
        Mean across processes.
    ci_low, ci_high : float
        Student-t interval of the mean on the log scale (the primary
        interval): always positive, as a time is.
    bootstrap_low, bootstrap_high : float
        BCa bootstrap interval over processes, a cross-check; nan when the
        data are too few (< 3) or all equal.
    minimum : float
        Smallest per-process value, a robust secondary figure (Chen & Revels
        2016): noise only ever adds time.
    sd : float
        Standard deviation across processes (nan for one process).
    n : int
        Number of processes.
    confidence : float
        Confidence level of both intervals.
    """

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
    seed: int = DEFAULTS.seed,
) -> Estimate:
    """Estimate a kernel's cost from its per-process values.

    Parameters
    ----------
    values : array_like
        One value per process (e.g. ``per_process(...)["ns_per_test"]``).
    confidence : float
        Two-sided confidence level.
    n_resamples, seed : int
        Bootstrap resamples and seed (seeded, so re-analysis is reproducible).

    Returns
    -------
    Estimate

    Examples
    --------
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
    boot_low, boot_high = _bca_interval(x, confidence, n_resamples, seed)
    sd = float(np.std(x, ddof=1)) if x.size > 1 else math.nan
    return Estimate(mean, low, high, boot_low, boot_high, float(x.min()), sd, x.size, confidence)


@dataclass(frozen=True)
class Speedup:
    """Speedup of a kernel over a baseline, ``time_baseline / time_kernel``.

    Attributes
    ----------
    ratio : float
        ``exp(mean d)`` with ``d_p = log baseline_p - log kernel_p``;
        above 1 means the kernel is faster.
    ci_low, ci_high : float
        ``exp(mean d -/+ t_{n-1} sd(d) / sqrt(n))``; nan for one process.
    p_value : float
        Two-sided one-sample t-test of ``d`` against 0.
    n : int
        Number of paired processes.
    confidence : float
        Confidence level of the interval.
    """

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
    """Speedup of a kernel over a baseline from paired per-process values.

    Parameters
    ----------
    baseline_values, kernel_values : array_like
        Per-process costs (e.g. median ns/test), element ``p`` of both from
        the same process: the pairing removes the process effect.
    confidence : float
        Two-sided confidence level.

    Returns
    -------
    Speedup

    Examples
    --------
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
    return Speedup(math.exp(mean), math.exp(low), math.exp(high), p, d.size, confidence)


@dataclass(frozen=True)
class GeometricMean:
    """Geometric mean of positive values with the t interval of their mean log."""

    mean: float
    ci_low: float
    ci_high: float
    n: int
    confidence: float


def geometric_mean(values: npt.ArrayLike, confidence: float = DEFAULTS.confidence) -> GeometricMean:
    """Geometric mean of rates or ratios, one value per replicate, with its interval.

    Rates and ratios are multiplicative, so the mean and its Student-t
    interval are taken on their logarithms and mapped back; the interval is
    nan for one value.

    Examples
    --------
    >>> g = geometric_mean([1.0, 4.0])
    >>> round(g.mean, 6), g.ci_low < 2.0 < g.ci_high
    (2.0, True)
    """
    _check_confidence(confidence)
    logs = np.log(_vector(values, "values", positive=True))
    mean, low, high, _ = _t_interval(logs, confidence)
    return GeometricMean(math.exp(mean), math.exp(low), math.exp(high), logs.size, confidence)
