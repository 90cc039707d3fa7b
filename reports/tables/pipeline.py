"""The analysis step: every derived table of a run, from its files alone.

:func:`analyse` makes estimates and speedups; :func:`write_all` (the end of ``tribench run``, ``tribench
stats``) writes every table of :data:`tribench.harness.runfolder.DERIVED`, the pictures and
``analysis.json``, so the report computes nothing. A run of several builds is analysed build by build, every
table led by a ``build`` column. The statistics (:mod:`tribench.harness.stats`) keep generic names; the
columns get their units here only (:data:`ESTIMATE_COLUMNS`, :data:`SPEEDUP_COLUMNS`)."""

from __future__ import annotations

import contextlib
import datetime as _dt
import json
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from ...common import UserError, write_text
from ...harness import runfolder, stats
from ...harness.margin import Margin
from ...harness.plan import DEFAULT_BASELINE
from ...workloads import mesh_files
from . import export, measured
from .frames import in_order
from .margin import TWINS, twin_margin
from .measured import Measured, file_digest

__all__ = [
    "Analysis",
    "Derived",
    "analyse",
    "by_build",
    "combined",
    "derive",
    "estimate",
    "estimate_builds",
    "write_tables",
    "write_all",
    "file_digest",
    "reanalyse",
    "ESTIMATES",
    "SPEEDUPS",
    "ESTIMATE_COLUMNS",
    "SPEEDUP_COLUMNS",
    "MAX_PICTURES",
    "PICTURE_DPI",
]

ESTIMATES = runfolder.ESTIMATES
SPEEDUPS = runfolder.SPEEDUPS
#: Workloads pictured in a run folder (the first ones of the sweep), and their resolution: at the
#: 110 dpi of ``workloads show --png`` the pictures were most of the report's bytes (60 dpi: 840 to 1080 px
#: wide, 1.5 to 2 times the ~550 px the report shows).
MAX_PICTURES = 16
PICTURE_DPI = 60

#: ``stats.estimate_table`` column -> its name in estimates.csv (times in ns per ray-triangle test).
ESTIMATE_COLUMNS = {
    "mean": "ns_per_test",
    "ci_low": "ns_per_test_ci_low",
    "ci_high": "ns_per_test_ci_high",
    "bootstrap_low": "ns_per_test_bootstrap_low",
    "bootstrap_high": "ns_per_test_bootstrap_high",
    "minimum": "ns_per_test_min",
    "sd": "ns_per_test_sd",
    "n": "n_processes",
}
#: ``stats.speedup_table`` column -> its name in speedups.csv (the ratio is unitless).
SPEEDUP_COLUMNS = {"ci_low": "ratio_ci_low", "ci_high": "ratio_ci_high", "n": "n_processes"}


@dataclass(frozen=True)
class Analysis:
    """Tables of one run and the choices behind them (``estimates``, ``speedups``: as their files)."""

    estimates: pd.DataFrame
    speedups: pd.DataFrame
    baseline: str
    margin: Margin
    batches: int
    processes: int
    #: The per-process table the estimates came from (:func:`tribench.harness.stats.per_process`), made once.
    per_process: pd.DataFrame = field(default_factory=pd.DataFrame, repr=False)


def analyse(run_dir: str | Path, baseline: str | None = None, margin: float | None = None) -> Analysis:
    """Estimates and speedups; ``baseline`` defaults to ``moller_seed`` else the first, ``margin`` to run.json's."""
    return estimate(measured.load(run_dir), baseline, margin)


def estimate(m: Measured, baseline: str | None = None, margin: float | None = None) -> Analysis:
    """Estimates and speedups of a run's measured files (``baseline`` and ``margin`` as :func:`analyse`'s),
    each build's from its own processes, stacked; the margin and baseline are the first build's."""
    return combined(estimate_builds(m, baseline, margin))


def estimate_builds(m: Measured, baseline: str | None = None, margin: float | None = None) -> dict[str, Analysis]:
    """Per build with timed batches, in the run's order, its :class:`Analysis` (no ``build`` column)."""
    parts = {}
    for build in m.builds:
        mb = m.of_build(build) if len(m.builds) > 1 else m
        if len(m.builds) == 1 or (~mb.batches["warmup"]).any():  # a live run may have none of a build yet
            parts[build] = _estimate_one(mb, baseline, margin)
    if not parts:
        raise UserError(f"{m.run_dir} has no timed batches yet")
    return parts


def combined(parts: dict[str, Analysis]) -> Analysis:
    """The builds' analyses as one: their tables stacked, each row's build in the first column."""
    first = next(iter(parts.values()))
    return Analysis(
        by_build({b: a.estimates for b, a in parts.items()}),
        by_build({b: a.speedups for b, a in parts.items()}),
        first.baseline,
        first.margin,
        sum(a.batches for a in parts.values()),
        sum(a.processes for a in parts.values()),
        by_build({b: a.per_process for b, a in parts.items()}),
    )


def by_build(frames: dict[str, pd.DataFrame]) -> pd.DataFrame:
    """One table per build, stacked in the builds' order, with its build as the first column."""
    parts = [f.reset_index(drop=True).assign(build=b) for b, f in frames.items()]
    table = pd.concat(parts, ignore_index=True) if len(parts) > 1 else parts[0]
    return table[["build", *(c for c in table.columns if c != "build")]]


def _estimate_one(m: Measured, baseline: str | None, margin: float | None) -> Analysis:
    from ...workloads.kinds import spec_from_dict

    run, batches = m.run, m.batches
    timed = batches.loc[~batches["warmup"]]
    if timed.empty:
        raise UserError(f"{m.run_dir} has no timed batches yet")
    kernels = [k for k in run.sweep.kernels if k in set(timed["kernel"])]
    if baseline is None:
        baseline = DEFAULT_BASELINE if DEFAULT_BASELINE in kernels else kernels[0]
    elif baseline not in kernels:
        raise UserError(f"baseline {baseline!r} is not in this run; its kernels: {', '.join(kernels)}")
    names = {wid: spec_from_dict(spec).summary() for wid, spec in m.specs.items()}
    table = stats.per_process(batches)
    # --margin, else the run's own A/A twin, else what run.json recorded (a calibration's or the default)
    mg = Margin(margin, "--margin") if margin is not None else twin_margin(table, baseline)
    if mg is None:
        mg = run.margin
    estimates = stats.estimate_table(table).rename(columns=ESTIMATE_COLUMNS)
    estimates["workload"] = estimates["workload_id"].map(names)
    dtypes = {wid: spec["dtype"] for wid, spec in m.specs.items()}
    estimates = estimates.join(_peak_columns(table, m.processes, dtypes, run.throughput), on=["kernel", "workload_id"])
    # against the baseline where it ran: a BVH workload runs only the kernels that can be a
    # BVH's leaf test (pairs workloads no wide kernel), so it may have no speedups (ranking.csv has it)
    ran = table.loc[table["kernel"] == baseline, "workload_id"].unique()
    speedups = stats.speedup_table(table.loc[table["workload_id"].isin(ran)], baseline, margin=mg.value)
    speedups = speedups.rename(columns=SPEEDUP_COLUMNS)
    speedups["workload"] = speedups["workload_id"].map(names)
    speedups["margin_source"] = mg.source
    return Analysis(estimates, speedups, baseline, mg, len(batches), int(table["process"].nunique()), table)


def _peak_columns(
    table: pd.DataFrame, processes: pd.DataFrame, dtypes: dict[str, str], throughput: Mapping[str, Any] | None
) -> pd.DataFrame:
    """Per kernel and workload: mean peak, operations per test, the bound and the fraction of it. Each process's
    time is scaled by its FMA peak over the one recorded with the rates; the t-interval of the mean maps to
    ``bound / time`` (ends swapped). No recorded rates: NaN."""
    from ... import ext
    from ...harness.peak import bound_from_mix

    keys = ["kernel", "workload_id"]
    columns = [
        "peak_gflops",
        "ops_per_test",
        "bound_ns_per_test",
        "peak_fraction",
        "peak_fraction_ci_low",
        "peak_fraction_ci_high",
    ]
    if processes.empty:
        return pd.DataFrame(columns=[*keys, *columns]).set_index(keys)
    peak = processes.groupby("process").agg(peak_gflops=("peak_gflops", "mean"))
    joined = table.join(peak, on="process").dropna(subset=["peak_gflops"])
    peaks = joined.groupby(keys).agg(peak_gflops=("peak_gflops", "mean"))
    known = set(ext.kernel_names(internal=True))
    ops = np.array([ext.kernel_info(k).ops if k in known else np.nan for k, _ in peaks.index], dtype=float)
    nan = np.full(len(peaks), np.nan)
    bound, fraction, low, high = nan, nan, nan, nan
    if throughput:
        ref = float(throughput["peak_gflops"])
        bound_ref = np.array(
            [
                bound_from_mix(ext.kernel_info(k).mix, throughput[dtypes[w]]) if k in known else np.nan
                for k, w in peaks.index
            ]
        )
        scaled = stats.estimate_table(joined.assign(ns_per_test=joined["ns_per_test"] * joined["peak_gflops"] / ref))
        scaled = scaled.set_index(keys).reindex(peaks.index)
        bound = bound_ref * ref / peaks["peak_gflops"].to_numpy()
        fraction = bound_ref / scaled["mean"].to_numpy()
        low = bound_ref / scaled["ci_high"].to_numpy()
        # a time interval reaching 0 or below (few, noisy processes) leaves the fraction unbounded above
        ci_low = scaled["ci_low"].to_numpy()
        high = np.where(ci_low > 0, bound_ref / np.where(ci_low > 0, ci_low, np.nan), np.inf)
    values = (peaks["peak_gflops"], ops, bound, fraction, low, high)
    return pd.DataFrame(dict(zip(columns, values, strict=True)), index=peaks.index)


def write_tables(run_dir: str | Path, analysis: Analysis) -> tuple[Path, Path]:
    """Write ``estimates.csv`` and ``speedups.csv`` atomically (a failed write: a UserError; the file unchanged)."""
    run_dir = Path(run_dir)
    paths = run_dir / ESTIMATES, run_dir / SPEEDUPS
    runfolder.write_csv(analysis.estimates, paths[0])
    runfolder.write_csv(analysis.speedups, paths[1])
    return paths


# ------------------------------------------------------------ every derived table


@dataclass(frozen=True)
class Derived:
    """What :func:`write_all` wrote: the tables by file name (as in the files) and ``analysis.json``."""

    analysis: Analysis
    tables: dict[str, pd.DataFrame]
    record: dict[str, Any] = field(default_factory=dict)

    @property
    def estimates(self) -> pd.DataFrame:
        return self.analysis.estimates

    @property
    def speedups(self) -> pd.DataFrame:
        return self.analysis.speedups


def _workloads(run: runfolder.Run, wids: list[str]) -> tuple[dict[str, Any], dict[str, str]]:
    """The run's workloads from the cache, made from their spec where the cache lacks them (the run's reader
    has checked that each spec still gives its recorded id); the source of each, or why it is not used."""
    import warnings

    from ...workloads import cache

    found: dict[str, Any] = {}
    sources: dict[str, str] = {}
    for wid in wids:
        with contextlib.suppress(FileNotFoundError, ValueError), warnings.catch_warnings():
            warnings.simplefilter("ignore")
            found[wid], sources[wid] = cache.load(wid), "cache"
            continue
        try:
            found[wid] = cache.make(run.sweep.spec_of(wid))
            sources[wid] = "not in the cache: rebuilt from the spec recorded in run.json (same bytes)"
        except Exception as exc:  # a mesh file that moved, a spec of another version...
            sources[wid] = f"not in the cache and cannot be rebuilt ({type(exc).__name__}: {exc})"
    return found, sources


def _pictures(run_dir: Path, wids: list[str], workloads: dict[str, Any]) -> dict[str, str]:
    """Draw the first :data:`MAX_PICTURES` workloads into ``pictures/``; workload id -> file name or why not.
    A picture already there is kept (its workload's id is its spec's hash)."""
    from ...workloads import picture

    folder = run_dir / runfolder.PICTURES_DIR
    out: dict[str, str] = {}
    for i, wid in enumerate(wids):
        if i >= MAX_PICTURES:
            out[wid] = f"(picture not drawn: only the first {MAX_PICTURES} workloads are pictured)"
            continue
        if wid not in workloads:
            continue
        name = f"{runfolder.PICTURES_DIR}/{wid}.png"
        if not (run_dir / name).is_file():
            try:
                folder.mkdir(exist_ok=True)
                picture.draw(workloads[wid], run_dir / name, dpi=PICTURE_DPI)
            except Exception as exc:  # a picture must never stop the analysis
                out[wid] = f"picture failed: {type(exc).__name__}: {exc}"
                continue
        out[wid] = name
    return out


def _peer_tables(m: Measured) -> tuple[dict[str, pd.DataFrame], str]:
    """``peer_rates.csv`` and ``peer_ratios.csv`` from ``peers.csv`` (none without it), and a sentence."""
    from .peers import summarise as summarise_peers

    if m.peers is None:
        return {}, m.peers_note
    try:
        rates, ratios = summarise_peers(m.peers)
    except (ValueError, KeyError, IndexError) as exc:
        return {}, f"{runfolder.PEERS} cannot be used ({type(exc).__name__}: {exc})"
    return {
        runfolder.PEER_RATES: rates.reindex(columns=list(runfolder.FILES[runfolder.PEER_RATES])),
        runfolder.PEER_RATIOS: ratios.reindex(columns=list(runfolder.FILES[runfolder.PEER_RATIOS])),
    }, "summarised"


def derive(
    m: Measured, parts: dict[str, Analysis], workloads: dict[str, Any], sources: dict[str, str]
) -> dict[str, pd.DataFrame]:
    """Every derived table of the run by file name, in :data:`runfolder.DERIVED`'s order: a pure
    function of the measured files and the workloads, each build's parts from its processes alone."""
    from .compare import builds_table

    one = {b: _derive_one(m.of_build(b) if len(m.builds) > 1 else m, a, workloads, sources) for b, a in parts.items()}
    first = next(iter(one.values()))
    tables = {
        name: by_build({b: t[name] for b, t in one.items()}) if name in runfolder.BY_BUILD else t0
        for name, t0 in first.items()
    }
    tables[runfolder.BUILDS] = builds_table(m, parts, one)
    for name, frame in tables.items():
        if list(frame.columns) != list(runfolder.FILES[name]):  # a bug: the table and the contract disagree
            raise AssertionError(f"{name}: columns {list(frame.columns)} are not runfolder.FILES[{name!r}]")
    return tables


def _derive_one(
    m: Measured, result: Analysis, workloads: dict[str, Any], sources: dict[str, str]
) -> dict[str, pd.DataFrame]:
    """The derived tables of one build's processes (no ``build`` column)."""
    from . import bvh, diagnostics, ranking, workload_tables

    batches, kernels, wids, specs = m.batches, m.kernels, m.workload_ids, m.specs
    base, margin = result.baseline, result.margin.value
    wl = workload_tables.workload_table(specs, wids, workloads, sources)
    est = workload_tables.estimates_with_workloads(result.estimates, wl)
    spd = result.speedups.merge(wl.drop(columns=["dtype"]), on="workload_id", how="left", suffixes=("", "_wl"))
    measured_pp = result.per_process
    labels = diagnostics.batch_labels(batches)
    correct = workload_tables.correctness_table(batches, kernels, workloads)
    # the A/A twin measured the margin (margin.py), and a kernel whose answers differ did other work:
    # the diagnostics keep both, no ranking does
    est, spd, pp, ranked_batches = (workload_tables.compared(f, correct) for f in (est, spd, measured_pp, batches))
    ranked = [k for k in kernels if k not in TWINS]
    rank = ranking.ranking_table(in_order(est, workload_id=wids), spd, pp, margin, m.validate, base)  # plan order
    return {
        runfolder.ESTIMATES: result.estimates,
        runfolder.SPEEDUPS: result.speedups,
        runfolder.WORKLOADS: wl,
        runfolder.WORKLOAD_FIGURES: workload_tables.workload_figures(wids, workloads),
        runfolder.CORRECTNESS: correct,
        runfolder.PER_PROCESS: measured_pp,
        runfolder.BATCH_LABELS: labels,
        runfolder.CROSSOVERS: workload_tables.crossovers(ranked, wl, pp),
        runfolder.SLOPES: workload_tables.scaling_slopes(est, pp),
        runfolder.DRIFT: diagnostics.drift_table(batches, kernels, base, wids, wl),
        runfolder.VARIANCE: diagnostics.variance_table(batches, kernels, wids, wl),
        runfolder.OUTLIERS: diagnostics.outlier_table(labels, wl),
        runfolder.WARMUP: diagnostics.warmup_table(labels, wl),
        runfolder.KERNELS: ranking.kernel_table(ranked, batches, est, spd, base),
        runfolder.RANKING: rank,
        runfolder.ALGORITHMS: ranking.algorithm_table(rank, pp, margin),
        # each kernel's robustness beside its speed
        runfolder.BANDS: ranking.band_table(est, pp, specs, base, margin, m.validate),
        runfolder.BVH: bvh.bvh_table(ranked_batches, m.traversals, wl, specs, pp, ranked, base, margin),
    }


def write_all(
    run_dir: str | Path, baseline: str | None = None, margin: float | None = None, validate_note: str | None = None
) -> Derived:
    """Write every derived table of ``run_dir``, its workload pictures and ``analysis.json``.

    ``validate.csv`` is read and the peer tables made when their files exist (``validate_note``: where
    ``validate.csv`` came from). ``analysis.json`` goes last, with the SHA-256 of the files read, so a reader
    can tell stale tables. Raises UserError when the folder cannot be read or written or has no timed batch."""
    m = measured.load(run_dir)
    parts = estimate_builds(m, baseline, margin)
    result = combined(parts)
    mesh_files.adopt(run_dir)  # the run folder's mesh copies: its workloads rebuild on any machine
    workloads, sources = _workloads(m.run, m.workload_ids)
    tables = derive(m, parts, workloads, sources)
    peer_tables, peer_note = _peer_tables(m)
    tables.update(peer_tables)
    for name, frame in tables.items():
        runfolder.write_csv(frame, m.run_dir / name)
    pictures = _pictures(m.run_dir, m.workload_ids, workloads)
    margin_record = {"value": result.margin.value, "source": result.margin.source}
    write_text(
        m.run_dir / runfolder.GOOGLE_BENCHMARK,
        export.dumps(export.google_benchmark(m.run, tables, result.baseline, margin_record)),
    )
    if validate_note is None:
        validate_note = f"Read from {runfolder.VALIDATE} in the run folder." if m.validate is not None else None
    record = {
        "created": _dt.datetime.now().astimezone().isoformat(timespec="seconds"),
        "batches_sha256": m.batches_sha256,
        "peers_sha256": m.peers_sha256 if peer_tables else None,
        "peers": peer_note,
        "baseline": result.baseline,
        "margin": margin_record,
        "tables": list(tables),
        "exports": [runfolder.GOOGLE_BENCHMARK],
        "validate": validate_note,
        "pictures": pictures,
    }
    write_text(m.run_dir / runfolder.ANALYSIS, json.dumps(record, indent=2, sort_keys=True) + "\n")
    return Derived(result, tables, record)


def reanalyse(run_dir: str | Path) -> Derived:
    """Redo the analysis of an analysed run folder with the choices its last one recorded (after
    ``tribench peers --out RUN_DIR``): its baseline, and its margin where ``--margin`` gave it."""
    run_dir = Path(run_dir)
    try:
        record = json.loads((run_dir / runfolder.ANALYSIS).read_text(encoding="utf-8"))
        kept = {
            "baseline": record["baseline"],
            "margin": record["margin"]["value"] if record["margin"]["source"] == "--margin" else None,
        }
    except (OSError, UnicodeDecodeError, ValueError, TypeError, KeyError):
        kept = {}
    return write_all(run_dir, **kept)
