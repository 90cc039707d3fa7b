"""``tribench compare RUN...``: the same kernels on N runs (N machines, N builds).

For N >= 2 runs (:func:`compare_many`): per workload in every run, a machine
x kernel table of speedups over the common baseline with each run's
intervals, and which orders of two kernels hold on every machine.

For two runs, also (:func:`compare_runs`): for every workload and kernel
present in both runs (matched by workload id, a hash of the spec, so the
workloads are byte-identical), with the same baseline:

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

__all__ = [
    "Comparison",
    "MultiComparison",
    "compare",
    "compare_many",
    "compare_runs",
    "format_compare_text",
    "format_comparison",
    "format_many",
    "order_summary",
    "render_compare",
    "RATIO_WORDS",
]

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


def _pair_parts(a: RunData, b: RunData, c: Comparison) -> list[str]:
    """The two-run sections: the ratio of speedups (B / A) and the time ratios, with the forest plot."""
    from . import figures

    spd = c.speedups
    parts = []
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
    if c.only_a or c.only_b:
        parts.append(
            page.p(
                f"Not compared: {', '.join(c.only_a) or 'none'} only in A; {', '.join(c.only_b) or 'none'} only in B."
            )
        )
    return parts


def _machines_part(runs: list[RunData], tags: list[str]) -> str:
    machines = []
    for tag, d in zip(tags, runs, strict=True):
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
    return page.section("machines", SECTIONS["machines"], "".join(machines))


def render_compare(runs: list[RunData], m: MultiComparison, pair: Comparison | None = None) -> str:
    """The comparison as one self-contained HTML page: every run's speedups and the orders that hold,
    then for two runs (``pair``, :func:`compare_runs`) the ratio of their speedups and their time ratios."""
    ids = [escape(str(d.run.get("run_id", t))) for t, d in zip(m.tags, runs, strict=True)]
    parts = [f"<h1>{' vs '.join(ids)}</h1>", f"<p>{'<br>'.join(escape(x) for x in _run_lines(runs, m.tags))}</p>"]
    parts += _many_parts(runs, m)
    nav = dict(MANY_SECTIONS)
    if pair is not None:
        parts += _pair_parts(runs[0], runs[1], pair)
        nav |= SECTIONS
    else:
        nav["machines"] = SECTIONS["machines"]
    parts.append(_machines_part(runs, m.tags))
    footer = page.p(f"Written by tribench compare at {page.now()}. Statistics: tribench.stats.", "note")
    return page.document("tribench compare", "".join(parts), nav, footer)


def compare(runs: list[RunData]) -> tuple[MultiComparison, Comparison | None]:
    """Every run side by side (:func:`compare_many`), and for two runs the ratio of their speedups too."""
    many = compare_many(runs)
    return many, compare_runs(runs[0], runs[1]) if len(runs) == 2 else None


def format_compare_text(runs: list[RunData], m: MultiComparison, pair: Comparison | None = None) -> str:
    """The terminal form of :func:`render_compare`."""
    text = format_many(runs, m)
    return text if pair is None else format_comparison(runs[0], runs[1], pair) + "\n\n" + text


# ------------------------------------------------------------------ N runs

#: The most runs one comparison takes: each is a letter in the tables, in the order given.
MAX_RUNS = 26

#: The N-run page's sections, by id, in page order (the two-run sections follow them for two runs).
MANY_SECTIONS = {
    "speedups": "Speedups on every machine",
    "orders": "Rankings that hold on every machine",
}


#: The verdict colours the page gives an order of two kernels.
ORDER_CLASSES = {"holds": "faster", "differs": "slower"}


@dataclass(frozen=True)
class MultiComparison:
    """N runs side by side: each run's speedups, and the orders of kernels every run agrees on.

    ``speedups`` has one row per run, workload and kernel: the run's own
    ``speedups.csv`` figures (``ratio``, ``ratio_ci_low``, ``ratio_ci_high``,
    ``verdict``; the baseline itself 1). ``orders`` has one row per workload
    and pair of kernels: ``kernel`` the faster on the first run by point
    estimate, ``other_kernel`` the other; per run tag ``T``, ``ratio_T``,
    ``ratio_T_ci_low``, ``ratio_T_ci_high`` (time_other / time_kernel) and
    ``verdict_T``; then ``order``: ``holds`` (faster on every run),
    ``differs`` (significantly faster on one run and slower on another) or
    ``undecided`` (neither).
    """

    tags: list[str]
    speedups: pd.DataFrame
    orders: pd.DataFrame
    baseline: str
    kernels: list[str]
    workload_ids: list[str]
    #: workload ids some runs have and others lack (not compared)
    not_shared: list[str]
    #: workload id -> (its label, its family), for headings
    labels: dict[str, tuple[str, str]]


def run_tags(n: int) -> list[str]:
    """``A``, ``B``, ... for ``n`` runs (at most :data:`MAX_RUNS`)."""
    if not 2 <= n <= MAX_RUNS:
        raise UserError(f"compare needs 2 to {MAX_RUNS} run folders (RUN RUN ...), got {n}")
    return [chr(ord("A") + i) for i in range(n)]


def compare_many(runs: list[RunData], confidence: float = 0.95) -> MultiComparison:
    """Speedups of every run, and which orders of two kernels hold on every run.

    Workloads match by id (a hash of the spec) and must be in every run; the
    kernels compared are those every run has on the workload. An order of two
    kernels on one workload is tested in each run as ``algorithms.csv`` tests
    one: a paired ratio of the per-process values (``stats.speedup``) with a
    Bonferroni-simultaneous interval over the workload's pairs and the run's
    equivalence margin (``stats.verdict``). It *holds* when every run finds
    the same kernel significantly faster: an intersection of tests, each at
    its level, so the whole claim keeps that level without a further correction.

    Raises
    ------
    UserError
        Fewer than two or more than 26 runs, different baselines, or no workload in every run.
    """
    tags = run_tags(len(runs))
    baselines = {d.baseline for d in runs}
    if len(baselines) > 1:
        named = ", ".join(f"{t}: {d.baseline}" for t, d in zip(tags, runs, strict=True))
        raise UserError(
            f"the runs have different baselines ({named}): re-run `tribench stats RUN_DIR --baseline NAME` "
            "on some of them so they share one"
        )
    baseline = runs[0].baseline
    in_all = set.intersection(*(set(d.workload_ids) for d in runs))
    wids = [w for w in runs[0].workload_ids if w in in_all]
    if not wids:
        raise UserError("the runs share no workload (workloads match by id, a hash of their spec)")
    seen = [w for d in runs for w in d.workload_ids]
    not_shared = list(dict.fromkeys(w for w in seen if w not in in_all))
    kernels = [k for k in runs[0].kernels if all(k in d.kernels for d in runs)]

    spd_rows = []
    for tag, d in zip(tags, runs, strict=True):
        s = d.speedups.loc[d.speedups["workload_id"].isin(in_all) & d.speedups["kernel"].isin(kernels)]
        for wid in wids:
            spec = d.specs[wid]
            info = {"run": tag, "workload_id": wid, "family": family_of(spec), "label": short_label(spec)}
            ran = set(d.estimates.loc[d.estimates["workload_id"] == wid, "kernel"])
            if baseline in ran:
                one = {"ratio": 1.0, "ratio_ci_low": 1.0, "ratio_ci_high": 1.0, "verdict": "baseline"}
                spd_rows.append({**info, "kernel": baseline, **one})
            for r in s.loc[s["workload_id"] == wid].itertuples(index=False):
                spd_rows.append(
                    {
                        **info,
                        "kernel": r.kernel,
                        "ratio": r.ratio,
                        "ratio_ci_low": r.ratio_ci_low,
                        "ratio_ci_high": r.ratio_ci_high,
                        "verdict": r.verdict,
                    }
                )
    order_rows = []
    for wid in wids:
        spec = runs[0].specs[wid]
        pers = []
        for d in runs:
            pp = d.tables[runfolder.PER_PROCESS]  # per kernel and process, as the analysis step wrote it
            pers.append(pp.loc[pp["workload_id"] == wid].pivot(index="process", columns="kernel", values="ns_per_test"))
        present = [k for k in kernels if all(k in per.columns for per in pers)]
        first = pers[0][present].mean().sort_values(kind="stable")  # orient each pair by run A's estimate
        ordered = list(first.index)
        pairs = [(a, b) for i, a in enumerate(ordered) for b in ordered[i + 1 :]]
        level = stats.simultaneous_confidence(confidence, max(len(pairs), 1))
        for a, b in pairs:
            row: dict[str, object] = {
                "workload_id": wid,
                "family": family_of(spec),
                "label": short_label(spec),
                "kernel": a,
                "other_kernel": b,
            }
            verdicts = []
            for tag, d, per in zip(tags, runs, pers, strict=True):
                both = per[[a, b]].dropna()
                if len(both) >= 2:
                    v = stats.speedup(both[b], both[a], confidence=level)
                    ratio, low, high = v.ratio, v.ci_low, v.ci_high
                else:
                    ratio = low = high = math.nan
                verdict = stats.verdict(low, high, d.margin)
                verdicts.append(verdict)
                row |= {
                    f"ratio_{tag}": ratio,
                    f"ratio_{tag}_ci_low": low,
                    f"ratio_{tag}_ci_high": high,
                    f"verdict_{tag}": verdict,
                }
            if all(v == "faster" for v in verdicts):
                row["order"] = "holds"
            elif "faster" in verdicts and "slower" in verdicts:
                row["order"] = "differs"
            else:
                row["order"] = "undecided"
            row["confidence"] = level
            order_rows.append(row)
    labels = {w: (short_label(runs[0].specs[w]), family_of(runs[0].specs[w])) for w in wids}
    return MultiComparison(
        tags, pd.DataFrame(spd_rows), pd.DataFrame(order_rows), baseline, kernels, wids, not_shared, labels
    )


def order_summary(m: MultiComparison) -> pd.DataFrame:
    """Per pair of kernels, over the workloads: on how many each kernel is faster on every machine,
    on how many the machines differ, and on how many some machine cannot tell (``undecided``)."""
    rank = {k: i for i, k in enumerate(m.kernels)}
    counts: dict[tuple[str, str], dict[str, int]] = {}
    for r in m.orders.itertuples(index=False):
        a, b = sorted((str(r.kernel), str(r.other_kernel)), key=rank.__getitem__)
        c = counts.setdefault((a, b), {"kernel_faster": 0, "other_faster": 0, "differs": 0, "undecided": 0})
        if r.order == "holds":
            c["kernel_faster" if r.kernel == a else "other_faster"] += 1
        else:
            c[str(r.order)] += 1
    rows = [{"kernel": a, "other_kernel": b, **c} for (a, b), c in counts.items()]
    return pd.DataFrame(
        rows, columns=["kernel", "other_kernel", "kernel_faster", "other_faster", "differs", "undecided"]
    )


def _run_lines(runs: list[RunData], tags: list[str]) -> list[str]:
    return [_run_line(t, d) for t, d in zip(tags, runs, strict=True)]


def _speedup_grid(m: MultiComparison, wid: str) -> pd.DataFrame:
    """One workload's speedups as kernel rows and one column of text per run."""
    g = m.speedups.loc[m.speedups["workload_id"] == wid] if not m.speedups.empty else m.speedups
    if g.empty:  # the baseline ran on no run's copy of this workload (a BVH workload, say)
        return pd.DataFrame(columns=["kernel", *m.tags])
    cells = g.assign(
        text=[
            stats.format_interval(r.ratio, r.ratio_ci_low, r.ratio_ci_high, ".3g", "×")
            if r.kernel != m.baseline
            else "1 (baseline)"
            for r in g.itertuples(index=False)
        ]
    )
    grid = cells.pivot(index="kernel", columns="run", values="text").reindex(columns=m.tags).fillna("–")
    return grid.reindex([k for k in m.kernels if k in grid.index]).reset_index()


def _order_text(r: pd.Series, tags: list[str]) -> str:
    ratios = ", ".join(f"{t} {r[f'ratio_{t}']:.3g}×" for t in tags)
    return f"{r['kernel']} faster than {r['other_kernel']} ({ratios})"


def format_many(runs: list[RunData], m: MultiComparison) -> str:
    """Terminal tables: per workload, each kernel's speedup on every run, then the orders that hold."""
    lines = [
        *_run_lines(runs, m.tags),
        f"speedup = time_{m.baseline} / time_kernel, 95% CIs simultaneous per workload (each run's speedups.csv)",
    ]
    for wid in m.workload_ids:
        grid = _speedup_grid(m, wid)
        label, family = m.labels[wid]
        lines += ["", f"{label}  ({family})  [{wid}]"]
        if grid.empty:
            lines.append(f"  no speedups: {m.baseline} did not run on this workload in every run")
        else:
            width = max(24, *(len(str(v)) + 2 for v in grid[m.tags].to_numpy().ravel()))
            lines.append((f"  {'kernel':<26}" + "".join(f"{t:<{width}}" for t in m.tags)).rstrip())
            lines += [
                (f"  {r['kernel']:<26}" + "".join(f"{r[t]:<{width}}" for t in m.tags)).rstrip()
                for _, r in grid.iterrows()
            ]
        o = m.orders.loc[m.orders["workload_id"] == wid]
        held = [_order_text(r, m.tags) for _, r in o.loc[o["order"] == "holds"].iterrows()]
        differ = [_order_text(r, m.tags) for _, r in o.loc[o["order"] == "differs"].iterrows()]
        lines.append(f"  holds on every machine: {'; '.join(held) if held else 'no order of two kernels'}")
        if differ:
            lines.append(f"  differs between machines: {'; '.join(differ)}")
    lines += ["", f"per pair of kernels, over the {len(m.workload_ids)} workloads:"]
    for r in order_summary(m).itertuples(index=False):
        lines.append(
            f"  {r.kernel} vs {r.other_kernel}: {r.kernel} faster on every machine on {r.kernel_faster}, "
            f"{r.other_kernel} on {r.other_faster}; machines differ on {r.differs}, undecided on {r.undecided}"
        )
    counts = m.orders["order"].value_counts() if not m.orders.empty else pd.Series(dtype=int)
    lines += [
        "",
        f"orders of two kernels on one workload: {int(counts.get('holds', 0))} hold on every machine, "
        f"{int(counts.get('differs', 0))} differ between machines, {int(counts.get('undecided', 0))} undecided "
        f"on some machine (of {len(m.orders)}; each run's intervals simultaneous over the workload's pairs)",
    ]
    if m.not_shared:
        lines.append(f"not compared: {len(m.not_shared)} workloads not in every run")
    return "\n".join(lines)


def _many_parts(runs: list[RunData], m: MultiComparison) -> list[str]:
    """The N-run sections: machine x kernel speedup tables per workload, and the orders that hold."""
    speed = []
    for wid in m.workload_ids:
        label, family = m.labels[wid]
        speed += [
            f"<h3>{escape(label)} <small>({escape(family)}, {escape(wid)})</small></h3>",
            page.table(_speedup_grid(m, wid), [("kernel", "kernel"), *((t, f"speedup on {t} (×)") for t in m.tags)]),
        ]
    o = m.orders
    order_cols = [
        ("label", "workload"),
        ("kernel", f"kernel (the faster on {m.tags[0]})"),
        ("other_kernel", "other kernel"),
        *((f"ratio_{t}", f"{t}: time other / kernel (×)") for t in m.tags),
        ("order", "order"),
    ]
    shown = o.loc[o["order"] != "undecided"] if not o.empty else o
    summary = order_summary(m)
    orders = [
        page.p(f"Per pair of kernels, over the {len(m.workload_ids)} workloads in every run:"),
        page.table(
            summary,
            [
                ("kernel", "kernel"),
                ("other_kernel", "other kernel"),
                ("kernel_faster", "workloads: kernel faster on every machine"),
                ("other_faster", "workloads: other faster on every machine"),
                ("differs", "workloads: machines differ"),
                ("undecided", "workloads: undecided on some machine"),
            ],
        ),
        page.p(
            "A pair of kernels on one workload: its time ratio (the other kernel's time over the kernel's, paired "
            "by process) in each run, with intervals simultaneous over the workload's pairs. It holds when every "
            "run finds the same kernel faster beyond its equivalence margin; it differs when one run finds "
            "each faster. Pairs undecided on some run are left out of this table "
            f"({int((o['order'] == 'undecided').sum()) if not o.empty else 0} of {len(o)})."
        ),
        page.table(shown, order_cols, classes={"order": lambda v: ORDER_CLASSES.get(v, "")}),
    ]
    return [
        page.section(
            "speedups",
            MANY_SECTIONS["speedups"],
            page.p(
                f"Speedup = time_{m.baseline} / time_kernel, with each run's 95% interval (simultaneous over "
                "the workload's kernels), as in its speedups.csv."
            )
            + "".join(speed),
        ),
        page.section("orders", MANY_SECTIONS["orders"], "".join(orders)),
    ]
