"""Tidy tables behind the report's figures, derived from one run folder.

Every interval, slope, crossover, drift test, outlier label and variance
component here is a call into :mod:`tribench.harness.stats`; this module only
selects, pairs and reshapes. Each function maps a :class:`RunData` (and the
workloads) to a DataFrame, so a figure or a table is a function of that frame.
"""

from __future__ import annotations

import itertools
import math
import warnings
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd

from .rundata import RunData, family_of, short_label, spec_text

__all__ = [
    "WorkloadInfo",
    "workload_table",
    "load_workloads",
    "kernel_table",
    "per_process_table",
    "crossovers",
    "scaling_slopes",
    "drift_table",
    "variance_table",
    "outlier_table",
    "warmup_table",
    "correctness_table",
    "batch_table",
]


@dataclass
class WorkloadInfo:
    """A workload of the run: its spec, and the workload itself when available."""

    workload_id: str
    spec: dict[str, Any]
    workload: Any  # tribench.workloads.Workload or None
    note: str  # how it was obtained ("cache", "rebuilt from its spec ...", or why not)


def load_workloads(data: RunData) -> dict[str, WorkloadInfo]:
    """Every workload of the run from the cache, rebuilt from its spec if absent.

    Workloads are pure functions of their spec, so a rebuilt one has the same
    bytes; if the rebuilt id differs (another generator version) it is not
    used and the note says so.
    """
    from tribench.workloads import cache
    from tribench.workloads.kinds import spec_from_dict
    from tribench.workloads.spec import workload_id

    out = {}
    for wid in data.workload_ids:
        spec = data.specs[wid]
        workload, note = None, "cache"
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                workload = cache.load(wid)
        except (FileNotFoundError, ValueError):
            try:
                rebuilt = spec_from_dict(spec)
                if workload_id(rebuilt) != wid:
                    note = ("not in the cache, and its spec now gives another id "
                            f"({workload_id(rebuilt)}): generator or mesh file changed; not shown")
                else:
                    workload = cache.make(rebuilt)
                    note = "not in the cache: rebuilt from the spec recorded in run.json (same bytes)"
            except Exception as exc:  # a mesh file that moved, a spec of another version...
                note = f"not in the cache and cannot be rebuilt ({type(exc).__name__}: {exc})"
        out[wid] = WorkloadInfo(wid, spec, workload, note)
    return out


def _bytes_per_triangle(kernel: str, dtype: str) -> int | None:
    from tribench import ext

    try:
        return int(ext.bytes_per_triangle(kernel, dtype))
    except (ValueError, TypeError, KeyError):
        return None


def workload_table(data: RunData, workloads: dict[str, WorkloadInfo]) -> pd.DataFrame:
    """One row per workload: family, label and the achieved figures.

    Columns: ``workload_id, kind, family, label, summary, dtype, triangles,
    rays, tests_per_pass, test_hit_rate, ray_hit_rate, source``. Hit rates
    are achieved values (per-test: fraction of ray-triangle tests that hit;
    per-ray: fraction of rays that hit anything); nan where not defined.
    """
    rows = []
    for wid in data.workload_ids:
        spec = data.specs[wid]
        info = workloads.get(wid)
        a = dict(info.workload.achieved) if info and info.workload is not None else {}
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
        rows.append({
            "workload_id": wid, "kind": spec["kind"], "family": family_of(spec),
            "label": short_label(spec), "summary": spec_text(spec), "dtype": spec.get("dtype", "float64"),
            "triangles": triangles, "rays": rays, "tests_per_pass": tests,
            "test_hit_rate": test_rate, "ray_hit_rate": ray_rate,
            "source": info.note if info else "cache",
        })
    return pd.DataFrame(rows)


def working_set_bytes(kernel: str, dtype: str, triangles: float, rays: float) -> float:
    """Bytes of prepared triangles plus rays (origin and direction, 3 components each)."""
    per = _bytes_per_triangle(kernel, dtype)
    if per is None or pd.isna(triangles) or pd.isna(rays):
        return math.nan
    return float(triangles) * per + float(rays) * 6 * np.dtype(dtype).itemsize


def estimates_table(data: RunData, wl: pd.DataFrame) -> pd.DataFrame:
    """``estimates.csv`` joined with the workload table and the working-set size."""
    est = data.estimates.merge(wl, on="workload_id", how="left", suffixes=("", "_wl"))
    est["working_set_bytes"] = [
        working_set_bytes(r.kernel, r.dtype, r.triangles, r.rays) for r in est.itertuples(index=False)
    ]
    return est


def _form(kernel: str) -> str:
    from tribench import ext

    try:
        lanes = ext.kernel_info(kernel).lanes
    except ValueError:  # a kernel this build no longer has
        return "?"
    return "scalar" if lanes == 1 else f"{lanes} lanes"


def _isas(data: RunData, kernel: str) -> str:
    """The instruction sets the kernel's batches ran with (run.json's record for older runs)."""
    if "isa" not in data.batches:
        return str(data.run.get("isa", {}).get(kernel, "?"))
    return ", ".join(dict.fromkeys(data.batches.loc[data.batches["kernel"] == kernel, "isa"].astype(str)))


def kernel_table(data: RunData, est: pd.DataFrame, spd: pd.DataFrame) -> pd.DataFrame:
    """Per kernel and workload family: how the kernel stores a triangle, beside how fast it ran there.

    ``est`` and ``spd`` are the estimates and speedups joined with the workload
    table (``family``, and ``dtype`` in ``est``). Columns ``kernel, form, isa,
    family, dtype, bytes_per_triangle, workloads, ops_per_test,
    peak_fraction_median, ns_per_test_median,
    ns_per_test_min, ns_per_test_max, ratio_median, ratio_min, ratio_max,
    verdicts``: ``form`` is ``scalar`` or ``N lanes``, ``isa`` what its batches
    ran with, ``bytes_per_triangle`` its prepared data per triangle at the
    family's precision (one per family), ``ops_per_test`` its documented
    arithmetic and ``peak_fraction_median`` the median over the family's
    workloads of its fraction of the arithmetic bound (nan in runs without
    peak probes). The times summarise the estimates of
    the family's workloads and the ratios their speedups over the baseline
    (median, lowest, highest; nan for the baseline); ``verdicts`` counts those
    workloads by verdict. Families where the kernel has no estimate (a wide
    kernel has no pairs mode) have no row.
    """
    rows = []
    for kernel in data.kernels:
        form, isa = _form(kernel), _isas(data, kernel)
        for family, g in est.loc[est["kernel"] == kernel].groupby("family", sort=False):
            s = spd.loc[(spd["kernel"] == kernel) & (spd["family"] == family)]
            dtype = str(g["dtype"].iloc[0])
            verdicts = ", ".join(f"{v} {n}" for v, n in s["verdict"].value_counts(sort=False).items())
            rows.append({
                "kernel": kernel, "form": form, "isa": isa, "family": family, "dtype": dtype,
                "bytes_per_triangle": _bytes_per_triangle(kernel, dtype), "workloads": len(g),
                "ops_per_test": g["ops_per_test"].iloc[0] if "ops_per_test" in g else math.nan,
                "peak_fraction_median": g["peak_fraction"].median() if "peak_fraction" in g else math.nan,
                "ns_per_test_median": g["ns_per_test"].median(), "ns_per_test_min": g["ns_per_test"].min(),
                "ns_per_test_max": g["ns_per_test"].max(),
                "ratio_median": s["ratio"].median() if len(s) else math.nan,
                "ratio_min": s["ratio"].min() if len(s) else math.nan,
                "ratio_max": s["ratio"].max() if len(s) else math.nan,
                "verdicts": verdicts or ("baseline" if kernel == data.baseline else "no comparison"),
            })
    return pd.DataFrame(rows, columns=["kernel", "form", "isa", "family", "dtype", "bytes_per_triangle",
                                       "workloads", "ops_per_test", "peak_fraction_median", "ns_per_test_median", "ns_per_test_min", "ns_per_test_max",
                                       "ratio_median", "ratio_min", "ratio_max", "verdicts"])


def per_process_table(data: RunData) -> pd.DataFrame:
    """``stats.per_process`` of the batches: one median ns/test per kernel, workload, process."""
    from tribench import stats

    return stats.per_process(data.batches)


def _wide(pp: pd.DataFrame, kernel: str, wids: list[str]) -> pd.DataFrame:
    sub = pp.loc[(pp["kernel"] == kernel) & pp["workload_id"].isin(wids)]
    return sub.pivot(index="process", columns="workload_id", values="ns_per_test").reindex(columns=wids)


def crossovers(data: RunData, wl: pd.DataFrame, pp: pd.DataFrame) -> pd.DataFrame:
    """Per pair family and pair of kernels: where their ranking flips along the per-test hit rate.

    Columns ``family, kernel_a, kernel_b, hit_rate, ci_low, ci_high, slope,
    n``: ``stats.crossover`` of ``log(time_b / time_a)`` against the achieved
    per-test hit rate, processes paired across the family's workloads. Only
    families with two or more hit rates; ``hit_rate`` is nan when the lines
    do not cross inside the measured range.
    """
    from tribench import stats

    rows = []
    for family, group in wl.loc[wl["kind"] == "pairs"].groupby("family", sort=False):
        group = group.sort_values("test_hit_rate")
        if group["test_hit_rate"].nunique() < 2:
            continue
        wids = list(group["workload_id"])
        for a, b in itertools.combinations(data.kernels, 2):
            wa, wb = _wide(pp, a, wids), _wide(pp, b, wids)
            both = (np.log(wb) - np.log(wa)).dropna()
            if len(both) < 2:
                continue
            c = stats.crossover(group["test_hit_rate"].to_numpy(), both.to_numpy())
            rows.append({"family": family, "kernel_a": a, "kernel_b": b, "hit_rate": c.hit_rate,
                         "ci_low": c.ci_low, "ci_high": c.ci_high, "slope": c.slope, "n": c.n,
                         "confidence": c.confidence})
    return pd.DataFrame(rows, columns=["family", "kernel_a", "kernel_b", "hit_rate", "ci_low", "ci_high",
                                       "slope", "n", "confidence"])


def scaling_slopes(data: RunData, est: pd.DataFrame, pp: pd.DataFrame) -> pd.DataFrame:
    """Log-log slope of ns/test against triangle count, per mesh family and kernel.

    Columns ``family, kernel, slope, ci_low, ci_high, n, sizes``
    (``stats.scaling_slope``, processes paired across triangle counts).
    """
    from tribench import stats

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
        rows.append({"family": family, "kernel": kernel, "slope": s.slope, "ci_low": s.ci_low,
                     "ci_high": s.ci_high, "n": s.n, "sizes": len(group)})
    return pd.DataFrame(rows, columns=["family", "kernel", "slope", "ci_low", "ci_high", "n", "sizes"])


def drift_table(data: RunData, wl: pd.DataFrame) -> pd.DataFrame:
    """``stats.drift`` of every kernel against the baseline on every workload.

    Columns ``workload_id, label, kernel, baseline_slope, ratio_slope,
    ratio_p, ratio_change, confound_bias, confound_p, flagged, reason, n``;
    ``reason`` explains a comparison that could not be tested.
    """
    from tribench import stats

    rows = []
    labels = dict(zip(wl["workload_id"], wl["label"]))
    for wid in data.workload_ids:
        for kernel in data.kernels:
            if kernel == data.baseline:
                continue
            row = {"workload_id": wid, "label": labels.get(wid, wid), "kernel": kernel}
            try:
                d = stats.drift(data.batches, kernel, data.baseline, workload_id=wid)
            except ValueError as exc:
                row.update(flagged=False, reason=f"not tested: {exc}")
            else:
                row.update(baseline_slope=d.baseline_slope, ratio_slope=d.ratio_slope, ratio_p=d.ratio_p,
                           ratio_change=d.ratio_change, confound_bias=d.confound_bias,
                           confound_p=d.confound_p, flagged=d.flagged, reason=d.reason, n=d.n)
            rows.append(row)
    return pd.DataFrame(rows, columns=["workload_id", "label", "kernel", "baseline_slope", "ratio_slope",
                                       "ratio_p", "ratio_change", "confound_bias", "confound_p", "flagged",
                                       "reason", "n"])


def variance_table(data: RunData, wl: pd.DataFrame) -> pd.DataFrame:
    """Kalibera-Jones variance components per kernel and workload.

    Columns ``workload_id, label, kernel, mean_ns, round_sd_pct,
    process_sd_pct, n_processes, n_rounds``: square roots of
    ``stats.variance_components`` relative to the mean, in percent.
    """
    from tribench import stats

    rows = []
    labels = dict(zip(wl["workload_id"], wl["label"]))
    for wid in data.workload_ids:
        for kernel in data.kernels:
            try:
                vc = stats.variance_components(stats.rounds_matrix(data.batches, kernel, wid))
            except ValueError:
                continue
            rows.append({"workload_id": wid, "label": labels.get(wid, wid), "kernel": kernel, "mean_ns": vc.mean,
                         "round_sd_pct": 100 * math.sqrt(vc.between_round) / vc.mean,
                         "process_sd_pct": 100 * math.sqrt(vc.between_process) / vc.mean,
                         "n_processes": vc.n_processes, "n_rounds": vc.n_rounds})
    return pd.DataFrame(rows, columns=["workload_id", "label", "kernel", "mean_ns", "round_sd_pct",
                                       "process_sd_pct", "n_processes", "n_rounds"])


def batch_table(data: RunData) -> pd.DataFrame:
    """Every batch with ``ns_per_test``, Tukey labels (``stats.label_outliers``),
    ``rel_to_median`` (ns/test over its process's timed median for that kernel and
    workload) and ``t_in_process_s`` (seconds since the process's first batch)."""
    from tribench import stats

    b = stats.label_outliers(data.batches)
    timed = b.loc[~b["warmup"]]
    med = timed.groupby(["kernel", "workload_id", "process"])["ns_per_test"].median().rename("median_ns")
    b = b.join(med, on=["kernel", "workload_id", "process"])
    start = b.groupby(["process", "attempt"])["start_ns"].transform("min")
    return b.assign(rel_to_median=b["ns_per_test"] / b["median_ns"], t_in_process_s=(b["start_ns"] - start) * 1e-9)


def outlier_table(batches: pd.DataFrame, wl: pd.DataFrame) -> pd.DataFrame:
    """Counts of Tukey-labelled batches (kept, never dropped) per kernel and workload."""
    timed = batches.loc[~batches["warmup"]]
    g = timed.groupby(["workload_id", "kernel"], sort=False)
    out = pd.DataFrame({"batches": g.size(), "outliers": g["outlier"].sum(), "far_out": g["far_out"].sum(),
                        "worst_rel": g["rel_to_median"].max()}).reset_index()
    out["label"] = out["workload_id"].map(dict(zip(wl["workload_id"], wl["label"])))
    return out


def warmup_table(batches: pd.DataFrame, wl: pd.DataFrame) -> pd.DataFrame:
    """Warm-up against timed batches: median of ``ns/test / process median`` of each."""
    g = batches.groupby(["workload_id", "kernel", "warmup"])["rel_to_median"].median().unstack("warmup")
    out = pd.DataFrame({
        "warmup_rel": g.get(True, pd.Series(np.nan, index=g.index)),
        "warmup_batches": batches.loc[batches["warmup"]].groupby(["workload_id", "kernel"]).size(),
    }).reset_index()
    out["warmup_batches"] = out["warmup_batches"].fillna(0).astype(int)
    out["label"] = out["workload_id"].map(dict(zip(wl["workload_id"], wl["label"])))
    return out


def correctness_table(data: RunData, workloads: dict[str, WorkloadInfo]) -> pd.DataFrame:
    """Each kernel's checksums against the float64 reference, per workload.

    Columns ``kernel, workload_id, batches, ref_hits, hits_per_pass_min,
    hits_per_pass_max, hit_difference, ambiguous_rays, t_sum_rel_diff,
    agrees``. ``hits_per_pass`` is a batch's hit count over its loops; the
    difference to the reference may only come from ambiguous rays (rays
    within 1e-5 barycentric of an edge, whose answer legitimately depends on
    rounding). ``t_sum_rel_diff`` is the largest relative difference between
    a batch's sum of t per pass and the reference's.
    """
    rows = []
    for (wid, kernel), g in data.batches.groupby(["workload_id", "kernel"], sort=False):
        info = workloads.get(wid)
        hits = g["hits"] / g["loops"]
        row = {"kernel": kernel, "workload_id": wid, "batches": len(g),
               "hits_per_pass_min": float(hits.min()), "hits_per_pass_max": float(hits.max())}
        if info is not None and info.workload is not None:
            w = info.workload
            ref_hits, ref_t = w.expected_checksum()
            ambiguous = int(w.ambiguous().sum())
            diff = float(np.max(np.abs(hits - ref_hits)))
            rel = float(np.max(np.abs(g["t_sum"] / g["loops"] - ref_t))) / abs(ref_t) if ref_t else 0.0
            row.update(ref_hits=ref_hits, hit_difference=diff, ambiguous_rays=ambiguous, t_sum_rel_diff=rel,
                       agrees=bool(diff <= ambiguous and hits.nunique() == 1))
        else:
            row.update(ref_hits=np.nan, hit_difference=np.nan, ambiguous_rays=np.nan, t_sum_rel_diff=np.nan,
                       agrees=None)
        rows.append(row)
    order = {k: i for i, k in enumerate(data.kernels)}
    out = pd.DataFrame(rows, columns=["kernel", "workload_id", "batches", "ref_hits", "hits_per_pass_min",
                                      "hits_per_pass_max", "hit_difference", "ambiguous_rays", "t_sum_rel_diff",
                                      "agrees"])
    return out.sort_values("kernel", key=lambda s: s.map(order), kind="stable").reset_index(drop=True)
