"""``report.html``: one self-contained page per run.

Plain HTML with a small inline stylesheet and no script; every figure is a
``data:`` URI, so the file opens offline and references nothing outside
itself. All text goes through :func:`html.escape`.

Sections (ids): ``headline``, ``kernels``, ``speedups``, ``hit-rate``,
``scaling``, ``peers``, ``processes``, ``drift``, ``diagnostics``, ``correctness``,
``robustness``, ``workloads``, ``machine``, ``reproduce``.
"""

from __future__ import annotations

import datetime as _dt
import json
import math
from collections.abc import Callable, Iterable, Sequence
from html import escape
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from tribench.harness import analysis, runfolder

from . import columns, content, figures
from .rundata import VALIDATE, PeerTables, RunData, load_peers, load_validation

__all__ = ["SECTIONS", "render", "headline_sentences", "sweep_toml", "MAX_PICTURES"]

#: Section ids, in page order, with their titles.
SECTIONS = {
    "headline": "Headline",
    "kernels": "Kernels",
    "speedups": "Speedups",
    "hit-rate": "Hit rate",
    "scaling": "Size and working set",
    "peers": "Against peers",
    "processes": "Per-process values",
    "drift": "Drift",
    "diagnostics": "Diagnostics",
    "correctness": "Correctness",
    "robustness": "Robustness",
    "workloads": "Workloads",
    "machine": "Machine and build",
    "reproduce": "Reproduce",
}

#: At most this many workload pictures are drawn, at this resolution, by the analysis step
#: (:mod:`tribench.harness.analysis`; 60 dpi: 840 to 1080 px wide, 1.5 to 2 times the ~550 px shown).
MAX_PICTURES, PICTURE_DPI = analysis.MAX_PICTURES, analysis.PICTURE_DPI

_CSS = """
body{font-family:system-ui,-apple-system,"Segoe UI",Roboto,Helvetica,Arial,sans-serif;margin:0;
 color:#1f2328;background:#fff;line-height:1.45}
main{max-width:1180px;margin:0 auto;padding:12px 28px 60px}
h1{font-size:1.6em;margin:.4em 0 .1em}h2{font-size:1.3em;border-bottom:2px solid #d0d7de;
 padding-bottom:.2em;margin-top:2.2em}h3{font-size:1.05em;margin:1.3em 0 .4em}
nav{position:sticky;top:0;background:#f6f8fa;border-bottom:1px solid #d0d7de;padding:6px 28px;
 font-size:.9em;z-index:2}nav a{margin-right:.9em;color:#0b57d0;text-decoration:none}
.sub{color:#57606a;margin:0 0 1em}
.verdicts{font-size:1.08em;padding-left:1.2em}.verdicts li{margin:.25em 0}
.faster{color:#1a7f37;font-weight:600}.slower{color:#c62828;font-weight:600}
.equivalent{color:#5f6b7a;font-weight:600}.inconclusive{color:#b45309;font-weight:600}.mixed{font-weight:600}
.broken{color:#c62828;font-weight:700;background:#ffebe9}
.warn{background:#fff8c5;border:1px solid #d4a72c;border-radius:6px;padding:6px 12px;margin:.6em 0}
.note{color:#57606a;font-size:.92em}
table{border-collapse:collapse;font-size:.86em;margin:.5em 0 1em}
th,td{border-bottom:1px solid #e5e7eb;padding:3px 9px;text-align:left;vertical-align:top}
th{background:#f6f8fa;font-weight:600}td.num{text-align:right;font-variant-numeric:tabular-nums}
figure{margin:.8em 0 1.4em}figure img{max-width:100%;height:auto;display:block}
figcaption{color:#57606a;font-size:.9em;margin-top:.3em}
pre{background:#f6f8fa;border:1px solid #d0d7de;border-radius:6px;padding:10px;overflow-x:auto;font-size:.85em}
code{font-family:ui-monospace,SFMono-Regular,Menlo,Consolas,monospace;font-size:.92em}
.pictures{display:grid;grid-template-columns:repeat(auto-fill,minmax(520px,1fr));gap:18px}
details summary{cursor:pointer;color:#0b57d0}
"""


# ------------------------------------------------------------------ helpers


def _num(x: Any, digits: int = 3) -> str:
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "–"
    if isinstance(x, (bool, np.bool_)):
        return "yes" if x else "no"
    if isinstance(x, (int, np.integer)):
        return f"{int(x):,}"
    if isinstance(x, (float, np.floating)):
        if x == 0:
            return "0"
        return f"{x:.{digits}g}" if abs(float(x)) < 1e5 else f"{x:.{digits}e}"
    return str(x)


def _table(frame: pd.DataFrame, cols: Sequence[tuple[str, str]], digits: int = 4,
           classes: dict[str, Callable[[Any], str]] | None = None) -> str:
    """An HTML table of ``frame``; ``cols`` pairs a column with its header (units in it).

    ``classes`` maps a column to a function giving each of its cells' CSS class from the value.
    """
    if frame.empty:
        return '<p class="note">(none)</p>'
    head = "".join(f"<th>{escape(h)}</th>" for _, h in cols)
    body = []
    for _, row in frame.iterrows():
        cells = []
        for c, _ in cols:
            v = row.get(c)
            numeric = isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, (bool, np.bool_))
            text = _num(v, digits) if v is not None and not (isinstance(v, float) and math.isnan(v)) else "–"
            cls = ' class="num"' if numeric else ""
            if c == "verdict" and isinstance(v, str):
                cls = f' class="{escape(v)}"'
            if classes and c in classes:
                cls = f' class="{escape(classes[c](v))}"'
            cells.append(f"<td{cls}>{escape(text)}</td>")
        body.append("<tr>" + "".join(cells) + "</tr>")
    return f"<table><thead><tr>{head}</tr></thead><tbody>{''.join(body)}</tbody></table>"


def _kv_table(items: Iterable[tuple[str, Any]]) -> str:
    rows = "".join(f"<tr><th>{escape(str(k))}</th><td>{escape(_plain(v))}</td></tr>" for k, v in items)
    return f"<table>{rows}</table>"


def _plain(v: Any) -> str:
    if v is None:
        return "–"
    if isinstance(v, (list, tuple)):
        return ", ".join(_plain(x) for x in v)
    if isinstance(v, dict):
        return ", ".join(f"{k} {_plain(x)}" for k, x in v.items())
    return str(v)


def _ordered(frame: pd.DataFrame, data: RunData) -> pd.DataFrame:
    """Rows in sweep order: workloads, then kernels."""
    if frame.empty:
        return frame
    w = {x: i for i, x in enumerate(data.workload_ids)}
    k = {x: i for i, x in enumerate(data.kernels)}
    key = frame["workload_id"].map(w) * 1000 + frame["kernel"].map(k)
    return frame.assign(_key=key).sort_values("_key", kind="stable").drop(columns="_key").reset_index(drop=True)


def _figure(uri: str, alt: str, caption: str) -> str:
    return (f'<figure><img src="{escape(uri)}" alt="{escape(alt)}">'
            f"<figcaption>{escape(caption)}</figcaption></figure>")


def _section(sid: str, body: str, heading: bool = True) -> str:
    h2 = f"<h2>{escape(SECTIONS[sid])}</h2>" if heading else ""
    return f'<section id="{sid}">{h2}{body}</section>'


def _p(text: str, cls: str = "") -> str:
    c = f' class="{cls}"' if cls else ""
    return f"<p{c}>{escape(text)}</p>"


def _ci(low: float, high: float) -> str:
    if not (math.isfinite(low) and math.isfinite(high)):
        return "no interval: too few processes"
    return f"{low:.3g}–{high:.3g}"


# ----------------------------------------------------------------- headline


def headline_sentences(spd: pd.DataFrame) -> dict[str, list[tuple[str, str]]]:
    """One sentence per kernel against the baseline, per workload family.

    ``spd`` is ``speedups.csv`` with ``family`` and ``label`` columns (and
    ``test_hit_rate``); returns ``{family: [(verdict, sentence), ...]}``.
    Verdicts are the ones in the table (``stats.verdict``); nothing is
    recomputed here.

    Examples
    --------
    >>> spd = pd.DataFrame({"family": ["pairs n=10"], "label": ["per-test hit rate 50%"],
    ...     "kernel": ["mt"], "baseline": ["seed"], "ratio": [1.18], "ratio_ci_low": [1.15],
    ...     "ratio_ci_high": [1.21], "n_processes": [10], "verdict": ["faster"], "confidence": [0.975]})
    >>> headline_sentences(spd)["pairs n=10"][0][1]
    'mt is faster than seed: 1.18× (95% CI 1.15–1.21, 10 processes) on pairs n=10 at per-test hit rate 50%.'
    """
    out: dict[str, list[tuple[str, str]]] = {}
    for family, fam in spd.groupby("family", sort=False):
        for kernel, g in fam.groupby("kernel", sort=False):
            base = g["baseline"].iloc[0]
            n = int(g["n_processes"].min())
            procs = f"{n} processes" if n != 1 else "1 process"
            verdicts = list(dict.fromkeys(g["verdict"]))
            if len(g) == 1:
                r = g.iloc[0]
                where = f"on {family} at {r['label']}" if r["label"] not in family else f"on {family}"
                out.setdefault(family, []).append(
                    (r["verdict"], f"{kernel} {_verdict_phrase(r['verdict'], base)}: {r['ratio']:.3g}× "
                                   f"(95% CI {_ci(r['ratio_ci_low'], r['ratio_ci_high'])}, {procs}) {where}."))
                continue
            lo, hi = g.loc[g["ratio"].idxmin()], g.loc[g["ratio"].idxmax()]
            span = (f"from {lo['ratio']:.3g}× (95% CI {_ci(lo['ratio_ci_low'], lo['ratio_ci_high'])}) "
                    f"at {lo['label']} to {hi['ratio']:.3g}× "
                    f"(95% CI {_ci(hi['ratio_ci_low'], hi['ratio_ci_high'])}) at {hi['label']}")
            if len(verdicts) == 1:
                text = f"{kernel} {_verdict_phrase(verdicts[0], base)} on all {len(g)} workloads: {span}; {procs}."
                out.setdefault(family, []).append((verdicts[0], text))
            else:
                parts = "; ".join(f"{v} at " + ", ".join(g.loc[g['verdict'] == v, 'label']) for v in verdicts)
                text = f"{kernel} against {base} depends on the workload — {parts}: {span}; {procs}."
                out.setdefault(family, []).append(("mixed", text))
    return out


def _verdict_phrase(verdict: str, base: str) -> str:
    return {
        "faster": f"is faster than {base}",
        "slower": f"is slower than {base}",
        "equivalent": f"is equivalent to {base} (inside the equivalence margin)",
    }.get(verdict, f"cannot be told apart from {base} (inconclusive)")


def _headline(data: RunData, spd: pd.DataFrame, wl: pd.DataFrame, warnings: list[str],
              peers: PeerTables | None = None) -> str:
    m = data.machine
    sweep = data.run["sweep"]
    families = list(dict.fromkeys(wl["family"]))
    parts = [
        f"<h1>{escape(', '.join(k for k in data.kernels if k != data.baseline))} against {escape(data.baseline)}"
        f"</h1>",
        _p(f"Run {data.run.get('run_id', data.run_dir.name)}, {data.run.get('created', '')}: "
           f"{len(data.kernels)} kernels on {len(wl)} workloads in {len(families)} families, "
           f"{data.n_processes} worker processes × {sweep.get('rounds')} rounds "
           f"(+{sweep.get('warmup')} warm-up), on {m.get('cpu_model', 'an unknown CPU')} "
           f"({m.get('build', {}).get('compiler', 'unknown compiler')}). Baseline: {data.baseline}. "
           f"Speedup = time_{data.baseline} / time_kernel, so above 1 means faster.", "sub"),
    ]
    sentences = headline_sentences(spd)
    if not sentences:
        parts.append(_p("No speedups: this run has a single kernel. Its estimates are below."))
    for family in families:
        if family not in sentences:
            continue
        items = "".join(f'<li><span class="{escape(v)}">{escape(v)}</span> — {escape(s)}</li>'
                        for v, s in sentences[family])
        parts.append(f"<h3>{escape(family)}</h3><ul class=\"verdicts\">{items}</ul>")
    if peers is not None and (sentence := peer_sentence(peers.ratios, peers.kernel, peers.workload)):
        parts.append(_p(sentence + " (see Against peers)"))
    parts.append(_p(
        f"Intervals are simultaneous 95% intervals over the kernels compared on each workload "
        f"(Bonferroni; p-values Holm-adjusted), with the worker process as the replicate. "
        f"Verdicts use an equivalence margin of ±{100 * data.margin:.2g}% ({data.margin_source}). "
        f"Pair workloads are described by their per-test hit rate (fraction of ray–triangle tests that hit); "
        f"mesh workloads by their per-ray hit rate (fraction of rays that hit the mesh at all).", "note"))
    parts += [f'<div class="warn">{escape(w)}</div>' for w in warnings]
    return _section("headline", "".join(parts), heading=False)


def _warnings(data: RunData, drift: pd.DataFrame, correct: pd.DataFrame) -> list[str]:
    out = []
    if data.n_processes < 5:
        out.append(f"Only {data.n_processes} worker processes: intervals rest on {data.n_processes - 1} "
                   f"degrees of freedom and are wide; use 10 or more for conclusions.")
    if data.margin_source.startswith("default"):
        out.append("The equivalence margin is the default, not an A/A calibration of this machine "
                   "(run `tribench calibrate`).")
    flagged = drift.loc[drift["flagged"] == True]  # noqa: E712 (nullable column)
    for r in flagged.itertuples(index=False):
        out.append(f"Drift: {r.kernel} against {data.baseline} on {r.label} ({r.reason}); see the drift section.")
    bad = correct.loc[correct["agrees"] == False]  # noqa: E712
    for r in bad.itertuples(index=False):
        out.append(f"Correctness: {r.kernel} on {r.workload_id} differs from the reference by "
                   f"{_num(r.hit_difference)} hits per pass (see the correctness table).")
    expected = data.run.get("n_batches")
    if expected and len(data.batches) < expected:
        out.append(f"Incomplete run: {len(data.batches)} of {expected} planned batches "
                   f"(finish it with `tribench sweep --resume {data.run_dir}`).")
    return out


# ----------------------------------------------------------------- sections


_EST_COLS = [("kernel", "kernel"), ("label", "workload"), ("ns_per_test", "ns/test (mean)"),
             ("ns_per_test_ci_low", "95% CI low (ns)"), ("ns_per_test_ci_high", "95% CI high (ns)"),
             ("ns_per_test_min", "min (ns)"), ("ns_per_test_bootstrap_low", "BCa low (ns)"),
             ("ns_per_test_bootstrap_high", "BCa high (ns)"), ("n_processes", "processes"),
             ("peak_fraction", "fraction of bound")]
_SPD_COLS = [("kernel", "kernel"), ("label", "workload"), ("ratio", "speedup (×)"),
             ("ratio_ci_low", "CI low (×)"), ("ratio_ci_high", "CI high (×)"), ("p_holm", "p (Holm)"),
             ("n_processes", "processes"), ("verdict", "verdict")]


def _speedups(data: RunData, spd: pd.DataFrame, est: pd.DataFrame) -> str:
    fig = figures.forest(spd, data.baseline, data.margin)
    body = [
        _figure(figures.svg_data_uri(fig), "forest plot of speedups",
                f"Every kernel against {data.baseline}, per workload family: the dot is the speedup "
                f"(time_{data.baseline} / time_kernel), the bar its simultaneous 95% confidence interval, "
                f"the grey band the equivalence margin ±{100 * data.margin:.2g}%. Log axis."),
        "<h3>Speedups</h3>", _table(spd, _SPD_COLS),
        "<h3>Estimates</h3>",
        _p("ns per ray–triangle test: per process the median of its timed batches, then the mean over "
           "processes with a Student-t interval; the BCa bootstrap over processes is a cross-check and the "
           "minimum a robust secondary figure. Fraction of bound: the kernel's documented operations per "
           "test at the process's measured FMA peak (an FMA = one operation), over the measured time; "
           "see the kernels section.", "note"),
        _table(est, _EST_COLS),
    ]
    return _section("speedups", "".join(body))


_KERNEL_COLS = [("kernel", "kernel"), ("form", "form"), ("isa", "ISA"), ("family", "workload family"),
                ("dtype", "precision"), ("bytes_per_triangle", "bytes per triangle"), ("workloads", "workloads"),
                ("ops_per_test", "ops per test"), ("peak_fraction_median", "fraction of bound (median)"),
                ("ns_per_test_median", "ns/test (median)"), ("ns_range", "ns/test (lowest–highest)"),
                ("ratio_median", "speedup (median, ×)"), ("ratio_range", "speedup (lowest–highest, ×)"),
                ("verdicts", "verdicts")]


def _range(low: float, high: float) -> str:
    if not (math.isfinite(low) and math.isfinite(high)):
        return "–"
    return f"{low:.3g}" if f"{low:.3g}" == f"{high:.3g}" else f"{low:.3g}–{high:.3g}"


def _kernels(data: RunData, kern: pd.DataFrame) -> str:
    shown = kern.assign(
        ns_range=[_range(a, b) for a, b in zip(kern["ns_per_test_min"], kern["ns_per_test_max"], strict=True)],
        ratio_range=[_range(a, b) for a, b in zip(kern["ratio_min"], kern["ratio_max"], strict=True)])
    note = ("Each kernel's storage beside its speed, per workload family (a family has one precision). "
            "Form: scalar (one triangle per test, early exit) or 8 lanes (eight triangles per step in SIMD "
            "registers); ISA: the instruction set its batches ran with. Bytes per triangle: its prepared data "
            "for one triangle at the family's precision, which the working set (section ")
    tail = (") counts. Ops per test: the kernel's arithmetic (adds, multiplies, divides, compares; for a "
            "scalar kernel the path of a hit), documented in its header. Fraction of bound: that arithmetic at "
            "the machine's measured FMA peak (one FMA = one operation; a double vector holds half the lanes) "
            "over the measured time; 1 would be the arithmetic limit. A scalar kernel uses one lane of eight, "
            "and its early exits do less than the count. "
            f"ns/test and the speedup over {data.baseline} summarise the family's workloads (median, lowest, "
            "highest); their 95% CIs are in the speedups section, and verdicts counts the workloads by verdict.")
    body = [f'<p class="note">{escape(note)}<a href="#scaling">size and working set</a>{escape(tail)}</p>',
            _table(shown, _KERNEL_COLS, digits=3)]
    return _section("kernels", "".join(body))


def _hit_rate(data: RunData, est: pd.DataFrame, spd: pd.DataFrame, cross: pd.DataFrame,
              colours: dict[str, str]) -> str:
    body = [_p("Pair workloads: N independent (ray, triangle) pairs at an exact per-test hit rate, "
               "the fraction of ray–triangle tests that hit (Löfstedt & Akenine-Möller 2005). "
               "Misses are spread over the three edges unless the family says otherwise; pair order "
               "is shuffled unless it says sorted.", "note")]
    body.append(_figure(figures.svg_data_uri(figures.hit_rate_curves(est, cross, colours)),
                        "ns per test against per-test hit rate",
                        "ns per test against the per-test hit rate, one line per kernel, bands: 95% CIs of "
                        "the mean. Dashed purple: a crossover where two kernels swap rank, with its 95% "
                        "Fieller interval shaded (stats.crossover)."))
    body.append(_figure(figures.svg_data_uri(figures.speedup_vs_hit_rate(spd, data.baseline, data.margin,
                                                                         colours)),
                        "speedup against per-test hit rate",
                        f"Speedup over {data.baseline} against the per-test hit rate (log axis), bands: "
                        f"simultaneous 95% CIs; grey: the equivalence margin."))
    body.append("<h3>Crossovers</h3>")
    found = cross.loc[np.isfinite(cross["hit_rate"].astype(float))] if not cross.empty else cross
    if cross.empty:
        body.append(_p("No family with two or more per-test hit rates: no crossover to look for.", "note"))
    else:
        none = cross.loc[~cross.index.isin(found.index)]
        if found.empty:
            body.append(_p("No ranking flips inside the measured per-test hit rates.", "note"))
        else:
            body.append(_p(f"Kernel pairs whose ranking flips inside the measured per-test hit rates "
                           f"({len(none)} other pairs keep their order throughout).", "note"))
        if not found.empty:
            shown = found.assign(hit_rate_pct=100 * found["hit_rate"], low_pct=100 * found["ci_low"],
                                 high_pct=100 * found["ci_high"])
            body.append(_table(shown, [("family", "family"), ("kernel_a", "kernel A"), ("kernel_b", "kernel B"),
                                       ("hit_rate_pct", "crossover (% per-test hit rate)"),
                                       ("low_pct", "95% CI low (%)"), ("high_pct", "95% CI high (%)"),
                                       ("n", "processes")]))
    return _section("hit-rate", "".join(body))


def _scaling(data: RunData, est: pd.DataFrame, slopes: pd.DataFrame, colours: dict[str, str]) -> str:
    caches = data.machine.get("caches", {})
    body = [
        _figure(figures.svg_data_uri(figures.scaling(est, caches, colours)), "cost against size",
                "Left: ns per test against the mesh's triangle count (camera or per-ray hit-rate rays, "
                "every ray against every triangle), bands: 95% CIs. Right: ns per test against the working "
                "set, bytes of the kernel's prepared triangles plus the rays, for every workload; dashed: "
                "the machine's data caches (" + (", ".join(f"{k} {v}" for k, v in caches.items()) or
                                                 "unknown") + "). Both axes log."),
        "<h3>Log–log slopes against triangle count</h3>",
        _p("Per process the least-squares slope of log ns/test on log triangles, then a t-interval "
           "across processes (stats.scaling_slope); 0 = cost per test independent of size.", "note"),
        _table(slopes, [("family", "family"), ("kernel", "kernel"), ("slope", "slope"), ("ci_low", "95% CI low"),
                        ("ci_high", "95% CI high"), ("sizes", "triangle counts"), ("n", "processes")]),
    ]
    return _section("scaling", "".join(body))


def peer_sentence(ratios: pd.DataFrame, kernel: str, workload: str) -> str | None:
    """tribench's rays/s over each peer's in one sentence (None when no peer was measured)."""
    rows = ratios.loc[ratios["contender"] == "tribench"]
    rows = rows.loc[rows["over"] != "tribench_call"]
    if rows.empty:
        return None
    parts = [f"{_num(r.ratio)}× {r.over}'s rays/s (95% CI {_ci(r.ci_low, r.ci_high)})" for r in rows.itertuples()]
    return f"Against peers ({workload}, one core): tribench's {kernel}, brute force, runs at {' and '.join(parts)}."


def _peers(peers: PeerTables | None, note: str) -> str:
    from tribench.harness.peers import PAUSE_S

    body = [_p("tribench's fastest brute-force kernel against trimesh's own intersector (NumPy after an rtree "
               "broad phase) and Embree (through embreex, after building its BVH), on the same camera rays, "
               "closest hit (tribench.harness.peers, as `tribench peers`). Embree's BVH skips most triangles "
               "of every ray; tribench tests every one: the ratio is what an acceleration structure is worth "
               "over the fastest brute force, not a comparison of ray–triangle tests.", "note")]
    if peers is None:
        return _section("peers", "".join(body + [_p(note, "note")]))
    body += [
        _p(peer_sentence(peers.ratios, peers.kernel, peers.workload) or "Only tribench was measured."),
        _figure(figures.svg_data_uri(figures.peers_rates(peers.rates)), "rays per second of every contender",
                f"Rays/s on {peers.workload}: geometric mean over processes, lines 95% CI. tribench: "
                f"{peers.kernel}, the fastest closest-mode kernel on these rays; tribench_call: the same kernel "
                f"through ext.intersect (checks and output arrays included, like a peer's one call)."),
        _table(peers.rates, [("contender", "contender"), ("implementation", "implementation"),
                             ("rays", "rays per call"), ("rays_per_s", "rays/s"), ("ci_low", "95% CI low"),
                             ("ci_high", "95% CI high"), ("n_processes", "processes"), ("cpu_share", "CPU / wall"),
                             ("setup_ms", "set-up ms (untimed)"), ("differ", "closest triangle ≠ reference"),
                             ("differ_ambiguous", "of which ambiguous")]),
        "<h3>Ratios of rays/s</h3>",
        _table(peers.ratios, [("contender", "contender"), ("over", "over"), ("ratio", "ratio (>1: faster)"),
                              ("ci_low", "95% CI low"), ("ci_high", "95% CI high"), ("n_processes", "processes")]),
        _p(f"Every process is a fresh interpreter pinned to one CPU with one BLAS thread; it times each "
           f"contender once per repetition in a random order, after a {PAUSE_S:g} s pause. The replicate is the "
           f"process (its geometric mean over repetitions); ratios are paired by process. trimesh runs a fixed "
           f"random subset of the rays (it is slow) and its rays/s is scaled from those. CPU / wall below 1: "
           f"other processes took the core; above 1: a contender used a second thread. Ambiguous rays pass "
           f"within 1e-5 barycentric of an edge, where rounding may pick either triangle. {note}", "note"),
    ]
    return _section("peers", "".join(body))


def _processes(data: RunData, pp: pd.DataFrame, est: pd.DataFrame, wl: pd.DataFrame,
               colours: dict[str, str]) -> str:
    labels = {r.workload_id: f"{r.label}\n{r.family}" for r in wl.itertuples(index=False)}
    fig = figures.process_dots(pp, est, labels, data.kernels, colours)
    return _section("processes", _figure(
        figures.svg_data_uri(fig), "per-process values",
        "Each dot is one worker process's median ns per test; below the dots, the estimate (diamond, mean "
        "over processes) and its 95% CI. The process is the replicate: batches inside one process share "
        "its memory layout and are not independent."))


def _drift(data: RunData, batches: pd.DataFrame, drift: pd.DataFrame, colours: dict[str, str]) -> str:
    body = [
        _figure(figures.svg_data_uri(figures.drift_panel(batches, colours)), "drift panel",
                "Every timed batch, ns/test relative to its process's median for that kernel and workload, "
                "against time since the process started; lines: binned medians per kernel. Kernels moving "
                "apart over time is drift that can bias a ratio."),
        _p("stats.drift per kernel against the baseline and workload: slopes are per second on the log "
           "scale; ratio change = the log speedup's move across one process; confound bias = what unequal "
           "timing of the two kernels on a drifting machine adds to the log speedup.", "note"),
        _table(drift, [("kernel", "kernel"), ("label", "workload"), ("baseline_slope", "baseline slope (/s)"),
                       ("ratio_slope", "ratio slope (/s)"), ("ratio_p", "p"), ("ratio_change", "ratio change"),
                       ("confound_bias", "confound bias"), ("confound_p", "p (confound)"),
                       ("flagged", "flagged"), ("reason", "reason")]),
    ]
    return _section("drift", "".join(body))


def _calibration(data: RunData) -> str:
    source = data.margin_source
    body = [_p(f"Equivalence margin used: ±{100 * data.margin:.3g}% — {source}.")]
    cal = None
    if (data.run_dir / "calibration.json").is_file():
        cal_path = data.run_dir / "calibration.json"
    elif source.startswith("calibration "):
        cal_path = Path(source.split(" ", 2)[1])
    else:
        cal_path = None
    if cal_path is not None:
        try:
            cal = json.loads(cal_path.read_text())
        except (OSError, ValueError):
            cal = None
    if cal is None:
        body.append(_p("No A/A calibration record is available to this report: the verdicts rest on the "
                       "default margin. `tribench calibrate` measures this machine's noise floor "
                       "(a kernel against its identical copy) and later sweeps use it.", "note"))
    else:
        if cal_path != data.run_dir / "calibration.json" and cal.get("created") not in source:
            body.append(_p(f"{cal_path} has been replaced since this run; shown for reference only.", "note"))
        body.append(_kv_table([
            ("A/A pair", f"{cal.get('kernel')} vs {cal.get('copy')}"),
            ("comparisons", f"{cal.get('experiments')} of {cal.get('processes_per_experiment')} processes"),
            ("coverage of 1 by 95% CIs", f"{100 * cal.get('coverage', math.nan):.0f}%"),
            ("false positives (p < 0.05)", f"{100 * cal.get('false_positive_rate', math.nan):.0f}% (expect 5%)"),
            ("p-values vs uniform", f"KS {cal.get('ks_statistic', math.nan):.3f}, "
                                    f"p = {cal.get('ks_p_value', math.nan):.3f}"),
            ("noise floor (97.5% of |log ratio|)", f"{cal.get('noise_floor', math.nan):.4g}"),
            ("margin", f"{100 * cal.get('margin', math.nan):.3g}%"),
            ("source", str(cal_path)),
        ]))
    return "".join(body)


def _diagnostics(data: RunData, batches: pd.DataFrame, wl: pd.DataFrame) -> str:
    from tribench import stats

    colours = figures.kernel_colours(data.kernels)
    warm = _ordered(content.table(data, runfolder.WARMUP), data)
    outl = _ordered(content.table(data, runfolder.OUTLIERS), data)
    var = content.table(data, runfolder.VARIANCE)
    timed = data.batches.loc[~data.batches["warmup"]]
    ctx = int(timed["invol_ctx_switches"].sum())
    steal = timed.loc[timed["steal_ticks"] > 0, "steal_ticks"].sum() if "steal_ticks" in timed else 0
    body = [
        _figure(figures.svg_data_uri(figures.rounds_panel(batches, colours)), "batches by round",
                f"Every batch against its round (shaded: warm-up rounds, kept and labelled, left out of every "
                f"estimate), relative to its process's median. Red rings: Tukey outliers (beyond "
                f"{stats.DEFAULTS.tukey_k} IQR within the process), crosses: far out "
                f"({stats.DEFAULTS.tukey_far_k} IQR). Outliers are labelled, never dropped: the per-process "
                f"median keeps the estimates robust."),
        "<h3>Warm-up</h3>",
        _table(warm, [("kernel", "kernel"), ("label", "workload"), ("warmup_batches", "warm-up batches"),
                      ("warmup_rel", "warm-up ns/test ÷ timed median")]),
        "<h3>Outliers (Tukey fences, per process)</h3>",
        _table(outl, [("kernel", "kernel"), ("label", "workload"), ("batches", "timed batches"),
                      ("outliers", "outliers"), ("far_out", "far out"), ("worst_rel", "worst ÷ median")]),
        "<h3>Variance components</h3>",
        _p("Kalibera & Jones (2013): between rounds inside a process and between processes, as standard "
           "deviations relative to the mean (stats.variance_components on a balanced processes × rounds "
           "matrix). Where processes dominate, more processes narrow the intervals; more rounds do not.",
           "note"),
        _table(var, [("kernel", "kernel"), ("label", "workload"), ("mean_ns", "mean ns/test"),
                     ("round_sd_pct", "between rounds (sd %)"), ("process_sd_pct", "between processes (sd %)"),
                     ("n_processes", "processes"), ("n_rounds", "rounds")]),
        "<h3>A/A calibration</h3>", _calibration(data),
        "<h3>Interference</h3>",
        _p(f"{ctx:,} involuntary context switches over {len(timed):,} timed batches; steal time "
           f"{'not readable' if (timed['steal_ticks'] < 0).all() else f'{int(steal)} ticks'}; "
           f"workers pinned to CPU {data.run.get('cpu', '?')}."),
    ]
    if not data.processes.empty:
        peak = data.processes.groupby("phase")["peak_gflops"].agg(["mean", "min", "max"]).reset_index()
        body += ["<h3>FMA peak per process (GFLOP/s)</h3>",
                 _table(peak, [("phase", "phase"), ("mean", "mean"), ("min", "min"), ("max", "max")])]
    return _section("diagnostics", "".join(body))


def _correctness(data: RunData, correct: pd.DataFrame, wl: pd.DataFrame) -> str:
    labels = dict(zip(wl["workload_id"], wl["label"], strict=True))
    frame = correct.assign(label=correct["workload_id"].map(labels))
    body = [
        _p("Every batch returns a checksum (hits and the sum of t) that the worker checked against the "
           "float64 reference before keeping it: a kernel that is fast because it is wrong stops the run. "
           "Hits may differ from the reference only on ambiguous rays (within 1e-5, in barycentric terms, "
           "of an edge). Mesh workloads count rays that hit; pair workloads count pairs that hit.", "note"),
        _table(frame, [("kernel", "kernel"), ("label", "workload"), ("batches", "batches"),
                       ("ref_hits", "reference hits per pass"), ("hits_per_pass_min", "kernel hits per pass"),
                       ("hit_difference", "|difference|"), ("ambiguous_rays", "ambiguous rays"),
                       ("t_sum_rel_diff", "sum of t, relative difference"), ("agrees", "agrees")], digits=3),
    ]
    water = data.run_dir / "watertightness.csv"
    if water.is_file():
        w = pd.read_csv(water)
        body += ["<h3>Watertightness</h3>", _table(w, [(c, c) for c in w.columns])]
    body.append('<p class="note">Watertightness figures (cracks at exactly shared edges and vertices, misses '
                "from inside Embree's far-off sphere) and every kernel's answers at extreme input are in "
                '<a href="#robustness">Robustness</a>.</p>')
    return _section("correctness", "".join(body))


#: What each robustness test measures, in one sentence (after tribench.harness.validate's documentation).
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
    "parallel_rays": "Hits by rays lying exactly in the triangle's plane or exactly parallel just above it: "
                     "every one must miss.",
    "degenerate_triangles": "Hits on a point, a segment with a repeated vertex and three collinear points, rays "
                            "aimed exactly at them: every one must miss.",
    "nonfinite": "Hits on safe pairs with one NaN, +Inf or −Inf in the origin, the direction or a vertex: the "
                 "call must return, and miss.",
}


def _rate_class(cell: Any) -> str:
    # validate.format_rate ends a broken promise's cell with "!"
    return "num broken" if isinstance(cell, str) and cell.endswith("!") else "num"


def _robustness(val: pd.DataFrame, note: str) -> str:
    from tribench.harness import validate

    body = [
        _p("Rays no timing workload asks (tribench.harness.validate, as `tribench validate`): aimed exactly at "
           "shared edges and vertices of exactly coplanar meshes, from inside a far-off sphere, and at extreme "
           "scales, sizes, shapes, angles and non-finite input. A cell is a kernel's failure rate on a test at "
           "one precision (failures / rays, 0 = none). What the papers promise (validate's expected column): "
           "no crack at shared edges and vertices, and Embree's 0.002% on the sphere, for Woop, Benthin & "
           "Wald's watertight test; no hit on parallel rays and degenerate triangles for every kernel, nor on "
           "non-finite input except for the seed kernels, faithful copies of flawed code. A cell marked ! in "
           "red breaks its promise; every other rate is measured, not judged. A culling kernel is asked about "
           "triangles facing the ray, so its rates measure robustness, not culling.", "note"),
        _p(note, "note"),
    ]
    if val.empty:
        return _section("robustness", "".join(body))
    tests = [t for t in validate.TESTS if t in set(val["test"])]
    names = [validate.SHORT_NAMES[t] for t in tests]
    broken = val.loc[val["verdict"] == "fail"]
    body.append(_p(f"{int((val['verdict'] != 'measured').sum())} promises checked, {len(broken)} broken."))
    body.append(_table(validate.table(val), [("kernel", "kernel"), ("dtype", "precision"), ("isa", "ISA")]
                       + [(n, n) for n in names], classes={n: _rate_class for n in names}))
    if not broken.empty:
        shown = broken.assign(cell=[validate.format_rate(f, r, v) for f, r, v in
                                    zip(broken["failures"], broken["rate"], broken["verdict"], strict=True)])
        body += ["<h3>Broken promises</h3>",
                 _table(shown, [("kernel", "kernel"), ("dtype", "precision"), ("test", "test"), ("cell", "rate"),
                                ("failures", "failures"), ("rays", "rays"), ("expected", "promised"),
                                ("detail", "breakdown")], classes={"cell": _rate_class})]
    rays = val.groupby(["test", "dtype"])["rays"].max()
    dtypes = list(dict.fromkeys(val["dtype"]))
    legend = pd.DataFrame([{"column": validate.SHORT_NAMES[t], "test": t, "what": _TEST_TEXT.get(t, ""),
                            **{f"rays {d}": rays.get((t, d)) for d in dtypes}} for t in tests])
    body += ["<h3>The tests</h3>",
             _p(f"Every kernel is asked the same rays at a precision. The breakdown of every rate is in "
                f"{VALIDATE}'s detail column.", "note"),
             _table(legend, [("column", "column"), ("test", "test"), ("what", "what is measured")]
                    + [(f"rays {d}", f"rays ({d})") for d in dtypes])]
    return _section("robustness", "".join(body))


def _pictures(data: RunData, wl: pd.DataFrame) -> str:
    body = [_p("What the kernels were timed on. Pair pictures map every pair's plane crossing into one "
               "reference triangle; mesh pictures show the mesh with its rays, hits and misses. Each title "
               "gives the targets against the achieved figures.", "note")]
    cards = []
    achieved = content.workload_figures(data)
    for r in wl.itertuples(index=False):
        rows = [("workload", f"{r.workload_id}: {r.summary}"), ("obtained from", r.source)]
        rows += [(f"{k}", f"target {_plain(t)}, achieved {_plain(a)}" if t is not None else _plain(a))
                 for k, t, a in achieved.get(r.workload_id, [])]
        png, why = content.picture(data, r.workload_id)
        img = (_figure(figures.png_data_uri(figures.palette_png(png)), f"picture of {r.workload_id}",
                       f"{r.label} ({r.family})") if png is not None else _p(why, "note"))
        cards.append(f"<div><h3>{escape(r.label)} · {escape(r.family)}</h3>{img}"
                     f"<details><summary>targets and achieved figures</summary>{_kv_table(rows)}</details></div>")
    body.append(f'<div class="pictures">{"".join(cards)}</div>')
    return _section("workloads", "".join(body))


def _machine(data: RunData) -> str:
    m = data.machine
    build = m.get("build", {})
    rows = [
        ("CPU", m.get("cpu_model")), ("logical CPUs", m.get("logical_cpus")), ("usable CPUs", m.get("usable_cpus")),
        ("workers pinned to CPU", data.run.get("cpu")), ("SIMD features", m.get("simd_features")),
        ("caches", m.get("caches")), ("governor", m.get("governor")), ("CPU MHz (at start)", m.get("cpu_mhz")),
        ("load average (at start)", m.get("load_average")), ("platform", m.get("platform")),
        ("Python", m.get("python")), ("numpy", m.get("numpy")), ("tribench", m.get("tribench")),
        ("git revision", m.get("git_revision")),
    ]
    brows = [(k, v) for k, v in build.items()]
    isa = data.run.get("isa", {})
    return _section("machine", "".join([
        _kv_table(rows), "<h3>Build of the C extension</h3>", _kv_table(brows),
        "<h3>Instruction set of each kernel</h3>", _kv_table(isa.items()),
        "<h3>Seeds and plan</h3>",
        _kv_table([("sweep seed", data.run["sweep"].get("seed")),
                   ("process seeds", data.run.get("process_seeds")),
                   ("plan sha256", data.run.get("plan_sha256")),
                   ("batches planned / recorded", f"{data.run.get('n_batches')} / {len(data.batches)}")]),
    ]))


# ---------------------------------------------------------------- reproduce


def _toml_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, float)):
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{" + ", ".join(f"{k} = {_toml_value(x)}" for k, x in v.items()) + "}"
    raise TypeError(f"cannot write {type(v).__name__} to TOML")


def sweep_toml(sweep: dict[str, Any]) -> str:
    """The run's sweep as a sweep file that ``tribench sweep --file`` reads back.

    Examples
    --------
    >>> print(sweep_toml({"kernels": ["a"], "processes": 2, "rounds": 3, "warmup": 1,
    ...     "target_ms": 2.0, "seed": 0, "workloads": [{"kind": "pairs", "n": 10}]}))
    # tribench sweep file, written by tribench report
    kernels = ["a"]
    processes = 2
    rounds = 3
    warmup = 1
    target_ms = 2.0
    seed = 0
    <BLANKLINE>
    [[workloads]]
    kind = "pairs"
    n = 10
    <BLANKLINE>
    """
    lines = ["# tribench sweep file, written by tribench report"]
    for key in ("kernels", "processes", "rounds", "warmup", "target_ms", "seed"):
        if key in sweep:
            lines.append(f"{key} = {_toml_value(sweep[key])}")
    for spec in sweep.get("workloads", []):
        lines += ["", "[[workloads]]"]
        lines += [f"{k} = {_toml_value(v)}" for k, v in spec.items() if v is not None]
    return "\n".join(lines) + "\n"


def _reproduce(data: RunData, sweep_file: str) -> str:
    rev = data.machine.get("git_revision")
    command = data.run.get("command")
    steps = []
    if rev:
        steps.append(f"git checkout {rev}")
    steps += ["pip install -e .", f"tribench sweep --file {sweep_file} --out NEW_RUN_DIR",
              "tribench report NEW_RUN_DIR"]
    body = [
        _p("The plan (which batches run, in which order, with which layout seeds) is a pure function of the "
           "sweep below, and every workload a pure function of its spec: the same sweep on the same revision "
           "repeats the run. The times will differ by the machine's noise; compare two runs with "
           "`tribench compare RUN_A RUN_B`."),
    ]
    if command:
        body += ["<h3>The command that made this run</h3>", f"<pre><code>{escape(_plain(command))}</code></pre>"]
    body += ["<h3>To run it again</h3>", f"<pre><code>{escape(chr(10).join(steps))}</code></pre>",
             f"<h3>{escape(sweep_file)} (written next to this report)</h3>",
             f"<pre><code>{escape(sweep_toml(data.run['sweep']))}</code></pre>",
             f"<h3>To redraw this report</h3><pre><code>tribench report {escape(str(data.run_dir))}"
             f"</code></pre>",
             "<h3>Files of the run folder</h3>",
             _p("Tidy CSVs, one row per observation, raw units (nanoseconds, counts, fractions).", "note")]
    for name, cols in columns.FILES.items():
        present = (data.run_dir / name).is_file()
        body.append(f"<details><summary>{escape(name)}{'' if present else ' (absent)'}</summary>"
                    + _kv_table(cols.items()) + "</details>")
    return _section("reproduce", "".join(body))


# -------------------------------------------------------------------- page


def render(data: RunData, sweep_file: str = "sweep.toml") -> str:
    """The whole page for one run, as a string: every number from the run folder's files."""
    wl = content.workload_table(data)
    est = content.estimates_table(data, wl)
    spd = content.speedups_table(data, wl)
    order = {w: i for i, w in enumerate(data.workload_ids)}
    korder = {k: i for i, k in enumerate(data.kernels)}
    spd = spd.assign(_w=spd["workload_id"].map(order), _k=spd["kernel"].map(korder)).sort_values(
        ["_w", "_k"]).drop(columns=["_w", "_k"]).reset_index(drop=True)
    est = est.assign(_w=est["workload_id"].map(order), _k=est["kernel"].map(korder)).sort_values(
        ["_w", "_k"]).drop(columns=["_w", "_k"]).reset_index(drop=True)
    pp = content.table(data, runfolder.PER_PROCESS)
    batches = content.table(data, runfolder.BATCH_LABELS)
    cross = content.table(data, runfolder.CROSSOVERS)
    slopes = content.table(data, runfolder.SLOPES)
    drift = content.table(data, runfolder.DRIFT)
    correct = content.table(data, runfolder.CORRECTNESS)
    kern = content.table(data, runfolder.KERNELS)
    val, val_note = load_validation(data)
    peers, peer_note = load_peers(data)
    colours = figures.kernel_colours(data.kernels)

    title = f"tribench report — {data.run.get('run_id', data.run_dir.name)}"
    nav = "".join(f'<a href="#{sid}">{escape(t)}</a>' for sid, t in SECTIONS.items())
    sections = [
        _headline(data, spd, wl, _warnings(data, drift, correct), peers),
        _kernels(data, kern),
        _speedups(data, spd, est),
        _hit_rate(data, est, spd, cross, colours),
        _scaling(data, est, slopes, colours),
        _peers(peers, peer_note),
        _processes(data, pp, est, wl, colours),
        _drift(data, batches, drift, colours),
        _diagnostics(data, batches, wl),
        _correctness(data, correct, wl),
        _robustness(val, val_note),
        _pictures(data, wl),
        _machine(data),
        _reproduce(data, sweep_file),
    ]
    made = _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds")
    footer = _p(f"Written by tribench report at {made} from {data.run_dir}; tables made by the analysis step "
                f"at {data.record.get('created', '?')}. Statistics: tribench.harness.stats.", "note")
    return ("<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
            "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">"
            f"<title>{escape(title)}</title><style>{_CSS}</style></head><body>"
            f"<nav>{nav}</nav><main>{''.join(sections)}<footer>{footer}</footer></main></body></html>\n")
