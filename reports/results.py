"""The report's measurement sections: kernels, speedups, hit rate, size and working set, peers, processes."""

from __future__ import annotations

from html import escape

import numpy as np
import pandas as pd

from . import charts, page, rundata, speed_charts
from .headline import peer_sentence
from .rundata import PeerTables, RunData

__all__ = [
    "kernels_section",
    "speedups_section",
    "hit_rate_section",
    "scaling_section",
    "peers_section",
    "processes_section",
]


_EST_COLS = [
    ("kernel", "kernel"),
    ("label", "workload"),
    ("ns_per_test", "ns/test (mean)"),
    ("ns_per_test_ci_low", "95% CI low (ns)"),
    ("ns_per_test_ci_high", "95% CI high (ns)"),
    ("ns_per_test_min", "min (ns)"),
    ("ns_per_test_bootstrap_low", "BCa low (ns)"),
    ("ns_per_test_bootstrap_high", "BCa high (ns)"),
    ("n_processes", "processes"),
    ("peak_fraction", "fraction of bound"),
]
_SPD_COLS = [
    ("kernel", "kernel"),
    ("label", "workload"),
    ("ratio", "speedup (×)"),
    ("ratio_ci_low", "CI low (×)"),
    ("ratio_ci_high", "CI high (×)"),
    ("p_holm", "p (Holm)"),
    ("n_processes", "processes"),
    ("verdict", "verdict"),
]


def speedups_section(data: RunData, spd: pd.DataFrame, est: pd.DataFrame) -> str:
    """The forest plot of every speedup, then the speedups and estimates tables."""
    chart = speed_charts.forest_chart(spd, data.margin, f"speedup over {data.baseline}", "faster")
    spd, est = rundata.named(spd, data), rundata.named(est, data)
    body = [
        charts.embed(
            chart,
            "chart-forest",
            "forest plot of speedups",
            f"Every kernel against {data.baseline}, per workload family: the dot is the speedup "
            f"(time_{data.baseline} / time_kernel), the bar its simultaneous 95% confidence interval, the colour "
            f"its verdict (equivalence margin ±{100 * data.margin:.2g}%). Log axis. Hover for the figures; the "
            "menu picks a kernel, the legend a verdict.",
        )
        if chart is not None
        else page.p(f"No speedups: the run has no kernel other than the baseline {data.baseline}.", "note"),
        "<h3>Speedups</h3>",
        page.table(spd, _SPD_COLS),
        "<h3>Estimates</h3>",
        page.p(
            "ns per ray–triangle test: per process the median of its timed batches, then the mean over "
            "processes with a Student-t interval; the BCa bootstrap over processes is a cross-check and the "
            "minimum a robust secondary figure. Fraction of bound: the port model's bound (the kernel's "
            "operations per test by class over the core's measured throughput per class at its widest vector "
            "width, FMA-capable) over the measured time; see the kernels section.",
            "note",
        ),
        page.table(est, _EST_COLS),
    ]
    return "".join(body)


_KERNEL_COLS = [
    ("kernel", "kernel"),
    ("form", "form"),
    ("isa", "ISA"),
    ("family", "workload family"),
    ("dtype", "precision"),
    ("bytes_per_triangle", "bytes per triangle"),
    ("workloads", "workloads"),
    ("ops_per_test", "ops per test"),
    ("peak_fraction_median", "fraction of bound (median)"),
    ("ns_per_test_median", "ns/test (median)"),
    ("ns_range", "ns/test (lowest–highest)"),
    ("ratio_median", "speedup (median, ×)"),
    ("ratio_range", "speedup (lowest–highest, ×)"),
    ("verdicts", "verdicts"),
]


def kernels_section(data: RunData, kern: pd.DataFrame) -> str:
    """Each kernel's form, storage and arithmetic beside its speed, per workload family."""
    shown = kern.assign(
        ns_range=[page.span(a, b) for a, b in zip(kern["ns_per_test_min"], kern["ns_per_test_max"], strict=True)],
        ratio_range=[page.span(a, b) for a, b in zip(kern["ratio_min"], kern["ratio_max"], strict=True)],
    )
    note = (
        "Each kernel's storage beside its speed, per workload family (a family has one precision). "
        "Form: scalar (one triangle per test, early exit) or 16 lanes (sixteen triangles per step in "
        "SIMD registers); ISA: the instruction set its batches ran with. Bytes per triangle: its prepared data "
        "for one triangle at the family's precision, which the working set (section "
    )
    tail = (
        ") counts. Ops per test: the kernel's arithmetic (adds, multiplies, divides, compares; for a "
        "scalar kernel the path of a hit), documented in its header. Fraction of bound: the port model's bound over "
        "the measured time, 1 at the limit. The bound takes the kernel's operations per test by class "
        "(FMA, multiply, add, compare, divide, logic, load) over the throughput of each class the core "
        "measured at its widest vector width (AVX-512, AVX2 or SSE2), FMA-capable, with adds, multiplies "
        "and FMAs sharing the FMA pipes where the probes show they do (tribench.harness.peak). A scalar "
        "kernel uses one lane of the widest vector, and its early exits do less than the count. "
        f"ns/test and the speedup over {data.baseline} summarise the family's workloads (median, lowest, "
        "highest); their 95% CIs are in the speedups section, and verdicts counts the workloads by verdict."
    )
    body = [
        f'<p class="note">{escape(note)}<a href="#scaling">size and working set</a>{escape(tail)}</p>',
        page.table(shown, _KERNEL_COLS, digits=3),
    ]
    return "".join(body)


def hit_rate_section(
    data: RunData, est: pd.DataFrame, spd: pd.DataFrame, cross: pd.DataFrame, colours: dict[str, str]
) -> str:
    body = [
        page.p(
            "Pair workloads: N independent (ray, triangle) pairs at an exact per-test hit rate, "
            "the fraction of ray–triangle tests that hit (Löfstedt & Akenine-Möller 2005). "
            "Misses are spread over the three edges unless the family says otherwise; pair order "
            "is shuffled unless it says sorted.",
            "note",
        )
    ]
    curves = speed_charts.hit_rate_chart(est, cross, colours)
    speedups = speed_charts.speedup_hit_rate_chart(spd, data.baseline, data.margin, colours)
    if curves is None or speedups is None:
        body.append(page.p("No pair workload family with two or more per-test hit rates in this run.", "note"))
    else:
        body.append(
            charts.embed(
                curves,
                "chart-hit-rate",
                "ns per test against per-test hit rate",
                "ns per test against the per-test hit rate, one line per kernel, bands: 95% CIs of the mean. "
                "Dashed purple: a crossover where two kernels swap rank, at its estimate (its 95% Fieller "
                "interval on hover and in the table below; stats.crossover). Hover for the figures; click a "
                "kernel in the legend to show it alone, shift-click to add more.",
            )
        )
        body.append(
            charts.embed(
                speedups,
                "chart-speedup-hit-rate",
                "speedup against per-test hit rate",
                f"Speedup over {data.baseline} against the per-test hit rate (log axis), bands: "
                f"simultaneous 95% CIs; grey: the equivalence margin. Hover and legend as above.",
            )
        )
    body.append("<h3>Crossovers</h3>")
    if cross.empty:
        return "".join(
            body + [page.p("No family with two or more per-test hit rates: no crossover to look for.", "note")]
        )
    found = cross.loc[np.isfinite(cross["hit_rate"].astype(float))]
    if found.empty:
        return "".join(body + [page.p("No ranking flips inside the measured per-test hit rates.", "note")])
    none = cross.loc[~cross.index.isin(found.index)]
    body.append(
        page.p(
            f"Kernel pairs whose ranking flips inside the measured per-test hit rates "
            f"({len(none)} other pairs keep their order throughout). An interval is shown cut to 0–100%, the hit "
            f"rates there are (crossovers.csv has Fieller's, which a line's extrapolation can carry past them).",
            "note",
        )
    )
    shown = found.assign(
        hit_rate_pct=100 * found["hit_rate"],
        low_pct=100 * found["ci_low"].clip(0, 1),
        high_pct=100 * found["ci_high"].clip(0, 1),
    )
    body.append(
        page.table(
            shown,
            [
                ("family", "family"),
                ("kernel_a", "kernel A"),
                ("kernel_b", "kernel B"),
                ("hit_rate_pct", "crossover (% per-test hit rate)"),
                ("low_pct", "95% CI low (%)"),
                ("high_pct", "95% CI high (%)"),
                ("n", "processes"),
            ],
        )
    )
    return "".join(body)


def scaling_section(data: RunData, est: pd.DataFrame, slopes: pd.DataFrame, colours: dict[str, str]) -> str:
    """Cost against triangle count and working set, and the log–log slopes."""
    caches = data.machine.get("caches", {})
    chart = speed_charts.scaling_chart(est, caches, colours)
    body = [
        charts.embed(
            chart,
            "chart-scaling",
            "cost against size",
            "Top: ns per test against the mesh's triangle count (camera or per-ray hit-rate rays, "
            "every ray against every triangle); bottom: ns per test against the working set, bytes of the "
            "kernel's prepared triangles plus the rays, for every workload; dashed grey: the machine's data "
            "caches (" + (", ".join(f"{k} {v}" for k, v in caches.items()) or "unknown") + "). Lines: 95% CIs; "
            "dashes tell workload families apart. Hover for the figures; click a kernel in the legend to show it "
            "alone, shift-click to add more.",
        )
        if chart is not None
        else page.p("No estimate to draw against size.", "note"),
        "<h3>Log–log slopes against triangle count</h3>",
        page.p(
            "Per process the least-squares slope of log ns/test on log triangles, then a t-interval "
            "across processes (stats.scaling_slope); 0 = cost per test independent of size.",
            "note",
        ),
        page.table(
            slopes,
            [
                ("family", "family"),
                ("kernel", "kernel"),
                ("slope", "slope"),
                ("ci_low", "95% CI low"),
                ("ci_high", "95% CI high"),
                ("sizes", "triangle counts"),
                ("n", "processes"),
            ],
        ),
    ]
    return "".join(body)


def peers_section(peers: PeerTables | None, note: str) -> str:
    """tribench against trimesh and Embree on the same rays, or ``note`` saying why there is nothing."""
    from ..harness.jobs.peers import PAUSE_S

    if peers is not None and peers.in_bvh:
        about = (
            "tribench's BVH with its fastest leaf kernel against native Embree (its C API, rtcIntersect1 and "
            "rtcIntersect16, plain and robust, after building its BVH), on the same camera rays, closest hit, "
            "one core, both loops timed in C (tribench.harness.jobs.peers, as `tribench peers --accel bvh`): two "
            "tracers, each with its own acceleration structure; the build is the untimed set-up of both. "
            "embreex is Embree called from Python, a secondary figure."
        )
    else:
        about = (
            "tribench's fastest brute-force kernel against trimesh's own intersector (NumPy after an rtree "
            "broad phase) and native Embree (its C API, after building its BVH; embreex: Embree from Python), "
            "on the same camera rays, closest hit (tribench.harness.jobs.peers, as `tribench peers`). Embree's BVH "
            "skips most triangles "
            "of every ray; tribench tests every one: the ratio is what an acceleration structure is worth "
            "over the fastest brute force, not a comparison of ray–triangle tests."
        )
    body = [page.p(about, "note")]
    if peers is None:
        return "".join(body + [page.p(note, "note")])
    body += [
        page.p(
            peer_sentence(peers.ratios, peers.kernel, peers.workload, peers.in_bvh) or "Only tribench was measured."
        ),
        charts.embed(
            speed_charts.peers_chart(peers.rates),
            "chart-peers",
            "rays per second of every contender",
            f"Rays/s on {peers.workload}: geometric mean over processes (dot), 95% CI (line); hover for the "
            f"figures. tribench: {peers.kernel}, the fastest closest-mode kernel on these rays; tribench_call: the "
            f"same kernel through ext.intersect (checks and output arrays included, like a peer's one call).",
        ),
        page.table(peers.rates, PEER_RATE_COLUMNS),
        "<h3>Ratios of rays/s</h3>",
        page.table(
            peers.ratios,
            [
                ("contender", "contender"),
                ("over", "over"),
                ("ratio", "ratio (>1: faster)"),
                ("ci_low", "95% CI low"),
                ("ci_high", "95% CI high"),
                ("n_processes", "processes"),
            ],
        ),
        page.p(
            f"Every process is a fresh interpreter pinned to one CPU with one BLAS thread; it times each "
            f"contender once per repetition in a random order, after a {PAUSE_S:g} s pause. The replicate is the "
            f"process (its geometric mean over repetitions); ratios are paired by process. trimesh runs a fixed "
            f"random subset of the rays (it is slow) and its rays/s is scaled from those. CPU / wall below 1: "
            f"other processes took the core; above 1: a contender used a second thread. Ambiguous rays pass "
            f"within 1e-5 barycentric, or the precision's rounding, of an edge, where either triangle is right. {note}",
            "note",
        ),
    ]
    return "".join(body)


#: The columns of a table of the contenders' rays/s (``peer_rates.csv``).
PEER_RATE_COLUMNS = [
    ("contender", "contender"),
    ("implementation", "implementation"),
    ("rays", "rays per call"),
    ("rays_per_s", "rays/s"),
    ("ci_low", "95% CI low"),
    ("ci_high", "95% CI high"),
    ("n_processes", "processes"),
    ("cpu_share", "CPU / wall"),
    ("setup_ms", "set-up ms (untimed)"),
    ("differ", "closest triangle ≠ reference"),
    ("differ_ambiguous", "of which ambiguous"),
]


def processes_section(pp: pd.DataFrame, est: pd.DataFrame, colours: dict[str, str]) -> str:
    """Every worker process's value beside the estimate: the replicate made visible."""
    labels = {r.workload_id: f"{r.family} · {r.label}" for r in est.drop_duplicates("workload_id").itertuples()}
    chart = charts.processes_chart(pp, est, labels, colours)
    if chart is None:
        return page.p("No estimate: no process to show.", "note")
    return charts.embed(
        chart,
        "chart-processes",
        "per-process values",
        "Each dot is one worker process's median ns per test; below the dots, the estimate (diamond, mean "
        "over processes) and its 95% CI, on the workload the menu picks. The process is the replicate: batches "
        "inside one process share its memory layout and are not independent. Hover for the figures; click a "
        "kernel in the legend to show it alone.",
    )
