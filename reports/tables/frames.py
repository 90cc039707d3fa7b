"""What every table builder shares: rows as a frame of exactly its columns, and two kernels' paired time ratio."""

from __future__ import annotations

import math
from typing import Any

import pandas as pd

from ...harness import runfolder, stats


def table_frame(rows: list[dict[str, Any]], name: str) -> pd.DataFrame:
    """Rows as a frame with exactly ``name``'s documented columns, in file order."""
    return pd.DataFrame(rows, columns=runfolder.part_columns(name))


def paired_time_ratio(per: pd.DataFrame, slower: str, faster: str, level: float) -> tuple[float, float, float, int]:
    """time_slower / time_faster from per-process values (``per``: one column per kernel), its interval at ``level``
    (``stats.speedup``; NaN when fewer than two processes ran both), and how many processes ran both."""
    both = per[[slower, faster]].dropna()
    if len(both) < 2:
        return math.nan, math.nan, math.nan, len(both)
    v = stats.speedup(both[slower], both[faster], confidence=level)
    return v.ratio, v.ci_low, v.ci_high, len(both)
