"""Statistics for tribench: pure functions from timed batches to estimates.

Nothing here reads or writes files, prints, or touches global random state:
every function maps its arguments to a value, and results are frozen
dataclasses that carry the confidence level they were computed at.

Conventions
-----------
* **The replicate is the worker process.** Batches inside one process share its
  memory layout, so they are not independent; each process is reduced to one
  number (the median ns/test of its non-warm-up batches) and intervals are taken
  across processes, with ``R - 1`` degrees of freedom.
* **Speedup of kernel K over baseline B** is ``time_B / time_K``: above 1 means
  K is faster. It is estimated on the log scale, ``d_p = log B_p - log K_p``,
  so swapping the two kernels gives exactly the inverse ratio and interval.
* **Warm-up batches** stay in the data, labelled by the ``warmup`` column, and
  are left out of every estimate. **Outliers** are labelled (Tukey fences),
  never dropped: the per-process median is what makes the estimates robust.
* Defaults live in one place, :data:`DEFAULTS`.

The batch table has one row per timed batch with (at least) the columns
``process, round, position, kernel, workload_id, warmup, loops, tests,
elapsed_ns, start_ns``.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import asdict, dataclass
from typing import Sequence

import numpy as np
import numpy.typing as npt
import pandas as pd
from scipy import stats as sps

from tribench.common import UserError

__all__ = [
    "DEFAULTS",
    "MAX_MARGIN",
    "Defaults",
    "AASummary",
    "Crossover",
    "Design",
    "Drift",
    "Estimate",
    "GeometricMean",
    "LogRatio",
    "Slope",
    "Speedup",
    "VarianceComponents",
    "unpaired_ratio",
    "aa_noise_floor",
    "aa_summary",
    "check_margin",
    "crossover",
    "drift",
    "estimate",
    "estimate_table",
    "geometric_mean",
    "holm",
    "label_outliers",
    "per_process",
    "rounds_matrix",
    "scaling_slope",
    "simultaneous_confidence",
    "speedup",
    "speedup_table",
    "suggest_design",
    "tukey_outliers",
    "variance_components",
    "verdict",
]


#: The largest equivalence margin tribench accepts. A margin is relative: at
#: 0.5 two kernels within 1.5x of each other would be "equivalent", which is
#: not a noise floor but a machine too noisy to compare on (an A/A noise floor
#: is 1-3 % on this project's machine, and stats.DEFAULTS.margin is 1 %).
MAX_MARGIN = 0.5


def check_margin(value: object, where: str) -> float:
    """``value`` as a margin: a finite number in ``[0, MAX_MARGIN]``; else a
    UserError naming ``where`` (a file and key, or a flag).

    >>> check_margin(0.02, "--margin")
    0.02
    >>> check_margin(float("nan"), "--margin")
    Traceback (most recent call last):
    ...
    tribench.common.errors.UserError: --margin: an equivalence margin must be a number between 0 and 0.5 (relative: 0.01 = 1 %), got nan
    """
    ok = isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)
    if not ok or not 0 <= value <= MAX_MARGIN:
        raise UserError(f"{where}: an equivalence margin must be a number between 0 and {MAX_MARGIN:g} "
                        f"(relative: 0.01 = 1 %), got {value!r:.40}")
    return float(value)


@dataclass(frozen=True)
class Defaults:
    """Every tunable default of this module, in one place."""

    #: Two-sided confidence level of every interval.
    confidence: float = 0.95
    #: Relative equivalence margin of :func:`verdict` (0.01 = 1 %). Used only
    #: when no A/A calibration exists; otherwise pass ``AASummary.margin``.
    #: 1 % matches Criterion.rs's noise threshold; too small a margin only
    #: makes "equivalent" rarer (it turns into "inconclusive"), never wrong.
    margin: float = 0.01
    #: Resamples of the BCa bootstrap (scipy's default).
    n_resamples: int = 9999
    #: Seed of the bootstrap, so that a re-analysis gives the same numbers.
    seed: int = 20130616
    #: Drift worth a warning: change of the log speedup across one process
    #: (0.01 is about 1 %), see :func:`drift`.
    drift_threshold: float = 0.01
    #: Tukey fences: outlier beyond ``k`` IQR, far out beyond ``far_k`` IQR.
    tukey_k: float = 1.5
    tukey_far_k: float = 3.0
    #: Cap of :func:`suggest_design` when rounds cost nothing in variance terms.
    max_rounds: int = 1000


DEFAULTS = Defaults()

_GROUP = ["kernel", "workload_id", "process"]
_BATCH_COLUMNS = ("process", "kernel", "workload_id", "warmup", "tests", "elapsed_ns")


# --------------------------------------------------------------------------
# Input checks and shared cores
# --------------------------------------------------------------------------


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


def _t_quantile(confidence: float, df: int) -> float:
    return float(sps.t.ppf(0.5 + confidence / 2, df))


def _t_interval(x: np.ndarray, confidence: float) -> tuple[float, float, float, float]:
    """Mean, t-interval and two-sided one-sample p-value (against 0) of ``x``.

    Fewer than two values give a nan interval and p-value; zero spread gives
    a zero-width interval (what the formula says), not an error.
    """
    mean = float(np.mean(x))
    n = x.size
    if n < 2:
        return mean, math.nan, math.nan, math.nan
    se = float(np.std(x, ddof=1)) / math.sqrt(n)
    half = _t_quantile(confidence, n - 1) * se
    with np.errstate(divide="ignore", invalid="ignore"):
        t_stat = np.float64(mean) / np.float64(se)
    p = float(2 * sps.t.sf(abs(t_stat), n - 1))
    return mean, mean - half, mean + half, p


def _bca_interval(x: np.ndarray, confidence: float, n_resamples: int, seed: int) -> tuple[float, float]:
    """BCa bootstrap interval of the mean; nan when the data cannot support one."""
    # BCa needs a jackknife with some spread; below 3 values or with all values
    # equal the bootstrap distribution is degenerate.
    if x.size < 3 or np.ptp(x) == 0:
        return math.nan, math.nan
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # DegenerateDataWarning is one
        result = sps.bootstrap(
            (x,),
            np.mean,
            confidence_level=confidence,
            n_resamples=n_resamples,
            method="BCa",
            # random_state (not rng) keeps scipy >= 1.10 working, as pyproject allows.
            random_state=np.random.default_rng(seed),
            vectorized=True,
        )
    interval = result.confidence_interval
    return float(interval.low), float(interval.high)


def _lines(x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Least-squares line of every row of ``y`` against ``x``.

    Returns the fitted value at ``mean(x)`` and the slope, one per row: with
    the same ``x`` for every process, their means are the pooled fit.
    """
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


# --------------------------------------------------------------------------
# Per process, per kernel
# --------------------------------------------------------------------------


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
    return (
        timed.groupby(_GROUP, sort=True)["ns_per_test"]
        .agg(ns_per_test="median", n_rounds="size")
        .reset_index()
    )


@dataclass(frozen=True)
class Estimate:
    """Mean of per-process values with its intervals.

    Attributes
    ----------
    mean : float
        Mean across processes.
    ci_low, ci_high : float
        Student-t interval of the mean (the primary interval).
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
    (3.0, 1.0368, 4.9632, 1.0, 5)
    >>> e.bootstrap_low < 3.0 < e.bootstrap_high
    True
    >>> estimate([2.0, 2.0, 2.0]).bootstrap_low  # degenerate: no interval
    nan
    """
    _check_confidence(confidence)
    x = _vector(values, "values")
    mean, low, high, _ = _t_interval(x, confidence)
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


# --------------------------------------------------------------------------
# Two independent runs (tribench compare)
# --------------------------------------------------------------------------


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
    """Ratio ``exp(mean(log_b) - mean(log_a))`` of two independent samples, with a Welch interval.

    Each sample holds one log value per process (log speedups for a ratio of
    speedups, log ns/test for a time ratio). The standard errors of the two
    means are combined, ``se = sqrt(s_a^2/n_a + s_b^2/n_b)``, with
    Welch-Satterthwaite degrees of freedom; the interval is
    ``exp(diff -/+ t_df * se)``. Swapping the samples inverts the ratio and
    its interval exactly. Fewer than two values in either sample gives a nan
    interval.

    Examples
    --------
    >>> r = unpaired_ratio(np.log([1.0, 1.1, 0.9]), np.log([2.0, 2.2, 1.8]))
    >>> round(r.ratio, 6), r.ci_low < 2.0 < r.ci_high
    (2.0, True)
    >>> back = unpaired_ratio(np.log([2.0, 2.2, 1.8]), np.log([1.0, 1.1, 0.9]))
    >>> round(back.ratio * r.ratio, 12), round(back.ci_low * r.ci_high, 12)
    (1.0, 1.0)
    """
    a = np.asarray(log_a, dtype=float)
    b = np.asarray(log_b, dtype=float)
    if a.ndim != 1 or b.ndim != 1 or a.size == 0 or b.size == 0:
        raise ValueError("both samples must be non-empty 1-D sequences")
    if not (np.all(np.isfinite(a)) and np.all(np.isfinite(b))):
        raise ValueError("log values must be finite")
    if not 0 < confidence < 1:
        raise ValueError(f"confidence must lie in (0, 1), got {confidence}")
    diff = float(b.mean() - a.mean())
    if a.size < 2 or b.size < 2:
        return LogRatio(math.exp(diff), math.nan, math.nan, math.nan, math.nan, math.nan, a.size, b.size,
                        confidence)
    va, vb = float(a.var(ddof=1)) / a.size, float(b.var(ddof=1)) / b.size
    se = math.sqrt(va + vb)
    if se == 0:
        return LogRatio(math.exp(diff), math.exp(diff), math.exp(diff), 0.0, math.inf,
                        0.0 if diff else 1.0, a.size, b.size, confidence)
    df = (va + vb) ** 2 / (va**2 / (a.size - 1) + vb**2 / (b.size - 1))
    q = float(sps.t.ppf(0.5 + confidence / 2, df))
    p = float(2 * sps.t.sf(abs(diff) / se, df))
    return LogRatio(math.exp(diff), math.exp(diff - q * se), math.exp(diff + q * se), se, df, p,
                    a.size, b.size, confidence)


# --------------------------------------------------------------------------
# Several kernels against one baseline
# --------------------------------------------------------------------------


def holm(p_values: npt.ArrayLike) -> np.ndarray:
    """Holm–Bonferroni adjusted p-values (step-down, family-wise error).

    The ``i``-th smallest of ``m`` p-values is multiplied by ``m - i + 1``,
    the running maximum keeps the order, and values are capped at 1.
    nan entries stay nan and do not count towards ``m``.

    Parameters
    ----------
    p_values : array_like
        Raw p-values, in any order.

    Returns
    -------
    ndarray
        Adjusted p-values, in the input order.

    Examples
    --------
    >>> holm([0.01, 0.04, 0.03, 0.005]).round(3).tolist()
    [0.03, 0.06, 0.06, 0.02]
    """
    p = np.asarray(p_values, dtype=float)
    if p.ndim != 1:
        raise ValueError("p_values must be 1-D")
    known = ~np.isnan(p)
    if np.any((p[known] < 0) | (p[known] > 1)):
        raise ValueError("p-values must lie in [0, 1]")
    q = p[known]
    m = q.size
    order = np.argsort(q, kind="stable")
    stepped = np.maximum.accumulate((m - np.arange(m)) * q[order])
    adjusted_sorted = np.minimum(stepped, 1.0)
    adjusted = np.empty(m)
    adjusted[order] = adjusted_sorted
    out = np.full(p.shape, np.nan)
    out[known] = adjusted
    return out


def simultaneous_confidence(confidence: float, m: int) -> float:
    """Per-comparison level giving simultaneous intervals for ``m`` comparisons.

    Bonferroni: each interval at ``1 - (1 - confidence) / m``, so all ``m``
    cover together with probability at least ``confidence``. Conservative,
    and consistent with Holm's first (strictest) step; Holm's later steps can
    reject where a Bonferroni interval still contains 1, never the reverse.

    Examples
    --------
    >>> simultaneous_confidence(0.95, 4)
    0.9875
    """
    _check_confidence(confidence)
    if m < 1:
        raise ValueError(f"m must be at least 1, got {m}")
    return 1 - (1 - confidence) / m


def verdict(ci_low: float, ci_high: float, margin: float = DEFAULTS.margin) -> str:
    """Classify a speedup interval against a relative equivalence margin.

    * ``"equivalent"``: the interval lies inside ``[1/(1+margin), 1+margin]``
      (an interval-inclusion equivalence test: with a 95 % interval this is
      TOST at the 2.5 % level, on the symmetric log scale);
    * ``"faster"``: ``ci_low > 1`` and not equivalent;
    * ``"slower"``: ``ci_high < 1`` and not equivalent;
    * ``"inconclusive"``: anything else, including a nan interval.

    A significant but tiny effect inside the margin is "equivalent", not
    "faster": the margin is what counts as a difference worth reporting.

    Examples
    --------
    >>> verdict(1.10, 1.30, margin=0.01), verdict(0.80, 0.95, margin=0.01)
    ('faster', 'slower')
    >>> verdict(0.995, 1.005, margin=0.01), verdict(0.97, 1.20, margin=0.01)
    ('equivalent', 'inconclusive')
    """
    if not margin >= 0:
        raise ValueError(f"margin must be non-negative, got {margin}")
    if math.isnan(ci_low) or math.isnan(ci_high):
        return "inconclusive"
    if 1 / (1 + margin) <= ci_low and ci_high <= 1 + margin:
        return "equivalent"
    if ci_low > 1:
        return "faster"
    if ci_high < 1:
        return "slower"
    return "inconclusive"


def estimate_table(table: pd.DataFrame, confidence: float = DEFAULTS.confidence) -> pd.DataFrame:
    """One :class:`Estimate` per kernel and workload, as a tidy table.

    Parameters
    ----------
    table : DataFrame
        Output of :func:`per_process`.
    confidence : float
        Two-sided confidence level.

    Returns
    -------
    DataFrame
        ``kernel, workload_id`` and the fields of :class:`Estimate`, named
        for any quantity; estimates.csv gives them units
        (``tribench.harness.analysis.ESTIMATE_COLUMNS``).

    Examples
    --------
    >>> import pandas as pd
    >>> table = pd.DataFrame({"kernel": ["a"] * 3, "workload_id": ["w"] * 3,
    ...                       "process": [0, 1, 2], "ns_per_test": [1.0, 2.0, 3.0]})
    >>> estimate_table(table)[["kernel", "mean", "minimum", "n"]]
      kernel  mean  minimum  n
    0      a   2.0      1.0  3
    """
    rows = [
        {"kernel": kernel, "workload_id": workload, **asdict(estimate(group["ns_per_test"], confidence))}
        for (kernel, workload), group in table.groupby(["kernel", "workload_id"], sort=True)
    ]
    return pd.DataFrame(rows)


def speedup_table(
    table: pd.DataFrame,
    baseline: str,
    confidence: float = DEFAULTS.confidence,
    margin: float = DEFAULTS.margin,
) -> pd.DataFrame:
    """Every kernel against one baseline, with multiplicity handled.

    The family is the set of kernels compared with ``baseline`` on one
    workload (``m`` = their number). Each interval is a Bonferroni
    simultaneous interval (:func:`simultaneous_confidence`), its verdict is
    taken from that interval, and ``p_holm`` holds the Holm-adjusted p-values.
    Processes are paired by their ``process`` id; a process missing either
    kernel is left out of that comparison.

    Parameters
    ----------
    table : DataFrame
        Output of :func:`per_process`.
    baseline : str
        Kernel name of the baseline.
    confidence : float
        Family-wise (simultaneous) confidence level.
    margin : float
        Relative equivalence margin for :func:`verdict`.

    Returns
    -------
    DataFrame
        ``workload_id, kernel, baseline, ratio, ci_low, ci_high, p_value,
        p_holm, n, confidence, margin, verdict``; ``confidence`` is the
        per-comparison level actually used. speedups.csv renames some of
        them (``tribench.harness.analysis.SPEEDUP_COLUMNS``).

    Examples
    --------
    >>> import pandas as pd
    >>> table = pd.DataFrame({
    ...     "kernel": ["base"] * 3 + ["fast"] * 3, "workload_id": ["w"] * 6,
    ...     "process": [0, 1, 2] * 2, "ns_per_test": [2.0, 2.2, 1.8, 1.0, 1.1, 0.9]})
    >>> row = speedup_table(table, "base").iloc[0]
    >>> row["kernel"], round(float(row["ratio"]), 6), row["verdict"]
    ('fast', 2.0, 'faster')
    """
    _check_confidence(confidence)
    columns = ["workload_id", "kernel", "baseline", "ratio", "ci_low", "ci_high", "p_value",
               "p_holm", "n", "confidence", "margin", "verdict"]
    rows = []
    for workload, group in table.groupby("workload_id", sort=True):
        wide = group.pivot(index="process", columns="kernel", values="ns_per_test")
        if baseline not in wide.columns:
            raise ValueError(f"baseline {baseline!r} has no data for workload {workload!r}")
        others = [k for k in wide.columns if k != baseline]
        if not others:
            continue
        level = simultaneous_confidence(confidence, len(others))
        results = []
        for kernel in others:
            pair = wide[[baseline, kernel]].dropna()
            results.append((kernel, speedup(pair[baseline], pair[kernel], level)))
        adjusted = holm([s.p_value for _, s in results])
        for (kernel, s), p_holm in zip(results, adjusted):
            rows.append({"workload_id": workload, "kernel": kernel, "baseline": baseline,
                         **asdict(s), "p_holm": p_holm, "margin": margin,
                         "verdict": verdict(s.ci_low, s.ci_high, margin)})
    return pd.DataFrame(rows, columns=columns)


# --------------------------------------------------------------------------
# A/A calibration
# --------------------------------------------------------------------------


def aa_noise_floor(log_ratios: npt.ArrayLike, quantile: float = 0.975) -> float:
    """Noise floor of A/A comparisons: a quantile of ``|log speedup|``.

    Parameters
    ----------
    log_ratios : array_like
        ``log(ratio)`` of many A/A comparisons (a kernel against itself).
    quantile : float
        0.975 by the protocol.

    Returns
    -------
    float
        On the log scale; ``math.expm1`` of it is a relative margin for
        :func:`verdict` (equivalence is symmetric on the log scale).

    Examples
    --------
    >>> aa_noise_floor([-0.02, 0.01, 0.0, 0.005, -0.01])
    0.019
    """
    x = _vector(log_ratios, "log_ratios")
    return float(np.quantile(np.abs(x), quantile))


@dataclass(frozen=True)
class AASummary:
    """How honest the intervals are on the real machine (A/A runs).

    Attributes
    ----------
    n : int
        Number of A/A comparisons.
    coverage : float
        Fraction of intervals containing 1 (should be near their confidence).
    false_positive_rate : float
        Fraction with ``p < 1 - confidence`` (should be near ``1 - confidence``).
    ks_statistic, ks_p_value : float
        Kolmogorov–Smirnov test of the p-values against Uniform(0, 1), which
        is their distribution when the intervals are honest.
    noise_floor : float
        :func:`aa_noise_floor` of the log ratios.
    margin : float
        ``expm1(noise_floor)``, the relative margin for :func:`verdict`.
    """

    n: int
    coverage: float
    false_positive_rate: float
    ks_statistic: float
    ks_p_value: float
    noise_floor: float
    margin: float


def aa_summary(results: Sequence[Speedup]) -> AASummary:
    """Summarise many A/A speedups (a kernel timed against a copy of itself).

    Parameters
    ----------
    results : sequence of Speedup
        One per A/A comparison; comparisons with a nan p-value are rejected.

    Returns
    -------
    AASummary

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(1)
    >>> runs = [speedup(rng.lognormal(0, 0.02, 10), rng.lognormal(0, 0.02, 10))
    ...         for _ in range(200)]
    >>> s = aa_summary(runs)
    >>> 0.9 < s.coverage <= 1.0, s.ks_p_value > 0.01, 0.0 < s.margin < 0.05
    (True, True, True)
    """
    if len(results) == 0:
        raise ValueError("no A/A results")
    p = np.array([r.p_value for r in results])
    if np.any(np.isnan(p)):
        raise ValueError("A/A results need p-values (at least two processes each)")
    covered = np.array([r.ci_low <= 1 <= r.ci_high for r in results])
    significant = np.array([r.p_value < 1 - r.confidence for r in results])
    ks = sps.kstest(p, "uniform")
    floor = aa_noise_floor([math.log(r.ratio) for r in results])
    return AASummary(len(results), float(covered.mean()), float(significant.mean()),
                     float(ks.statistic), float(ks.pvalue), floor, math.expm1(floor))


# --------------------------------------------------------------------------
# Variance components and experiment design (Kalibera & Jones 2013)
# --------------------------------------------------------------------------


def rounds_matrix(batches: pd.DataFrame, kernel: str, workload_id: str | None = None) -> np.ndarray:
    """Balanced processes x rounds matrix of ns/test for one kernel and workload.

    Warm-up batches are left out. Processes with different numbers of rounds
    are balanced by keeping every process's first ``n`` rounds (in round
    order), ``n`` the smallest count: the balanced ANOVA estimators then stay
    exact, and using the earliest rounds everywhere keeps time effects alike
    across processes.

    Parameters
    ----------
    batches : DataFrame
        The batch table; must include a ``round`` column.
    kernel : str
        Kernel to select.
    workload_id : str, optional
        Workload to select; required when ``batches`` holds several.

    Returns
    -------
    ndarray
        Shape ``(processes, rounds)``, rows in process order.

    Examples
    --------
    >>> import pandas as pd
    >>> batches = pd.DataFrame({
    ...     "process": [0, 0, 0, 1, 1], "round": [0, 1, 2, 0, 1], "kernel": ["k"] * 5,
    ...     "workload_id": ["w"] * 5, "warmup": [False] * 5, "tests": [10] * 5,
    ...     "elapsed_ns": [10, 20, 30, 40, 50]})
    >>> rounds_matrix(batches, "k")
    array([[1., 2.],
           [4., 5.]])
    """
    _require_columns(batches, ("round",))
    timed = _timed(batches)
    timed = timed.loc[timed["kernel"] == kernel]
    if workload_id is not None:
        timed = timed.loc[timed["workload_id"] == workload_id]
    if timed["workload_id"].nunique() != 1:
        raise ValueError("select exactly one workload (pass workload_id)")
    ordered = timed.sort_values(["process", "round"])
    per_process_rounds = [g.to_numpy() for _, g in ordered.groupby("process", sort=True)["ns_per_test"]]
    n = min(len(r) for r in per_process_rounds)
    return np.array([r[:n] for r in per_process_rounds])


@dataclass(frozen=True)
class VarianceComponents:
    """Two-level random-effects decomposition of one kernel's cost.

    The model is ``y[p, r] = mu + b_p + e_pr`` with independent process
    effects ``b_p`` (variance ``between_process``) and round effects
    ``e_pr`` (variance ``between_round``).

    Attributes
    ----------
    between_round : float
        ``T1^2 = S1^2``: the mean within-process sample variance.
    between_process : float
        ``T2^2 = S2^2 - S1^2 / n_rounds``, clipped at 0, where ``S2^2`` is the
        sample variance of the process means (method of moments / ANOVA).
    mean : float
        Grand mean.
    n_processes, n_rounds : int
        The balanced design used.
    """

    between_round: float
    between_process: float
    mean: float
    n_processes: int
    n_rounds: int


def variance_components(matrix: npt.ArrayLike) -> VarianceComponents:
    """Split the variance of a balanced processes x rounds matrix.

    Kalibera & Jones (2013), "Rigorous Benchmarking in Reasonable Time",
    with level 1 = rounds within a process and level 2 = processes. Their
    ``T_i^2`` are the unbiased (ANOVA) estimators of the variance added at
    level ``i``; for two levels the paper's erratum (``T_i^2 = S_i^2 -
    S_{i-1}^2 / n_{i-1}``) and the original formula coincide.

    Parameters
    ----------
    matrix : array_like
        Shape ``(processes, rounds)``, at least 2 x 2 (see :func:`rounds_matrix`).

    Returns
    -------
    VarianceComponents

    Examples
    --------
    >>> vc = variance_components([[1.0, 3.0], [5.0, 7.0]])
    >>> vc.between_round, vc.between_process, vc.mean
    (2.0, 7.0, 4.0)
    """
    y = np.asarray(matrix, dtype=float)
    if y.ndim != 2 or y.shape[0] < 2 or y.shape[1] < 2:
        raise ValueError(f"need at least 2 processes x 2 rounds, got shape {y.shape}")
    if not np.all(np.isfinite(y)):
        raise ValueError("matrix must be finite")
    n_processes, n_rounds = y.shape
    s1 = float(np.mean(np.var(y, axis=1, ddof=1)))
    s2 = float(np.var(y.mean(axis=1), ddof=1))
    # A negative moment estimate means "no detectable process effect".
    t2 = max(0.0, s2 - s1 / n_rounds)
    return VarianceComponents(s1, t2, float(y.mean()), n_processes, n_rounds)


@dataclass(frozen=True)
class Design:
    """A suggested experiment: rounds per process and number of processes.

    Attributes
    ----------
    rounds_per_process : int
    processes : int
    rel_halfwidth : float
        Predicted relative half-width of the interval of the mean.
    confidence : float
    """

    rounds_per_process: int
    processes: int
    rel_halfwidth: float
    confidence: float


def suggest_design(
    components: VarianceComponents,
    round_cost: float,
    process_cost: float,
    target_rel_halfwidth: float,
    confidence: float = DEFAULTS.confidence,
    max_rounds: int = DEFAULTS.max_rounds,
    rounds: int | None = None,
) -> Design:
    """Rounds per process and processes needed, from a pilot's components.

    Rounds per process follow Kalibera & Jones (2013):
    ``ceil(sqrt((c2 / c1) * (T1^2 / T2^2)))`` with ``c1 = round_cost`` (one
    round) and ``c2 = process_cost`` (starting a process, without its
    rounds): spend repetitions where the variance is and where they are
    cheap. With ``T2^2 = 0`` more rounds always pay; ``max_rounds`` caps them.

    Processes: the smallest ``R >= 2`` with
    ``t_{R-1} * sqrt((T2^2 + T1^2 / I) / R) / mean <= target_rel_halfwidth``,
    the variance of a mean of process means. tribench summarises a process
    by its median, which for Gaussian rounds is noisier than the mean (up to
    ``pi/2`` on ``T1^2``): treat the answer as a lower bound.

    Parameters
    ----------
    components : VarianceComponents
        From :func:`variance_components` on a pilot run.
    round_cost, process_cost : float
        ``c1`` and ``c2``, in any common unit (e.g. seconds).
    target_rel_halfwidth : float
        Wanted half-width of the interval relative to the mean (0.01 = 1 %).
    confidence : float
        Confidence level of that interval.
    max_rounds : int
        Upper bound on rounds per process.
    rounds : int, optional
        Rounds per process fixed by the caller (e.g. a sweep's default): only
        the processes are then chosen.

    Returns
    -------
    Design

    Examples
    --------
    >>> vc = VarianceComponents(between_round=4.0, between_process=1.0, mean=100.0,
    ...                         n_processes=10, n_rounds=10)
    >>> d = suggest_design(vc, round_cost=0.01, process_cost=1.0, target_rel_halfwidth=0.01)
    >>> d.rounds_per_process, d.processes
    (20, 8)
    """
    _check_confidence(confidence)
    if round_cost <= 0 or process_cost < 0 or target_rel_halfwidth <= 0:
        raise ValueError("costs must be positive (process_cost may be 0) and the target positive")
    t1, t2 = components.between_round, components.between_process
    if rounds is not None:
        if rounds < 1:
            raise ValueError(f"rounds must be at least 1, got {rounds}")
    else:
        if t1 == 0:
            rounds = 1
        elif t2 == 0:
            rounds = max_rounds
        else:
            rounds = math.ceil(math.sqrt((process_cost / round_cost) * (t1 / t2)))
        rounds = int(min(max(rounds, 1), max_rounds))

    rel_sd = math.sqrt(t2 + t1 / rounds) / abs(components.mean)

    def rel_halfwidth(n: int) -> float:
        return _t_quantile(confidence, n - 1) * rel_sd / math.sqrt(n)

    # The normal approximation never asks for too many; walk up from there.
    z = float(sps.norm.ppf(0.5 + confidence / 2))
    processes = max(2, math.ceil((z * rel_sd / target_rel_halfwidth) ** 2))
    while rel_halfwidth(processes) > target_rel_halfwidth:
        processes += 1
    return Design(rounds, processes, rel_halfwidth(processes), confidence)


# --------------------------------------------------------------------------
# Across workloads: crossover and scaling
# --------------------------------------------------------------------------


@dataclass(frozen=True)
class Crossover:
    """Hit rate at which a speedup crosses 1 (the ranking flips).

    Attributes
    ----------
    hit_rate : float
        Root of the fitted line ``log ratio = intercept + slope * hit_rate``;
        nan when the line does not cross 0 inside the measured range.
    ci_low, ci_high : float
        Fieller interval of the root; nan when the root is not in range, or
        the interval is unbounded (slope not clearly non-zero).
    intercept, slope : float
        The fitted line, mean of the per-process fits.
    n : int
        Number of processes.
    confidence : float
    """

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

    Each process gets its own least-squares line of log speedup against hit
    rate; the lines are averaged and the root is ``-intercept / slope``. The
    interval is Fieller's, with the process as replicate: the hit rates at
    which the mean fitted log speedup is not significantly different from 0,
    i.e. where the two kernels cannot be told apart. It is exact for normal
    per-process coefficients (no bootstrap noise, no delta-method symmetry)
    and is unbounded, reported as nan, when the slope itself is not
    significant. A straight line is a local model: use hit rates near the
    crossing.

    Parameters
    ----------
    hit_rates : array_like
        The ``k >= 2`` distinct hit rates of the workloads.
    per_process_log_ratios : array_like
        Shape ``(processes, k)``: ``log(speedup)`` of each process at each
        hit rate (processes paired across workloads).
    confidence : float

    Returns
    -------
    Crossover

    Examples
    --------
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
    """Log–log slope of cost against size, with its interval.

    Attributes
    ----------
    slope : float
        Mean of the per-process slopes of ``log ns/test`` on ``log size``
        (1 = cost proportional to size, 0 = flat).
    ci_low, ci_high : float
        t-interval across processes.
    intercept : float
        ``log ns/test`` at size 1 of the mean line.
    n : int
        Number of processes.
    confidence : float
    """

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
    """Log–log slope of cost versus triangle count or working-set size.

    One least-squares slope per process, then a t-interval across processes:
    pooling all points into one regression would treat the sizes measured in
    the same process as independent, which they are not.

    Parameters
    ----------
    sizes : array_like
        The ``k >= 2`` distinct positive sizes.
    ns_per_test_per_process : array_like
        Shape ``(processes, k)``, positive.
    confidence : float

    Returns
    -------
    Slope

    Examples
    --------
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


# --------------------------------------------------------------------------
# Drift and outliers
# --------------------------------------------------------------------------


@dataclass(frozen=True)
class Drift:
    """Trends against wall time inside processes, and whether to warn.

    Slopes are per second, on the log scale (0.001 is about 0.1 % per
    second), each the mean of per-process Theil–Sen slopes, tested across
    processes with a one-sample t-test.

    Attributes
    ----------
    baseline_slope, baseline_p : float
        Trend of the per-round log baseline time. On its own harmless when
        kernels are interleaved, so it does not raise the flag.
    ratio_slope, ratio_p : float
        Trend of the per-round log speedup: the kernels drift differently.
    ratio_change : float
        ``ratio_slope`` times the median process duration: how much the log
        speedup moves across one process.
    confound_bias : float
        Bias of the log speedup that time drift causes through unequal
        timing of the two kernels: per process, the common drift rate times
        the gap between the kernels' mean start times. Near 0 when rounds
        are interleaved in random order; large when one kernel runs after
        the other on a drifting machine.
    confound_p : float
        t-test of the per-process biases against 0.
    flagged : bool
        ``ratio_p < alpha`` and ``|ratio_change| > threshold``, or
        ``confound_p < alpha`` and ``|confound_bias| > threshold``, with
        ``alpha = 1 - confidence``: significant *and* large enough to matter.
    reason : str
        Which of the two raised the flag ("" when not flagged).
    n : int
        Processes used.
    confidence : float
    """

    baseline_slope: float
    baseline_p: float
    ratio_slope: float
    ratio_p: float
    ratio_change: float
    confound_bias: float
    confound_p: float
    flagged: bool
    reason: str
    n: int
    confidence: float


def _theil_sen_slopes(frame: pd.DataFrame, by: str | list[str], x: str, y: str) -> pd.Series:
    """Theil–Sen slope of ``y`` on ``x`` in every group (robust to spikes)."""
    return pd.Series({
        key: float(sps.theilslopes(group[y].to_numpy(), group[x].to_numpy())[0])
        for key, group in frame.groupby(by, sort=True)
    })


def drift(
    batches: pd.DataFrame,
    kernel: str,
    baseline: str,
    workload_id: str | None = None,
    confidence: float = DEFAULTS.confidence,
    threshold: float = DEFAULTS.drift_threshold,
) -> Drift:
    """Trend tests against wall time, and a time/order confound check.

    Rounds pair the two kernels (same process and round). Three checks, each
    per process (the replicate) and then tested across processes:

    1. per-round log baseline time against its start time (reported);
    2. per-round log speedup against the pair's mean start time (flags when
       the kernels drift differently);
    3. confound: common drift rate (Theil–Sen of each kernel's log time on
       start time, averaged over the two kernels) times the gap between the
       mean start times of baseline and kernel batches. Flags designs where
       one kernel runs later than the other on a drifting machine, a bias
       that no per-round ratio trend shows.

    Parameters
    ----------
    batches : DataFrame
        The batch table (needs ``round`` and ``start_ns``).
    kernel, baseline : str
        The two kernels compared.
    workload_id : str, optional
        Required when ``batches`` holds several workloads.
    confidence : float
        Significance level is ``1 - confidence``.
    threshold : float
        Practical size (log scale, ~relative) of a drift worth a warning.

    Returns
    -------
    Drift

    Examples
    --------
    >>> import numpy as np, pandas as pd
    >>> rng = np.random.default_rng(0)
    >>> rows = []
    >>> for p in range(6):
    ...     for r in range(12):
    ...         for pos, k in enumerate(rng.permutation(["base", "new"])):
    ...             t = (r * 2 + pos) * 0.01  # seconds
    ...             slower = 1 + 0.5 * t * (k == "new")  # "new" drifts, "base" does not
    ...             rows.append(dict(process=p, round=r, kernel=k, workload_id="w",
    ...                              warmup=False, tests=1000, start_ns=int(t * 1e9),
    ...                              elapsed_ns=int(2000 * slower * rng.lognormal(0, 0.01))))
    >>> d = drift(pd.DataFrame(rows), kernel="new", baseline="base")
    >>> d.flagged, d.reason, d.ratio_slope < 0
    (True, 'ratio drift', True)
    """
    _check_confidence(confidence)
    _require_columns(batches, ("round", "start_ns"))
    timed = _timed(batches)
    timed = timed.loc[timed["kernel"].isin([kernel, baseline])]
    if workload_id is not None:
        timed = timed.loc[timed["workload_id"] == workload_id]
    if timed["workload_id"].nunique() != 1:
        raise ValueError("select exactly one workload (pass workload_id)")
    if set(timed["kernel"]) != {kernel, baseline}:
        raise ValueError(f"need timed batches of both {kernel!r} and {baseline!r}")
    timed = timed.assign(log_ns=np.log(timed["ns_per_test"]), t_s=timed["start_ns"] * 1e-9)

    wide = timed.pivot(index=["process", "round"], columns="kernel", values=["log_ns", "t_s"]).dropna()
    rounds = pd.DataFrame({
        "process": wide.index.get_level_values("process"),
        "log_ratio": (wide["log_ns", baseline] - wide["log_ns", kernel]).to_numpy(),
        "log_base": wide["log_ns", baseline].to_numpy(),
        "t_base": wide["t_s", baseline].to_numpy(),
        "t_pair": ((wide["t_s", baseline] + wide["t_s", kernel]) / 2).to_numpy(),
    })
    # Theil–Sen needs a few rounds; a process with fewer cannot show a trend.
    counts = rounds.groupby("process")["log_ratio"].transform("size")
    rounds = rounds.loc[counts >= 3]
    used = np.unique(rounds["process"])
    if used.size < 2:
        raise ValueError("drift needs at least 2 processes with 3 or more paired rounds")
    timed = timed.loc[timed["process"].isin(used)]

    base_slopes = _theil_sen_slopes(rounds, "process", "t_base", "log_base").to_numpy()
    ratio_slopes = _theil_sen_slopes(rounds, "process", "t_pair", "log_ratio").to_numpy()
    base_slope, _, _, base_p = _t_interval(base_slopes, confidence)
    ratio_slope, _, _, ratio_p = _t_interval(ratio_slopes, confidence)
    duration = float(timed.groupby("process")["t_s"].agg(lambda t: t.max() - t.min()).median())
    ratio_change = ratio_slope * duration

    # Common drift rate per process, and how far apart in time the kernels ran.
    rate = _theil_sen_slopes(timed, ["process", "kernel"], "t_s", "log_ns").groupby(level=0).mean()
    mean_time = timed.groupby(["process", "kernel"])["t_s"].mean().unstack("kernel")
    gap = mean_time[baseline] - mean_time[kernel]
    bias, _, _, bias_p = _t_interval((rate * gap).to_numpy(), confidence)

    alpha = 1 - confidence
    reasons = []
    if ratio_p < alpha and abs(ratio_change) > threshold:
        reasons.append("ratio drift")
    if bias_p < alpha and abs(bias) > threshold:
        reasons.append("time confound")
    return Drift(base_slope, base_p, ratio_slope, ratio_p, ratio_change, bias, bias_p,
                 bool(reasons), ", ".join(reasons), int(used.size), confidence)


def tukey_outliers(values: npt.ArrayLike, k: float = DEFAULTS.tukey_k) -> np.ndarray:
    """Mask of values outside Tukey's fences ``[Q1 - k IQR, Q3 + k IQR]``.

    Labels only: nothing is dropped. ``k = 1.5`` marks outliers and
    ``k = DEFAULTS.tukey_far_k`` (3) far-out values. Quartiles are numpy's
    default (linear interpolation), which differs slightly from Tukey's
    hinges on small samples.

    Examples
    --------
    >>> x = [1, 2, 3, 4, 5, 6, 7, 8, 9, 17, 40]
    >>> tukey_outliers(x).nonzero()[0].tolist(), tukey_outliers(x, k=3.0).nonzero()[0].tolist()
    ([9, 10], [10])
    """
    x = _vector(values, "values")
    q1, q3 = np.quantile(x, [0.25, 0.75])
    spread = k * (q3 - q1)
    return (x < q1 - spread) | (x > q3 + spread)


def label_outliers(batches: pd.DataFrame) -> pd.DataFrame:
    """Copy of ``batches`` with ``ns_per_test``, ``outlier`` and ``far_out`` columns.

    Fences are computed per kernel, workload and process over non-warm-up
    batches (warm-up batches are never labelled outliers).

    Examples
    --------
    >>> import pandas as pd
    >>> batches = pd.DataFrame({
    ...     "process": [0] * 6, "kernel": ["k"] * 6, "workload_id": ["w"] * 6,
    ...     "warmup": [True] + [False] * 5, "tests": [1] * 6,
    ...     "elapsed_ns": [99, 10, 11, 10, 12, 30]})
    >>> label_outliers(batches)[["elapsed_ns", "outlier", "far_out"]].to_numpy().tolist()
    [[99, False, False], [10, False, False], [11, False, False], [10, False, False], [12, False, False], [30, True, True]]
    """
    timed = _timed(batches)
    groups = timed.groupby(_GROUP, sort=False)["ns_per_test"]
    outlier = groups.transform(lambda s: tukey_outliers(s.to_numpy()))
    far_out = groups.transform(lambda s: tukey_outliers(s.to_numpy(), DEFAULTS.tukey_far_k))
    return batches.assign(
        ns_per_test=batches["elapsed_ns"] / batches["tests"],
        outlier=outlier.reindex(batches.index, fill_value=False).astype(bool),
        far_out=far_out.reindex(batches.index, fill_value=False).astype(bool),
    )
