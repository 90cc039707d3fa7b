"""An estimate and its confidence interval as text: the one style every table, page and sentence uses.

It lives with the statistics because an interval is theirs (a non-finite bound
is how :mod:`tribench.harness.stats` says there is none, e.g. from one process), and so
that both ``harness`` (the seed replay's terminal table) and ``reports`` can
use it.
"""

from __future__ import annotations

import math

__all__ = ["format_estimate", "format_interval", "NO_INTERVAL"]

#: What stands for an interval that could not be computed (a non-finite bound).
NO_INTERVAL = "[no interval]"


def format_interval(value: float | None, low: float, high: float, spec: str = ".3g", unit: str = "") -> str:
    """``value`` followed by its interval in brackets: ``"1.18× [1.15, 1.21]"``.

    Parameters
    ----------
    value : float or None
        The estimate; None writes the interval alone. A non-finite estimate is ``–``.
    low, high : float
        The interval's bounds; if either is not finite, :data:`NO_INTERVAL` stands for it.
    spec : str
        The format spec of all three numbers (``".3g"``: 3 significant digits; ``".3f"``: 3 decimals).
    unit : str
        Written right after the estimate, as given: ``"×"``, ``" ns"`` (unused without one).

    Examples
    --------
    >>> format_interval(1.18, 1.15, 1.21, unit="×")
    '1.18× [1.15, 1.21]'
    >>> format_interval(None, 0.0123456, 0.0234567, ".4g")
    '[0.01235, 0.02346]'
    >>> format_interval(2.5, math.nan, math.nan, ".3f", " s")
    '2.500 s [no interval]'
    >>> format_interval(None, 1.0, math.inf)
    '[no interval]'
    """
    interval = f"[{low:{spec}}, {high:{spec}}]" if math.isfinite(low) and math.isfinite(high) else NO_INTERVAL
    if value is None:
        return interval
    shown = f"{value:{spec}}" if math.isfinite(value) else "–"
    return f"{shown}{unit} {interval}"


def format_estimate(value: float | None, low: float, high: float, unit: str = "") -> str:
    """:func:`format_interval` of an estimate that may be missing: ``–`` alone where it is (None or NaN).

    >>> format_estimate(math.nan, 1.0, 2.0), format_estimate(1.5, 1.2, 1.8, "×")
    ('–', '1.5× [1.2, 1.8]')
    """
    if value is None or math.isnan(value):
        return "–"
    return format_interval(value, low, high, unit=unit)
