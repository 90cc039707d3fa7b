"""Per workload: its spec and achieved figures, and every kernel's answers against the reference; across a family's
workloads: where two kernels cross over in hit rate, and how time scales with triangles."""

from __future__ import annotations

import dataclasses
import itertools
import json
import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import pandas as pd

from ...harness import runfolder, stats
from ...workloads.labels import family_of, short_label, spec_text
from .frames import in_order, table_frame
from .margin import contenders


def workload_table(
    specs: Mapping[str, Mapping[str, Any]],
    workload_ids: Sequence[str],
    workloads: Mapping[str, Any],
    sources: Mapping[str, str],
) -> pd.DataFrame:
    """One row per workload: family, label and the achieved figures (``workloads.csv``).

    ``workloads`` maps an id to its :class:`~tribench.workloads.Workload`, or None
    when it could not be had: the spec's targets then stand in."""
    rows = []
    for wid in workload_ids:
        spec = specs[wid]
        w = workloads.get(wid)
        a = dict(w.achieved) if w is not None else {}
        rays: Any  # a count, or what the run folder holds
        if spec["kind"] == "pairs":
            n = int(a.get("pairs", spec["n"]))
            hits = a.get("hits", round(spec["hit_rate"] * spec["n"]))
            triangles, rays, tests = n, n, n
            test_rate, ray_rate = hits / n, hits / n
        else:
            triangles = a.get("triangles", spec.get("triangles") or math.nan)
            rays = a.get("rays", (spec.get("width") or 0) * (spec.get("height") or 0) or spec.get("n_rays"))
            tests = a.get("tests", triangles * rays if not pd.isna(triangles) else math.nan)
            test_rate = a.get("test_hit_rate", math.nan)
            ray_rate = a.get("ray_hit_rate", spec.get("hit_rate") if spec.get("rays") == "hit_rate" else math.nan)
        rows.append(
            {
                "workload_id": wid,
                "kind": spec["kind"],
                "family": family_of(spec),
                "label": short_label(spec),
                "summary": spec_text(spec),
                "dtype": spec.get("dtype", "float64"),
                "triangles": triangles,
                "rays": rays,
                "tests_per_pass": tests,
                "test_hit_rate": test_rate,
                "ray_hit_rate": ray_rate,
                "source": sources.get(wid, "cache"),
            }
        )
    return table_frame(rows, runfolder.WORKLOADS)


def workload_figures(workload_ids: Sequence[str], workloads: Mapping[str, Any]) -> pd.DataFrame:
    """Every workload's targets against its achieved figures (``workload_figures.csv``), values as JSON text."""
    rows = []
    for wid in workload_ids:
        w = workloads.get(wid)
        if w is None:
            continue
        for figure, target, achieved in w.compare():
            if not figure.startswith("generated_with"):
                rows.append(
                    {
                        "workload_id": wid,
                        "figure": figure,
                        "target": json.dumps(target, default=str),
                        "achieved": json.dumps(achieved, default=str),
                    }
                )
    return table_frame(rows, runfolder.WORKLOAD_FIGURES)


def correctness_table(batches: pd.DataFrame, kernels: Sequence[str], workloads: Mapping[str, Any]) -> pd.DataFrame:
    """Each kernel's checksums against the float64 reference, per workload (``correctness.csv``); a
    difference may only come from ambiguous rays, whose answer is rounding's."""
    rows = []
    for (wid, kernel), g in batches.groupby(["workload_id", "kernel"], sort=False):
        w = workloads.get(wid)
        hits = g["hits"] / g["loops"]
        row = {
            "kernel": kernel,
            "workload_id": wid,
            "batches": len(g),
            "hits_per_pass_min": float(hits.min()),
            "hits_per_pass_max": float(hits.max()),
        }
        if w is not None:
            ref_hits, ref_t = w.expected_checksum()
            ambiguous = int(w.ambiguous().sum())
            diff = float(np.max(np.abs(hits - ref_hits)))
            rel = float(np.max(np.abs(g["t_sum"] / g["loops"] - ref_t))) / abs(ref_t) if ref_t else 0.0
            row.update(
                ref_hits=ref_hits,
                hit_difference=diff,
                ambiguous_rays=ambiguous,
                t_sum_rel_diff=rel,
                agrees=bool(diff <= ambiguous and hits.nunique() == 1),
            )
        rows.append(row)
    return in_order(table_frame(rows, runfolder.CORRECTNESS), kernel=kernels)


def agreeing(frame: pd.DataFrame, correct: pd.DataFrame) -> pd.DataFrame:
    """``frame`` without the rows of a kernel on a workload where its answers differ from the reference.

    A ranking compares the same work: a culling kernel on randomly wound pairs
    skips half the tests. Rows of unknown agreement (workload not loaded) stay."""
    differs = correct.loc[correct["agrees"].eq(False), ["workload_id", "kernel"]]
    if differs.empty:
        return frame
    key = pd.MultiIndex.from_frame(differs)
    return frame.loc[~pd.MultiIndex.from_frame(frame[["workload_id", "kernel"]]).isin(key)]


def compared(frame: pd.DataFrame, correct: pd.DataFrame | None) -> pd.DataFrame:
    """The rows of ``frame`` a ranking compares: no A/A twin (a measuring instrument,
    :mod:`.margin`) and, given ``correctness.csv``, no kernel where its answers differ."""
    frame = contenders(frame)
    return frame if correct is None else agreeing(frame, correct)


def estimates_with_workloads(estimates: pd.DataFrame, wl: pd.DataFrame) -> pd.DataFrame:
    """``estimates.csv`` joined with the workload table (family, kind, triangles, rays...)."""
    return estimates.merge(wl, on="workload_id", how="left", suffixes=("", "_wl"))


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
