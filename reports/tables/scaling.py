"""Across workloads: where two kernels cross over in hit rate, and how time scales with triangles."""

from __future__ import annotations

import dataclasses
import itertools
from collections.abc import Sequence

import numpy as np
import pandas as pd

from ...harness import runfolder, stats
from .frames import table_frame


def _wide(pp: pd.DataFrame, kernel: str, wids: list[str]) -> pd.DataFrame:
    sub = pp.loc[(pp["kernel"] == kernel) & pp["workload_id"].isin(wids)]
    return sub.pivot(index="process", columns="workload_id", values="ns_per_test").reindex(columns=wids)


def crossovers(kernels: Sequence[str], wl: pd.DataFrame, pp: pd.DataFrame) -> pd.DataFrame:
    """Per pair family and pair of kernels: where their ranking flips along the per-test hit rate.

    ``stats.crossover`` on processes paired across the family's workloads (two
    hit rates at least); ``hit_rate`` is nan when the lines do not cross in range."""
    rows = []
    for family, group in wl.loc[wl["kind"] == "pairs"].groupby("family", sort=False):
        group = group.sort_values("test_hit_rate")
        if group["test_hit_rate"].nunique() < 2:
            continue
        wids = list(group["workload_id"])
        for a, b in itertools.combinations(kernels, 2):
            wa, wb = _wide(pp, a, wids), _wide(pp, b, wids)
            both = (np.log(wb) - np.log(wa)).dropna()
            if len(both) < 2:
                continue
            c = stats.crossover(group["test_hit_rate"].to_numpy(), both.to_numpy())
            # of the result's fields, table_frame keeps the file's columns (here: not the intercept)
            rows.append({"family": family, "kernel_a": a, "kernel_b": b, **dataclasses.asdict(c)})
    return table_frame(rows, runfolder.CROSSOVERS)


def scaling_slopes(est: pd.DataFrame, pp: pd.DataFrame) -> pd.DataFrame:
    """``slopes.csv``: log-log slope of ns/test against triangle count per mesh family and kernel, paired by process."""
    rows = []
    mesh = est.loc[est["kind"] == "mesh"]
    for (family, kernel), group in mesh.groupby(["family", "kernel"], sort=False):
        group = group.dropna(subset=["triangles"]).sort_values("triangles")
        if group["triangles"].nunique() < 2:
            continue
        wide = _wide(pp, kernel, list(group["workload_id"])).dropna()
        if len(wide) < 2:
            continue
        s = stats.scaling_slope(group["triangles"].to_numpy(dtype=float), wide.to_numpy())
        rows.append({"family": family, "kernel": kernel, **dataclasses.asdict(s), "sizes": len(group)})
    return table_frame(rows, runfolder.SLOPES)
