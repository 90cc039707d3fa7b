"""Statistics for tribench: pure functions from timed batches to estimates, importing ``tribench.common`` only.

Nothing here reads or writes files, prints, or touches global random state; results are frozen dataclasses
carrying their confidence level; defaults live in :data:`DEFAULTS`. The replicate is the worker process (its
batches share a memory layout), reduced to the median ns/test of its non-warm-up batches; a speedup of K over
B is ``time_B / time_K``, from ``log B_p - log K_p``, so swapping the two inverts it exactly. What each
figure means: docs/methodology.md, "The statistics"."""

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
