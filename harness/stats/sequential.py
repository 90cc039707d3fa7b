"""The stopping rule of a sequential design: which comparisons still need processes.

A sequential sweep runs its processes in stages. After each stage, every
comparison (a kernel against its workload's reference kernel, paired per
process) whose interval is already narrower than a target stops: later
processes no longer run that kernel on that workload. The rule looks only at
the interval's *width*, never at its position (not at whether it excludes 1),
so stopping barely changes what the interval covers; tests/test_stats.py
measures the coverage of the 95% intervals with the rule in the loop.
"""

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

#: Fewest processes before a comparison may stop. A t-interval's own width is
#: a noisy guide on few processes: a lucky small spread stops a comparison whose
#: true spread is larger, and those intervals cover less. 8 keeps the rule's
#: coverage near the fixed design's in tests/test_stats.py's simulation (the
#: figures for 4, 8 and 12: docs/decisions.md, "3 rounds per process, stages of 2").
MIN_PROCESSES = 8


def relative_halfwidth(
    baseline_values: npt.ArrayLike, kernel_values: npt.ArrayLike, confidence: float = DEFAULTS.confidence
) -> float:
    """Half the width of the speedup's interval, relative: ``sqrt(high / low) - 1``.

    The interval is :func:`tribench.harness.stats.speedup`'s (a t-interval of the paired
    per-process log-ratios), symmetric on the log scale, so this is
    ``exp(half-width of the log interval) - 1``: 0.02 means "within about 2%".
    Infinite with fewer than two pairs.

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
    """The (workload id, kernel) comparisons that need no more processes.

    Parameters
    ----------
    table : DataFrame
        :func:`tribench.harness.stats.per_process` of the batches so far.
    references : mapping
        Per workload id, the kernel every other kernel of it is compared with.
    target : float
        Relative half-width (:func:`relative_halfwidth`) at or below which a
        comparison has enough processes.
    min_processes : int
        A comparison on fewer pairs of processes is never narrow.

    Returns
    -------
    set of (workload_id, kernel)
        Every kernel of ``table`` other than its workload's reference whose
        interval against the reference is at most ``target`` wide, on at least
        ``min_processes`` processes. A comparison absent from ``table`` (not
        measured yet) is not in it.

    Examples
    --------
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
