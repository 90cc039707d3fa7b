"""The derived tables of a run beyond estimates and speedups: pure functions of frames.

Every interval, slope, crossover, drift test, outlier label and variance
component is a call into :mod:`tribench.stats`; this module selects,
pairs and reshapes. :func:`tribench.analysis.pipeline.write_all` calls these
at the end of a sweep (and ``tribench stats``) and writes each result into
the run folder (columns: :data:`tribench.harness.runfolder.FILES`), so the
report reads them and computes nothing.

Arguments are plain: the batches as :func:`~tribench.harness.runfolder.read_batches`
gives them, ``kernels`` and ``workload_ids`` in sweep order (those with
batches), ``specs`` mapping a workload id to its spec dict (``run.json``).
"""

from __future__ import annotations

import itertools
import json
import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from tribench import stats
from tribench.harness import runfolder

__all__ = [
    "BAND_EDGES",
    "band_of",
    "band_table",
    "batch_labels",
    "bvh_baseline",
    "bvh_table",
    "correctness_table",
    "crossovers",
    "drift_table",
    "estimates_with_workloads",
    "family_of",
    "kernel_table",
    "outlier_table",
    "scaling_slopes",
    "short_label",
    "spec_text",
    "variance_table",
    "warmup_table",
    "workload_figures",
    "workload_table",
]


def _frame(rows: list[dict[str, Any]], name: str) -> pd.DataFrame:
    """Rows as a frame with exactly ``name``'s documented columns, in file order."""
    return pd.DataFrame(rows, columns=list(runfolder.FILES[name]))


# ------------------------------------------------------------ workload labels


def family_of(spec: Mapping[str, Any]) -> str:
    """The family a workload belongs to: its spec without the swept axis.

    Pair workloads that differ only in hit rate form one family (the hit-rate
    curves); mesh workloads that differ only in triangle count form another
    (the scaling curves).

    Examples
    --------
    >>> family_of({"kind": "pairs", "n": 100, "hit_rate": 0.5, "order": "shuffled",
    ...            "shape": "sphere", "dtype": "float64", "seed": 0, "scale": 1.0, "offset": 0.0})
    'pairs n=100 shuffled sphere float64'
    >>> family_of({"kind": "mesh", "mesh": "suzanne", "triangles": 200, "rays": "camera",
    ...            "width": 64, "height": 64, "dtype": "float64", "seed": 0})
    'mesh suzanne camera 64x64 float64'

    A BVH workload is not in its brute-force twin's family (its times per test
    are of another kind: a scaling slope across both would mean nothing):

    >>> family_of({"kind": "mesh", "mesh": "suzanne", "triangles": 200, "rays": "camera",
    ...            "width": 64, "height": 64, "dtype": "float64", "seed": 0, "accel": "bvh"})
    'mesh suzanne camera 64x64 bvh float64'
    """
    if spec.get("kind") == "pairs":
        extra = (
            ""
            if (spec.get("scale", 1.0), spec.get("offset", 0.0)) == (1.0, 0.0)
            else f" scale={spec['scale']:g} offset={spec['offset']:g}"
        )
        mix = spec.get("miss_mix")
        mix_text = ""
        if isinstance(mix, dict) and not _even_edges(mix):
            mix_text = " misses[" + ",".join(f"{k}={v:.2g}" for k, v in mix.items() if v) + "]"
        return (
            f"pairs n={spec.get('n')} {spec.get('order', '')} {spec.get('shape', '')} "
            f"{spec.get('dtype', '')}{mix_text}{extra}"
        ).replace("  ", " ")
    mesh = Path(str(spec.get("mesh", "?"))).name
    if spec.get("rays") == "hit_rate":
        rays = f"{spec.get('n_rays')} rays per-ray hit rate {spec.get('hit_rate'):g}"
    elif spec.get("rays") == "bounce":
        rays = f"bounces of camera {spec.get('width')}x{spec.get('height')}"
    else:
        rays = f"camera {spec.get('width')}x{spec.get('height')}"
    accel = " bvh" if spec.get("accel") == "bvh" else ""
    return f"mesh {mesh} {rays}{accel} {spec.get('dtype', '')}"


def _even_edges(mix: Mapping[str, float]) -> bool:
    edges = [mix.get(f"outside_edge_{i}", 0.0) for i in (1, 2, 3)]
    return all(abs(e - 1 / 3) < 1e-6 for e in edges)


def short_label(spec: Mapping[str, Any]) -> str:
    """What varies inside a family, in words (for table rows and plot labels).

    Examples
    --------
    >>> short_label({"kind": "pairs", "hit_rate": 0.5})
    'per-test hit rate 50%'
    >>> short_label({"kind": "mesh", "mesh": "suzanne", "triangles": None})
    'suzanne, base mesh'
    """
    if spec.get("kind") == "pairs":
        return f"per-test hit rate {100 * spec['hit_rate']:.4g}%"
    count = spec.get("triangles")
    mesh = Path(str(spec.get("mesh", "?"))).name
    return f"{mesh}, {count} triangles" if count else f"{mesh}, base mesh"


def spec_text(spec: Mapping[str, Any]) -> str:
    """The spec's own one-line summary (falls back to JSON for an unknown spec)."""
    try:
        from tribench.workloads.kinds import spec_from_dict

        return spec_from_dict(dict(spec)).summary()
    except Exception:  # an old or foreign spec: still show something true
        return json.dumps(spec, sort_keys=True)


# ------------------------------------------------------------ workloads


def workload_table(
    specs: Mapping[str, Mapping[str, Any]],
    workload_ids: Sequence[str],
    workloads: Mapping[str, Any],
    sources: Mapping[str, str],
) -> pd.DataFrame:
    """One row per workload: family, label and the achieved figures (``workloads.csv``).

    ``workloads`` maps an id to its :class:`~tribench.workloads.Workload` (or
    None when it could not be had); without it the spec's targets stand in.
    Hit rates are achieved values (per-test: fraction of ray-triangle tests
    that hit; per-ray: fraction of rays that hit anything); nan where not defined.
    """
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
    return _frame(rows, runfolder.WORKLOADS)


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
    return _frame(rows, runfolder.WORKLOAD_FIGURES)


def correctness_table(batches: pd.DataFrame, kernels: Sequence[str], workloads: Mapping[str, Any]) -> pd.DataFrame:
    """Each kernel's checksums against the float64 reference, per workload (``correctness.csv``).

    ``hits_per_pass`` is a batch's hit count over its loops; the difference
    to the reference may only come from ambiguous rays (rays within 1e-5
    barycentric of an edge, whose answer legitimately depends on rounding).
    """
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
    order = {k: i for i, k in enumerate(kernels)}
    out = _frame(rows, runfolder.CORRECTNESS)
    return out.sort_values("kernel", key=lambda s: s.map(order), kind="stable").reset_index(drop=True)


# ------------------------------------------------------------ batches


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
    return b[list(runfolder.FILES[runfolder.BATCH_LABELS])].reset_index(drop=True)


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
    return out[list(runfolder.FILES[runfolder.OUTLIERS])]


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
    return out[list(runfolder.FILES[runfolder.WARMUP])]


# ------------------------------------------------------------ statistics over workloads


def _wide(pp: pd.DataFrame, kernel: str, wids: list[str]) -> pd.DataFrame:
    sub = pp.loc[(pp["kernel"] == kernel) & pp["workload_id"].isin(wids)]
    return sub.pivot(index="process", columns="workload_id", values="ns_per_test").reindex(columns=wids)


def crossovers(kernels: Sequence[str], wl: pd.DataFrame, pp: pd.DataFrame) -> pd.DataFrame:
    """Per pair family and pair of kernels: where their ranking flips along the per-test hit rate.

    ``stats.crossover`` of ``log(time_b / time_a)`` against the achieved
    per-test hit rate, processes paired across the family's workloads. Only
    families with two or more hit rates; ``hit_rate`` is nan when the lines
    do not cross inside the measured range.
    """
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
            rows.append(
                {
                    "family": family,
                    "kernel_a": a,
                    "kernel_b": b,
                    "hit_rate": c.hit_rate,
                    "ci_low": c.ci_low,
                    "ci_high": c.ci_high,
                    "slope": c.slope,
                    "n": c.n,
                    "confidence": c.confidence,
                }
            )
    return _frame(rows, runfolder.CROSSOVERS)


def estimates_with_workloads(estimates: pd.DataFrame, wl: pd.DataFrame) -> pd.DataFrame:
    """``estimates.csv`` joined with the workload table (family, kind, triangles, rays...)."""
    return estimates.merge(wl, on="workload_id", how="left", suffixes=("", "_wl"))


def scaling_slopes(est: pd.DataFrame, pp: pd.DataFrame) -> pd.DataFrame:
    """Log-log slope of ns/test against triangle count, per mesh family and kernel (``slopes.csv``).

    ``est`` is :func:`estimates_with_workloads`; ``stats.scaling_slope``,
    processes paired across triangle counts.
    """
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
        rows.append(
            {
                "family": family,
                "kernel": kernel,
                "slope": s.slope,
                "ci_low": s.ci_low,
                "ci_high": s.ci_high,
                "n": s.n,
                "sizes": len(group),
            }
        )
    return _frame(rows, runfolder.SLOPES)


def drift_table(
    batches: pd.DataFrame, kernels: Sequence[str], baseline: str, workload_ids: Sequence[str], wl: pd.DataFrame
) -> pd.DataFrame:
    """``stats.drift`` of every kernel against the baseline on every workload (``drift.csv``);
    ``reason`` explains a comparison that could not be tested."""
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
                row.update(
                    baseline_slope=d.baseline_slope,
                    ratio_slope=d.ratio_slope,
                    ratio_p=d.ratio_p,
                    ratio_change=d.ratio_change,
                    confound_bias=d.confound_bias,
                    confound_p=d.confound_p,
                    flagged=d.flagged,
                    reason=d.reason,
                    n=d.n,
                )
            rows.append(row)
    return _frame(rows, runfolder.DRIFT)


def variance_table(
    batches: pd.DataFrame, kernels: Sequence[str], workload_ids: Sequence[str], wl: pd.DataFrame
) -> pd.DataFrame:
    """Kalibera-Jones variance components per kernel and workload (``variance.csv``): square roots of
    ``stats.variance_components`` relative to the mean, in percent."""
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
    return _frame(rows, runfolder.VARIANCE)


# ------------------------------------------------------------ kernels


def _bytes_per_triangle(kernel: str, dtype: str) -> int | None:
    from tribench import ext

    try:
        return int(ext.bytes_per_triangle(kernel, dtype))
    except (ValueError, TypeError, KeyError):
        return None


def _form(kernel: str) -> str:
    from tribench import ext

    try:
        lanes = ext.kernel_info(kernel).lanes
    except ValueError:  # a kernel this build no longer has
        return "?"
    return "scalar" if lanes == 1 else f"{lanes} lanes"


def _isas(batches: pd.DataFrame, run: Mapping[str, Any], kernel: str) -> str:
    """The instruction sets the kernel's batches ran with (run.json's record for older runs)."""
    if "isa" not in batches:
        return str(run.get("isa", {}).get(kernel, "?"))
    return ", ".join(dict.fromkeys(batches.loc[batches["kernel"] == kernel, "isa"].astype(str)))


def kernel_table(
    kernels: Sequence[str],
    batches: pd.DataFrame,
    run: Mapping[str, Any],
    est: pd.DataFrame,
    spd: pd.DataFrame,
    baseline: str,
) -> pd.DataFrame:
    """Per kernel and workload family: how the kernel stores a triangle, beside how fast it ran there.

    ``est`` and ``spd`` are the estimates and speedups joined with the
    workload table (:func:`estimates_with_workloads`). The times summarise the
    estimates of the family's workloads and the ratios their speedups over the
    baseline (median, lowest, highest; nan for the baseline); ``verdicts``
    counts those workloads by verdict. Families where the kernel has no
    estimate (a wide kernel has no pairs mode) have no row (``kernels.csv``).
    """
    rows = []
    for kernel in kernels:
        form, isa = _form(kernel), _isas(batches, run, kernel)
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
                    "ops_per_test": g["ops_per_test"].iloc[0] if "ops_per_test" in g else math.nan,
                    "peak_fraction_median": g["peak_fraction"].median() if "peak_fraction" in g else math.nan,
                    "ns_per_test_median": g["ns_per_test"].median(),
                    "ns_per_test_min": g["ns_per_test"].min(),
                    "ns_per_test_max": g["ns_per_test"].max(),
                    "ratio_median": s["ratio"].median() if len(s) else math.nan,
                    "ratio_min": s["ratio"].min() if len(s) else math.nan,
                    "ratio_max": s["ratio"].max() if len(s) else math.nan,
                    "verdicts": verdicts or ("baseline" if kernel == baseline else "no comparison"),
                }
            )
    return _frame(rows, runfolder.KERNELS)


# ------------------------------------------------------------ ranking


def _declared(kernel: str, field: str) -> Any:
    """A declared property of the kernel (watertight as a bool); None for a kernel this build lacks."""
    from tribench import ext

    try:
        info = ext.kernel_info(kernel)
    except ValueError:
        return None
    return info.watertight != "none" if field == "watertight" else getattr(info, field)


def _paired_ratio(per: pd.DataFrame, slower: str, faster: str, level: float) -> tuple[float, float, float, int]:
    """time_slower / time_faster from per-process values (``per``: one column per kernel), its
    interval at ``level`` (``stats.speedup``; NaN when fewer than two processes ran both), and
    how many processes ran both."""
    both = per[[slower, faster]].dropna()
    if len(both) < 2:
        return math.nan, math.nan, math.nan, len(both)
    v = stats.speedup(both[slower], both[faster], confidence=level)
    return v.ratio, v.ci_low, v.ci_high, len(both)


def ranking_table(est: pd.DataFrame, spd: pd.DataFrame, pp: pd.DataFrame, margin: float) -> pd.DataFrame:
    """Per workload, every kernel from the fastest down, each against the fastest (``ranking.csv``).

    ``est`` and ``spd`` are the estimates and speedups joined with the
    workload table (:func:`estimates_with_workloads`). The fastest is the
    kernel with the lowest mean ns/test; every other kernel's time over the
    fastest's is a paired ratio (``stats.speedup`` of the per-process
    values), with simultaneous intervals: Bonferroni over the workload's
    other kernels, as the speedups over the baseline. A kernel is tied with
    the fastest when its interval reaches down to ``1 + margin``: choosing
    the fastest by its point estimate is not evidence that it beats those.
    """
    rows = []
    for wid, g in est.groupby("workload_id", sort=False):
        g = g.sort_values(["ns_per_test", "kernel"]).reset_index(drop=True)
        fastest = str(g["kernel"].iloc[0])
        per = pp.loc[pp["workload_id"] == wid].pivot(index="process", columns="kernel", values="ns_per_test")
        level = stats.simultaneous_confidence(stats.DEFAULTS.confidence, max(len(g) - 1, 1))
        s = spd.loc[spd["workload_id"] == wid].set_index("kernel")
        for rank, r in enumerate(g.itertuples(index=False), start=1):
            kernel = str(r.kernel)
            ratio, low, high = (1.0, 1.0, 1.0) if kernel == fastest else _paired_ratio(per, kernel, fastest, level)[:3]
            base = s.loc[kernel] if kernel in s.index else None
            baseline = str(s["baseline"].iloc[0]) if len(s) else kernel
            rows.append(
                {
                    "workload_id": wid,
                    "family": r.family,
                    "label": r.label,
                    "dtype": r.dtype,
                    "rank": rank,
                    "kernel": kernel,
                    "algorithm": _declared(kernel, "algorithm"),
                    "ns_per_test": r.ns_per_test,
                    "ns_per_test_ci_low": r.ns_per_test_ci_low,
                    "ns_per_test_ci_high": r.ns_per_test_ci_high,
                    "vs_fastest": ratio,
                    "vs_fastest_ci_low": low,
                    "vs_fastest_ci_high": high,
                    "tied_with_fastest": bool(low <= 1 + margin) if not math.isnan(low) else False,
                    "speedup": base["ratio"] if base is not None else (1.0 if kernel == baseline else math.nan),
                    "speedup_ci_low": base["ratio_ci_low"] if base is not None else math.nan,
                    "speedup_ci_high": base["ratio_ci_high"] if base is not None else math.nan,
                    "baseline": baseline,
                    "watertight": _declared(kernel, "watertight"),
                    "culls_back_faces": _declared(kernel, "culls_back_faces"),
                    "bytes_per_triangle": _bytes_per_triangle(kernel, str(r.dtype)),
                    "form": _form(kernel),
                }
            )
    return _frame(rows, runfolder.RANKING)


def algorithm_table(rank: pd.DataFrame, pp: pd.DataFrame, margin: float) -> pd.DataFrame:
    """Per workload, every pair of algorithms, each in its fastest form there (``algorithms.csv``).

    ``rank`` is :func:`ranking_table`'s frame. An algorithm's fastest form is
    its kernel of best rank on the workload (chosen by point estimate, as the
    ranking's fastest). Each pair is a paired ratio (``stats.speedup`` of the
    per-process values) with simultaneous intervals, Bonferroni over the
    workload's pairs, and the verdict of ``stats.verdict``; the faster of the
    pair by point estimate comes first, so the ratio is at least 1.
    """
    rows = []
    for wid, g in rank.groupby("workload_id", sort=False):
        best = g.sort_values("rank").drop_duplicates("algorithm")
        best = best.loc[best["algorithm"].notna()]
        pairs = list(itertools.combinations(best.itertuples(index=False), 2))
        per = pp.loc[pp["workload_id"] == wid].pivot(index="process", columns="kernel", values="ns_per_test")
        level = stats.simultaneous_confidence(stats.DEFAULTS.confidence, max(len(pairs), 1))
        for a, b in pairs:  # a ranks before b
            ratio, low, high, n = _paired_ratio(per, b.kernel, a.kernel, level)
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
    return _frame(rows, runfolder.ALGORITHMS)


# ------------------------------------------------------------ bands

#: Edges of the per-test hit-rate bands of pair workloads: low below the first, high from the second on.
BAND_EDGES = (0.35, 0.65)


def band_of(kind: str, test_hit_rate: float, accel: str | None = None) -> str:
    """The band of a workload in the report's first table: pairs by per-test hit rate, meshes by accel.

    Examples
    --------
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


def _robustness(val: pd.DataFrame | None, kernel: str, dtype: str) -> dict[str, Any]:
    """validate.csv's figures of one kernel at one precision (NaN without the table or its rows)."""
    none = {"promises_checked": math.nan, "broken_promises": math.nan, "crack_rate": math.nan}
    if val is None or val.empty:
        return none
    rows = val.loc[(val["kernel"] == kernel) & (val["dtype"] == dtype)]
    if rows.empty:
        return none
    cracks = rows.loc[rows["test"] == "shared_edges", "rate"]
    return {
        "promises_checked": int((rows["verdict"] != "measured").sum()),
        "broken_promises": int((rows["verdict"] == "fail").sum()),
        "crack_rate": float(cracks.iloc[0]) if len(cracks) else math.nan,
    }


def band_table(
    est: pd.DataFrame,
    pp: pd.DataFrame,
    specs: Mapping[str, Mapping[str, Any]],
    baseline: str,
    margin: float,
    val: pd.DataFrame | None = None,
) -> pd.DataFrame:
    """Per precision and hit-rate band (:func:`band_of`), every kernel from the fastest down (``bands.csv``).

    ``est`` is the estimates joined with the workload table
    (:func:`estimates_with_workloads`), ``pp`` the per-process values,
    ``specs`` each workload's spec, ``val`` the robustness table
    (``validate.csv``) if there is one. A band holds the kernels timed on
    every one of its workloads; a kernel's value in a process is the geometric
    mean of its per-process medians over the band's workloads, so each workload
    weighs the same whatever its ns/test. On those values: the mean over
    processes with its t interval (``stats.estimate``), and paired ratios
    (``stats.speedup``) to the fastest and from the baseline, each with
    simultaneous intervals over the band's other kernels (Bonferroni), as in
    :func:`ranking_table`.
    """
    frame = est.assign(
        band=[
            band_of(str(r.kind), float(r.test_hit_rate), specs.get(r.workload_id, {}).get("accel"))
            for r in est.itertuples(index=False)
        ]
    )
    order = {b: i for i, b in enumerate(band_of(*a) for a in (("pairs", 0), ("pairs", 0.5), ("pairs", 1), ("mesh", 0)))}
    keys = sorted(frame.groupby(["dtype", "band"]).groups, key=lambda k: (k[0], order.get(k[1], len(order)), k[1]))
    rows = []
    for dtype, band in keys:
        g = frame.loc[(frame["dtype"] == dtype) & (frame["band"] == band)]
        wids = list(dict.fromkeys(g["workload_id"]))
        kernels = [k for k, n in g.groupby("kernel", sort=False)["workload_id"].nunique().items() if n == len(wids)]
        sub = pp.loc[pp["workload_id"].isin(wids) & pp["kernel"].isin(kernels)]
        logs = sub.assign(log=np.log(sub["ns_per_test"])).groupby(["process", "kernel"])["log"].agg(["mean", "size"])
        logs = logs.loc[logs["size"] == len(wids), "mean"]  # processes that ran every workload of the band
        per = np.exp(logs.unstack("kernel")) if len(logs) else pd.DataFrame()
        kernels = [k for k in kernels if k in per and per[k].notna().sum() >= 1]
        if not kernels:
            continue
        estimates = {k: stats.estimate(per[k].dropna()) for k in kernels}
        ranked = sorted(kernels, key=lambda k: (estimates[k].mean, k))
        fastest = ranked[0]
        level = stats.simultaneous_confidence(stats.DEFAULTS.confidence, max(len(ranked) - 1, 1))
        for rank, kernel in enumerate(ranked, start=1):
            e = estimates[kernel]
            ratio, low, high = (1.0, 1.0, 1.0) if kernel == fastest else _paired_ratio(per, kernel, fastest, level)[:3]
            if kernel == baseline:
                speedup = (1.0, math.nan, math.nan)
            elif baseline in per:
                speedup = _paired_ratio(per, baseline, kernel, level)[:3]
            else:
                speedup = (math.nan, math.nan, math.nan)
            rows.append(
                {
                    "dtype": dtype,
                    "band": band,
                    "workloads": len(wids),
                    "rank": rank,
                    "kernel": kernel,
                    "algorithm": _declared(kernel, "algorithm"),
                    "form": _form(kernel),
                    "ns_per_test": e.mean,
                    "ns_per_test_ci_low": e.ci_low,
                    "ns_per_test_ci_high": e.ci_high,
                    "vs_fastest": ratio,
                    "vs_fastest_ci_low": low,
                    "vs_fastest_ci_high": high,
                    "tied_with_fastest": bool(low <= 1 + margin) if not math.isnan(low) else False,
                    "speedup": speedup[0],
                    "speedup_ci_low": speedup[1],
                    "speedup_ci_high": speedup[2],
                    "baseline": baseline,
                    "n_processes": e.n,
                    "watertight": _declared(kernel, "watertight"),
                    "culls_back_faces": _declared(kernel, "culls_back_faces"),
                    "bytes_per_triangle": _bytes_per_triangle(kernel, str(dtype)),
                    **_robustness(val, kernel, str(dtype)),
                }
            )
    return _frame(rows, runfolder.BANDS)


# ------------------------------------------------------------ in a BVH

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
    for algorithm in (_declared(baseline, "algorithm"), BVH_FALLBACK_ALGORITHM):
        for k in kernels:
            if algorithm is not None and _declared(k, "algorithm") == algorithm:
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
        return _frame(rows, runfolder.BVH)
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
            speedup = (1.0, 1.0, 1.0) if kernel == base else _paired_ratio(per_ray, base, kernel, level)[:3]
            brute_speedup = nan3
            if brute is not None and {base, kernel} <= set(brute.columns):
                brute_speedup = (1.0, 1.0, 1.0) if kernel == base else _paired_ratio(brute, base, kernel, level)[:3]
            rows.append(
                {
                    "workload_id": wid,
                    "family": w["family"],
                    "label": w["label"],
                    "dtype": w["dtype"],
                    "rays_kind": specs[wid].get("rays"),
                    "triangles": w["triangles"],
                    "kernel": kernel,
                    "algorithm": _declared(kernel, "algorithm"),
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
    return _frame(rows, runfolder.BVH)
