"""``tribench stats``: estimates and speedups of a run, from its files alone.

Reads ``batches.csv``, ``processes.csv`` and ``run.json``; never measures.
All statistics come from :mod:`tribench.harness.stats`.

``estimates.csv``: the fields of :func:`~tribench.harness.stats.estimate_table`
renamed by :data:`ESTIMATE_COLUMNS` so each name carries its unit
(``kernel, workload_id, ns_per_test, ns_per_test_ci_low, ns_per_test_ci_high,
ns_per_test_bootstrap_low, ns_per_test_bootstrap_high, ns_per_test_min,
ns_per_test_sd, n_processes, confidence``), then ``workload`` (the spec's
one-line summary), ``peak_gflops`` (mean FMA peak of the processes) and
``peak_flops_per_test, peak_flops_per_test_ci_low,
peak_flops_per_test_ci_high``: the cost of one test in flops at the machine's
peak of that moment (``ns_per_test * peak_gflops`` per process, then the same
t-interval), a machine-normalised figure steadier than raw time.

``speedups.csv``: the columns of :func:`~tribench.harness.stats.speedup_table`
renamed by :data:`SPEEDUP_COLUMNS` (``workload_id, kernel, baseline, ratio,
ratio_ci_low, ratio_ci_high, p_value, p_holm, n_processes, confidence,
margin, verdict``), then ``workload`` and ``margin_source``.

The renaming happens here and only here: :mod:`~tribench.harness.stats`
keeps its generic names (``mean``, ``ci_low``...), which fit any quantity,
and :class:`Analysis` holds the tables exactly as the files have them.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import pandas as pd

from . import records, stats
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
    batches = records.read_batches(run_dir)
    timed = batches.loc[~batches["warmup"]]
    if timed.empty:
        raise ValueError(f"{run_dir} has no timed batches yet")
    kernels = [k for k in run["sweep"]["kernels"] if k in set(timed["kernel"])]
    if baseline is None:
        baseline = DEFAULT_BASELINE if DEFAULT_BASELINE in kernels else kernels[0]
    elif baseline not in kernels:
        raise ValueError(f"baseline {baseline!r} is not in this run; its kernels: {', '.join(kernels)}")
    m = (Margin(margin, "--margin") if margin is not None
         else Margin(run["margin"]["value"], run["margin"]["source"]))
    names = {wid: _summary(spec) for wid, spec in zip(run["sweep"]["workload_ids"], run["sweep"]["workloads"])}

    table = stats.per_process(batches)
    estimates = stats.estimate_table(table).rename(columns=ESTIMATE_COLUMNS)
    estimates["workload"] = estimates["workload_id"].map(names)
    estimates = estimates.join(_peak_columns(table, records.read_processes(run_dir)),
                               on=["kernel", "workload_id"])
    speedups = stats.speedup_table(table, baseline, margin=m.value).rename(columns=SPEEDUP_COLUMNS)
    speedups["workload"] = speedups["workload_id"].map(names)
    speedups["margin_source"] = m.source
    return Analysis(estimates, speedups, baseline, m, len(batches), int(table["process"].nunique()))


def _summary(spec: dict) -> str:
    from tribench.workloads.spec import spec_from_dict

    return spec_from_dict(spec).summary()


def _peak_columns(table: pd.DataFrame, processes: pd.DataFrame) -> pd.DataFrame:
    """Per kernel and workload: mean peak and cost in peak flops per test."""
    columns = ["peak_gflops", "peak_flops_per_test", "peak_flops_per_test_ci_low", "peak_flops_per_test_ci_high"]
    if processes.empty:
        return pd.DataFrame(columns=["kernel", "workload_id", *columns]).set_index(["kernel", "workload_id"])
    peak = processes.groupby("process")["peak_gflops"].mean().rename("peak_gflops")
    joined = table.join(peak, on="process").dropna(subset=["peak_gflops"])
    scaled = joined.assign(ns_per_test=joined["ns_per_test"] * joined["peak_gflops"])
    est = stats.estimate_table(scaled).set_index(["kernel", "workload_id"])
    out = pd.DataFrame({
        "peak_gflops": joined.groupby(["kernel", "workload_id"])["peak_gflops"].mean(),
        "peak_flops_per_test": est["mean"],
        "peak_flops_per_test_ci_low": est["ci_low"],
        "peak_flops_per_test_ci_high": est["ci_high"],
    })
    return out


def write_tables(run_dir: str | Path, analysis: Analysis) -> tuple[Path, Path]:
    """Write ``estimates.csv`` and ``speedups.csv`` into ``run_dir``."""
    run_dir = Path(run_dir)
    paths = run_dir / ESTIMATES, run_dir / SPEEDUPS
    analysis.estimates.to_csv(paths[0], index=False)
    analysis.speedups.to_csv(paths[1], index=False)
    return paths
