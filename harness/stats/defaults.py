"""Defaults of every statistic, in one place, and the equivalence margin's check."""

from __future__ import annotations

from dataclasses import dataclass

from ...common import UserError

#: The largest equivalence margin tribench accepts: at 0.5, kernels within 1.5x of each other would be
#: "equivalent", not a noise floor but a machine too noisy to compare on (an A/A noise floor is a few
#: percent: docs/decisions.md, "The equivalence margin").
MAX_MARGIN = 0.5


def check_margin(value: object, where: str) -> float:
    """``value`` as a margin, a finite number in ``[0, MAX_MARGIN]``; else a UserError naming ``where``.

    >>> check_margin(0.02, "--margin")
    0.02
    >>> check_margin(float("nan"), "--margin")
    Traceback (most recent call last):
    ...
    tribench.common.errors.UserError: --margin: an equivalence margin must be a number between 0 and 0.5
    (relative: 0.01 = 1 %), got nan
    """
    # nan and inf fail the range test, and an int of any size is compared exactly
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not 0 <= value <= MAX_MARGIN:
        raise UserError(
            f"{where}: an equivalence margin must be a number between 0 and {MAX_MARGIN:g} "
            f"(relative: 0.01 = 1 %), got {value!r:.40}"
        )
    return float(value)


@dataclass(frozen=True)
class Defaults:
    """Every tunable default of this module, in one place."""

    #: Two-sided confidence level of every interval.
    confidence: float = 0.95
    #: Relative equivalence margin of :func:`verdict` (0.01 = 1 %, Criterion.rs's noise threshold) where no
    #: A/A calibration exists (else ``AASummary.margin``). Too small a margin only makes "equivalent" rarer
    #: (it turns into "inconclusive"), never wrong.
    margin: float = 0.01
    #: Resamples of the BCa bootstrap (scipy's default).
    n_resamples: int = 9999
    #: Seed of the bootstrap, so that a re-analysis gives the same numbers.
    rng_seed: int = 20130616
    #: Drift worth a warning: change of the log speedup across one process
    #: (0.01 is about 1 %), see :func:`drift`.
    drift_threshold: float = 0.01
    #: Tukey fences: outlier beyond ``k`` IQR, far out beyond ``far_k`` IQR.
    tukey_k: float = 1.5
    tukey_far_k: float = 3.0
    #: Cap of :func:`suggest_design` when rounds cost nothing in variance terms.
    max_rounds: int = 1000


DEFAULTS = Defaults()
