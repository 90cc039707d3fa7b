"""In a BVH: rays/s, the work per ray and the leaf tests' share of trace time, per kernel."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import pandas as pd

from tribench import stats
from tribench.harness import runfolder

from .frames import paired_time_ratio, table_frame
from .ranking import declared

#: The algorithm whose BVH-capable form the speedups in a BVH are against when the run's
#: baseline has none (the seed's kernels are scalar only): the standard test, as in Baldwin & Weber.
BVH_FALLBACK_ALGORITHM = "moller_trumbore"


_KEY = ["process", "workload_id", "round", "position", "kernel"]


def bvh_baseline(kernels: Sequence[str], baseline: str) -> str:
    """The kernel the speedups on a BVH workload are against, from those that ran it (sweep order).

    The run's baseline if it ran there; else its algorithm's first form that
    did (``ext.kernel_info(k).algorithm``); else :data:`BVH_FALLBACK_ALGORITHM`'s;
    else the first kernel.

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
    """Per BVH workload and kernel: end-to-end rays/s, the work per ray, the leaf tests' share of trace
    time, and the speedup over a baseline beside the same speedup in brute force (``bvh.csv``).

    ``batches`` and ``traversals`` as :mod:`~tribench.harness.runfolder` reads them,
    ``wl`` the workload table, ``pp`` the per-process values (``per_process.csv``),
    ``kernels`` in sweep order, ``baseline`` the run's.
    Rays/s: per process the median over its timed batches of ``loops x rays /
    elapsed``, geometric mean over processes (``stats.geometric_mean``). The
    leaf share is ``1 - null / real`` with ``null / real`` per process the
    median of each batch's ratio to its null-leaf twin (``traversals.csv``),
    geometric mean over processes. Speedups are paired per-process ratios
    (``stats.speedup``) with Bonferroni-simultaneous intervals over the
    workload's kernels: of ns per ray in the BVH, of ns per test in brute force
    on the brute-force twin (:func:`bvh_baseline` on both). A run without a
    BVH workload gives an empty table.
    """
    from tribench.workloads.kinds import spec_from_dict
    from tribench.workloads.spec import MeshSpec, workload_id

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
        base = bvh_baseline(ran, baseline)
        level = stats.simultaneous_confidence(stats.DEFAULTS.confidence, max(len(ran) - 1, 1))
        per_ray = _per_process_wide(b.assign(ns=b["elapsed_ns"] / (b["loops"] * rays[wid])), "ns")
        spec = spec_from_dict(dict(specs[wid]))
        assert isinstance(spec, MeshSpec)  # only a mesh has accel "bvh"
        twin = workload_id(spec.brute_twin())
        twin_pp = pp.loc[pp["workload_id"] == twin]
        brute = twin_pp.pivot(index="process", columns="kernel", values="ns_per_test") if len(twin_pp) else None
        t = trav.loc[trav["workload_id"] == wid]
        shares = _per_process_wide(paired.loc[paired["workload_id"] == wid], "null_ratio")
        w = wl.loc[wl["workload_id"] == wid].iloc[0]
        for kernel in ran:
            rate = stats.geometric_mean(1e9 / per_ray[kernel].dropna())
            tk = t.loc[t["kernel"] == kernel]
            n_rays = tk["rays"].sum()

            def per(column: str, tk: pd.DataFrame = tk, n_rays: float = n_rays) -> float:
                return float(tk[column].sum() / n_rays) if n_rays else math.nan

            share_low = share = share_high = math.nan
            if kernel in shares and shares[kernel].notna().any():
                g = stats.geometric_mean(shares[kernel].dropna())
                share, share_low, share_high = 1 - g.mean, 1 - g.ci_high, 1 - g.ci_low
            nan3 = (math.nan, math.nan, math.nan)
            speedup = (1.0, 1.0, 1.0) if kernel == base else paired_time_ratio(per_ray, base, kernel, level)[:3]
            brute_speedup = nan3
            if brute is not None and {base, kernel} <= set(brute.columns):
                brute_speedup = (1.0, 1.0, 1.0) if kernel == base else paired_time_ratio(brute, base, kernel, level)[:3]
            rows.append(
                {
                    "workload_id": wid,
                    "family": w["family"],
                    "label": w["label"],
                    "dtype": w["dtype"],
                    "rays_kind": specs[wid].get("rays"),
                    "triangles": w["triangles"],
                    "kernel": kernel,
                    "algorithm": declared(kernel, "algorithm"),
                    "rays_per_s": rate.mean,
                    "rays_per_s_ci_low": rate.ci_low,
                    "rays_per_s_ci_high": rate.ci_high,
                    "n_processes": rate.n,
                    "nodes_per_ray": per("nodes"),
                    "box_tests_per_ray": per("box_tests"),
                    "leaves_per_ray": per("leaves"),
                    "triangle_tests_per_ray": per("triangle_tests"),
                    "null_nodes_per_ray": per("null_nodes"),
                    "leaf_share": share,
                    "leaf_share_ci_low": share_low,
                    "leaf_share_ci_high": share_high,
                    "baseline": base,
                    "speedup": speedup[0],
                    "speedup_ci_low": speedup[1],
                    "speedup_ci_high": speedup[2],
                    "verdict": "baseline" if kernel == base else stats.verdict(speedup[1], speedup[2], margin),
                    "brute_workload_id": twin if brute is not None else "",
                    "brute_speedup": brute_speedup[0],
                    "brute_speedup_ci_low": brute_speedup[1],
                    "brute_speedup_ci_high": brute_speedup[2],
                }
            )
    return table_frame(rows, runfolder.BVH)
