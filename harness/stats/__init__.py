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

What this package owns and may import
-------------------------------------
``tribench.harness.stats`` owns every statistic of tribench, as pure functions on arrays
and data frames. It may import ``tribench.common`` only; the rest of ``harness`` (the
sequential rule, while measuring) and ``reports`` call it. One module per section:
:mod:`.defaults` (:data:`DEFAULTS`, the margin), :mod:`.estimates` (per process, per
kernel), :mod:`.compare` (two runs), :mod:`.multiplicity` (several kernels against a
baseline, verdicts, tables), :mod:`.calibration` (A/A), :mod:`.design` (variance
components, design), :mod:`.curves` (crossover, scaling), :mod:`.outliers` (drift,
outliers), :mod:`.sequential` (the stopping rule of a sequential design) and
:mod:`.formatting` (an estimate with its interval as text, the one style of every table
and page).
"""

from .calibration import AASummary, aa_noise_floor, aa_summary
from .compare import LogRatio, unpaired_ratio
from .curves import Crossover, Slope, crossover, scaling_slope
from .defaults import DEFAULTS, MAX_MARGIN, Defaults, check_margin
from .design import Design, VarianceComponents, rounds_matrix, suggest_design, variance_components
from .estimates import (
    Estimate,
    GeometricMean,
    Speedup,
    estimate,
    geometric_mean,
    per_process,
    speedup,
)
from .formatting import format_estimate, format_interval
from .multiplicity import estimate_table, holm, simultaneous_confidence, speedup_table, verdict
from .outliers import Drift, drift, label_outliers, tukey_outliers
from .sequential import MIN_PROCESSES, narrow_comparisons, relative_halfwidth

__all__ = [
    "DEFAULTS",
    "MAX_MARGIN",
    "MIN_PROCESSES",
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
    "format_estimate",
    "format_interval",
    "geometric_mean",
    "holm",
    "label_outliers",
    "narrow_comparisons",
    "per_process",
    "relative_halfwidth",
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
