"""The stopping rule of a sequential design: which comparisons still need processes. A comparison (a kernel
against its workload's reference kernel, paired per process) stops once its interval is narrower than a
target; the rule reads the width, never the position, so stopping barely changes what the interval covers
(docs/methodology.md, "The main job's sequential design"; tests/test_stats.py measures it)."""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np
import numpy.typing as npt
import pandas as pd

from ._core import _check_confidence, _require_columns
from .defaults import DEFAULTS
from .estimates import speedup

__all__ = ["MIN_PROCESSES", "narrow_comparisons", "relative_halfwidth"]

#: Fewest processes before a comparison may stop: on few processes a t-interval's own width is a noisy guide
#: (a lucky small spread stops a comparison early, and such intervals cover less). 8 keeps the coverage near
#: the fixed design's (the figures for 4, 8 and 12: docs/decisions.md, "3 rounds per process, stages of 2").
MIN_PROCESSES = 8


def relative_halfwidth(
    baseline_values: npt.ArrayLike, kernel_values: npt.ArrayLike, confidence: float = DEFAULTS.confidence
) -> float:
    """Half the width of :func:`tribench.harness.stats.speedup`'s interval, relative: ``sqrt(high / low) - 1``
    (the interval is symmetric on the log scale: 0.02 means "within about 2%"); infinite under two pairs.

    >>> round(relative_halfwidth([2.0, 2.2, 1.8], [1.0, 1.1, 0.9]), 12)
    0.0
    >>> relative_halfwidth([2.0], [1.0])
    inf
    """
    base, kern = np.asarray(baseline_values, dtype=float), np.asarray(kernel_values, dtype=float)
    if base.size < 2:
        return math.inf
    s = speedup(base, kern, confidence)
    return math.sqrt(s.ci_high / s.ci_low) - 1.0


def narrow_comparisons(
    table: pd.DataFrame,
    references: Mapping[str, str],
    target: float,
    confidence: float = DEFAULTS.confidence,
    min_processes: int = MIN_PROCESSES,
) -> set[tuple[str, str]]:
    """The (workload id, kernel) comparisons of a :func:`tribench.harness.stats.per_process` table that need no
    more processes: each kernel whose interval against its workload's ``references`` kernel is at most
    ``target`` wide (:func:`relative_halfwidth`) on at least ``min_processes`` pairs. A comparison not measured
    yet is not among them.

    >>> t = pd.DataFrame({"workload_id": ["w"] * 6, "kernel": ["b"] * 3 + ["k"] * 3,
    ...                   "process": [0, 1, 2] * 2, "ns_per_test": [2.0, 2.2, 1.8, 1.0, 1.1, 0.95]})
    >>> narrow_comparisons(t, {"w": "b"}, target=0.5, min_processes=3)
    {('w', 'k')}
    >>> narrow_comparisons(t, {"w": "b"}, target=0.02, min_processes=3)
    set()
    """
    _check_confidence(confidence)
    _require_columns(table, ("workload_id", "kernel", "process", "ns_per_test"))
    if not target > 0:
        raise ValueError(f"target must be a positive relative half-width, got {target!r}")
    out = set()
    for wid, g in table.groupby("workload_id", sort=True):
        ref = references.get(str(wid))
        wide = g.pivot(index="process", columns="kernel", values="ns_per_test")
        if ref not in wide.columns:
            continue
        for kernel in wide.columns:
            if kernel == ref:
                continue
            both = wide[[ref, kernel]].dropna()
            if len(both) >= min_processes and relative_halfwidth(both[ref], both[kernel], confidence) <= target:
                out.add((str(wid), str(kernel)))
    return out
