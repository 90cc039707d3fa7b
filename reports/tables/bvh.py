"""In a BVH: rays/s, the work per ray and the leaf tests' share of trace time, per kernel."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import pandas as pd

from ...harness import runfolder, stats
from .frames import paired_time_ratio, table_frame, with_ci
from .ranking import declared

#: The algorithm whose BVH-capable form the speedups in a BVH are against when the run's
#: baseline has none (the seed's kernels are scalar only): the standard test, as in Baldwin & Weber.
BVH_FALLBACK_ALGORITHM = "moller_trumbore"


_KEY = ["process", "workload_id", "round", "position", "kernel"]


def bvh_baseline(kernels: Sequence[str], baseline: str) -> str:
    """The kernel the speedups on a BVH workload are against, from those that ran it: the run's baseline,
    else its algorithm's first form there, else :data:`BVH_FALLBACK_ALGORITHM`'s, else the first kernel.

    >>> bvh_baseline(["woop_fma", "moller_trumbore_fma"], "moller_seed")
    'moller_trumbore_fma'
    >>> bvh_baseline(["woop_fma"], "moller_seed")
    'woop_fma'
    """
    if baseline in kernels:
        return baseline
    for algorithm in (declared(baseline, "algorithm"), BVH_FALLBACK_ALGORITHM):
        for k in kernels:
            if algorithm is not None and declared(k, "algorithm") == algorithm:
                return k
    return kernels[0]


def _per_process_wide(values: pd.DataFrame, column: str) -> pd.DataFrame:
    """Per process (rows) and kernel (columns): the median of ``column`` over the process's timed batches."""
    med = values.groupby(["process", "kernel"])[column].median()
    return med.unstack("kernel")


def bvh_table(
    batches: pd.DataFrame,
    traversals: pd.DataFrame,
    wl: pd.DataFrame,
    specs: Mapping[str, Mapping[str, Any]],
    pp: pd.DataFrame,
    kernels: Sequence[str],
    baseline: str,
    margin: float,
) -> pd.DataFrame:
    """Per BVH workload and kernel: rays/s, the work per ray, the leaf tests' share of trace time, and the
    speedup over a baseline beside the same in brute force (``bvh.csv``; empty without a BVH workload).

    Rates and the ``null / real`` ratio are per-process medians, geometric means
    over processes; speedups are paired per-process ratios, Bonferroni over the
    workload's kernels, of ns per ray in the BVH and ns per test on the brute-force twin."""
    rows: list[dict[str, Any]] = []
    bvh_wids = [wid for wid in wl["workload_id"] if specs[wid].get("accel") == "bvh"]
    if not bvh_wids:
        return table_frame(rows, runfolder.BVH)
    timed = batches.loc[~batches["warmup"]]
    rays = dict(zip(wl["workload_id"], wl["rays"], strict=True))
    order = {k: i for i, k in enumerate(kernels)}
    trav = traversals.loc[~traversals["warmup"].astype(bool)]
    if len(trav):
        paired = trav.merge(timed[[*_KEY, "elapsed_ns"]], on=_KEY, how="inner")
        paired = paired.assign(null_ratio=paired["null_elapsed_ns"] / paired["elapsed_ns"])
    else:  # a run made before traversals.csv existed: no counts, no leaf share
        paired = pd.DataFrame(columns=["process", "kernel", "workload_id", "null_ratio"])
    for wid in bvh_wids:
        b = timed.loc[timed["workload_id"] == wid]
        ran = sorted(set(b["kernel"]), key=lambda k: order.get(k, len(order)))
        if not ran:
            continue
        w = wl.loc[wl["workload_id"] == wid].iloc[0]
        about = {
            "workload_id": wid,
            "family": w["family"],
            "label": w["label"],
            "dtype": w["dtype"],
            "rays_kind": specs[wid].get("rays"),
            "triangles": w["triangles"],
        }
        speeds = _Speeds(ran, baseline, b.assign(ns=b["elapsed_ns"] / (b["loops"] * rays[wid])), pp, specs[wid])
        shares = _per_process_wide(paired.loc[paired["workload_id"] == wid], "null_ratio")
        t = trav.loc[trav["workload_id"] == wid]
        for kernel in ran:
            rows.append(
                {
                    **about,
                    "kernel": kernel,
                    "algorithm": declared(kernel, "algorithm"),
                    **_rate(speeds.per_ray[kernel]),
                    **_work_per_ray(t.loc[t["kernel"] == kernel]),
                    **_leaf_share(shares, kernel),
                    **speeds.of(kernel, margin),
                }
            )
    return table_frame(rows, runfolder.BVH)


def _rate(per_ray_ns: pd.Series) -> dict[str, float]:
    """Rays/s: the geometric mean over processes of each process's median rate."""
    rate = stats.geometric_mean(1e9 / per_ray_ns.dropna())
    return with_ci("rays_per_s", rate.mean, rate.ci_low, rate.ci_high) | {"n_processes": rate.n}


def _work_per_ray(tk: pd.DataFrame) -> dict[str, float]:
    """Nodes, box tests, leaves and triangle tests per ray over a kernel's traversal rows (NaN without them)."""
    n_rays = tk["rays"].sum()
    columns = ("nodes", "box_tests", "leaves", "triangle_tests", "null_nodes")
    return {f"{c}_per_ray": float(tk[c].sum() / n_rays) if n_rays else math.nan for c in columns}


def _leaf_share(shares: pd.DataFrame, kernel: str) -> dict[str, float]:
    """The leaf tests' share of trace time, 1 - null / real, with its interval (NaN without null twins)."""
    share_low = share = share_high = math.nan
    if kernel in shares and shares[kernel].notna().any():
        g = stats.geometric_mean(shares[kernel].dropna())
        share, share_low, share_high = 1 - g.mean, 1 - g.ci_high, 1 - g.ci_low
    return with_ci("leaf_share", share, share_low, share_high)


class _Speeds:
    """One BVH workload's speedups over its baseline, in the BVH and in brute force on its twin."""

    def __init__(self, ran: list[str], baseline: str, batches: pd.DataFrame, pp: pd.DataFrame, spec: Mapping) -> None:
        from ...workloads.kinds import spec_from_dict
        from ...workloads.spec import MeshSpec, workload_id

        self.base = bvh_baseline(ran, baseline)
        self.level = stats.simultaneous_confidence(stats.DEFAULTS.confidence, max(len(ran) - 1, 1))
        self.per_ray = _per_process_wide(batches, "ns")
        mesh = spec_from_dict(dict(spec))
        assert isinstance(mesh, MeshSpec)  # only a mesh has accel "bvh"
        self.twin = workload_id(mesh.brute_twin())
        twin_pp = pp.loc[pp["workload_id"] == self.twin]
        self.brute = twin_pp.pivot(index="process", columns="kernel", values="ns_per_test") if len(twin_pp) else None

    def of(self, kernel: str, margin: float) -> dict[str, Any]:
        base, nan3 = self.base, (math.nan, math.nan, math.nan)
        one = (1.0, 1.0, 1.0)
        speedup = one if kernel == base else paired_time_ratio(self.per_ray, base, kernel, self.level)[:3]
        brute_speedup = nan3
        if self.brute is not None and {base, kernel} <= set(self.brute.columns):
            brute_speedup = one if kernel == base else paired_time_ratio(self.brute, base, kernel, self.level)[:3]
        return {
            "baseline": base,
            **with_ci("speedup", *speedup),
            "verdict": "baseline" if kernel == base else stats.verdict(speedup[1], speedup[2], margin),
            "brute_workload_id": self.twin if self.brute is not None else "",
            **with_ci("brute_speedup", *brute_speedup),
        }
