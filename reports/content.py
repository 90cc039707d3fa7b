"""The tables behind the report's figures, as the analysis step wrote them into the run folder.

Nothing here computes a statistic (:func:`tribench.reports.tables.pipeline.write_all` did);
this module only joins those tables for display and reads the workload pictures."""

from __future__ import annotations

import json
import math
from typing import Any

import numpy as np
import pandas as pd

from ..harness import runfolder
from .rundata import RunData

__all__ = [
    "estimates_table",
    "speedups_table",
    "working_set_bytes",
    "workload_figures",
    "picture",
]


def sweep_order(frame: pd.DataFrame, data: RunData) -> pd.DataFrame:
    """Rows in sweep order: workloads, then kernels."""
    if frame.empty:
        return frame
    w = {x: i for i, x in enumerate(data.workload_ids)}
    k = {x: i for i, x in enumerate(data.kernels)}
    key = frame["workload_id"].map(w) * 1000 + frame["kernel"].map(k)
    return frame.assign(_key=key).sort_values("_key", kind="stable").drop(columns="_key").reset_index(drop=True)


def working_set_bytes(bytes_per_triangle: float, dtype: str, triangles: float, rays: float) -> float:
    """Bytes of prepared triangles plus rays (origin and direction, 3 components each)."""
    if any(pd.isna(x) for x in (bytes_per_triangle, triangles, rays)):
        return math.nan
    return float(triangles) * float(bytes_per_triangle) + float(rays) * 6 * np.dtype(dtype).itemsize


def estimates_table(data: RunData, wl: pd.DataFrame) -> pd.DataFrame:
    """``estimates.csv`` joined with the workload table and the working-set size, from the bytes per
    triangle ``kernels.csv`` recorded for the kernel and family (the build that measured the run)."""
    est = data.estimates.merge(wl, on="workload_id", how="left", suffixes=("", "_wl"))
    kern = data.tables[runfolder.KERNELS]
    per = dict(zip(zip(kern["kernel"], kern["family"], strict=True), kern["bytes_per_triangle"], strict=True))
    est["working_set_bytes"] = [
        working_set_bytes(per.get((r.kernel, r.family), math.nan), r.dtype, r.triangles, r.rays)
        for r in est.itertuples(index=False)
    ]
    return est


def speedups_table(data: RunData, wl: pd.DataFrame) -> pd.DataFrame:
    """``speedups.csv`` joined with the workload table."""
    return data.speedups.merge(wl.drop(columns=["dtype"]), on="workload_id", how="left", suffixes=("", "_wl"))


def workload_figures(data: RunData) -> dict[str, list[tuple[str, Any, Any]]]:
    """Per workload id, its ``(figure, target, achieved)`` rows from ``workload_figures.csv``."""
    out: dict[str, list[tuple[str, Any, Any]]] = {}
    frame = data.tables[runfolder.WORKLOAD_FIGURES]
    for r in frame.itertuples(index=False):
        out.setdefault(r.workload_id, []).append((r.figure, json.loads(r.target), json.loads(r.achieved)))
    return out


def picture(data: RunData, workload_id: str) -> tuple[bytes | None, str]:
    """The workload's PNG drawn by the analysis step, or None and why there is none."""
    entry = (data.record.get("pictures") or {}).get(workload_id)
    if entry is None:
        return None, "no picture: the workload was not available to the analysis"
    if entry != f"{runfolder.PICTURES_DIR}/{workload_id}.png":
        return None, entry  # the analysis's reason why not
    path = data.run_dir / entry
    try:
        return path.read_bytes(), ""
    except OSError:
        return None, f"{entry} is missing: run `tribench stats {data.run_dir}`"
