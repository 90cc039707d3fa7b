"""The run folder's contract: every file name, and every CSV's columns in file order with their meaning.

Written once here (the derived tables' in :mod:`.derived_columns`), importing nothing else, so every stage
reads it; docs/run-folder.md is made from it. Every CSV is tidy, in raw units (ns, counts, fractions); tests
check a run's files against these lists exactly, so a change here is a deliberate change of the format."""

from __future__ import annotations

from . import derived_columns as _derived
from .rows import BatchRow, CheckRow, PeerRow, ProcessRow, TraversalRow, column_docs
from .seed_files import SEED, SEED_FILES, SEED_KINDS, SEED_PICTURES, SEED_WORKLOADS

__all__ = [
    "ALGORITHMS",
    "ANALYSIS",
    "BANDS",
    "BATCHES",
    "BATCH_LABELS",
    "BVH",
    "BUILDS",
    "BY_BUILD",
    "part_columns",
    "CALIBRATION",
    "CHECKS",
    "MEASURED",
    "CORRECTNESS",
    "CROSSOVERS",
    "DERIVED",
    "DRIFT",
    "ESTIMATES",
    "FILES",
    "GOOGLE_BENCHMARK",
    "KERNELS",
    "LOCK",
    "OPTIONAL",
    "OUTLIERS",
    "PEERS",
    "PEER_RATES",
    "REPLICATION",
    "PEER_RATIOS",
    "PER_PROCESS",
    "PICTURES_DIR",
    "MESHES_DIR",
    "RAYS_DIR",
    "PROCESSES",
    "RANKING",
    "REPORT",
    "FIGURES_DIR",
    "RUN",
    "SEED",
    "SEED_KINDS",
    "SEED_PICTURES",
    "SEED_FILES",
    "SEED_WORKLOADS",
    "SLOPES",
    "SPEEDUPS",
    "STAGES",
    "SWEEP_FILE",
    "TRAVERSALS",
    "VALIDATE",
    "VARIANCE",
    "WARMUP",
    "WORKLOADS",
    "WORKLOAD_FIGURES",
    "describe",
]

# ------------------------------------------------------------------ names

#: Written once at the start of a sweep: sweep, plan seeds, machine, build, margin, and the
#: throughput probes' rates (key ``throughput``: tribench.harness.peak.throughput_record).
#: A sequential sweep writes it again when its stages end: ``n_batches`` becomes the
#: batches they ran, and ``n_batches_most`` keeps the most its plan held.
RUN = "run.json"
#: Held by the one process writing the folder.
LOCK = ".lock"
BATCHES = "batches.csv"
PROCESSES = "processes.csv"
CHECKS = "checks.csv"
#: Per batch on a BVH workload: the traversal's counts and the same traversal timed with a null leaf test.
TRAVERSALS = "traversals.csv"
PEERS = "peers.csv"
#: A sequential sweep's stages (tribench.harness.stages): per stage its processes and the
#: comparisons still open, recorded before it runs; ``end``: why the sweep stopped.
STAGES = "stages.json"
#: An A/A calibration's record (``tribench calibrate --out RUN_DIR``).
CALIBRATION = "calibration.json"

#: What the runner measured: a run folder's files no command may write over.
MEASURED = (RUN, LOCK, BATCHES, PROCESSES, CHECKS, TRAVERSALS, STAGES)

ESTIMATES = "estimates.csv"
SPEEDUPS = "speedups.csv"
VALIDATE = "validate.csv"
WORKLOADS = "workloads.csv"
WORKLOAD_FIGURES = "workload_figures.csv"
CORRECTNESS = "correctness.csv"
PER_PROCESS = "per_process.csv"
BATCH_LABELS = "batch_labels.csv"
CROSSOVERS = "crossovers.csv"
SLOPES = "slopes.csv"
DRIFT = "drift.csv"
VARIANCE = "variance.csv"
OUTLIERS = "outliers.csv"
WARMUP = "warmup.csv"
KERNELS = "kernels.csv"
RANKING = "ranking.csv"
ALGORITHMS = "algorithms.csv"
#: The answer the report opens on: per precision and hit-rate band, every kernel from the fastest down.
BANDS = "bands.csv"
BVH = "bvh.csv"
PEER_RATES = "peer_rates.csv"
#: ``tribench replicate``: each conclusion of the original run beside the same measured here.
REPLICATION = "replication.csv"
PEER_RATIOS = "peer_ratios.csv"
#: Across the builds of a ``--builds`` run: which order of two kernels holds under every build.
BUILDS = "builds.csv"
#: The estimates and speedups with their intervals and the machine record, in Google Benchmark's
#: JSON format (``context`` + ``benchmarks``; :mod:`tribench.reports.tables.export`), for tools that read it.
GOOGLE_BENCHMARK = "google_benchmark.json"
#: What the derived tables were made from (batches.csv's digest, baseline, margin, tables, pictures).
ANALYSIS = "analysis.json"
#: One PNG per workload (``<workload_id>.png``), drawn by the analysis step.
PICTURES_DIR = "pictures"
MESHES_DIR = "meshes"  # the copies of tribench.workloads.mesh_files (its RUN_FOLDER)
RAYS_DIR = "rays"  # the ray file copies of tribench.workloads.mesh_files (its RAYS_FOLDER)

REPORT = "report.html"
#: The report's main charts as SVG and PDF, for a paper (:func:`tribench.reports.charts.write_figures`).
FIGURES_DIR = "figures"
SWEEP_FILE = "sweep.toml"


# ---------------------------------------------------------------- columns
# The measured files' columns are the fields of their row dataclasses (:mod:`.rows`),
# the derived tables' are in :mod:`.derived_columns`.

#: Every CSV of a run folder: file name -> {column: meaning}, columns in file order.
FILES: dict[str, dict[str, str]] = {
    BATCHES: column_docs(BatchRow),
    PROCESSES: column_docs(ProcessRow),
    CHECKS: column_docs(CheckRow),
    TRAVERSALS: column_docs(TraversalRow),
    ESTIMATES: _derived.ESTIMATES_COLUMNS,
    SPEEDUPS: _derived.SPEEDUPS_COLUMNS,
    VALIDATE: _derived.VALIDATE_COLUMNS,
    PEERS: column_docs(PeerRow),
    WORKLOADS: _derived.WORKLOADS_COLUMNS,
    WORKLOAD_FIGURES: _derived.WORKLOAD_FIGURES_COLUMNS,
    CORRECTNESS: _derived.CORRECTNESS_COLUMNS,
    PER_PROCESS: _derived.PER_PROCESS_COLUMNS,
    BATCH_LABELS: _derived.BATCH_LABELS_COLUMNS,
    CROSSOVERS: _derived.CROSSOVERS_COLUMNS,
    SLOPES: _derived.SLOPES_COLUMNS,
    DRIFT: _derived.DRIFT_COLUMNS,
    VARIANCE: _derived.VARIANCE_COLUMNS,
    OUTLIERS: _derived.OUTLIERS_COLUMNS,
    WARMUP: _derived.WARMUP_COLUMNS,
    KERNELS: _derived.KERNELS_COLUMNS,
    RANKING: _derived.RANKING_COLUMNS,
    ALGORITHMS: _derived.ALGORITHMS_COLUMNS,
    BANDS: _derived.BANDS_COLUMNS,
    BVH: _derived.BVH_COLUMNS,
    PEER_RATES: _derived.PEER_RATES_COLUMNS,
    PEER_RATIOS: _derived.PEER_RATIOS_COLUMNS,
    BUILDS: _derived.BUILDS_COLUMNS,
    REPLICATION: _derived.REPLICATION_COLUMNS,
}
#: The derived tables made from the batches, one part per build: each starts with a ``build`` column,
#: and a build's rows are made from its own processes alone (the processes take the builds in turn).
BY_BUILD: frozenset[str] = frozenset(
    {ESTIMATES, SPEEDUPS, CORRECTNESS, PER_PROCESS, BATCH_LABELS, CROSSOVERS, SLOPES, DRIFT, VARIANCE}
    | {OUTLIERS, WARMUP, KERNELS, RANKING, ALGORITHMS, BANDS, BVH}
)
_BUILD = {"build": "the build of the kernels (a --builds spec, or installed): rows made from its processes"}
FILES.update({name: {**_BUILD, **FILES[name]} for name in BY_BUILD})


def part_columns(name: str) -> list[str]:
    """The columns of one build's part of a derived table: its file's, but a leading ``build``."""
    return [c for c in FILES[name] if not (name in BY_BUILD and c == "build")]


#: The tables the analysis step derives from the measured files, in the order it writes them
#: (``peer_rates.csv`` and ``peer_ratios.csv`` only when the folder has ``peers.csv``).
DERIVED: tuple[str, ...] = (
    ESTIMATES,
    SPEEDUPS,
    VALIDATE,
    WORKLOADS,
    WORKLOAD_FIGURES,
    CORRECTNESS,
    PER_PROCESS,
    BATCH_LABELS,
    CROSSOVERS,
    SLOPES,
    DRIFT,
    VARIANCE,
    OUTLIERS,
    WARMUP,
    KERNELS,
    RANKING,
    ALGORITHMS,
    BANDS,
    BVH,
    BUILDS,
    PEER_RATES,
    PEER_RATIOS,
)

#: Files a run folder has only sometimes (the peers need an installed peer; a replication has its table).
OPTIONAL = frozenset({PEERS, PEER_RATES, PEER_RATIOS, REPLICATION})


def describe(name: str) -> str:
    """The column documentation of one CSV as plain text.

    >>> print(describe("speedups.csv").splitlines()[0])
    speedups.csv
    >>> "elapsed_ns" in describe("batches.csv")
    True
    """
    columns = FILES[name] if name in FILES else SEED_FILES[name]
    width = max(len(c) for c in columns)
    return "\n".join([name] + [f"  {c:<{width}}  {d}" for c, d in columns.items()])
