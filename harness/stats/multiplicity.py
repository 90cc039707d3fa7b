"""Several kernels against one baseline: Holm's correction, simultaneous intervals, verdicts and the tables."""

from __future__ import annotations

import math
from dataclasses import asdict

import numpy as np
import numpy.typing as npt
import pandas as pd

from ._core import _check_confidence
from .defaults import DEFAULTS
from .estimates import estimate, speedup


def holm(p_values: npt.ArrayLike) -> np.ndarray:
    """Holm–Bonferroni adjusted p-values (step-down, family-wise), in the input order; nan entries stay nan and do
    not count towards ``m``.

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
    out = np.full(p.shape, np.nan)
    out[np.flatnonzero(known)[order]] = np.minimum(stepped, 1.0)
    return out


def simultaneous_confidence(confidence: float, m: int) -> float:
    """Per-comparison level giving simultaneous intervals for ``m`` comparisons (Bonferroni:
    ``1 - (1 - confidence) / m``). Conservative, and consistent with Holm's strictest step: Holm can reject
    where such an interval holds 1, never the reverse.

    >>> simultaneous_confidence(0.95, 4)
    0.9875
    """
    _check_confidence(confidence)
    if m < 1:
        raise ValueError(f"m must be at least 1, got {m}")
    return 1 - (1 - confidence) / m


def verdict(ci_low: float, ci_high: float, margin: float = DEFAULTS.margin) -> str:
    """Classify a speedup interval against a relative equivalence ``margin``: ``"equivalent"`` inside
    ``[1/(1+margin), 1+margin]`` (at 95 %, TOST at 2.5 % on the log scale), significant or not, as the margin is
    what counts as a difference worth reporting; else ``"faster"`` (``ci_low > 1``), ``"slower"``
    (``ci_high < 1``) or ``"inconclusive"`` (a nan interval too).

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
    """One :class:`Estimate` per kernel and workload of a :func:`per_process` table; estimates.csv gives the
    columns units (``tribench.reports.tables.pipeline.ESTIMATE_COLUMNS``).

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


#: The columns of :func:`speedup_table`, in order.
_SPEEDUP_COLUMNS = [
    "workload_id",
    "kernel",
    "baseline",
    "ratio",
    "ci_low",
    "ci_high",
    "p_value",
    "p_holm",
    "n",
    "confidence",
    "margin",
    "verdict",
]


def _family_rows(workload: str, group: pd.DataFrame, baseline: str, confidence: float, margin: float) -> list[dict]:
    """One workload's family: every other kernel against the baseline, paired by process, Holm-adjusted."""
    wide = group.pivot(index="process", columns="kernel", values="ns_per_test")
    if baseline not in wide.columns:
        raise ValueError(f"baseline {baseline!r} has no data for workload {workload!r}")
    others = [k for k in wide.columns if k != baseline]
    if not others:
        return []
    level = simultaneous_confidence(confidence, len(others))
    results = []
    for kernel in others:
        pair = wide[[baseline, kernel]].dropna()
        results.append((kernel, speedup(pair[baseline], pair[kernel], level)))
    adjusted = holm([s.p_value for _, s in results])
    return [
        {
            "workload_id": workload,
            "kernel": kernel,
            "baseline": baseline,
            **asdict(s),
            "p_holm": p_holm,
            "margin": margin,
            "verdict": verdict(s.ci_low, s.ci_high, margin),
        }
        for (kernel, s), p_holm in zip(results, adjusted, strict=True)
    ]


def speedup_table(
    table: pd.DataFrame,
    baseline: str,
    confidence: float = DEFAULTS.confidence,
    margin: float = DEFAULTS.margin,
) -> pd.DataFrame:
    """Every kernel of a :func:`per_process` table against ``baseline``, workload by workload, with multiplicity.

    A workload's kernels against ``baseline`` are one family: Bonferroni simultaneous intervals (``confidence``:
    the per-comparison level), verdicts from them, Holm-adjusted ``p_holm``. Processes pair by id (one missing
    either kernel is left out); speedups.csv renames columns (``tribench.reports.tables.pipeline.SPEEDUP_COLUMNS``).

    >>> import pandas as pd
    >>> table = pd.DataFrame({
    ...     "kernel": ["base"] * 3 + ["fast"] * 3, "workload_id": ["w"] * 6,
    ...     "process": [0, 1, 2] * 2, "ns_per_test": [2.0, 2.2, 1.8, 1.0, 1.1, 0.9]})
    >>> row = speedup_table(table, "base").iloc[0]
    >>> row["kernel"], round(float(row["ratio"]), 6), row["verdict"]
    ('fast', 2.0, 'faster')
    """
    _check_confidence(confidence)
    rows: list[dict] = []
    for workload, group in table.groupby("workload_id", sort=True):
        rows += _family_rows(workload, group, baseline, confidence, margin)
    return pd.DataFrame(rows, columns=_SPEEDUP_COLUMNS)
