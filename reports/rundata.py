"""Everything the report needs from one run folder, read once; nothing is computed or written here.

Stale tables (made from another ``batches.csv``, by its SHA-256), missing ones or ones in other columns are
refused in one line that says to run ``tribench stats RUN_DIR``, rather than a report with sections silently
empty. Peers and robustness are optional (:func:`load_peers`, :func:`load_validation`): their sections say why.
The last functions join those tables for display and read the workload pictures."""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from ..common import UserError
from ..ext.builds import INSTALLED
from ..harness import runfolder
from ..harness.plan import rows_of_build
from .tables.frames import in_order
from .tables.margin import TWINS
from .tables.measured import file_digest, has_columns, read_documented
from .tables.workload_tables import compared, estimates_with_workloads

__all__ = [
    "RunData",
    "RunError",
    "load_run",
    "load_validation",
    "load_peers",
    "PeerTables",
    "estimates_table",
    "named",
    "speedups_table",
    "workload_figures",
    "picture",
]


class RunError(UserError):
    """A run folder the report cannot use (one line saying why)."""


@dataclass
class RunData:
    """One run folder, read."""

    run_dir: Path
    run: runfolder.Run
    batches: pd.DataFrame
    processes: pd.DataFrame
    estimates: pd.DataFrame
    speedups: pd.DataFrame
    baseline: str
    margin: float
    margin_source: str
    #: workload id -> spec dict, in sweep order
    specs: dict[str, dict[str, Any]] = field(default_factory=dict)
    #: the derived tables, by file name, as the files have them
    tables: dict[str, pd.DataFrame] = field(default_factory=dict)
    #: ``analysis.json``: what the tables were made from
    record: dict[str, Any] = field(default_factory=dict)
    #: the build this view shows (a run of several builds is read one build at a time: ``load_run(build=)``)
    build: str = INSTALLED
    #: the tables of :data:`~tribench.harness.runfolder.BY_BUILD` as their files have them, every build's rows
    every_build: dict[str, pd.DataFrame] = field(default_factory=dict)

    @property
    def builds(self) -> list[str]:
        """The run's builds, in the order its processes take them (one: the installed build)."""
        return list(self.run.sweep.build_names)

    @property
    def kernels(self) -> list[str]:
        """Kernels of the run that have timed batches, in sweep order; no A/A twin (a measuring instrument)."""
        present = set(self.batches["kernel"]) - TWINS
        return [k for k in self.run.sweep.kernels if k in present]

    @property
    def workload_ids(self) -> list[str]:
        present = set(self.batches["workload_id"])
        return [w for w in self.specs if w in present]

    @property
    def dtypes(self) -> list[str]:
        """Precisions of the run's batches, float32 first."""
        return sorted(set(self.batches["dtype"]))

    @property
    def n_processes(self) -> int:
        timed = self.batches.loc[~self.batches["warmup"]]
        return int(timed["process"].nunique())

    @property
    def machine(self) -> Mapping[str, Any]:
        return self.run.machine


def _stats_hint(run_dir: Path) -> str:
    return f"run `tribench stats {run_dir}` to make them (the report only reads)"


def _read_record(run_dir: Path) -> dict[str, Any]:
    path = run_dir / runfolder.ANALYSIS
    if not path.is_file():
        raise RunError(f"{run_dir} has no analysis tables (no {runfolder.ANALYSIS}): {_stats_hint(run_dir)}")
    try:
        record = json.loads(path.read_text(encoding="utf-8"))
        if not isinstance(record, dict) or not isinstance(record.get("tables"), list):
            raise ValueError("not an analysis record")
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        raise RunError(f"{path} cannot be read ({exc}): {_stats_hint(run_dir)}") from None
    return record


def _read_table(run_dir: Path, name: str) -> pd.DataFrame:
    """A derived table, refused unless it has exactly its documented columns."""
    path = run_dir / name
    if name not in runfolder.FILES:
        raise RunError(
            f"{run_dir / runfolder.ANALYSIS} lists {name!r}, not a table of this tribench: {_stats_hint(run_dir)}"
        )
    if not path.is_file() or path.is_symlink():
        raise RunError(f"{path} is missing: {_stats_hint(run_dir)}")
    if not has_columns(path, name):
        raise RunError(
            f"{path} is not in today's columns (an older tribench, or an edited file): {_stats_hint(run_dir)}"
        )
    try:
        if name == runfolder.WORKLOAD_FIGURES:  # JSON text, read as written
            return pd.read_csv(path, dtype=str, keep_default_na=False)
        return pd.read_csv(path)
    except (OSError, UnicodeDecodeError, ValueError, pd.errors.ParserError) as exc:
        raise RunError(f"{path} cannot be read ({type(exc).__name__}: {exc}): {_stats_hint(run_dir)}") from None


def _read_measured(run_dir: Path) -> tuple[runfolder.Run, pd.DataFrame, pd.DataFrame]:
    """``run.json``, ``batches.csv`` and ``processes.csv``, validated; a RunError says what is wrong."""
    if not run_dir.is_dir():
        raise RunError(f"no run directory {run_dir}")
    try:
        run = runfolder.read_run(run_dir)
        batches = runfolder.read_batches(run_dir, run)
        processes = runfolder.read_processes(run_dir, run)
    except runfolder.MissingRunFile as exc:
        raise RunError(f"{exc} (was the sweep started?)") from None
    except UserError as exc:  # the records' validation: file:line and what is wrong
        raise RunError(str(exc)) from None
    if batches.loc[~batches["warmup"]].empty:
        raise RunError(f"{run_dir} has no timed batches yet")
    return run, batches, processes


def load_run(run_dir: str | Path, baseline: str | None = None, build: str | None = None) -> RunData:
    """Read a run folder and its derived tables, as one build measured them (default: its first): its batches,
    processes and rows of every :data:`~tribench.harness.runfolder.BY_BUILD` table. Raises RunError when the
    folder is unusable, has nothing timed, or its tables are stale or against another ``baseline`` than asked."""

    run_dir = Path(run_dir)
    run, batches, processes = _read_measured(run_dir)
    builds = list(run.sweep.build_names)
    build = builds[0] if build is None else build
    if build not in builds:
        raise RunError(f"{run_dir} has no build {build!r}; its builds: {'; '.join(builds)}")
    batches, processes = (rows_of_build(f, batches, build) for f in (batches, processes))

    record = _read_record(run_dir)
    if record.get("batches_sha256") != file_digest(run_dir / runfolder.BATCHES):
        raise RunError(
            f"the tables in {run_dir} were made from another {runfolder.BATCHES} (a resumed or edited "
            f"run): {_stats_hint(run_dir)}"
        )
    if baseline is not None and baseline != record.get("baseline"):
        raise RunError(
            f"the tables in {run_dir} compare against {record.get('baseline')}, not {baseline}: run "
            f"`tribench stats {run_dir} --baseline {baseline}` to remake them"
        )
    tables = {name: _read_table(run_dir, name) for name in record["tables"]}
    every_build = {name: t for name, t in tables.items() if name in runfolder.BY_BUILD}
    tables = {
        name: t.loc[t["build"] == build].reset_index(drop=True) if name in runfolder.BY_BUILD else t
        for name, t in tables.items()
    }
    for name in (runfolder.ESTIMATES, runfolder.SPEEDUPS):
        if name not in tables:
            raise RunError(f"{run_dir / runfolder.ANALYSIS} lists no {name}: {_stats_hint(run_dir)}")
    # an A/A twin measured the margin (its sentence says so), and a kernel whose answers differ from the
    # reference did other work (the correctness section says so): the report's speeds are the others'
    correct = tables.get(runfolder.CORRECTNESS)
    estimates, speedups = (compared(tables[name], correct) for name in (runfolder.ESTIMATES, runfolder.SPEEDUPS))
    margin = record.get("margin") or {}
    if len(builds) > 1 and not speedups.empty:  # each build's own margin (its A/A twin's), as its rows have it
        margin = {"value": float(speedups["margin"].iloc[0]), "source": str(speedups["margin_source"].iloc[0])}
    return RunData(
        run_dir,
        run,
        batches,
        processes,
        estimates,
        speedups,
        str(record.get("baseline")),
        float(margin.get("value", 0.01)),
        str(margin.get("source", "unknown")),
        run.specs,
        tables,
        record,
        build,
        every_build,
    )


def load_validation(data: RunData) -> tuple[pd.DataFrame, str]:
    """``validate.csv``'s rows of the run's kernels (in its order) and precisions, and a sentence saying
    where they came from; missing or unusable: an empty frame and a sentence saying what to run."""
    path = data.run_dir / runfolder.VALIDATE
    df, why = read_documented(path)
    if df is None:
        if not path.is_file():
            from ..harness.jobs.sweep import robustness_command

            why = data.record.get("validate") or f"No {runfolder.VALIDATE} in the run folder."
            return (
                _NO_VALIDATION,
                f"{why} `{robustness_command(data.run_dir)}` measures it; then `tribench stats {data.run_dir}`.",
            )
        return _NO_VALIDATION, (
            f"{why}: remove it, measure it again with `tribench validate ... --out {path}`, then "
            f"`tribench stats {data.run_dir}`."
        )
    note = str(data.record.get("validate") or f"Read from {runfolder.VALIDATE} in the run folder.")
    missing = [
        f"{k} {d}" for k in data.kernels for d in data.dtypes if not ((df["kernel"] == k) & (df["dtype"] == d)).any()
    ]
    if missing:
        note += f" Not in the table: {', '.join(missing)}."
    df = df.loc[df["kernel"].isin(data.kernels) & df["dtype"].isin(data.dtypes)]
    return in_order(df, kernel=data.kernels), note


_NO_VALIDATION = pd.DataFrame(columns=list(runfolder.FILES[runfolder.VALIDATE]))


@dataclass
class PeerTables:
    """A run's ``peers.csv`` and its figures (``peer_rates.csv``, ``peer_ratios.csv``)."""

    frame: pd.DataFrame
    rates: pd.DataFrame
    ratios: pd.DataFrame

    @property
    def kernel(self) -> str:
        return str(self.frame["kernel"].iloc[0])

    @property
    def workload(self) -> str:
        return str(self.frame["workload"].iloc[0])

    @property
    def in_bvh(self) -> bool:
        """Whether tribench was timed through its BVH (``--accel bvh``: its implementation says ``bvh``)."""
        ours = self.rates.loc[self.rates["contender"] == "tribench", "implementation"]
        return not ours.empty and " bvh " in f" {ours.iloc[0]} "


def load_peers(data: RunData) -> tuple[PeerTables | None, str]:
    """The run's peers (rows and figures) and a sentence on where they came from; None, and what to run,
    when ``peers.csv`` is absent, unusable or not yet summarised by the analysis step."""
    from ..harness.jobs.peers import INSTALL

    path = data.run_dir / runfolder.PEERS
    how = (
        f"`{INSTALL}` (embreex and rtree) and `apt-get install libembree-dev` (native Embree), "
        f"then `tribench peers --out {data.run_dir}` (it refreshes the run's "
        f"tables) and `tribench report {data.run_dir}` add them"
    )
    frame, why = read_documented(path)
    if frame is None:
        return None, (
            f"No peers were measured with this run ({why}): " if not path.is_file() else f"{why}: "
        ) + f"{how}."
    if runfolder.PEER_RATES not in data.tables or runfolder.PEER_RATIOS not in data.tables:
        reason = data.record.get("peers") or "not summarised"
        return None, (
            f"{runfolder.PEERS} is not summarised by the analysis ({reason}): run `tribench stats {data.run_dir}`."
        )
    if data.record.get("peers_sha256") != file_digest(path):
        return None, (
            f"{runfolder.PEERS} changed since the analysis summarised it: run `tribench stats {data.run_dir}`."
        )
    return (
        PeerTables(frame, data.tables[runfolder.PEER_RATES], data.tables[runfolder.PEER_RATIOS]),
        f"Read from {runfolder.PEERS}, {runfolder.PEER_RATES} and {runfolder.PEER_RATIOS} in the run folder.",
    )


# ------------------------------------------------------------ the tables joined for display


def sweep_order(frame: pd.DataFrame, data: RunData) -> pd.DataFrame:
    """Rows in sweep order: workloads, then kernels."""
    return in_order(frame, workload_id=data.workload_ids, kernel=data.kernels)


def named(frame: pd.DataFrame, data: RunData) -> pd.DataFrame:
    """``frame`` with its ``label`` the workload in words, family and label (``pairs n=10000 shuffled sphere float32
    · per-test hit rate 50%``), as the ranking names it: a label alone is two workloads' when the run has a hit
    rate or a mesh at both precisions."""
    wl = data.tables[runfolder.WORKLOADS]
    names = {w: f"{f} · {lab}" for w, f, lab in zip(wl["workload_id"], wl["family"], wl["label"], strict=True)}
    return frame.assign(label=frame["workload_id"].map(names).fillna(frame["label"])) if len(frame) else frame


def estimates_table(data: RunData, wl: pd.DataFrame) -> pd.DataFrame:
    """``estimates.csv`` joined with the workload table and the working-set size: bytes of prepared triangles (as
    ``kernels.csv`` recorded them for the kernel and family, the build that measured the run) plus rays (origin and
    direction, 3 components each); NaN where a figure is unknown."""
    est = estimates_with_workloads(data.estimates, wl)
    kern = data.tables[runfolder.KERNELS]
    per = dict(zip(zip(kern["kernel"], kern["family"], strict=True), kern["bytes_per_triangle"], strict=True))
    keys = zip(est["kernel"], est["family"], strict=True)
    per_triangle = pd.Series([per.get(k, math.nan) for k in keys], est.index, float)
    itemsize = est["dtype"].map(lambda d: np.dtype(d).itemsize)
    est["working_set_bytes"] = est["triangles"] * per_triangle + est["rays"] * 6 * itemsize
    return est


def speedups_table(data: RunData, wl: pd.DataFrame) -> pd.DataFrame:
    """``speedups.csv`` joined with the workload table."""
    return data.speedups.merge(wl.drop(columns=["dtype"]), on="workload_id", how="left", suffixes=("", "_wl"))


def workload_figures(data: RunData) -> dict[str, list[tuple[str, Any, Any]]]:
    """Per workload id, its ``(figure, target, achieved)`` rows from ``workload_figures.csv``."""
    out: dict[str, list[tuple[str, Any, Any]]] = {}
    frame = data.tables[runfolder.WORKLOAD_FIGURES]
    for r in frame.itertuples(index=False):
        out.setdefault(r.workload_id, []).append((r.figure, json.loads(r.target), json.loads(r.achieved)))
    return out


def picture(data: RunData, workload_id: str) -> tuple[bytes | None, str]:
    """The workload's PNG drawn by the analysis step, or None and why there is none."""
    entry = (data.record.get("pictures") or {}).get(workload_id)
    if entry is None:
        return None, "no picture: the workload was not available to the analysis"
    if entry != f"{runfolder.PICTURES_DIR}/{workload_id}.png":
        return None, entry  # the analysis's reason why not
    path = data.run_dir / entry
    try:
        return path.read_bytes(), ""
    except OSError:
        return None, f"{entry} is missing: run `tribench stats {data.run_dir}`"
