"""A run's own equivalence margin, from the A/A twin of its baseline timed beside it.

The twin (``moller_seed_aa``) is the baseline's source compiled again under another name, so each workload gives an
A/A speedup whose true value is 1; its noise floor (:func:`tribench.harness.stats.aa_noise_floor`) is what this
machine, build and load do to identical code, and the margin the run's verdicts use unless ``--margin`` is given.
The twin is an instrument, not a contender: :func:`contenders` leaves it out of every ranking."""

from __future__ import annotations

import math

import pandas as pd

from ...harness import stats
from ...harness.margin import AA_TWINS, Margin
from ...harness.stats.defaults import MAX_MARGIN

__all__ = ["MIN_WORKLOADS", "TWINS", "contenders", "twin_margin", "twin_speedups"]

#: The twins' names: measuring instruments, never contenders.
TWINS = frozenset(AA_TWINS.values())

#: Fewer A/A speedups than this say too little about the noise floor: the run keeps its recorded margin.
MIN_WORKLOADS = 3


def twin_speedups(per_process: pd.DataFrame, baseline: str) -> list[stats.Speedup]:
    """One A/A speedup (baseline against its twin, paired by process) per workload both ran."""
    twin = AA_TWINS.get(baseline)
    if twin is None:
        return []
    out = []
    for _, group in per_process.loc[per_process["kernel"].isin([baseline, twin])].groupby("workload_id"):
        wide = group.pivot(index="process", columns="kernel", values="ns_per_test").dropna()
        if {baseline, twin} <= set(wide.columns) and len(wide) >= 2:
            out.append(stats.speedup(wide[baseline], wide[twin]))
    return out


def twin_margin(per_process: pd.DataFrame, baseline: str) -> Margin | None:
    """The margin the twin's A/A speedups give, or None when the run has too few of them.

    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> rows = [dict(kernel=k, workload_id=f"w{w}", process=p, ns_per_test=rng.lognormal(0, 0.01))
    ...         for k in ("moller_seed", "moller_seed_aa") for w in range(5) for p in range(6)]
    >>> m = twin_margin(pd.DataFrame(rows), "moller_seed")
    >>> 0 < m.value < 0.05, m.source.startswith("A/A twin in this run")
    (True, True)

    A twin past :data:`~tribench.harness.stats.defaults.MAX_MARGIN` (a loaded machine) gives that bound, saying so:

    >>> rows = [dict(kernel=k, workload_id=f"w{w}", process=p, ns_per_test=rng.lognormal(0, 1.0))
    ...         for k in ("moller_seed", "moller_seed_aa") for w in range(5) for p in range(6)]
    >>> m = twin_margin(pd.DataFrame(rows), "moller_seed")
    >>> m.value, m.source.endswith("capped at 50%, the widest margin: this run's timings are too noisy")
    (0.5, True)
    """
    results = twin_speedups(per_process, baseline)
    if len(results) < MIN_WORKLOADS:
        return None
    value = math.expm1(stats.aa_noise_floor([math.log(r.ratio) for r in results]))
    covered = sum(r.ci_low <= 1 <= r.ci_high for r in results)
    source = (
        f"A/A twin in this run ({baseline} against {AA_TWINS[baseline]} on {len(results)} workloads; "
        f"{covered} of {len(results)} intervals cover 1)"
    )
    if value > MAX_MARGIN:  # a run this noisy still gets its results, and is told why its verdicts are loose
        source += f", {value:.0%} capped at {MAX_MARGIN:.0%}, the widest margin: this run's timings are too noisy"
        value = MAX_MARGIN
    return Margin(value, source)


def contenders(frame: pd.DataFrame) -> pd.DataFrame:
    """``frame`` without the A/A twins' rows: what rankings compare."""
    return frame.loc[~frame["kernel"].isin(TWINS)]
