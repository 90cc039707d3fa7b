"""Which kernel to use: per workload, per algorithm and per band, every kernel from the fastest down."""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import pandas as pd

from ...harness import runfolder, stats
from .frames import paired_time_ratio, table_frame, with_ci


def _bytes_per_triangle(kernel: str, dtype: str) -> int | None:
    from ... import ext

    try:
        return int(ext.bytes_per_triangle(kernel, dtype))
    except (ValueError, TypeError, KeyError):
        return None


def _form(kernel: str) -> str:
    lanes = declared(kernel, "lanes")  # None: a kernel this build no longer has
    return "?" if lanes is None else "scalar" if lanes == 1 else f"{lanes} lanes"


def _isas(batches: pd.DataFrame, kernel: str) -> str:
    """The instruction sets the kernel's batches ran with."""
    return ", ".join(dict.fromkeys(batches.loc[batches["kernel"] == kernel, "isa"].astype(str)))


def kernel_table(
    kernels: Sequence[str],
    batches: pd.DataFrame,
    est: pd.DataFrame,
    spd: pd.DataFrame,
    baseline: str,
) -> pd.DataFrame:
    """Per kernel and workload family: how the kernel stores a triangle, beside how fast it ran there (``kernels.csv``).

    ``est`` and ``spd``: joined with the workload table (:func:`estimates_with_workloads`).
    A family where the kernel has no estimate (a wide kernel on pairs) has no row."""
    rows = []
    for kernel in kernels:
        form, isa = _form(kernel), _isas(batches, kernel)
        for family, g in est.loc[est["kernel"] == kernel].groupby("family", sort=False):
            s = spd.loc[(spd["kernel"] == kernel) & (spd["family"] == family)]
            dtype = str(g["dtype"].iloc[0])
            verdicts = ", ".join(f"{v} {n}" for v, n in s["verdict"].value_counts(sort=False).items())
            rows.append(
                {
                    "kernel": kernel,
                    "form": form,
                    "isa": isa,
                    "family": family,
                    "dtype": dtype,
                    "bytes_per_triangle": _bytes_per_triangle(kernel, dtype),
                    "workloads": len(g),
                    "ops_per_test": g["ops_per_test"].iloc[0],
                    "peak_fraction_median": g["peak_fraction"].median(),
                    "ns_per_test_median": g["ns_per_test"].median(),
                    "ns_per_test_min": g["ns_per_test"].min(),
                    "ns_per_test_max": g["ns_per_test"].max(),
                    "ratio_median": s["ratio"].median() if len(s) else math.nan,
                    "ratio_min": s["ratio"].min() if len(s) else math.nan,
                    "ratio_max": s["ratio"].max() if len(s) else math.nan,
                    "verdicts": verdicts or ("baseline" if kernel == baseline else "no comparison"),
                }
            )
    return table_frame(rows, runfolder.KERNELS)


def declared(kernel: str, field: str) -> Any:
    """A declared property of the kernel (watertight as a bool); None for a kernel this build lacks."""
    from ... import ext

    try:
        info = ext.kernel_info(kernel)
    except ValueError:
        return None
    return info.watertight != "none" if field == "watertight" else getattr(info, field)


def _ranked(rank: int, kernel: str, dtype: str, against: tuple[pd.DataFrame, str, float], margin: float) -> dict:
    """The columns ranking.csv and bands.csv share: the kernel's rank, its time over the fastest's (``against``:
    the per-process values, the fastest kernel and the interval's level), whether it is tied with the fastest,
    and what it declares."""
    per, fastest, level = against
    ratio, low, high = (1.0, 1.0, 1.0) if kernel == fastest else paired_time_ratio(per, kernel, fastest, level)[:3]
    return {
        "rank": rank,
        "kernel": kernel,
        "algorithm": declared(kernel, "algorithm"),
        "form": _form(kernel),
        **with_ci("vs_fastest", ratio, low, high),
        "tied_with_fastest": bool(low <= 1 + margin),  # False where there is no interval (NaN)
        "watertight": declared(kernel, "watertight"),
        "culls_back_faces": declared(kernel, "culls_back_faces"),
        "bytes_per_triangle": _bytes_per_triangle(kernel, dtype),
    }


def ranking_table(
    est: pd.DataFrame,
    spd: pd.DataFrame,
    pp: pd.DataFrame,
    margin: float,
    val: pd.DataFrame | None = None,
    baseline: str | None = None,
) -> pd.DataFrame:
    """Per workload, every kernel from the fastest down, each against the fastest (``ranking.csv``).

    Paired ratios with Bonferroni intervals over the workload's other kernels. A kernel is tied with the fastest
    when its interval reaches down to ``1 + margin``: the fastest by point estimate is no evidence it beats those.
    ``val`` (``validate.csv``, optional) adds each kernel's measured failures. ``baseline``: the run's (default:
    the speedups'); on a workload it did not run (a BVH's) no kernel has a speedup, and none is the baseline."""
    if baseline is None:
        baseline = str(spd["baseline"].iloc[0]) if len(spd) else ""
    rows = []
    for wid, g in est.groupby("workload_id", sort=False):
        g = g.sort_values(["ns_per_test", "kernel"]).reset_index(drop=True)
        fastest = str(g["kernel"].iloc[0])
        per = pp.loc[pp["workload_id"] == wid].pivot(index="process", columns="kernel", values="ns_per_test")
        level = stats.simultaneous_confidence(stats.DEFAULTS.confidence, max(len(g) - 1, 1))
        s = spd.loc[spd["workload_id"] == wid].set_index("kernel")
        for rank, r in enumerate(g.itertuples(index=False), start=1):
            kernel = str(r.kernel)
            if kernel in s.index:
                speedup = tuple(s.loc[kernel, ["ratio", "ratio_ci_low", "ratio_ci_high"]])
            else:
                speedup = (1.0 if kernel == baseline else math.nan, math.nan, math.nan)
            rows.append(
                {
                    "workload_id": wid,
                    "family": r.family,
                    "label": r.label,
                    "dtype": r.dtype,
                    **with_ci("ns_per_test", r.ns_per_test, r.ns_per_test_ci_low, r.ns_per_test_ci_high),
                    **with_ci("speedup", *speedup),
                    "baseline": baseline,
                    **_ranked(rank, kernel, str(r.dtype), (per, fastest, level), margin),
                    **measured_robustness(val, kernel, str(r.dtype)),
                }
            )
    return table_frame(rows, runfolder.RANKING)


def algorithm_table(rank: pd.DataFrame, pp: pd.DataFrame, margin: float) -> pd.DataFrame:
    """Per workload, every pair of algorithms, each in its fastest form there (``algorithms.csv``).

    A form is chosen by ``rank``'s point estimate; each pair is a paired ratio,
    Bonferroni over the workload's pairs, the faster first so the ratio is at least 1."""
    rows = []
    for wid, g in rank.groupby("workload_id", sort=False):
        best = g.sort_values("rank").drop_duplicates("algorithm")
        best = best.loc[best["algorithm"].notna()]
        pairs = list(itertools.combinations(best.itertuples(index=False), 2))
        per = pp.loc[pp["workload_id"] == wid].pivot(index="process", columns="kernel", values="ns_per_test")
        level = stats.simultaneous_confidence(stats.DEFAULTS.confidence, max(len(pairs), 1))
        for a, b in pairs:  # a ranks before b
            ratio, low, high, n = paired_time_ratio(per, b.kernel, a.kernel, level)
            rows.append(
                {
                    "workload_id": wid,
                    "family": a.family,
                    "label": a.label,
                    "dtype": a.dtype,
                    "algorithm": a.algorithm,
                    "kernel": a.kernel,
                    "other_algorithm": b.algorithm,
                    "other_kernel": b.kernel,
                    "ratio": ratio,
                    "ratio_ci_low": low,
                    "ratio_ci_high": high,
                    "n_processes": n,
                    "confidence": level,
                    "verdict": stats.verdict(low, high, margin),
                }
            )
    return table_frame(rows, runfolder.ALGORITHMS)


#: Edges of the per-test hit-rate bands of pair workloads: low below the first, high from the second on.
BAND_EDGES = (0.35, 0.65)


def band_of(kind: str, test_hit_rate: float, accel: str | None = None) -> str:
    """The band of a workload in the report's first table: pairs by per-test hit rate, meshes by accel.

    >>> band_of("pairs", 0.3), band_of("pairs", 0.5), band_of("pairs", 1.0)
    ('pairs, hit rate 0–35%', 'pairs, hit rate 35–65%', 'pairs, hit rate 65–100%')
    >>> band_of("mesh", float("nan")), band_of("mesh", 0.01, "bvh")
    ('meshes, brute force', 'meshes, in a BVH')
    """
    if kind != "pairs":
        return "meshes, in a BVH" if accel == "bvh" else "meshes, brute force"
    low, high = BAND_EDGES
    if test_hit_rate < low:
        return f"pairs, hit rate 0–{100 * low:.0f}%"
    if test_hit_rate < high:
        return f"pairs, hit rate {100 * low:.0f}–{100 * high:.0f}%"
    return f"pairs, hit rate {100 * high:.0f}–100%"


#: validate.csv's tests whose failures the first table counts: the test, then the columns of its failures
#: per million rays and of the rays they come from.
ROBUSTNESS_TESTS = {
    "shared_edges": ("cracks_per_million", "shared_edge_rays"),
    "inside_sphere": ("sphere_misses_per_million", "sphere_rays"),
}


def _validated(val: pd.DataFrame | None, kernel: str, dtype: str) -> pd.DataFrame:
    """validate.csv's rows of one kernel at one precision (none without it): float32 says nothing of float64."""
    if val is None or val.empty:
        return pd.DataFrame()
    return val.loc[(val["kernel"] == kernel) & (val["dtype"] == dtype)]


def measured_robustness(val: pd.DataFrame | None, kernel: str, dtype: str) -> dict[str, Any]:
    """The failures users compare, from validate.csv: per test of :data:`ROBUSTNESS_TESTS`, per million rays
    and the rays they come from (NaN without the table or the row).

    >>> val = pd.DataFrame({"kernel": ["a", "a"], "dtype": ["float32", "float64"], "test": ["shared_edges"] * 2,
    ...     "rays": [200, 200], "rate": [0.005, 0.0]})
    >>> r = measured_robustness(val, "a", "float32")
    >>> r["cracks_per_million"], r["shared_edge_rays"], r["sphere_rays"]
    (5000.0, 200, nan)
    """
    out: dict[str, Any] = {column: math.nan for columns in ROBUSTNESS_TESTS.values() for column in columns}
    rows = _validated(val, kernel, dtype)
    for test, (per_million, rays) in ROBUSTNESS_TESTS.items():
        row = rows.loc[rows["test"] == test] if len(rows) else rows
        if len(row):
            out[per_million], out[rays] = 1e6 * float(row["rate"].iloc[0]), int(row["rays"].iloc[0])
    return out


def _robustness(val: pd.DataFrame | None, kernel: str, dtype: str) -> dict[str, Any]:
    """validate.csv's figures of one kernel and precision for bands.csv (NaN without): promises, then failures."""
    rows = _validated(val, kernel, dtype)
    out: dict[str, Any] = {"promises_checked": math.nan, "broken_promises": math.nan}
    if len(rows):
        out["promises_checked"] = int((rows["verdict"] != "measured").sum())
        out["broken_promises"] = int((rows["verdict"] == "fail").sum())
    return out | measured_robustness(val, kernel, dtype)


def band_table(
    est: pd.DataFrame,
    pp: pd.DataFrame,
    specs: Mapping[str, Mapping[str, Any]],
    baseline: str,
    margin: float,
    val: pd.DataFrame | None = None,
) -> pd.DataFrame:
    """Per precision and hit-rate band (:func:`band_of`), every kernel from the fastest down (``bands.csv``).

    A band holds the kernels timed on all its workloads; a kernel's value in a process is the geometric mean of its
    medians over them, so each workload weighs the same whatever its ns/test. Then as :func:`ranking_table`: a mean
    with its t interval, paired ratios to the fastest and from the baseline."""
    frame = est.assign(
        band=[
            band_of(str(r.kind), float(r.test_hit_rate), specs.get(r.workload_id, {}).get("accel"))
            for r in est.itertuples(index=False)
        ]
    )
    order = {b: i for i, b in enumerate(band_of(*a) for a in (("pairs", 0), ("pairs", 0.5), ("pairs", 1), ("mesh", 0)))}
    keys = sorted(frame.groupby(["dtype", "band"]).groups, key=lambda k: (k[0], order.get(k[1], len(order)), k[1]))
    rows: list[dict[str, Any]] = []
    for dtype, band in keys:
        g = frame.loc[(frame["dtype"] == dtype) & (frame["band"] == band)]
        n_workloads, per = _band_values(g, pp)
        if len(per.columns):
            rows += _band_rows(str(dtype), band, n_workloads, per, baseline, margin, val)
    return table_frame(rows, runfolder.BANDS)


def _band_values(g: pd.DataFrame, pp: pd.DataFrame) -> tuple[int, pd.DataFrame]:
    """A band's workload count, and per process and kernel the geometric mean of the kernel's medians
    over the band's workloads (kernels timed on all, processes that ran them all)."""
    wids = list(dict.fromkeys(g["workload_id"]))
    kernels = [k for k, n in g.groupby("kernel", sort=False)["workload_id"].nunique().items() if n == len(wids)]
    sub = pp.loc[pp["workload_id"].isin(wids) & pp["kernel"].isin(kernels)]
    logs = sub.assign(log=np.log(sub["ns_per_test"])).groupby(["process", "kernel"])["log"].agg(["mean", "size"])
    logs = logs.loc[logs["size"] == len(wids), "mean"]  # processes that ran every workload of the band
    per = np.exp(logs.unstack("kernel")) if len(logs) else pd.DataFrame()
    return len(wids), per[[k for k in kernels if k in per and per[k].notna().sum() >= 1]]


def _band_rows(
    dtype: str,
    band: str,
    n_workloads: int,
    per: pd.DataFrame,
    baseline: str,
    margin: float,
    val: pd.DataFrame | None,
) -> list[dict[str, Any]]:
    """One band's kernels from the fastest down, each against the fastest and from the baseline."""
    kernels = list(per.columns)
    estimates = {k: stats.estimate(per[k].dropna()) for k in kernels}
    ranked = sorted(kernels, key=lambda k: (estimates[k].mean, k))
    fastest = ranked[0]
    level = stats.simultaneous_confidence(stats.DEFAULTS.confidence, max(len(ranked) - 1, 1))
    rows = []
    for rank, kernel in enumerate(ranked, start=1):
        e = estimates[kernel]
        if kernel == baseline:
            speedup = (1.0, math.nan, math.nan)
        elif baseline in per:
            speedup = paired_time_ratio(per, baseline, kernel, level)[:3]
        else:
            speedup = (math.nan, math.nan, math.nan)
        rows.append(
            {
                "dtype": dtype,
                "band": band,
                "workloads": n_workloads,
                **with_ci("ns_per_test", e.mean, e.ci_low, e.ci_high),
                **with_ci("speedup", *speedup),
                "baseline": baseline,
                "n_processes": e.n,
                **_ranked(rank, kernel, dtype, (per, fastest, level), margin),
                **_robustness(val, kernel, dtype),
            }
        )
    return rows
