"""How the batches behaved: outlier and warm-up labels, drift over a run, variance components."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from typing import Any

import numpy as np
import pandas as pd

from ...harness import runfolder, stats
from .frames import table_frame


def batch_labels(batches: pd.DataFrame) -> pd.DataFrame:
    """Every batch's key with ``ns_per_test``, Tukey labels (``stats.label_outliers``),
    ``rel_to_median`` (ns/test over its process's timed median for that kernel and
    workload) and ``t_in_process_s`` (seconds since the process's first batch)."""
    b = stats.label_outliers(batches)
    timed = b.loc[~b["warmup"]]
    med = timed.groupby(["kernel", "workload_id", "process"])["ns_per_test"].median().rename("median_ns")
    b = b.join(med, on=["kernel", "workload_id", "process"])
    start = b.groupby(["process", "attempt"])["start_ns"].transform("min")
    b = b.assign(rel_to_median=b["ns_per_test"] / b["median_ns"], t_in_process_s=(b["start_ns"] - start) * 1e-9)
    return b[runfolder.part_columns(runfolder.BATCH_LABELS)].reset_index(drop=True)


def outlier_table(labels: pd.DataFrame, wl: pd.DataFrame) -> pd.DataFrame:
    """Counts of Tukey-labelled batches (kept, never dropped) per kernel and workload (``outliers.csv``)."""
    timed = labels.loc[~labels["warmup"]]
    g = timed.groupby(["workload_id", "kernel"], sort=False)
    out = pd.DataFrame(
        {
            "batches": g.size(),
            "outliers": g["outlier"].sum(),
            "far_out": g["far_out"].sum(),
            "worst_rel": g["rel_to_median"].max(),
        }
    ).reset_index()
    out["label"] = out["workload_id"].map(dict(zip(wl["workload_id"], wl["label"], strict=True)))
    return out[runfolder.part_columns(runfolder.OUTLIERS)]


def warmup_table(labels: pd.DataFrame, wl: pd.DataFrame) -> pd.DataFrame:
    """Warm-up against timed batches: median of ``ns/test / process median`` of each (``warmup.csv``)."""
    g = labels.groupby(["workload_id", "kernel"])
    warm = labels.loc[labels["warmup"]].groupby(["workload_id", "kernel"])
    out = pd.DataFrame(
        {
            "warmup_rel": warm["rel_to_median"].median().reindex(g.size().index),
            "warmup_batches": warm.size().reindex(g.size().index),
        }
    ).reset_index()
    out["warmup_batches"] = out["warmup_batches"].fillna(0).astype(int)
    out["label"] = out["workload_id"].map(dict(zip(wl["workload_id"], wl["label"], strict=True)))
    return out[runfolder.part_columns(runfolder.WARMUP)]


def drift_table(
    batches: pd.DataFrame, kernels: Sequence[str], baseline: str, workload_ids: Sequence[str], wl: pd.DataFrame
) -> pd.DataFrame:
    """``drift.csv``: ``stats.drift`` of each kernel against the baseline per workload (``reason``: why untested)."""
    rows = []
    labels = dict(zip(wl["workload_id"], wl["label"], strict=True))
    for wid in workload_ids:
        for kernel in kernels:
            if kernel == baseline:
                continue
            row: dict[str, Any] = {"workload_id": wid, "label": labels.get(wid, wid), "kernel": kernel}
            try:
                d = stats.drift(batches, kernel, baseline, workload_id=wid)
            except ValueError as exc:
                row.update(flagged=False, reason=f"not tested: {exc}")
            else:
                row.update(dataclasses.asdict(d))  # the fields drift.csv has (table_frame keeps only those)
            rows.append(row)
    return table_frame(rows, runfolder.DRIFT)


def variance_table(
    batches: pd.DataFrame, kernels: Sequence[str], workload_ids: Sequence[str], wl: pd.DataFrame
) -> pd.DataFrame:
    """``variance.csv``: the roots of ``stats.variance_components`` in percent of the mean, per kernel and workload."""
    rows = []
    labels = dict(zip(wl["workload_id"], wl["label"], strict=True))
    for wid in workload_ids:
        for kernel in kernels:
            try:
                vc = stats.variance_components(stats.rounds_matrix(batches, kernel, wid))
            except ValueError:
                continue
            rows.append(
                {
                    "workload_id": wid,
                    "label": labels.get(wid, wid),
                    "kernel": kernel,
                    "mean_ns": vc.mean,
                    "round_sd_pct": 100 * math.sqrt(vc.between_round) / vc.mean,
                    "process_sd_pct": 100 * math.sqrt(vc.between_process) / vc.mean,
                    "n_processes": vc.n_processes,
                    "n_rounds": vc.n_rounds,
                }
            )
    return table_frame(rows, runfolder.VARIANCE)


def _quartiles(groups: Any, out: dict[str, Any]) -> pd.DataFrame:
    """``out`` with the median and quartiles of ``rel_to_median`` in each of ``groups`` and their batches."""
    rel = groups["rel_to_median"]
    out |= {"rel_q1": rel.quantile(0.25), "rel_median": rel.median(), "rel_q3": rel.quantile(0.75)}
    return pd.DataFrame(out | {"batches": groups.size()}).reset_index()


def drift_bins(labels: pd.DataFrame, bins: int = 12) -> pd.DataFrame:
    """The drift chart's points: each kernel's timed batches of :func:`batch_labels` in ``bins`` equal spans of
    time in the process, pooled over workloads: the spans' median time ``t_s``, the quartiles of ``rel_to_median``,
    and ``batches``. A page holds a few hundred of these where the batches are thousands."""
    timed = labels.loc[~labels["warmup"]]
    if timed.empty:
        return pd.DataFrame(columns=["kernel", "t_s", "rel_q1", "rel_median", "rel_q3", "batches"])
    t = timed["t_in_process_s"]
    span = pd.cut(t, np.linspace(t.min(), t.max(), bins + 1), include_lowest=True, labels=False)
    g = timed.groupby(["kernel", span.rename("span")], sort=False)
    return _quartiles(g, {"t_s": g["t_in_process_s"].median()}).drop(columns="span")


def round_summary(labels: pd.DataFrame) -> pd.DataFrame:
    """The rounds chart's points: per kernel and round (warm-ups negative), pooled over processes and workloads,
    the quartiles, least and most of ``rel_to_median``, the Tukey outliers and far-outs among the batches, and
    ``worst_outlier``, the ``rel_to_median`` of the outlier farthest from 1 (NaN without one)."""
    keys = ["kernel", "round"]
    g = labels.groupby(keys, sort=False)
    rel = g["rel_to_median"]
    out = labels.loc[labels["outlier"]]
    farthest = np.log(out["rel_to_median"]).abs().groupby([out["kernel"], out["round"]]).idxmax()
    worst = out.loc[farthest.to_numpy()].set_index(keys)["rel_to_median"].reindex(rel.min().index)
    fields = {"warmup": g["warmup"].first(), "rel_min": rel.min(), "rel_max": rel.max()}
    fields |= {"outliers": g["outlier"].sum(), "far_out": g["far_out"].sum(), "worst_outlier": worst}
    return _quartiles(g, fields)
