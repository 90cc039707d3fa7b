"""A run in the forms a paper takes, every number from its ``run.json`` and tables: booktabs tables of
``bands.csv`` (per build, precision and band, every kernel from the fastest down), a methods paragraph
(Markdown or LaTeX) and Bencher's Metric Format (https://bencher.dev/docs/reference/bencher-metric-format/)."""

from __future__ import annotations

import math
import re
from typing import Any

import pandas as pd

from ..ext.builds import INSTALLED
from ..harness import runfolder, stats
from .about import pinning
from .rundata import RunData
from .tables.workload_tables import compared

__all__ = ["bencher", "latex_tables", "methods"]

_TEX_SPECIAL = {"\\": r"\textbackslash{}", "&": r"\&", "%": r"\%", "$": r"\$", "#": r"\#", "_": r"\_",
                "{": r"\{", "}": r"\}", "~": r"\textasciitilde{}", "^": r"\textasciicircum{}",
                "–": "--", "×": r"$\times$", "±": r"$\pm$"}  # fmt: skip


def tex(text: object) -> str:
    """``text`` with LaTeX's special characters escaped (and the few non-ASCII ones tribench writes spelled), and a
    line break allowed after a comma inside a word (a workload's spec: ``misses[outside_edge_1=0.333,...]``)."""
    return re.sub(r",(?=\S)", r",\\allowbreak{}", "".join(_TEX_SPECIAL.get(c, c) for c in str(text)))


def _interval(value: float, low: float, high: float, digits: int = 2) -> tuple[str, str]:
    """The estimate and its interval ("" when it has none), as the table's two lines show them."""
    if not math.isfinite(value):
        return "--", ""
    if not (math.isfinite(low) and math.isfinite(high)):
        return f"{value:.{digits}f}", ""
    return f"{value:.{digits}f}", f"[{low:.{digits}f}, {high:.{digits}f}]"


def _verdict(r: Any, margin: float) -> str:
    if r.kernel == r.baseline:
        return "baseline"
    return stats.verdict(r.speedup_ci_low, r.speedup_ci_high, margin)


def _every_build(data: RunData, name: str) -> pd.DataFrame:
    """Table ``name`` with every build's rows (``data`` shows one build's): a paper gets each build's figures."""
    return data.every_build.get(name, data.tables[name])


def latex_tables(data: RunData) -> str:
    """One booktabs table per build, precision and band (``bands.csv``), with intervals and verdicts."""
    bands = _every_build(data, runfolder.BANDS)
    confidence = float(data.estimates["confidence"].iloc[0]) if len(data.estimates) else 0.95
    several = bands["build"].nunique() > 1
    out = []
    for (build, dtype, band), g in bands.groupby(["build", "dtype", "band"], sort=False):
        where = f"{dtype}, {band}" + (f", build {build}" if several else "")
        rows = []
        for r in g.sort_values("rank").itertuples(index=False):
            ns = _interval(r.ns_per_test, r.ns_per_test_ci_low, r.ns_per_test_ci_high)
            vs = ("1.00", "") if r.rank == 1 else _interval(r.vs_fastest, r.vs_fastest_ci_low, r.vs_fastest_ci_high)
            speedup = _interval(r.speedup, r.speedup_ci_low, r.speedup_ci_high)
            tied = " (tied)" if r.rank > 1 and r.tied_with_fastest else ""
            rows.append(
                rf"{r.rank} & {tex(r.kernel)} & {ns[0]} & {vs[0]}{tied} & {speedup[0]} & {_verdict(r, data.margin)} \\"
            )
            # each interval in small type under its estimate: the table fits an article's text width
            small = [rf"{{\footnotesize {i}}}" if i else "" for _, i in (ns, vs, speedup)]
            rows += [rf" & & {' & '.join(small)} & \\"] if any(small) else []
        processes = _spread(g["n_processes"])  # tex() writes its en dash as --
        caption = (
            f"Ranking, {where} ({_count(int(g['workloads'].iloc[0]), 'workload')}, {processes} processes). "
            f"Times in ns per ray–triangle test, mean over processes with a {confidence:.0%} interval; "
            f"speedups against {g['baseline'].iloc[0]}, simultaneous intervals, and their verdicts against "
            f"a margin of {data.margin:.1%}."
        )
        out.append(
            "\n".join(
                [
                    r"\begin{table}[ht]",
                    r"\centering",
                    r"\small",
                    rf"\caption{{{tex(caption)}}}",
                    r"\begin{tabular}{rlllll}",
                    r"\toprule",
                    r"Rank & Kernel & ns/test & vs fastest & Speedup & Verdict \\",
                    r"\midrule",
                    *rows,
                    r"\bottomrule",
                    r"\end{tabular}",
                    r"\end{table}",
                ]
            )
        )
    return "\n\n".join(out) + "\n"


def _count(n: int, noun: str) -> str:
    return f"{n} {noun}" + ("" if n == 1 else "s")


def _spread(values: pd.Series) -> str:
    low, high = int(values.min()), int(values.max())
    return f"{low}" if low == high else f"{low}–{high}"


def methods(data: RunData, latex: bool = False) -> str:
    """The run's methods as one paragraph: machine and build, design, statistics, workloads."""
    m, sweep = data.machine, data.run.sweep
    est = compared(_every_build(data, runfolder.ESTIMATES), _every_build(data, runfolder.CORRECTNESS))
    confidence = float(est["confidence"].iloc[0]) if len(est) else 0.95
    workloads = list(dict.fromkeys(est["workload"])) if len(est) else [w.summary() for w in sweep.workloads]
    sequential = sweep.sequential
    design = (
        f"processes ran in stages of {sequential.stage} until each kernel's paired interval against its "
        f"workload's reference was within ±{sequential.target:.0%} (at most {sweep.processes} processes "
        f"and {sequential.budget_s:g} s), "
        if sequential is not None
        else f"{sweep.processes} processes were planned, "
    )
    text = (
        f"Measurements were taken with tribench {m.get('tribench', '?')} on {m.get('cpu_model', '?')} "
        f"({', '.join(m.get('simd_features') or []) or 'no SIMD features recorded'}; {m.get('platform', '?')}), "
        f"with the kernels compiled by {_compilers(data)}, "
        f"Python {m.get('python', '?')} and numpy {m.get('numpy', '?')}. "
        f"Each worker process was a fresh interpreter, {pinning(data.run)}, with its memory layout randomised; "
        f"{design}each of {sweep.warmup} warm-up and {sweep.rounds} timed rounds ran every kernel once "
        f"in a random order, with batches of about {sweep.target_ms:g} ms; "
        + (
            f"the estimates rest on {_spread(est['n_processes'])} processes per kernel and workload. "
            if len(est)  # none where every kernel is an A/A copy or disagrees with the reference
            else "no kernel's estimate is reported (each was an A/A copy or disagreed with the reference). "
        )
        + f"A time is the mean over processes of each process's median ns per test, with a {confidence:.0%} "
        f"Student-t interval on the log scale; a speedup over {data.baseline} is the geometric mean of the "
        f"paired per-process time ratios, with Bonferroni-simultaneous intervals over a workload's kernels "
        f"and Holm-adjusted p-values. Two kernels are called equivalent where the interval lies within a "
        f"margin of {data.margin:.1%} (its source: {data.margin_source}). "
        f"The {_count(len(workloads), 'workload')}: {'; '.join(workloads)}. Every kernel's answers were checked "
        f"against float64 reference answers, and a kernel is ranked only where they agree."
    )
    # \sloppy: a line with a workload's long spec in it stretches its spaces rather than run into the margin
    return f"{{\\sloppy {tex(text)}\\par}}\n" if latex else text + "\n"


def _compilers(data: RunData) -> str:
    """The compiler and flags of each build the run's processes took in turn (one: the installed build's)."""
    installed = data.machine.get("build", {})
    records = {b.get("spec"): b for b in data.run.builds if b.get("spec") != INSTALLED}  # the installed: machine.build
    each = [
        f"{r.get('compiler', '?')} (flags {r.get('flags', '?')})"
        for r in (records.get(spec, installed) for spec in data.builds)
    ]
    if len(each) == 1:
        return each[0]
    named = "; ".join(f"{spec}: {text}" for spec, text in zip(data.builds, each, strict=True))
    return f"each of {len(each)} builds, whose processes took turns ({named})"


def bencher(data: RunData) -> dict[str, Any]:
    """Bencher's Metric Format: per kernel, workload (and build, if several), its ns per test and, where it
    has one, its speedup over the baseline, each with its interval as lower and upper values."""
    correct = _every_build(data, runfolder.CORRECTNESS)
    est, spd = (compared(_every_build(data, name), correct) for name in (runfolder.ESTIMATES, runfolder.SPEEDUPS))
    several = est["build"].nunique() > 1
    doc: dict[str, Any] = {}
    speedups = spd.set_index(["build", "kernel", "workload_id"]) if len(spd) else None
    for r in est.itertuples(index=False):
        name = f"{r.kernel}/{r.workload}" + (f"/{r.build}" if several else "")
        measures = {"ns-per-test": _bounds(r.ns_per_test, r.ns_per_test_ci_low, r.ns_per_test_ci_high)}
        key = (r.build, r.kernel, r.workload_id)
        if speedups is not None and key in speedups.index:
            s = speedups.loc[key]
            measures[f"speedup-over-{data.baseline}"] = _bounds(s["ratio"], s["ratio_ci_low"], s["ratio_ci_high"])
        doc[name] = {k: v for k, v in measures.items() if v}
    return doc


def _bounds(value: float, low: float, high: float) -> dict[str, float]:
    """A measure: its value, with bounds where they are finite (JSON has no NaN)."""
    if not math.isfinite(value):
        return {}
    out = {"value": float(value)}
    if math.isfinite(low) and math.isfinite(high):
        out |= {"lower_value": float(low), "upper_value": float(high)}
    return out
