"""Input checks and the cores the statistics share (private)."""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence
from types import ModuleType

import numpy as np
import numpy.typing as npt
import pandas as pd


def _scipy_stats() -> ModuleType:
    """scipy.stats, imported at first use: most of a second that every command would pay before its arguments."""
    import scipy.stats

    return scipy.stats


_GROUP = ["kernel", "workload_id", "process"]
_BATCH_COLUMNS = ("process", "kernel", "workload_id", "warmup", "tests", "elapsed_ns")


def _finite(x: np.ndarray, name: str, positive: bool) -> np.ndarray:
    if not np.all(np.isfinite(x)):
        raise ValueError(f"{name} must be finite")
    if positive and np.any(x <= 0):
        raise ValueError(f"{name} must be positive")
    return x


def _vector(values: npt.ArrayLike, name: str, positive: bool = False) -> np.ndarray:
    x = np.asarray(values, dtype=float)
    if x.ndim != 1 or x.size == 0:
        raise ValueError(f"{name} must be a non-empty 1-D sequence, got shape {x.shape}")
    return _finite(x, name, positive)


def _matrix(values: npt.ArrayLike, name: str, columns: int, positive: bool = False) -> np.ndarray:
    y = np.asarray(values, dtype=float)
    if y.ndim != 2 or y.shape[0] == 0 or y.shape[1] != columns:
        raise ValueError(f"{name} must have shape (processes, {columns}), got {y.shape}")
    return _finite(y, name, positive)


def _check_confidence(confidence: float) -> None:
    if not 0 < confidence < 1:
        raise ValueError(f"confidence must lie in (0, 1), got {confidence}")


def _t_quantile(confidence: float, df: float) -> float:
    return float(_scipy_stats().t.ppf(0.5 + confidence / 2, df))


def _exp(x: float) -> float:
    """``math.exp``, saturating at infinity: a t quantile of one degree of freedom at a simultaneous level (two
    processes, thirty kernels) is in the thousands, so an interval on the log scale can end past e^709."""
    try:
        return math.exp(x)
    except OverflowError:
        return math.inf


def _t_interval(x: np.ndarray, confidence: float) -> tuple[float, float, float, float]:
    """Mean, t-interval and two-sided p-value (against 0) of ``x``: nan under two values; zero spread gives a
    zero-width interval (what the formula says), not an error."""
    mean = float(np.mean(x))
    n = x.size
    if n < 2:
        return mean, math.nan, math.nan, math.nan
    se = float(np.std(x, ddof=1)) / math.sqrt(n)
    half = _t_quantile(confidence, n - 1) * se
    with np.errstate(divide="ignore", invalid="ignore"):
        t_stat = np.float64(mean) / np.float64(se)
    p = float(2 * _scipy_stats().t.sf(abs(t_stat), n - 1))
    return mean, mean - half, mean + half, p


def _log_interval(x: np.ndarray, confidence: float) -> tuple[float, float, float]:
    """Mean of positive ``x`` and its t-interval on the log scale, ``mean * exp(-/+ t * cv / sqrt(n))``.

    A time is positive, so its interval is taken where a speedup's is (delta method: the standard error of
    ``log mean`` is ``sd / (mean sqrt n)``): it never reaches 0, equals the plain t-interval to first order
    where the spread is small, and widens upward where it is large."""
    mean = float(np.mean(x))
    n = x.size
    if n < 2:
        return mean, math.nan, math.nan
    if not mean > 0:
        raise ValueError(f"times must be positive for a log-scale interval, got a mean of {mean}")
    half = _t_quantile(confidence, n - 1) * float(np.std(x, ddof=1)) / (mean * math.sqrt(n))
    return mean, mean * _exp(-half), mean * _exp(half)


def _bca_interval(x: np.ndarray, confidence: float, n_resamples: int, rng_seed: int) -> tuple[float, float]:
    """BCa bootstrap interval of the mean; nan when the data cannot support one."""
    # BCa needs a jackknife with some spread; below 3 values or with all values
    # equal the bootstrap distribution is degenerate.
    if x.size < 3 or np.ptp(x) == 0:
        return math.nan, math.nan
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # DegenerateDataWarning is one
        result = _scipy_stats().bootstrap(
            (x,),
            np.mean,
            confidence_level=confidence,
            n_resamples=n_resamples,
            method="BCa",
            # random_state (not rng) keeps scipy >= 1.10 working, as pyproject allows.
            random_state=np.random.default_rng(rng_seed),
            vectorized=True,
        )
    interval = result.confidence_interval
    return float(interval.low), float(interval.high)


def _lines(x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Least-squares line of every row of ``y`` against ``x``: its value at ``mean(x)`` and its slope (with one
    ``x`` for every process, their means are the pooled fit)."""
    centred = x - x.mean()
    slope = y @ centred / (centred @ centred)
    return y.mean(axis=1), slope


def _require_columns(frame: pd.DataFrame, columns: Sequence[str]) -> None:
    missing = [c for c in columns if c not in frame.columns]
    if missing:
        raise ValueError(f"missing columns: {missing}")


def _timed(batches: pd.DataFrame) -> pd.DataFrame:
    """Non-warm-up batches with their ns/test."""
    _require_columns(batches, _BATCH_COLUMNS)
    if batches["warmup"].dtype != bool:
        # A string "False" would be truthy: refuse rather than guess.
        raise TypeError(f"column 'warmup' must be bool, got {batches['warmup'].dtype}")
    timed = batches.loc[~batches["warmup"]]
    return timed.assign(ns_per_test=timed["elapsed_ns"] / timed["tests"])
