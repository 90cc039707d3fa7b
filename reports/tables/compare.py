"""The same kernels on N runs (N machines, N builds): what ``tribench compare`` shows, as tables.

What it shows is docs/results.md's ("Compare runs"). Workloads match by id (a hash of the spec, so byte-identical).
The runs are independent, so two runs' ratios are Welch intervals on the log scale
(:func:`tribench.harness.stats.unpaired_ratio`), simultaneous over a workload's kernels, judged with the larger
margin. As in a run's rankings, a kernel whose answers differ from the reference on a workload did other work there
and is compared nowhere on it. A run is any object with the fields of :class:`RunTables`. The builds of one run
(``--builds``) are compared as runs too: :func:`builds_table`."""

from __future__ import annotations

import dataclasses
import itertools
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

import numpy as np
import pandas as pd

from ...common import UserError
from ...harness import runfolder, stats
from ...workloads.labels import family_of, short_label
from .frames import paired_time_ratio
from .margin import TWINS
from .workload_tables import compared

__all__ = [
    "MAX_RUNS",
    "BuildView",
    "Comparison",
    "MultiComparison",
    "RunTables",
    "builds_table",
    "compare",
    "compare_many",
    "compare_runs",
    "order_summary",
    "run_tags",
    "slower",
]


class RunTables(Protocol):
    """What a comparison reads of one analysed run (read-only)."""

    @property
    def run_dir(self) -> Path: ...
    @property
    def baseline(self) -> str: ...
    @property
    def margin(self) -> float: ...
    @property
    def kernels(self) -> list[str]: ...
    @property
    def workload_ids(self) -> list[str]: ...
    @property
    def specs(self) -> Mapping[str, Mapping[str, Any]]: ...
    @property
    def tables(self) -> Mapping[str, pd.DataFrame]: ...
    @property
    def estimates(self) -> pd.DataFrame: ...
    @property
    def speedups(self) -> pd.DataFrame: ...


@dataclass(frozen=True)
class Comparison:
    """Both tables of a comparison and what they rest on."""

    # Columns named as in speedups.csv (ratio, ratio_ci_low, ratio_ci_high), so speed_charts.forest_chart draws both.
    speedups: pd.DataFrame  # ratio of speedups, per workload and kernel
    times: pd.DataFrame  # time ratio, per workload and kernel
    baseline: str
    margin: float
    only_a: list[str]  # workload ids only in run A
    only_b: list[str]


def _workload(wid: str, spec: Mapping[str, Any]) -> dict[str, str]:
    """A row's workload: its id, family and label."""
    return {"workload_id": wid, "family": family_of(spec), "label": short_label(spec)}


def _per_process(data: RunTables) -> pd.DataFrame:
    """The run's per-process values, none of a kernel where its answers differ from the reference (other work)."""
    return compared(data.tables[runfolder.PER_PROCESS], data.tables.get(runfolder.CORRECTNESS))


def _ratio_fields(a: pd.Series, b: pd.Series, confidence: float, margin: float) -> dict[str, float | int | str]:
    """The columns every row of a comparison has: the ratio of ``b`` to ``a`` (logs), its interval (``ratio_ci_*``)
    and test, and the verdict (the frame's columns pick them: not ``se``)."""
    r = stats.unpaired_ratio(a, b, confidence)
    fields = {k.replace("ci_", "ratio_ci_"): v for k, v in dataclasses.asdict(r).items()}
    return fields | {"verdict": stats.verdict(r.ci_low, r.ci_high, margin)}


def compare_runs(a: RunTables, b: RunTables) -> Comparison:
    """Ratio of speedups (``speedup_B / speedup_A``) and time ratios (``time_B / time_A``) of the kernels
    and workloads two runs share; ValueError when they share none or their baselines differ."""
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
    pa, pb = (pp.assign(log_ns=np.log(pp["ns_per_test"])) for pp in (_per_process(a), _per_process(b)))
    spd_rows, time_rows = [], []
    for wid in shared:
        info = _workload(wid, a.specs[wid])
        wa = pa.loc[pa["workload_id"] == wid].pivot(index="process", columns="kernel", values="log_ns")
        wb = pb.loc[pb["workload_id"] == wid].pivot(index="process", columns="kernel", values="log_ns")
        present = [k for k in kernels if k in wa.columns and k in wb.columns]
        # no speedups where the baseline did not run (a BVH workload runs native kernels only): times still
        others = [k for k in present if k != a.baseline] if a.baseline in present else []
        level_s = stats.simultaneous_confidence(stats.DEFAULTS.confidence, max(len(others), 1))
        level_t = stats.simultaneous_confidence(stats.DEFAULTS.confidence, max(len(present), 1))
        for k in others:
            da, db = (wa[a.baseline] - wa[k]).dropna(), (wb[a.baseline] - wb[k]).dropna()
            row = {**info, "kernel": k, "baseline": a.baseline, "speedup_a": math.exp(da.mean())}
            spd_rows.append({**row, "speedup_b": math.exp(db.mean()), **_ratio_fields(da, db, level_s, margin)})
        for k in present:
            ta, tb = wa[k].dropna(), wb[k].dropna()
            row = {**info, "kernel": k, "ns_per_test_a": math.exp(ta.mean()), "ns_per_test_b": math.exp(tb.mean())}
            time_rows.append({**row, **_ratio_fields(ta, tb, level_t, margin)})
    ratio = ["ratio", "ratio_ci_low", "ratio_ci_high", "p_value", "df", "n_a", "n_b", "confidence", "verdict"]
    keys = ["workload_id", "family", "label", "kernel"]  # explicit: two runs may share only the baseline
    return Comparison(
        pd.DataFrame(spd_rows, columns=[*keys, "baseline", "speedup_a", "speedup_b", *ratio]),
        pd.DataFrame(time_rows, columns=[*keys, "ns_per_test_a", "ns_per_test_b", *ratio]),
        a.baseline,
        margin,
        [w for w in a.workload_ids if w not in set(b.workload_ids)],
        [w for w in b.workload_ids if w not in set(a.workload_ids)],
    )


#: The most runs one comparison takes: each is a letter in the tables, in the order given.
MAX_RUNS = 26


@dataclass(frozen=True)
class MultiComparison:
    """N runs side by side: each run's speedups, and the orders of kernels every run agrees on.

    ``orders``: per workload and pair, ``kernel`` the faster on the first run, per run tag ``T`` its ``ratio_T``
    (time_other / time_kernel) with interval and ``verdict_T``, then ``order``: ``holds`` (faster on every run),
    ``differs`` (significantly faster on one and slower on another) or ``undecided``."""

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


def order_summary(m: MultiComparison) -> pd.DataFrame:
    """Per pair of kernels, over the workloads: faster everywhere, machines differ, or one cannot tell."""
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


def compare_many(runs: Sequence[RunTables], same_run: bool = False) -> MultiComparison:
    """Speedups of every run, and which orders of two kernels hold on every run.

    Each order is tested in each run as ``algorithms.csv`` tests one (paired, Bonferroni over the workload's pairs,
    the run's margin). It *holds* when every run finds the same kernel significantly faster: an intersection of
    tests, so the claim keeps their level without a further correction. ``same_run``: the runs are one folder's
    builds. Raises UserError for fewer than two or more than 26 runs, different baselines, or no workload in every
    run."""
    tags = run_tags(len(runs))
    folders = [Path(d.run_dir).resolve() for d in runs]
    twice = sorted({str(f) for f in folders if folders.count(f) > 1})
    if twice and not same_run:
        raise UserError(f"{twice[0]} is given twice: a run compared with itself is not two machines")
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
    spd_rows = [row for tag, d in zip(tags, runs, strict=True) for row in _run_speedups(tag, d, wids, kernels)]
    order_rows = [row for wid in wids for row in _orders(tags, runs, wid, kernels)]
    labels = {w: (short_label(runs[0].specs[w]), family_of(runs[0].specs[w])) for w in wids}
    # explicit columns: runs that share only the baseline have no pair of kernels, and still a table
    order_columns = [
        *_ORDER_KEYS,
        *(c for t in tags for c in (f"ratio_{t}", f"ratio_{t}_ci_low", f"ratio_{t}_ci_high", f"verdict_{t}")),
        "order",
        "confidence",
    ]
    return MultiComparison(
        tags,
        pd.DataFrame(spd_rows, columns=_SPEEDUP_COLUMNS),
        pd.DataFrame(order_rows, columns=order_columns),
        baseline,
        kernels,
        wids,
        not_shared,
        labels,
    )


#: The columns of a comparison's speedups, and the first columns of its orders.
_SPEEDUP_COLUMNS = [
    "run",
    "workload_id",
    "family",
    "label",
    "kernel",
    "ratio",
    "ratio_ci_low",
    "ratio_ci_high",
    "verdict",
]
_ORDER_KEYS = ["workload_id", "family", "label", "kernel", "other_kernel"]


def _run_speedups(tag: str, d: RunTables, wids: list[str], kernels: list[str]) -> list[dict[str, Any]]:
    """One run's own speedups.csv figures on the shared workloads and kernels (the baseline itself 1)."""
    s = d.speedups.loc[d.speedups["workload_id"].isin(set(wids)) & d.speedups["kernel"].isin(kernels)]
    rows = []
    for wid in wids:
        info = {"run": tag, **_workload(wid, d.specs[wid])}
        ran = set(d.estimates.loc[d.estimates["workload_id"] == wid, "kernel"])
        if d.baseline in ran:
            one = {"ratio": 1.0, "ratio_ci_low": 1.0, "ratio_ci_high": 1.0, "verdict": "baseline"}
            rows.append({**info, "kernel": d.baseline, **one})
        mine = s.loc[s["workload_id"] == wid, ["kernel", "ratio", "ratio_ci_low", "ratio_ci_high", "verdict"]]
        rows += [{**info, **r} for r in mine.to_dict("records")]
    return rows


def _orders(tags: list[str], runs: Sequence[RunTables], wid: str, kernels: list[str]) -> list[dict[str, object]]:
    """Every pair of kernels on one workload, oriented by run A's estimates, tested in each run."""
    pers = []
    for d in runs:
        pp = _per_process(d)
        pers.append(pp.loc[pp["workload_id"] == wid].pivot(index="process", columns="kernel", values="ns_per_test"))
    present = [k for k in kernels if all(k in per.columns for per in pers)]
    first = pers[0][present].mean().sort_values(kind="stable")  # orient each pair by run A's estimate
    ordered = list(first.index)
    pairs = list(itertools.combinations(ordered, 2))
    level = stats.simultaneous_confidence(stats.DEFAULTS.confidence, max(len(pairs), 1))
    rows = []
    for a, b in pairs:
        row: dict[str, object] = {**_workload(wid, runs[0].specs[wid]), "kernel": a, "other_kernel": b}
        verdicts = []
        for tag, d, per in zip(tags, runs, pers, strict=True):
            ratio, low, high, _ = paired_time_ratio(per, b, a, level)
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
        rows.append(row)
    return rows


def slower(c: Comparison) -> pd.DataFrame:
    """The time rows where run B is slower than run A beyond the margin: a time ratio past ``1 + margin``
    whose interval excludes no change (``ratio_ci_low > 1``), the gate of ``compare --fail-if-slower``."""
    t = c.times
    return t.loc[(t["ratio"] > 1 + c.margin) & (t["ratio_ci_low"] > 1)]


def compare(runs: Sequence[RunTables]) -> tuple[MultiComparison, Comparison | None]:
    """Every run side by side (:func:`compare_many`), and for two runs the ratio of their speedups too."""
    many = compare_many(runs)
    return many, compare_runs(runs[0], runs[1]) if len(runs) == 2 else None


@dataclass(frozen=True)
class BuildView:
    """One build's part of a run, as a comparison reads a run (:class:`RunTables`)."""

    run_dir: Path
    baseline: str
    margin: float
    kernels: list[str]
    workload_ids: list[str]
    specs: dict[str, Any]
    tables: dict[str, pd.DataFrame]
    estimates: pd.DataFrame
    speedups: pd.DataFrame


def builds_table(m: Any, parts: dict[str, Any], tables: dict[str, dict[str, pd.DataFrame]]) -> pd.DataFrame:
    """``builds.csv``: every order of two kernels per workload, tested under each build (none for one build), in
    long form: a row per pair and build. ``parts`` maps a build to its analysis, ``tables`` to its tables."""
    columns = list(runfolder.FILES[runfolder.BUILDS])
    if len(parts) < 2:
        return pd.DataFrame(columns=columns)
    baseline = next(iter(parts.values())).baseline
    views = []
    for build, analysis in parts.items():
        est = tables[build][runfolder.ESTIMATES]
        kernels = [k for k in dict.fromkeys(est["kernel"]) if k not in TWINS]
        wids = [w for w in m.specs if w in set(est["workload_id"])]
        speedups = tables[build][runfolder.SPEEDUPS]
        views.append(
            BuildView(m.run_dir, baseline, analysis.margin.value, kernels, wids, m.specs, tables[build], est, speedups)
        )
    orders = compare_many(views, same_run=True).orders
    per_build = [
        orders.assign(
            build=build,
            ratio=orders[f"ratio_{tag}"],
            ratio_ci_low=orders[f"ratio_{tag}_ci_low"],
            ratio_ci_high=orders[f"ratio_{tag}_ci_high"],
            verdict=orders[f"verdict_{tag}"],
        )
        for tag, build in zip(run_tags(len(parts)), parts, strict=True)
    ]
    return pd.concat(per_build).sort_index(kind="stable")[columns].reset_index(drop=True)
