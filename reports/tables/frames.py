"""What every table builder shares: rows as a frame of exactly its columns, a figure's interval columns, rows in a
given order, and two kernels' paired time ratio."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
import pandas as pd

from ...harness import runfolder, stats


def table_frame(rows: list[dict[str, Any]], name: str) -> pd.DataFrame:
    """Rows as a frame with exactly ``name``'s documented columns, in file order."""
    return pd.DataFrame(rows, columns=runfolder.part_columns(name))


def with_ci(name: str, value: Any, low: Any, high: Any) -> dict[str, Any]:
    """A figure and its interval as the columns ``name``, ``name_ci_low`` and ``name_ci_high``."""
    return {name: value, f"{name}_ci_low": low, f"{name}_ci_high": high}


def in_order(frame: pd.DataFrame, **orders: Sequence[Any]) -> pd.DataFrame:
    """``frame``'s rows by each named column's place in its sequence, the first column first, renumbered; a row
    whose value is in no sequence goes last, in the order it had."""
    key = pd.Series(0.0, index=frame.index)
    for column, values in orders.items():
        place = {v: i for i, v in enumerate(values)}
        key = key * len(place) + frame[column].map(place)
    return frame.iloc[np.argsort(key.to_numpy(), kind="stable")].reset_index(drop=True)


def paired_time_ratio(per: pd.DataFrame, slower: str, faster: str, level: float) -> tuple[float, float, float, int]:
    """time_slower / time_faster from per-process values (``per``: one column per kernel), its interval at ``level``
    (``stats.speedup``; NaN when fewer than two processes ran both), and how many processes ran both."""
    both = per[[slower, faster]].dropna()
    if len(both) < 2:
        return math.nan, math.nan, math.nan, len(both)
    v = stats.speedup(both[slower], both[faster], confidence=level)
    return v.ratio, v.ci_low, v.ci_high, len(both)
