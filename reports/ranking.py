"""The report's ranking: the answer it opens on, per band, and the ranking per workload; and their terminal tables.

Every number is read from ``bands.csv``, ``ranking.csv`` and ``algorithms.csv``
(:mod:`tribench.reports.tables.ranking` wrote them)."""

from __future__ import annotations

import math
from html import escape

import pandas as pd

from ..harness import runfolder
from ..harness.stats import format_estimate, format_interval
from ..workloads.labels import family_of, short_label
from . import charts, page
from .rundata import RunData
from .speed_charts import answer_chart
from .tables.frames import in_order

__all__ = [
    "QUESTIONS",
    "algorithm_order",
    "answer_section",
    "answer_sentences",
    "band_rows",
    "format_answer",
    "format_run",
    "question_rows",
    "ranking_rows",
    "ranking_section",
]

#: Why a run's tables rank nothing: the analysis ranks no A/A copy and no kernel whose answers differ.
NOTHING_RANKED = "no kernel of this run is ranked (each was an A/A copy or disagreed with the reference)"

#: The head-to-head questions the report answers when a run has both algorithms (algorithm names:
#: tribench.ext.kernel_info(k).algorithm): Baldwin & Weber's claim, and the seed's question.
QUESTIONS: tuple[tuple[str, str], ...] = (
    ("baldwin_weber_12", "moller_trumbore"),
    ("baldwin_weber_9", "moller_trumbore"),
    ("curless", "moller_trumbore"),
    ("curless_seed", "moller_seed"),
)


def _named(kernel: str, rows: pd.DataFrame) -> str:
    """The kernel's name, marked when it culls back faces (it answers another question: front faces only)."""
    if "culls_back_faces" not in rows:
        return kernel
    culls = rows.loc[rows["kernel"] == kernel, "culls_back_faces"]
    return f"{kernel} (front faces only)" if len(culls) and str(culls.iloc[0]) == "True" else kernel


def _vs_fastest(r: pd.Series) -> str:
    return format_estimate(r["vs_fastest"], r["vs_fastest_ci_low"], r["vs_fastest_ci_high"], "×")


def _slower(r: pd.Series, g: pd.DataFrame) -> str:
    return f"{_named(r['kernel'], g)}: {_vs_fastest(r)} slower"


def _fastest_cells(best: pd.Series, g: pd.DataFrame) -> dict[str, str]:
    """The fastest kernel of ``g``: its name, ns/test, speedup, measured robustness and bytes per triangle cells."""
    if best["kernel"] == best["baseline"]:
        speedup = "(the baseline)"
    else:
        speedup = format_estimate(best["speedup"], best["speedup_ci_low"], best["speedup_ci_high"], "×")
    ns = format_estimate(best["ns_per_test"], best["ns_per_test_ci_low"], best["ns_per_test_ci_high"])
    return {
        "fastest": _named(best["kernel"], g),
        "ns": ns,
        "speedup": speedup,
        # a frame built by hand may lack validate's columns: its cells then say not validated
        "cracks": _per_million(best.get("cracks_per_million", math.nan), best.get("shared_edge_rays")),
        "sphere": _per_million(best.get("sphere_misses_per_million", math.nan), best.get("sphere_rays")),
        "bytes": best["bytes_per_triangle"],
    }


def _pair(frame: pd.DataFrame, a: str, b: str) -> pd.DataFrame:
    """The rows of ``algorithms.csv`` that set algorithms ``a`` and ``b`` against each other, either way round."""
    algorithm, other = frame["algorithm"], frame["other_algorithm"]
    return frame.loc[((algorithm == a) & (other == b)) | ((algorithm == b) & (other == a))]


def ranking_rows(rank: pd.DataFrame) -> pd.DataFrame:
    """One display row per workload of ``ranking.csv`` (its rows in file order).

    >>> rank = pd.DataFrame({"workload_id": ["w", "w"], "family": ["f", "f"], "label": ["l", "l"],
    ...     "dtype": ["float32"] * 2, "rank": [1, 2], "kernel": ["a", "b"], "ns_per_test": [1.0, 2.0],
    ...     "ns_per_test_ci_low": [0.9, 1.9], "ns_per_test_ci_high": [1.1, 2.1], "vs_fastest": [1.0, 2.0],
    ...     "vs_fastest_ci_low": [1.0, 1.8], "vs_fastest_ci_high": [1.0, 2.2], "tied_with_fastest": [True, False],
    ...     "speedup": [2.0, 1.0], "speedup_ci_low": [1.8, float("nan")], "speedup_ci_high": [2.2, float("nan")],
    ...     "baseline": ["b", "b"], "watertight": [False, True], "bytes_per_triangle": [36, 48]})
    >>> r = ranking_rows(rank).iloc[0]
    >>> r["fastest"], r["ns"], r["next"], r["watertight_best"]
    ('a', '1 [0.9, 1.1]', 'b: 2× [1.8, 2.2] slower', 'b: 2× [1.8, 2.2] slower')
    >>> ranking_rows(rank.assign(culls_back_faces=[True, False])).iloc[0]["fastest"]
    'a (front faces only)'
    """
    rows = []
    for _, g in rank.groupby("workload_id", sort=False):
        g = g.sort_values("rank")
        best = g.iloc[0]
        tied = [_named(k, g) for k in g.loc[g["tied_with_fastest"].astype(bool), "kernel"] if k != best["kernel"]]
        rest = g.iloc[1:]

        tight = g.loc[g["watertight"].astype(str) == "True"]
        if tight.empty:
            watertight = "none in this run"
        elif tight.iloc[0]["rank"] == 1:
            watertight = f"{tight.iloc[0]['kernel']} (the fastest)"
        else:
            watertight = _slower(tight.iloc[0], g)
        rows.append(
            {
                "dtype": best["dtype"],
                "workload": f"{best['family']} · {best['label']}",
                **_fastest_cells(best, g),
                "tied": ", ".join(tied) or "none",
                "next": _slower(rest.iloc[0], g) if len(rest) else "–",
                "watertight_best": watertight,
            }
        )
    return pd.DataFrame(rows)


def algorithm_order(rank: pd.DataFrame) -> pd.DataFrame:
    """Per workload, the algorithms from the fastest down, each by its fastest form, in one line.

    >>> rank = pd.DataFrame({"workload_id": ["w"] * 3, "family": ["f"] * 3, "label": ["l"] * 3,
    ...     "dtype": ["float32"] * 3, "rank": [1, 2, 3], "kernel": ["a_fast", "b", "a"],
    ...     "algorithm": ["a", "b", "a"], "vs_fastest": [1.0, 1.5, 2.0], "vs_fastest_ci_low": [1.0, 1.4, 1.9],
    ...     "vs_fastest_ci_high": [1.0, 1.6, 2.1]})
    >>> algorithm_order(rank)["order"].iloc[0]
    'a (a_fast) · b 1.5× [1.4, 1.6]'
    """
    rows = []
    for _, g in rank.groupby("workload_id", sort=False):
        best = g.sort_values("rank").drop_duplicates("algorithm")
        parts = []
        for r in best.itertuples(index=False):
            form = f" ({r.kernel})" if r.kernel != r.algorithm else ""
            ratio = format_estimate(r.vs_fastest, r.vs_fastest_ci_low, r.vs_fastest_ci_high, "×")
            parts.append(f"{r.algorithm}{form}" + ("" if r.rank == 1 else f" {ratio}"))
        first = g.iloc[0]
        rows.append(
            {"dtype": first["dtype"], "workload": f"{first['family']} · {first['label']}", "order": " · ".join(parts)}
        )
    return pd.DataFrame(rows)


def question_rows(alg: pd.DataFrame) -> pd.DataFrame:
    """Per workload, the answer to each of :data:`QUESTIONS` the run can answer (``algorithms.csv``).

    >>> alg = pd.DataFrame({"workload_id": ["w"], "family": ["f"], "label": ["l"], "dtype": ["float64"],
    ...     "algorithm": ["moller_trumbore"], "kernel": ["mt"], "other_algorithm": ["curless"],
    ...     "other_kernel": ["c"], "ratio": [1.5], "ratio_ci_low": [1.4], "ratio_ci_high": [1.6],
    ...     "verdict": ["faster"]})
    >>> question_rows(alg).iloc[0]["curless vs moller_trumbore"]
    'moller_trumbore faster: 1.5× [1.4, 1.6]'
    """
    rows = []
    for _, g in alg.groupby("workload_id", sort=False):
        first = g.iloc[0]
        row = {"dtype": first["dtype"], "workload": f"{first['family']} · {first['label']}"}
        for a, b in QUESTIONS:
            hit = _pair(g, a, b)
            if hit.empty:
                continue
            r = hit.iloc[0]
            ratio = format_estimate(r["ratio"], r["ratio_ci_low"], r["ratio_ci_high"], "×")
            said = {"faster": f"{r['algorithm']} faster", "equivalent": "equivalent"}.get(
                r["verdict"], "not told apart"
            )
            row[f"{a} vs {b}"] = f"{said}: {ratio}"
        if len(row) > 2:
            rows.append(row)
    return pd.DataFrame(rows)


def ranking_section(data: RunData, rank: pd.DataFrame, alg: pd.DataFrame | None = None) -> str:
    """The ranking table per precision, the order of the algorithms, the head-to-head questions."""
    if rank.empty:
        return page.p(f"No ranking: {NOTHING_RANKED}.")
    shown = ranking_rows(rank)
    cols = [
        ("workload", "workload"),
        ("fastest", "fastest kernel"),
        ("ns", "its ns/test [95% CI]"),
        ("speedup", f"its speedup over {data.baseline}"),
        ("tied", "not told apart from it"),
        ("next", "next kernel, time / fastest's"),
        ("watertight_best", "fastest watertight kernel"),
        ("cracks", "shared-edge cracks per 10⁶ rays (fastest)"),
        ("sphere", "far-sphere misses per 10⁶ rays (fastest)"),
        ("bytes", "bytes per triangle (fastest)"),
    ]
    parts = []
    for dtype, g in shown.groupby("dtype", sort=False):
        parts.append(f"<h3>{dtype}</h3>" + page.table(g, cols, titles=ROBUSTNESS_TIPS))
    if rank["algorithm"].nunique() > 1:
        order = algorithm_order(rank)
        parts.append("<h3>The algorithms in order</h3>")
        parts.append(
            page.p(
                "Each algorithm by its fastest form on the workload, and that form's time over the fastest's "
                "[simultaneous 95% CI].",
                "note",
            )
        )
        for dtype, g in order.groupby("dtype", sort=False):
            parts.append(page.table(g, [("workload", f"workload ({dtype})"), ("order", "fastest first")]))
    answers = question_rows(alg) if alg is not None and not alg.empty else pd.DataFrame()
    if not answers.empty:
        asked = [c for c in answers.columns if c not in ("dtype", "workload")]
        parts.append("<h3>Head to head</h3>")
        parts.append(
            page.p(
                "Baldwin & Weber's claim (faster than Möller–Trumbore at every hit rate) and the seed's question "
                "(Curless against Möller), each algorithm in its fastest form here: the faster one's speedup "
                "[simultaneous 95% CI, Bonferroni over the workload's pairs of algorithms] (algorithms.csv).",
                "note",
            )
        )
        for dtype, g in answers.groupby("dtype", sort=False):
            parts.append(page.table(g, [("workload", f"workload ({dtype})")] + [(c, c) for c in asked]))
    parts.append(
        page.p(
            "Per workload, the kernel with the lowest mean ns per test, and every other kernel's time over "
            "its time, paired by process, with simultaneous 95% intervals (Bonferroni over the workload's kernels). "
            f"“Not told apart” lists the kernels whose interval reaches down to 1 + the equivalence margin "
            f"({100 * data.margin:.2g}%): the point estimate alone picked the fastest among them. Every kernel's "
            "rank is in ranking.csv.",
            "note",
        )
    )
    return "".join(parts)


# ------------------------------------------------------------ the answer: bands.csv


def band_rows(bands: pd.DataFrame) -> pd.DataFrame:
    """One display row per precision and band of ``bands.csv``: the fastest, its figures, the runners-up.

    >>> bands = pd.DataFrame({"dtype": ["float32"] * 3, "band": ["meshes, brute force"] * 3, "workloads": [2] * 3,
    ...     "rank": [1, 2, 3], "kernel": ["a", "b", "c"], "ns_per_test": [1.0, 1.1, 2.0],
    ...     "ns_per_test_ci_low": [0.9, 1.0, 1.9], "ns_per_test_ci_high": [1.1, 1.2, 2.1],
    ...     "vs_fastest": [1.0, 1.1, 2.0], "vs_fastest_ci_low": [1.0, 0.95, 1.8], "vs_fastest_ci_high": [1.0, 1.2, 2.2],
    ...     "tied_with_fastest": [True, True, False], "speedup": [3.0, 2.7, 1.0], "speedup_ci_low": [2.8, 2.5, None],
    ...     "speedup_ci_high": [3.2, 2.9, None], "baseline": ["c"] * 3, "watertight": [False, True, False],
    ...     "culls_back_faces": [False] * 3, "bytes_per_triangle": [48, 64, 36],
    ...     "cracks_per_million": [31600.0, 0.0, 5.0], "shared_edge_rays": [20000] * 3,
    ...     "sphere_misses_per_million": [0.0, 0.0, 1.0], "sphere_rays": [2000] * 3})
    >>> r = band_rows(bands).iloc[0]
    >>> r["band"], r["fastest"], r["speedup"], r["tied"], r["next"]
    ('meshes, brute force (2 workloads)', 'a', '3× [2.8, 3.2]', 'b', 'c: 2× [1.8, 2.2] slower')
    >>> r["watertight"], r["cracks"], r["sphere"], int(r["bytes"])
    ('no; fastest watertight: b, not told apart (1.1× [0.95, 1.2])', '31,600 (20,000 rays)', '0 (2,000 rays)', 48)
    >>> band_rows(bands.assign(tied_with_fastest=[True, False, False])).iloc[0]["watertight"]
    'no; fastest watertight: b, 1.1× [0.95, 1.2] slower'
    """
    rows = []
    for _, g in bands.groupby(["dtype", "band"], sort=False):
        g = g.sort_values("rank")
        best = g.iloc[0]
        tied = g.iloc[1:].loc[g["tied_with_fastest"].iloc[1:].astype(bool)]
        rest = g.iloc[1:].loc[~g["tied_with_fastest"].iloc[1:].astype(bool)]

        tight = g.loc[g["watertight"].astype(str) == "True"]
        if str(best["watertight"]) == "True":
            watertight = "yes"
        elif tight.empty:
            watertight = "no (no watertight kernel in this run)"
        else:  # a tied one is "not told apart": "slower" would overstate what its interval shows
            r = tight.iloc[0]
            cost = f"not told apart ({_vs_fastest(r)})" if bool(r["tied_with_fastest"]) else f"{_vs_fastest(r)} slower"
            watertight = f"no; fastest watertight: {_named(r['kernel'], g)}, {cost}"
        rows.append(
            {
                "dtype": best["dtype"],
                "band": f"{best['band']} ({best['workloads']} workload{'s' if best['workloads'] != 1 else ''})",
                **_fastest_cells(best, g),
                "tied": ", ".join(_named(k, g) for k in tied["kernel"]) or "none",
                "next": _slower(rest.iloc[0], g) if len(rest) else "–",
                "watertight": watertight,
            }
        )
    return pd.DataFrame(rows)


#: Header tooltips of the measured-robustness columns: what each counts, at the row's precision.
ROBUSTNESS_TIPS = {
    "cracks": "tribench validate's shared_edges test at this precision: rays aimed exactly at an edge two "
    "coplanar triangles share that hit neither, per million rays (cracks_per_million in bands.csv and ranking.csv)",
    "sphere": "tribench validate's inside_sphere test (Embree's watertightness test) at this precision: rays "
    "from inside a closed sphere of radius 2 centred at (148376, 1234, -223423), where float32 spacing is "
    "1/64, that hit nothing, "
    "per million rays (sphere_misses_per_million in bands.csv and ranking.csv)",
}


def _per_million(rate: float, rays: float) -> str:
    """A failure count per million rays, with the rays it was measured on (few rays: a coarse figure)."""
    return "not validated" if pd.isna(rate) else f"{rate:,.0f} ({int(rays):,} rays)"


def _span(values: list[float]) -> str:
    return page.span(min(values), max(values), "×")


def _bands_named(places: list[str]) -> str:
    """Bands for a sentence, the shared words of a precision's hit-rate bands said once.

    >>> _bands_named(["float32 pairs, hit rate 0–35%", "float32 pairs, hit rate 35–65%", "float64 meshes, in a BVH"])
    'float32 pairs, hit rate 0–35%, 35–65% and float64 meshes, in a BVH'
    """
    shared: dict[str, list[str]] = {}
    for place in places:
        words, _, last = place.rpartition(" ")
        shared.setdefault(words, []).append(last)
    return " and ".join(f"{words} {', '.join(last)}" for words, last in shared.items())


def answer_sentences(bands: pd.DataFrame, alg: pd.DataFrame | None) -> list[str]:
    """One sentence per question a user asks (docs/results.md), from ``bands.csv`` and ``algorithms.csv``.

    >>> bands = pd.DataFrame({"dtype": ["float32"] * 2, "band": ["meshes"] * 2, "rank": [1, 2],
    ...     "kernel": ["a", "b"], "vs_fastest": [1.0, 1.5], "speedup": [1.5, 1.0], "baseline": ["b"] * 2,
    ...     "watertight": [False, True]})
    >>> for s in answer_sentences(bands, None): print(s)
    Fastest: a on float32 meshes.
    Against b: the fastest kernel of each band is 1.5× as fast.
    Watertight: the fastest watertight kernel (b) takes 1.5× the fastest's time.
    """
    out = []
    best = bands.loc[bands["rank"] == 1]
    places = {k: [f"{r.dtype} {r.band}" for r in g.itertuples()] for k, g in best.groupby("kernel", sort=False)}
    n = len(best)
    out.append(
        "Fastest: "
        + "; ".join(
            f"{k} on " + (f"every band ({n})" if len(p) == n and n > 2 else _bands_named(p)) for k, p in places.items()
        )
        + "."
    )
    baseline = str(bands["baseline"].iloc[0])
    gains = [float(r.speedup) for r in best.itertuples() if r.kernel != baseline and not pd.isna(r.speedup)]
    if gains:
        out.append(f"Against {baseline}: the fastest kernel of each band is {_span(gains)} as fast.")
    tight = bands.loc[bands["watertight"].astype(str) == "True"]
    if tight.empty:
        out.append("Watertight: no kernel of this run promises it.")
    else:
        first = tight.sort_values("rank").groupby(["dtype", "band"], sort=False).head(1)
        costs = [float(v) for v in first["vs_fastest"] if not pd.isna(v)]
        names = ", ".join(dict.fromkeys(first["kernel"]))
        free = int((first["rank"] == 1).sum())
        if free == len(first):
            out.append(f"Watertight: {names}, watertight by its paper, is the fastest in every band: it costs nothing.")
        else:
            text = f"Watertight: the fastest watertight kernel ({names}) takes {_span(costs)} the fastest's time"
            out.append(text + (f"; it is the fastest in {free} of {len(first)} bands." if free else "."))
    if alg is not None and not alg.empty:
        for a, b in QUESTIONS:
            rows = _pair(alg, a, b)
            if rows.empty:
                continue
            parts = []
            for winner in (a, b):
                won = rows.loc[(rows["verdict"] == "faster") & (rows["algorithm"] == winner)]
                if len(won):
                    parts.append(f"{winner} faster on {len(won)} ({_span(list(won['ratio']))})")
            same = int((rows["verdict"] == "equivalent").sum())
            unclear = int((~rows["verdict"].isin(["faster", "equivalent"])).sum())
            if same:
                parts.append(f"equivalent on {same}")
            if unclear:
                parts.append(f"not told apart on {unclear}")
            out.append(
                f"{a} or {b}? Of {len(rows)} workloads, each algorithm in its fastest form: " + ", ".join(parts) + "."
            )
    return out


def answer_section(data: RunData, bands: pd.DataFrame | None, alg: pd.DataFrame | None, colours: dict[str, str]) -> str:
    """The answer section (docs/results.md); ``colours``: the chart's kernels."""
    if bands is None:
        return page.p(
            f"No ranking by band: these tables were made by an older tribench. Run `tribench stats {data.run_dir}`."
        )
    if bands.empty:
        return page.p(f"No ranking: {NOTHING_RANKED}.")
    shown = band_rows(bands)
    cols = [
        ("band", "band"),
        ("fastest", "fastest kernel"),
        ("ns", "ns/test [95% CI]"),
        ("speedup", f"speedup over {data.baseline} [95% CI]"),
        ("tied", "not told apart from it"),
        ("next", "next, time / fastest's"),
        ("watertight", "watertight"),
        ("cracks", "shared-edge cracks per 10⁶ rays"),
        ("sphere", "far-sphere misses per 10⁶ rays"),
        ("bytes", "bytes per triangle"),
    ]
    parts = []
    for dtype, g in shown.groupby("dtype", sort=False):
        table = page.table(g, cols, titles=ROBUSTNESS_TIPS)
        parts.append(f'<h3>{escape(str(dtype))}</h3><div class="answer">{table}</div>')
    items = "".join(f"<li>{escape(s)}</li>" for s in answer_sentences(bands, alg))
    parts.append(f'<ul class="verdicts">{items}</ul>')
    if bands["cracks_per_million"].isna().all():  # a missing rate is not 0: the chart has nowhere to put a kernel
        parts.append(
            page.p(
                f"This run has no {runfolder.VALIDATE}, so the chart below has no robustness to place its kernels "
                f"at: `tribench validate --out {data.run_dir}`, then `tribench stats {data.run_dir}`.",
                "note",
            )
        )
    parts.append(
        charts.embed(
            answer_chart(bands, colours),
            "chart-answer",
            "speed against robustness against memory",
            "Speed against robustness against memory, in the band the menu picks: each kernel's ns/test "
            "(dot) with its 95% CI (line), its measured robustness failures per million rays (height: cracks at "
            "exactly shared edges plus misses from inside Embree's far-off sphere, at the band's precision), bytes "
            "per prepared triangle (size), watertight by its paper (shape). "
            "Hover for the figures; click a kernel in the legend to show it alone, shift-click to add more, "
            "double-click the plot to show all.",
        )
    )
    parts.append(
        page.p(
            "Per precision and band (pairs by their achieved per-test hit rate, meshes brute force or in a BVH), "
            "each kernel's value in a process is the geometric mean of its median ns/test over the band's "
            "workloads; the table gives the mean over processes with its 95% t interval, and paired ratios with "
            "simultaneous 95% intervals (Bonferroni over the band's kernels). “Not told apart” lists the kernels "
            "whose interval against the fastest reaches down to 1 + the equivalence margin "
            f"({100 * data.margin:.2g}%). "
            "Watertight: the kernel's paper promises no crack on shared edges (tribench.ext.kernel_info). Cracks "
            "and far-sphere misses: measured by the robustness suite at that precision (rays aimed exactly at an "
            "edge two triangles share that hit neither; rays from inside a closed sphere far from the origin, "
            "Embree's test, that hit nothing); the promises the suite holds each kernel to are in Robustness. "
            "Every kernel of every band is in bands.csv; per workload, in the ranking below.",
            "note",
        )
    )
    return "".join(parts)


# ------------------------------------------------------------ the terminal


def format_run(data: RunData) -> str:
    """Per workload (sweep order): each kernel's ns/test with its 95% CI, then its speedup and verdict."""
    est, spd = data.estimates, data.speedups
    lines = [
        f"run {data.run.run_id}: {len(data.kernels)} kernels x "
        f"{len(data.workload_ids)} workloads, {data.n_processes} processes x {data.run.sweep.rounds} rounds"
        + (
            f"; build {data.build} ({len(data.builds)} builds: the report's Across builds compares them)"
            if len(data.builds) > 1
            else ""
        ),
        f"ns/test: mean over processes, 95% CI; speedup = time_{data.baseline} / time_kernel, "
        f"simultaneous 95% CI; margin ±{100 * data.margin:.2g}%",
    ]
    for wid in data.workload_ids:
        spec = data.specs[wid]
        rows = in_order(est.loc[est["workload_id"] == wid], kernel=data.kernels)
        if rows.empty:
            continue
        sp = spd.loc[spd["workload_id"] == wid].set_index("kernel")
        lines += [
            "",
            f"{family_of(spec)}: {short_label(spec)}  [{wid}]",
            f"  {'kernel':<24}{'ns/test':>9}  {'95% CI':<18}{'speedup':>8}  {'CI':<16}  verdict",
        ]
        for r in rows.itertuples(index=False):
            ci = format_interval(None, r.ns_per_test_ci_low, r.ns_per_test_ci_high, ".3f")
            left = f"  {r.kernel:<24}{r.ns_per_test:9.3f}  {ci:<18}"
            if r.kernel in sp.index:
                s = sp.loc[r.kernel]
                ci = format_interval(None, s["ratio_ci_low"], s["ratio_ci_high"], ".3f")
                left += f"{s['ratio']:7.3f}x  {ci:<16}  {s['verdict']}"
            elif r.kernel == data.baseline:
                left += "(baseline)"
            lines.append(left.rstrip())
        if data.baseline not in set(rows["kernel"]):  # a BVH workload: the brute-force baseline is no leaf test
            lines.append(f"  no speedups: {data.baseline} did not run on this workload")
    return "\n".join(lines + ["", format_answer(data)])


def format_answer(data: RunData) -> str:
    """The first screen in words: per precision and band the fastest kernel, its speedup and ties, then the answers."""
    bands = data.tables.get(runfolder.BANDS)
    if bands is None:
        return "the answer: no ranking by band in these tables (run tribench stats on the folder)"
    if bands.empty:
        return f"the answer: {NOTHING_RANKED}"
    lines = [f"the answer, per precision and band (speedup over {data.baseline}, 95% CI):"]
    for r in band_rows(bands).itertuples(index=False):
        lines.append(
            f"  {r.dtype} {r.band}: {r.fastest}, {r.ns} ns/test, {r.speedup}; tied with it: {r.tied}; "
            f"watertight: {r.watertight}"
        )
    lines += [f"  {sentence}" for sentence in answer_sentences(bands, data.tables.get(runfolder.ALGORITHMS))]
    return "\n".join(lines)
