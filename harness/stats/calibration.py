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
    """Noise floor of A/A comparisons (a kernel against itself): the ``quantile`` of ``|log speedup|``.
    ``math.expm1`` of it is a relative margin for :func:`verdict` (equivalence is symmetric on the log scale).

    >>> aa_noise_floor([-0.02, 0.01, 0.0, 0.005, -0.01])
    0.019
    """
    x = _vector(log_ratios, "log_ratios")
    return float(np.quantile(np.abs(x), quantile))


@dataclass(frozen=True)
class AASummary:
    """How honest the intervals are on the real machine (:func:`aa_summary`).

    ``coverage`` (intervals holding 1) should be near their confidence and ``false_positive_rate``
    (``p < 1 - confidence``) near ``1 - confidence``; ``ks_*`` tests the p-values against Uniform(0, 1), their
    distribution when the intervals are honest; ``margin`` is ``expm1(noise_floor)``."""

    n: int
    coverage: float
    false_positive_rate: float
    ks_statistic: float
    ks_p_value: float
    noise_floor: float
    margin: float


def aa_summary(results: Sequence[Speedup]) -> AASummary:
    """Summarise many A/A speedups (a kernel timed against a copy of itself); a nan p-value is refused.

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
