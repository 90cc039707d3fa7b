"""The report's checking sections: drift, diagnostics (with the margin's calibration), correctness, robustness."""

from __future__ import annotations

import json
import math
from typing import Any

import pandas as pd

from ..harness import runfolder, stats
from ..harness.jobs import validate
from . import about, charts, page, rundata
from .rundata import RunData
from .tables.diagnostics import drift_bins, round_summary
from .tables.ranking import declared

__all__ = ["drift_section", "diagnostics_section", "calibration", "correctness_section", "robustness_section"]


def drift_section(batches: pd.DataFrame, drift: pd.DataFrame, colours: dict[str, str]) -> str:
    """Batches over time relative to their process, and stats.drift per kernel against the baseline."""
    body = [
        _chart(
            charts.drift_chart(drift_bins(batches), colours),
            "chart-drift",
            "drift of every kernel over time",
            "Every timed batch's ns/test relative to its process's median for that kernel and workload, against "
            "time since the process started, pooled over workloads in twelve equal spans of time: a line through "
            "each kernel's medians; click a kernel in the legend to show it alone with its quartiles (band). "
            "Kernels moving apart over time is drift that can bias a ratio.",
        ),
        page.p(
            "stats.drift per kernel against the baseline and workload: slopes are per second on the log "
            "scale; ratio change = the log speedup's move across one process; confound bias = what unequal "
            "timing of the two kernels on a drifting machine adds to the log speedup.",
            "note",
        ),
        page.table(
            drift,
            [
                ("kernel", "kernel"),
                ("label", "workload"),
                ("baseline_slope", "baseline slope (/s)"),
                ("ratio_slope", "ratio slope (/s)"),
                ("ratio_p", "p"),
                ("ratio_change", "ratio change"),
                ("confound_bias", "confound bias"),
                ("confound_p", "p (confound)"),
                ("flagged", "flagged"),
                ("reason", "reason"),
            ],
        ),
    ]
    return "".join(body)


def calibration(data: RunData) -> str:
    """The margin the verdicts used and where it came from, as run.json and the analysis record say.

    Only the run folder is read: the calibration file the margin's source names may have changed since,
    or not exist on this machine."""
    body = [page.p(f"Equivalence margin of the verdicts: ±{100 * data.margin:.3g}% — {data.margin_source}.")]
    value, source = data.run.margin.value, data.run.margin.source
    if value != data.margin or source != data.margin_source:
        body.append(
            page.p(
                f"The sweep recorded ±{100 * value:.3g}% ({source}) in {runfolder.RUN}; the analysis "
                f"was made with the margin above (`tribench stats --margin`).",
                "note",
            )
        )
    path = data.run_dir / runfolder.CALIBRATION
    try:
        cal = json.loads(path.read_text(encoding="utf-8")) if path.is_file() else None
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        body.append(page.p(f"{path} cannot be read ({exc}).", "note"))
        return "".join(body)
    if not isinstance(cal, dict):
        if data.margin_source.startswith("calibration "):
            why = (
                "That A/A calibration's record is not part of this run folder; its margin and "
                f"source are the ones {runfolder.RUN} recorded when the sweep started."
            )
        else:
            why = (
                "No A/A calibration stood behind this run: the verdicts rest on the default margin. "
                "`tribench calibrate` measures this machine's noise floor (a kernel against its "
                "identical copy) and later sweeps use it."
            )
        return "".join([*body, page.p(why, "note")])
    body.append(page.p(f"This run folder is an A/A calibration; its record ({runfolder.CALIBRATION}):", "note"))
    body.append(
        page.kv_table(
            [
                ("A/A pair", f"{cal.get('kernel')} vs {cal.get('copy')}"),
                ("comparisons", f"{cal.get('experiments')} of {cal.get('processes_per_experiment')} processes"),
                ("coverage of 1 by 95% CIs", f"{100 * cal.get('coverage', math.nan):.0f}%"),
                ("false positives (p < 0.05)", f"{100 * cal.get('false_positive_rate', math.nan):.0f}% (expect 5%)"),
                (
                    "p-values vs uniform",
                    f"KS {cal.get('ks_statistic', math.nan):.3f}, p = {cal.get('ks_p_value', math.nan):.3f}",
                ),
                ("noise floor (97.5% of |log ratio|)", f"{cal.get('noise_floor', math.nan):.4g}"),
                ("margin", f"{100 * cal.get('margin', math.nan):.3g}%"),
                ("created", cal.get("created")),
            ]
        )
    )
    return "".join(body)


def _chart(chart: Any, chart_id: str, description: str, caption: str) -> str:
    return page.p("No batches.", "note") if chart is None else charts.embed(chart, chart_id, description, caption)


def diagnostics_section(data: RunData, batches: pd.DataFrame, colours: dict[str, str]) -> str:
    """Rounds, warm-up, outliers, variance components, the margin, interference, FMA peak."""
    warm = rundata.named(rundata.sweep_order(data.tables[runfolder.WARMUP], data), data)
    outl = rundata.named(rundata.sweep_order(data.tables[runfolder.OUTLIERS], data), data)
    var = rundata.named(data.tables[runfolder.VARIANCE], data)
    timed = data.batches.loc[~data.batches["warmup"]]
    ctx = int(timed["invol_ctx_switches"].sum())
    steal = timed.loc[timed["steal_ticks"] > 0, "steal_ticks"].sum()
    body = [
        _chart(
            charts.rounds_chart(round_summary(batches), colours),
            "chart-rounds",
            "batches by round",
            f"Every batch by its round (shaded: warm-up rounds, kept and labelled, left out of every estimate), "
            f"relative to its process's median, pooled over processes and workloads per kernel: the median (dot), "
            f"quartiles (thick) and least to most (thin). Red ring: the round's farthest Tukey outlier (beyond "
            f"{stats.DEFAULTS.tukey_k} IQR within the process), a cross when far out "
            f"({stats.DEFAULTS.tukey_far_k} IQR); hover for the counts. Outliers are labelled, never dropped: the "
            f"per-process median keeps the estimates robust.",
        ),
        "<h3>Warm-up</h3>",
        page.table(
            warm,
            [
                ("kernel", "kernel"),
                ("label", "workload"),
                ("warmup_batches", "warm-up batches"),
                ("warmup_rel", "warm-up ns/test ÷ timed median"),
            ],
        ),
        "<h3>Outliers (Tukey fences, per process)</h3>",
        page.table(
            outl,
            [
                ("kernel", "kernel"),
                ("label", "workload"),
                ("batches", "timed batches"),
                ("outliers", "outliers"),
                ("far_out", "far out"),
                ("worst_rel", "worst ÷ median"),
            ],
        ),
        "<h3>Variance components</h3>",
        page.p(
            "Kalibera & Jones (2013): between rounds inside a process and between processes, as standard "
            "deviations relative to the mean (stats.variance_components on a balanced processes × rounds "
            "matrix). Where processes dominate, more processes narrow the intervals; more rounds do not.",
            "note",
        ),
        page.table(
            var,
            [
                ("kernel", "kernel"),
                ("label", "workload"),
                ("mean_ns", "mean ns/test"),
                ("round_sd_pct", "between rounds (sd %)"),
                ("process_sd_pct", "between processes (sd %)"),
                ("n_processes", "processes"),
                ("n_rounds", "rounds"),
            ],
        ),
        "<h3>A/A calibration</h3>",
        calibration(data),
        "<h3>Interference</h3>",
        page.p(
            f"{ctx:,} involuntary context switches over {len(timed):,} timed batches; steal time "
            f"{'not readable' if (timed['steal_ticks'] < 0).all() else f'{int(steal)} ticks'}; "
            f"workers {about.pinning(data.run)}."
        ),
    ]
    if not data.processes.empty:
        peak = data.processes.groupby("phase")["peak_gflops"].agg(["mean", "min", "max"]).reset_index()
        body += [
            "<h3>FMA peak per process (GFLOP/s)</h3>",
            page.table(peak, [("phase", "phase"), ("mean", "mean"), ("min", "min"), ("max", "max")]),
        ]
    return "".join(body)


def correctness_section(correct: pd.DataFrame, wl: pd.DataFrame) -> str:
    """Every kernel's hits against the float64 reference, per workload."""
    # the family too: two workloads of a run can share a label (a hit rate at both precisions or windings)
    labels = {
        w: f"{label} ({family})" for w, label, family in zip(wl["workload_id"], wl["label"], wl["family"], strict=True)
    }
    frame = correct.assign(label=correct["workload_id"].map(labels))
    body = [
        page.p(
            "Every batch returns a checksum (hits and the sum of t) that the worker checked against the "
            "float64 reference before keeping it: a kernel that is fast because it is wrong stops the run. "
            "Hits may differ from the reference only on ambiguous rays (within 1e-5, in barycentric terms, "
            "of an edge, or within the precision's rounding of it). Mesh workloads count rays that hit; "
            "pair workloads count pairs that hit.",
            "note",
        ),
        page.table(
            frame,
            [
                ("kernel", "kernel"),
                ("label", "workload"),
                ("batches", "batches"),
                ("ref_hits", "reference hits per pass"),
                ("hits_per_pass_min", "kernel hits per pass"),
                ("hit_difference", "|difference|"),
                ("ambiguous_rays", "ambiguous rays"),
                ("t_sum_rel_diff", "sum of t, relative difference"),
                ("agrees", "agrees"),
            ],
            digits=3,
        ),
    ]
    differs = frame.loc[frame["agrees"].eq(False)]
    if len(differs):
        body.append(page.warn(_left_out(differs)))
    body.append(
        '<p class="note">Watertightness figures (cracks at exactly shared edges and vertices, misses '
        "from inside Embree's far-off sphere) and every kernel's answers at extreme input are in "
        '<a href="#robustness">Robustness</a>.</p>'
    )
    return "".join(body)


def _left_out(differs: pd.DataFrame) -> str:
    """The sentence naming the kernels left out of the rankings where their answers differ, and why."""
    parts = []
    for r in differs.itertuples(index=False):
        why = (
            "it culls back faces, so the tests it rejects at once are work it skipped, not speed"
            if declared(r.kernel, "culls_back_faces")  # None: a kernel this build lacks
            else "its answers differ"
        )
        share = f", {100 * r.hits_per_pass_min / r.ref_hits:.0f}%" if r.ref_hits else ""
        parts.append(
            f"{r.kernel} on {r.label}: {page.num(r.hits_per_pass_min)} hits per pass of the reference's "
            f"{page.num(r.ref_hits)}{share} ({why})"
        )
    return "Left out of every ranking, as doing other work than the reference asks: " + "; ".join(parts) + "."


#: What each robustness test measures, in one sentence (after tribench.harness.jobs.validate's documentation).
_TEST_TEXT = {
    "shared_edges": "Cracks: rays aimed exactly at a point inside an edge shared by two triangles of an exactly "
    "coplanar mesh (dyadic coordinates, exact at both precisions) that hit no triangle of it.",
    "shared_edges_double": "Double hits: those rays hitting both triangles of their edge, each asked alone; by "
    "design for closed-triangle rules (the reference's, Woop's), a defect only where "
    "crossings are counted.",
    "shared_vertices": "Cracks: rays aimed exactly at an interior vertex of six triangles that hit no triangle "
    "of the mesh.",
    "inside_sphere": "Misses: rays from inside a radius-2 icosphere of 20,480 triangles centred at "
    "(148376, 1234, −223423), where float32 spacing is 1/64 (Embree's watertightness test, "
    "which fails above 0.002%).",
    "scales": "Answers other than the float64 reference's on safe pairs (every crossing at least 1e-3 "
    "barycentric from an edge) scaled by 1e-8, 1e-4, 1, 1e4 and 1e8.",
    "tiny_triangles": "Misses on near-equilateral triangles from 1e-2 down to about 100 ulps across, rays aimed "
    "at least 0.2 barycentric inside.",
    "needle_triangles": "Misses on needles of base 1 and aspect ratios 1e3 to 1e6, rays aimed at least 0.2 "
    "barycentric inside.",
    "grazing_rays": "Misses on unit triangles met at slopes of 1e-3 to 1e-6 to their plane, rays aimed at least "
    "0.2 barycentric inside.",
    "parallel_rays": "Hits by rays exactly parallel to the triangle's plane, just above it: every one must miss.",
    "in_plane_rays": "Hits by rays lying exactly in the triangle's plane, through it: measured, never judged (the "
    "exact answer is a segment of contact; a kernel that rounds its plane or its ray transform decides by rounding).",
    "degenerate_triangles": "Hits on a point, a segment with a repeated vertex and three collinear points, rays "
    "aimed exactly at them: every one must miss.",
    "nonfinite": "Hits on safe pairs with one NaN, +Inf or −Inf in the origin, the direction or a vertex: the "
    "call must return, and miss.",
}


def _rate_class(cell: Any) -> str:
    # validate.format_rate ends a broken promise's cell with "!"
    return "num broken" if isinstance(cell, str) and cell.endswith("!") else "num"


#: What the robustness section says first: where its rays come from and how to read a cell.
_ROBUSTNESS_INTRO = (
    "Rays no timing workload asks (tribench.harness.jobs.validate, as `tribench validate`): aimed exactly at "
    "shared edges and vertices of exactly coplanar meshes, from inside a far-off sphere, and at extreme "
    "scales, sizes, shapes, angles and non-finite input. A cell is a kernel's failure rate on a test at "
    "one precision (failures / rays, 0 = none). What the papers promise (validate's expected column): "
    "no crack at shared edges and vertices, and Embree's 0.002% on the sphere, for Woop, Benthin & "
    "Wald's watertight test; no hit on parallel rays and degenerate triangles for every kernel, nor on "
    "non-finite input except for the seed kernels, faithful copies of flawed code. A cell marked ! in "
    "red breaks its promise; every other rate is measured, not judged. A culling kernel is asked about "
    "triangles facing the ray, so its rates measure robustness, not culling."
)


def _broken_promises(broken: pd.DataFrame) -> list[str]:
    """The rows of validate.csv whose verdict is fail, with their rate as the main table writes it."""
    shown = broken.assign(
        cell=[
            validate.format_rate(f, r, v)
            for f, r, v in zip(broken["failures"], broken["rate"], broken["verdict"], strict=True)
        ]
    )
    return [
        "<h3>Broken promises</h3>",
        page.table(
            shown,
            [
                ("kernel", "kernel"),
                ("dtype", "precision"),
                ("test", "test"),
                ("cell", "rate"),
                ("failures", "failures"),
                ("rays", "rays"),
                ("expected", "promised"),
                ("detail", "breakdown"),
            ],
            classes={"cell": _rate_class},
        ),
    ]


def _test_legend(val: pd.DataFrame, tests: list[str]) -> list[str]:
    """A row per test: its column in the table, what it measures and how many rays it asks at each precision."""
    rays = val.groupby(["test", "dtype"])["rays"].max()
    dtypes = list(dict.fromkeys(val["dtype"]))
    legend = pd.DataFrame(
        [
            {
                "column": validate.SHORT_NAMES[t],
                "test": t,
                "what": _TEST_TEXT.get(t, ""),
                **{f"rays {d}": rays.get((t, d)) for d in dtypes},
            }
            for t in tests
        ]
    )
    return [
        "<h3>The tests</h3>",
        page.p(
            f"Every kernel is asked the same rays at a precision. The breakdown of every rate is in "
            f"{runfolder.VALIDATE}'s detail column.",
            "note",
        ),
        page.table(
            legend,
            [("column", "column"), ("test", "test"), ("what", "what is measured")]
            + [(f"rays {d}", f"rays ({d})") for d in dtypes],
        ),
    ]


def promises_kept(val: pd.DataFrame) -> pd.DataFrame:
    """Per kernel and precision of validate.csv, its promises as a cell: judged tests and how many broke
    (here, not on the first screen: docs/results.md).

    >>> val = pd.DataFrame({"kernel": ["a", "a", "a", "b"], "dtype": ["float32"] * 3 + ["float64"],
    ...     "verdict": ["pass", "fail", "measured", "measured"]})
    >>> promises_kept(val).values.tolist()
    [['a', 'float32', '1 of 2 broken'], ['b', 'float64', 'none promised']]
    """
    judged = val.assign(checked=val["verdict"] != "measured", broken=val["verdict"] == "fail")
    counts = judged.groupby(["kernel", "dtype"], sort=False)[["checked", "broken"]].sum().reset_index()
    pairs = zip(counts["checked"], counts["broken"], strict=True)
    return counts[["kernel", "dtype"]].assign(
        promises=[f"{b} of {c} broken" if c else "none promised" for c, b in pairs]
    )


def robustness_section(val: pd.DataFrame, note: str) -> str:
    """validate.csv: failure rates per kernel, precision and test, broken promises marked; ``note``: its source."""
    body = [page.p(_ROBUSTNESS_INTRO, "note"), page.p(note, "note")]
    if val.empty:
        return "".join(body)
    tests = [t for t in validate.TESTS if t in set(val["test"])]
    names = [validate.SHORT_NAMES[t] for t in tests]
    broken = val.loc[val["verdict"] == "fail"]
    body.append(page.p(f"{int((val['verdict'] != 'measured').sum())} promises checked, {len(broken)} broken."))
    body.append(
        page.table(
            validate.table(val).merge(promises_kept(val), on=["kernel", "dtype"], how="left"),
            [("kernel", "kernel"), ("dtype", "precision"), ("isa", "ISA"), ("promises", "promises (validate)")]
            + [(n, n) for n in names],
            classes={n: _rate_class for n in names},
        )
    )
    if not broken.empty:
        body += _broken_promises(broken)
    body += _test_legend(val, tests)
    return "".join(body)
