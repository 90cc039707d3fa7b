"""``tribench compare RUN_A RUN_B``: the same kernels on two runs (two machines, two builds).

For every workload and kernel present in both runs (matched by workload id,
a hash of the spec, so the workloads are byte-identical), with the same
baseline:

* **ratio of speedups** ``speedup_B / speedup_A``: above 1, the kernel's
  advantage over the baseline is larger on run B;
* **time ratio** ``time_B / time_A`` of each kernel: above 1, run B is slower.

The runs are independent, so each figure is a two-sample (Welch) interval on
the log scale from the runs' per-process values, not a paired one. Intervals
are simultaneous over the kernels of one workload (Bonferroni, as in
``stats.speedup_table``); verdicts come from ``stats.verdict`` with the larger
of the two runs' equivalence margins.

The interval is :func:`tribench.stats.unpaired_ratio`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from html import escape

import numpy as np
import pandas as pd

from tribench import stats
from tribench.common import UserError
from tribench.harness import runfolder

from . import page
from .rundata import RunData, family_of, short_label

__all__ = ["Comparison", "compare_runs", "format_comparison", "render_compare", "RATIO_WORDS"]

#: The page's sections, by id, in page order.
SECTIONS = {
    "speedup-ratios": "Ratio of speedups (B / A)",
    "time-ratios": "Time ratio (B / A)",
    "machines": "Machines and builds",
}

#: How verdicts read for a ratio of run B to run A.
RATIO_WORDS = {
    "faster": "larger on B",
    "slower": "smaller on B",
    "equivalent": "same on both",
    "inconclusive": "inconclusive",
}
TIME_WORDS = {"faster": "B slower", "slower": "B faster", "equivalent": "same on both", "inconclusive": "inconclusive"}


@dataclass(frozen=True)
class Comparison:
    """Both tables of a comparison and what they rest on."""

    # Columns named as in speedups.csv (ratio, ratio_ci_low, ratio_ci_high), so figures.forest draws both.
    speedups: pd.DataFrame  # ratio of speedups, per workload and kernel
    times: pd.DataFrame  # time ratio, per workload and kernel
    baseline: str
    margin: float
    only_a: list[str]  # workload ids only in run A
    only_b: list[str]


def _log_per_process(data: RunData) -> pd.DataFrame:
    pp = data.tables[runfolder.PER_PROCESS]  # written by the analysis step (stats.per_process)
    return pp.assign(log_ns=np.log(pp["ns_per_test"]))


def _ratio_fields(r: stats.LogRatio, confidence: float, margin: float) -> dict[str, float | int | str]:
    """The columns every row of a comparison has: the ratio, its interval and test, and the verdict."""
    return {
        "ratio": r.ratio,
        "ratio_ci_low": r.ci_low,
        "ratio_ci_high": r.ci_high,
        "p_value": r.p_value,
        "df": r.df,
        "n_a": r.n_a,
        "n_b": r.n_b,
        "confidence": confidence,
        "verdict": stats.verdict(r.ci_low, r.ci_high, margin),
    }


def compare_runs(a: RunData, b: RunData, confidence: float = 0.95) -> Comparison:
    """Ratio of speedups and time ratios of the kernels and workloads two runs share.

    Raises
    ------
    ValueError
        The runs share no workload, or their baselines differ.
    """
    if a.baseline != b.baseline:
        raise UserError(
            f"the runs have different baselines ({a.baseline} and {b.baseline}): "
            f"re-run `tribench stats --baseline` on one of them"
        )
    shared = [w for w in a.workload_ids if w in set(b.workload_ids)]
    if not shared:
        raise UserError("the two runs share no workload (workloads match by id, a hash of their spec)")
    kernels = [k for k in a.kernels if k in set(b.kernels)]
    if a.baseline not in kernels:
        raise UserError(f"baseline {a.baseline} is missing from one run")
    margin = max(a.margin, b.margin)
    pa, pb = _log_per_process(a), _log_per_process(b)
    spd_rows, time_rows = [], []
    for wid in shared:
        spec = a.specs[wid]
        info = {"workload_id": wid, "family": family_of(spec), "label": short_label(spec)}
        wa = pa.loc[pa["workload_id"] == wid].pivot(index="process", columns="kernel", values="log_ns")
        wb = pb.loc[pb["workload_id"] == wid].pivot(index="process", columns="kernel", values="log_ns")
        present = [k for k in kernels if k in wa.columns and k in wb.columns]
        others = [k for k in present if k != a.baseline]
        level_s = stats.simultaneous_confidence(confidence, len(others)) if others else confidence
        level_t = stats.simultaneous_confidence(confidence, len(present)) if present else confidence
        for k in others:
            da = (wa[a.baseline] - wa[k]).dropna()
            db = (wb[a.baseline] - wb[k]).dropna()
            r = stats.unpaired_ratio(da, db, level_s)
            spd_rows.append(
                {
                    **info,
                    "kernel": k,
                    "baseline": a.baseline,
                    "speedup_a": math.exp(da.mean()),
                    "speedup_b": math.exp(db.mean()),
                    **_ratio_fields(r, level_s, margin),
                }
            )
        for k in present:
            ta, tb = wa[k].dropna(), wb[k].dropna()
            r = stats.unpaired_ratio(ta, tb, level_t)
            time_rows.append(
                {
                    **info,
                    "kernel": k,
                    "ns_per_test_a": math.exp(ta.mean()),
                    "ns_per_test_b": math.exp(tb.mean()),
                    **_ratio_fields(r, level_t, margin),
                }
            )
    return Comparison(
        pd.DataFrame(spd_rows),
        pd.DataFrame(time_rows),
        a.baseline,
        margin,
        [w for w in a.workload_ids if w not in set(b.workload_ids)],
        [w for w in b.workload_ids if w not in set(a.workload_ids)],
    )


def _run_line(tag: str, d: RunData) -> str:
    m = d.machine
    rev = (m.get("git_revision") or "?")[:12]
    return (
        f"{tag}: {d.run_dir}  run {d.run.get('run_id', '?')}, {m.get('cpu_model', '?')}, "
        f"{m.get('build', {}).get('compiler', '?')}, git {rev}, {d.n_processes} processes"
    )


def format_comparison(a: RunData, b: RunData, c: Comparison) -> str:
    """Terminal table: per workload, each kernel's speedup on A and B and their ratio."""
    lines = [
        _run_line("A", a),
        _run_line("B", b),
        f"ratio of speedups = speedup_B / speedup_A (speedup = time_{c.baseline} / time_kernel); "
        f"Welch 95% CIs, simultaneous per workload; margin ±{100 * c.margin:.2g}%",
    ]
    for wid, g in c.speedups.groupby("workload_id", sort=False):
        lines += [
            "",
            f"{g['label'].iloc[0]}  ({g['family'].iloc[0]})  [{wid}]",
            f"  {'kernel':<22}{'on A':>8}{'on B':>8}{'B/A':>8}  {'CI':<18}verdict",
        ]
        for r in g.itertuples(index=False):
            ci = stats.format_interval(None, r.ratio_ci_low, r.ratio_ci_high, ".3f")
            lines.append(
                f"  {r.kernel:<22}{r.speedup_a:8.3f}{r.speedup_b:8.3f}{r.ratio:8.3f}  "
                f"{ci:<18}{RATIO_WORDS.get(r.verdict, r.verdict)}"
            )
    if c.speedups.empty:
        lines += ["", "no kernel besides the baseline in both runs: time ratios only"]
    lines += ["", "time ratio time_B / time_A (above 1: B is slower):"]
    for r in c.times.itertuples(index=False):
        ci = stats.format_interval(None, r.ratio_ci_low, r.ratio_ci_high, ".3f")
        lines.append(f"  {r.kernel:<22}{r.label:<30}{r.ratio:8.3f}  {ci:<18}{TIME_WORDS.get(r.verdict, r.verdict)}")
    if c.only_a or c.only_b:
        lines.append(f"\nnot compared: {len(c.only_a)} workloads only in A, {len(c.only_b)} only in B")
    return "\n".join(lines)


def render_compare(a: RunData, b: RunData, c: Comparison) -> str:
    """The comparison as one self-contained HTML page."""
    from . import figures

    spd = c.speedups
    parts = [
        f"<h1>{escape(a.run.get('run_id', 'A'))} vs {escape(b.run.get('run_id', 'B'))}</h1>",
        f"<p>{escape(_run_line('A', a))}<br>{escape(_run_line('B', b))}</p>",
    ]
    if not spd.empty:
        fig = figures.forest(
            spd,
            c.baseline,
            c.margin,
            verdict_words=RATIO_WORDS,
            xlabel=f"speedup_B / speedup_A (speedup = time_{c.baseline} / time_kernel; log axis; "
            f"> 1: the kernel's advantage is larger on B; Welch 95% CIs)",
        )
        parts.append(
            page.figure(
                figures.svg_data_uri(fig),
                "ratio of speedups",
                f"Ratio of speedups per workload family; grey: the equivalence margin "
                f"±{100 * c.margin:.2g}% (the larger of the two runs').",
            )
        )
    parts.append(
        page.section(
            "speedup-ratios",
            SECTIONS["speedup-ratios"],
            page.table(
                spd.assign(verdict=spd["verdict"].map(RATIO_WORDS)) if not spd.empty else spd,
                [
                    ("kernel", "kernel"),
                    ("label", "workload"),
                    ("speedup_a", "speedup on A (×)"),
                    ("speedup_b", "speedup on B (×)"),
                    ("ratio", "B / A"),
                    ("ratio_ci_low", "CI low"),
                    ("ratio_ci_high", "CI high"),
                    ("df", "Welch df"),
                    ("n_a", "processes A"),
                    ("n_b", "processes B"),
                    ("verdict", "verdict"),
                ],
            ),
        )
    )
    parts.append(
        page.section(
            "time-ratios",
            SECTIONS["time-ratios"],
            "".join(
                [
                    page.p(
                        "Absolute ns/test across machines moves with clock speed and load; the ratio of speedups above "
                        "is the steadier figure."
                    ),
                    page.table(
                        c.times.assign(verdict=c.times["verdict"].map(TIME_WORDS)) if not c.times.empty else c.times,
                        [
                            ("kernel", "kernel"),
                            ("label", "workload"),
                            ("ns_per_test_a", "ns/test on A (geo. mean)"),
                            ("ns_per_test_b", "ns/test on B (geo. mean)"),
                            ("ratio", "B / A"),
                            ("ratio_ci_low", "CI low"),
                            ("ratio_ci_high", "CI high"),
                            ("verdict", "verdict"),
                        ],
                    ),
                ]
            ),
        )
    )
    machines = []
    for tag, d in (("A", a), ("B", b)):
        m = d.machine
        machines += [
            f"<h3>{tag}: {escape(str(d.run_dir))}</h3>",
            page.kv_table(
                [
                    ("CPU", m.get("cpu_model")),
                    ("caches", m.get("caches")),
                    ("compiler", m.get("build", {}).get("compiler")),
                    ("flags", m.get("build", {}).get("flags")),
                    ("git", m.get("git_revision")),
                    ("margin", f"{100 * d.margin:.3g}% ({d.margin_source})"),
                ]
            ),
        ]
    parts.append(page.section("machines", SECTIONS["machines"], "".join(machines)))
    if c.only_a or c.only_b:
        parts.append(
            page.p(
                f"Not compared: {', '.join(c.only_a) or 'none'} only in A; {', '.join(c.only_b) or 'none'} only in B."
            )
        )
    footer = page.p(f"Written by tribench compare at {page.now()}. Statistics: tribench.stats.", "note")
    return page.document("tribench compare", "".join(parts), SECTIONS, footer)
