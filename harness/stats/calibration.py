"""A/A calibration: the noise floor of identical kernels and the margin it gives."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from ._core import _scipy_stats, _vector
from .estimates import Speedup


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
    >>> from tribench.harness.stats import speedup
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
    ks = _scipy_stats().kstest(p, "uniform")
    floor = aa_noise_floor([math.log(r.ratio) for r in results])
    return AASummary(
        len(results),
        float(covered.mean()),
        float(significant.mean()),
        float(ks.statistic),
        float(ks.pvalue),
        floor,
        math.expm1(floor),
    )
