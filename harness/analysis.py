"""``tribench stats``: estimates and speedups of a run, from its files alone.

Reads ``batches.csv``, ``processes.csv`` and ``run.json``; never measures.
All statistics come from :mod:`tribench.harness.stats`.

``estimates.csv``: the fields of :func:`~tribench.harness.stats.estimate_table`
renamed by :data:`ESTIMATE_COLUMNS` so each name carries its unit
(``kernel, workload_id, ns_per_test, ns_per_test_ci_low, ns_per_test_ci_high,
ns_per_test_bootstrap_low, ns_per_test_bootstrap_high, ns_per_test_min,
ns_per_test_sd, n_processes, confidence``), then ``workload`` (the spec's
one-line summary), ``peak_gflops`` (mean FMA peak of the processes),
``ops_per_test`` (the kernel's documented arithmetic), ``bound_ns_per_test``
(that arithmetic at the peak) and ``peak_fraction, peak_fraction_ci_low,
peak_fraction_ci_high``: bound over measured time, each process against its
own peak of that moment, a machine-normalised figure steadier than raw time
(:mod:`tribench.harness.peak`).

``speedups.csv``: the columns of :func:`~tribench.harness.stats.speedup_table`
renamed by :data:`SPEEDUP_COLUMNS` (``workload_id, kernel, baseline, ratio,
ratio_ci_low, ratio_ci_high, p_value, p_holm, n_processes, confidence,
margin, verdict``), then ``workload`` and ``margin_source``.

The renaming happens here and only here: :mod:`~tribench.harness.stats`
keeps its generic names (``mean``, ``ci_low``...), which fit any quantity,
and :class:`Analysis` holds the tables exactly as the files have them.
"""

from __future__ import annotations

import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from tribench import stats
from tribench.common import UserError

from . import records
from .calibration import Margin

__all__ = ["Analysis", "analyse", "write_tables", "ESTIMATES", "SPEEDUPS", "ESTIMATE_COLUMNS",
           "SPEEDUP_COLUMNS"]

ESTIMATES = "estimates.csv"
SPEEDUPS = "speedups.csv"
DEFAULT_BASELINE = "moller_seed"

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
    """Tables of one run and the choices behind them.

    ``estimates`` and ``speedups`` have the columns of estimates.csv and
    speedups.csv (documented in :mod:`tribench.reports.columns`).
    """

    estimates: pd.DataFrame
    speedups: pd.DataFrame
    baseline: str
    margin: Margin
    batches: int
    processes: int


def analyse(run_dir: str | Path, baseline: str | None = None, margin: float | None = None) -> Analysis:
    """Estimates and speedups of ``run_dir``.

    Parameters
    ----------
    baseline : str, optional
        Default ``moller_seed`` if the run has it, else the sweep's first kernel.
    margin : float, optional
        Equivalence margin; default the one recorded in ``run.json``.
    """
    run = records.read_run(run_dir)
    batches = records.read_batches(run_dir, run)
    writer = records.live_writer(run_dir)
    if writer is not None:
        print(f"tribench: note: {run_dir} is still being written by {writer}; these tables cover "
              f"{len(batches)} of its {run['n_batches']} batches", file=sys.stderr)
    timed = batches.loc[~batches["warmup"]]
    if timed.empty:
        raise UserError(f"{run_dir} has no timed batches yet")
    kernels = [k for k in run["sweep"]["kernels"] if k in set(timed["kernel"])]
    if baseline is None:
        baseline = DEFAULT_BASELINE if DEFAULT_BASELINE in kernels else kernels[0]
    elif baseline not in kernels:
        raise UserError(f"baseline {baseline!r} is not in this run; its kernels: {', '.join(kernels)}")
    m = (Margin(margin, "--margin") if margin is not None
         else Margin(run["margin"]["value"], run["margin"]["source"]))
    names = {wid: _summary(spec) for wid, spec in zip(run["sweep"]["workload_ids"], run["sweep"]["workloads"])}

    table = stats.per_process(batches)
    estimates = stats.estimate_table(table).rename(columns=ESTIMATE_COLUMNS)
    estimates["workload"] = estimates["workload_id"].map(names)
    dtypes = {wid: spec["dtype"] for wid, spec in zip(run["sweep"]["workload_ids"], run["sweep"]["workloads"])}
    estimates = estimates.join(_peak_columns(table, records.read_processes(run_dir, run), dtypes),
                               on=["kernel", "workload_id"])
    speedups = stats.speedup_table(table, baseline, margin=m.value).rename(columns=SPEEDUP_COLUMNS)
    speedups["workload"] = speedups["workload_id"].map(names)
    speedups["margin_source"] = m.source
    return Analysis(estimates, speedups, baseline, m, len(batches), int(table["process"].nunique()))


def _summary(spec: dict) -> str:
    from tribench.workloads.kinds import spec_from_dict

    return spec_from_dict(spec).summary()


def _peak_columns(table: pd.DataFrame, processes: pd.DataFrame, dtypes: dict[str, str]) -> pd.DataFrame:
    """Per kernel and workload: mean peak, operations per test, the bound and the fraction of it.

    Per process, one test's time in lane-operation slots at that process's
    peak (``ns_per_test * lane_ops_per_ns``); the t-interval of their mean
    maps to the fraction ``ops / slots`` (a monotone map, so the interval
    carries over, ends swapped). See :mod:`tribench.harness.peak`."""
    from tribench import ext

    from .peak import lane_ops_per_ns

    columns = ["peak_gflops", "ops_per_test", "bound_ns_per_test", "peak_fraction", "peak_fraction_ci_low",
               "peak_fraction_ci_high"]
    if processes.empty:
        return pd.DataFrame(columns=["kernel", "workload_id", *columns]).set_index(["kernel", "workload_id"])
    peak = processes.groupby("process").agg(peak_gflops=("peak_gflops", "mean"), peak_isa=("peak_isa", "first"))
    joined = table.join(peak, on="process").dropna(subset=["peak_gflops"])
    rate = [lane_ops_per_ns(g, dtypes[w], isa)
            for g, w, isa in zip(joined["peak_gflops"], joined["workload_id"], joined["peak_isa"])]
    slots = stats.estimate_table(joined.assign(ns_per_test=joined["ns_per_test"] * rate))
    slots = slots.set_index(["kernel", "workload_id"])
    keys = ["kernel", "workload_id"]
    peaks = joined.groupby(keys).agg(peak_gflops=("peak_gflops", "mean"), peak_isa=("peak_isa", "first"))
    peaks = peaks.reindex(slots.index)
    known = set(ext.kernel_names(internal=True))
    ops = np.array([ext.kernel_info(k).ops if k in known else np.nan for k, _ in peaks.index], dtype=float)
    mean_rate = np.array([lane_ops_per_ns(g, dtypes[w], isa)
                          for (_, w), g, isa in zip(peaks.index, peaks["peak_gflops"], peaks["peak_isa"])])
    return pd.DataFrame({
        "peak_gflops": peaks["peak_gflops"],
        "ops_per_test": ops,
        "bound_ns_per_test": ops / mean_rate,
        "peak_fraction": ops / slots["mean"],
        "peak_fraction_ci_low": ops / slots["ci_high"],
        "peak_fraction_ci_high": ops / slots["ci_low"],
    }, index=slots.index)


def write_tables(run_dir: str | Path, analysis: Analysis) -> tuple[Path, Path]:
    """Write ``estimates.csv`` and ``speedups.csv`` into ``run_dir``, each atomically.

    A failed write (a full disk) raises a UserError naming the file and
    leaves that file as it was, never empty or cut.
    """
    run_dir = Path(run_dir)
    paths = run_dir / ESTIMATES, run_dir / SPEEDUPS
    records.write_csv(analysis.estimates, paths[0])
    records.write_csv(analysis.speedups, paths[1])
    return paths
