"""An estimate and its confidence interval as text: the one style of every table, page and sentence. It lives
with the statistics, whose intervals it writes (a non-finite bound: none), so that ``harness`` (the seed
replay's terminal table) and ``reports`` share it."""

from __future__ import annotations

import math

__all__ = ["format_estimate", "format_interval", "NO_INTERVAL"]

#: What stands for an interval that could not be computed (a non-finite bound).
NO_INTERVAL = "[no interval]"


def format_interval(value: float | None, low: float, high: float, spec: str = ".3g", unit: str = "") -> str:
    """``value`` followed by its interval in brackets: ``"1.18× [1.15, 1.21]"``.

    ``value`` None writes the interval alone, a non-finite one ``–``; a non-finite bound gives :data:`NO_INTERVAL`.
    ``spec`` formats all three numbers; ``unit`` follows the estimate as given (``"×"``, ``" ns"``).

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
