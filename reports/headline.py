"""The report's title, the run's warnings, and one sentence per kernel and workload family against the baseline."""

from __future__ import annotations

from html import escape

import pandas as pd

from ..harness.jobs.peers import HEADLINE_PEERS
from ..harness.stats import format_interval
from ..workloads.labels import family_of, short_label
from . import page
from .rundata import PeerTables, RunData

__all__ = ["title", "headline_sentences", "headline_section", "run_warnings", "peer_sentence"]


def headline_sentences(spd: pd.DataFrame) -> dict[str, list[tuple[str, str]]]:
    """``{family: [(verdict, sentence), ...]}``: one sentence per kernel against the baseline, per workload
    family, from ``speedups.csv`` with ``family`` and ``label`` added; verdicts are the table's.

    >>> spd = pd.DataFrame({"family": ["pairs n=10"], "label": ["per-test hit rate 50%"],
    ...     "kernel": ["mt"], "baseline": ["seed"], "ratio": [1.18], "ratio_ci_low": [1.15],
    ...     "ratio_ci_high": [1.21], "n_processes": [10], "verdict": ["faster"], "confidence": [0.975]})
    >>> headline_sentences(spd)["pairs n=10"][0][1]
    'mt is faster than seed: 1.18× [1.15, 1.21] (95% CI, 10 processes) on pairs n=10 at per-test hit rate 50%.'
    """
    out: dict[str, list[tuple[str, str]]] = {}
    for family, fam in spd.groupby("family", sort=False):
        said = out[family] = []
        for kernel, g in fam.groupby("kernel", sort=False):
            base = g["baseline"].iloc[0]
            n = int(g["n_processes"].min())
            procs = f"{n} processes" if n != 1 else "1 process"
            verdicts = list(dict.fromkeys(g["verdict"]))
            if len(g) == 1:
                r = g.iloc[0]
                where = f"on {family} at {r['label']}" if r["label"] not in family else f"on {family}"
                text = f"{kernel} {_verdict_phrase(r['verdict'], base)}: {_ratio(r)} (95% CI, {procs}) {where}."
                said.append((r["verdict"], text))
                continue
            lo, hi = g.loc[g["ratio"].idxmin()], g.loc[g["ratio"].idxmax()]
            span = f"from {_ratio(lo)} at {lo['label']} to {_ratio(hi)} at {hi['label']} (95% CIs)"
            if len(verdicts) == 1:
                text = f"{kernel} {_verdict_phrase(verdicts[0], base)} on all {len(g)} workloads: {span}; {procs}."
                said.append((verdicts[0], text))
            else:
                parts = "; ".join(f"{v} at " + ", ".join(g.loc[g["verdict"] == v, "label"]) for v in verdicts)
                said.append(("mixed", f"{kernel} against {base} depends on the workload — {parts}: {span}; {procs}."))
    return out


def _ratio(row: pd.Series) -> str:
    return format_interval(row["ratio"], row["ratio_ci_low"], row["ratio_ci_high"], unit="×")


def _verdict_phrase(verdict: str, base: str) -> str:
    return {
        "faster": f"is faster than {base}",
        "slower": f"is slower than {base}",
        "equivalent": f"is equivalent to {base} (inside the equivalence margin)",
    }.get(verdict, f"cannot be told apart from {base} (inconclusive)")


def title(data: RunData, wl: pd.DataFrame) -> str:
    """The page's title and the run in one paragraph: kernels, workloads, processes, machine, baseline."""
    m = data.machine
    sweep = data.run.sweep
    return f"<h1>Which intersector, on {escape(str(m.get('cpu_model', 'this machine')))}</h1>" + page.p(
        f"Run {data.run.run_id}, {data.run.created}: "
        f"{len(data.kernels)} kernels on {len(wl)} workloads in {wl['family'].nunique()} families, "
        f"{data.n_processes} worker processes × {sweep.rounds} rounds "
        f"(+{sweep.warmup} warm-up), on {m.get('cpu_model', 'an unknown CPU')} "
        f"({m.get('build', {}).get('compiler', 'unknown compiler')}). Baseline: {data.baseline}. "
        f"Speedup = time_{data.baseline} / time_kernel, so above 1 means faster.",
        "sub",
    )


def headline_section(data: RunData, spd: pd.DataFrame, wl: pd.DataFrame, peers: PeerTables | None = None) -> str:
    """Every kernel against the baseline, one sentence per kernel and family, and how to read them."""
    families = list(dict.fromkeys(wl["family"]))
    parts = []
    sentences = headline_sentences(spd)
    if not sentences:
        parts.append(page.p("No speedups: this run has a single kernel. Its estimates are below."))
    for family in families:
        if family not in sentences:
            continue
        items = "".join(
            f'<li><span class="{escape(v)}">{escape(v)}</span> — {escape(s)}</li>' for v, s in sentences[family]
        )
        parts.append(f'<h3>{escape(family)}</h3><ul class="verdicts">{items}</ul>')
    if peers is not None and (sentence := peer_sentence(peers.ratios, peers.kernel, peers.workload, peers.in_bvh)):
        parts.append(page.p(sentence + " (see Against peers)"))
    parts.append(
        page.p(
            f"Intervals are simultaneous 95% intervals over the kernels compared on each workload "
            f"(Bonferroni; p-values Holm-adjusted), with the worker process as the replicate. "
            f"Verdicts use an equivalence margin of ±{100 * data.margin:.2g}% ({data.margin_source}). "
            f"Pair workloads are described by their per-test hit rate (fraction of ray–triangle tests that hit); "
            f"mesh workloads by their per-ray hit rate (fraction of rays that hit the mesh at all).",
            "note",
        )
    )
    return "".join(parts)


def run_warnings(data: RunData, drift: pd.DataFrame, correct: pd.DataFrame) -> list[str]:
    """What the reader must know before trusting the numbers: few processes, default margin, drift, wrong answers."""
    out = []
    if data.n_processes < 5:
        out.append(
            f"Only {data.n_processes} worker processes: intervals rest on {data.n_processes - 1} "
            f"degrees of freedom and are wide; use 10 or more for conclusions."
        )
    if data.margin_source.startswith("default"):
        out.append(
            "The equivalence margin is the default, not an A/A calibration of this machine (run `tribench calibrate`)."
        )
    flagged = drift.loc[drift["flagged"] == True]  # noqa: E712 (nullable column)
    for r in flagged.itertuples(index=False):
        out.append(f"Drift: {r.kernel} against {data.baseline} on {r.label} ({r.reason}); see the drift section.")
    bad = correct.loc[correct["agrees"] == False]  # noqa: E712
    for r in bad.itertuples(index=False):
        spec = data.specs.get(r.workload_id)
        where = f"{short_label(spec)} ({family_of(spec)})" if spec else r.workload_id
        out.append(
            f"Correctness: {r.kernel} on {where} differs from the reference by "
            f"{page.num(r.hit_difference)} hits per pass, so no ranking names it there (see the correctness table)."
        )
    expected = data.run.n_batches
    if expected and len(data.batches) < expected:
        out.append(
            f"Incomplete run: {len(data.batches)} of {expected} planned batches "
            f"(finish it with `tribench sweep --resume {data.run_dir}`)."
        )
    return out


def peer_sentence(ratios: pd.DataFrame, kernel: str, workload: str, in_bvh: bool = False) -> str | None:
    """tribench's rays/s over each peer's in one sentence (None when no peer was measured);
    ``in_bvh``: tribench was timed through its BVH with ``kernel`` as the leaf test."""
    rows = ratios.loc[(ratios["contender"] == "tribench") & ratios["over"].isin(HEADLINE_PEERS)]
    if rows.empty:
        return None
    parts = [f"{format_interval(r.ratio, r.ci_low, r.ci_high, unit='×')} {r.over}'s rays/s" for r in rows.itertuples()]
    ours = f"BVH with {kernel}" if in_bvh else f"{kernel}, brute force,"
    return f"Against peers ({workload}, one core): tribench's {ours} runs at {' and '.join(parts)} (95% CIs)."
