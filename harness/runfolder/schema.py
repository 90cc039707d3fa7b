"""The run folder's contract: every file name, and every CSV's columns in file order with their meaning.

Written once here (the measured files' columns are their row dataclasses' fields, :mod:`.rows`), so every
stage reads it; docs/run-folder.md is made from it. Every CSV is tidy, in raw units (ns, counts, fractions); tests
check a run's files against these lists exactly, so a change here is a deliberate change of the format."""

from __future__ import annotations

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

#: Every CSV of a run folder: file name -> {column: meaning}, columns in file order.
FILES: dict[str, dict[str, str]] = {
    BATCHES: column_docs(BatchRow),
    PROCESSES: column_docs(ProcessRow),
    CHECKS: column_docs(CheckRow),
    TRAVERSALS: column_docs(TraversalRow),
    ESTIMATES: {
        "kernel": "kernel name",
        "workload_id": "workload identifier",
        "ns_per_test": "ns per ray-triangle test: mean over processes of each process's median",
        "ns_per_test_ci_low": "lower end of the log-scale Student-t interval of ns_per_test (always positive)",
        "ns_per_test_ci_high": "upper end of the Student-t confidence interval of ns_per_test",
        "ns_per_test_bootstrap_low": "lower end of the BCa bootstrap interval over processes (cross-check), ns",
        "ns_per_test_bootstrap_high": "upper end of the BCa bootstrap interval over processes, ns",
        "ns_per_test_min": "smallest per-process median, ns (robust secondary figure)",
        "ns_per_test_sd": "standard deviation of the per-process medians, ns",
        "n_processes": "number of processes (replicates) behind the estimate",
        "confidence": "two-sided confidence level of both intervals (0.95)",
        "workload": "the workload's spec in one line",
        "peak_gflops": "mean measured FMA peak of the processes, GFLOP/s",
        "ops_per_test": "the kernel's arithmetic operations per test (documented in its header)",
        "bound_ns_per_test": (
            "the port model's bound, ns: the kernel's operations per test by class over the throughput "
            "rates run.json recorded at the widest vector width, FMA-capable (tribench.harness.peak); "
            "NaN for a run made before rates were recorded"
        ),
        "peak_fraction": "bound / measured time (1 = at the bound), each process against its own clock of that moment",
        "peak_fraction_ci_low": "lower end of its 95% confidence interval",
        "peak_fraction_ci_high": "upper end of its 95% confidence interval",
    },
    SPEEDUPS: {
        "workload_id": "workload identifier",
        "kernel": "kernel compared with the baseline",
        "baseline": "baseline kernel",
        "ratio": "speedup, time_baseline / time_kernel (above 1: the kernel is faster); unitless",
        "ratio_ci_low": "lower end of the simultaneous (Bonferroni) confidence interval of the ratio",
        "ratio_ci_high": "upper end of that interval",
        "p_value": "two-sided paired t-test of the per-process log ratios against 0",
        "p_holm": "Holm-adjusted p-value over the kernels compared on this workload",
        "n_processes": "number of paired processes",
        "confidence": "per-comparison confidence level actually used (Bonferroni-adjusted)",
        "margin": "relative equivalence margin of the verdict (0.01 = 1 %)",
        "verdict": "faster, slower, equivalent or inconclusive (stats.verdict)",
        "workload": "the workload's spec in one line",
        "margin_source": "where the margin came from (A/A calibration or default)",
    },
    VALIDATE: {
        "kernel": "kernel name, as registered in the C extension",
        "dtype": "precision of every array: float32 or float64",
        "isa": "instruction set the kernel ran with (scalar kernels: scalar)",
        "test": "robustness test (see tribench.harness.jobs.validate)",
        "rays": "rays asked (count, after dropping rays rounding made ambiguous)",
        "failures": "cracks, double hits, misses, wrong answers or hits, as the test defines (count)",
        "rate": "failures / rays (fraction)",
        "expected": "what the papers promise for this kernel, or 'measured'",
        "verdict": "pass or fail against the promise; 'measured' where there is none",
        "detail": "a short breakdown of the failures",
    },
    PEERS: column_docs(PeerRow),
    WORKLOADS: {
        "workload_id": "workload identifier",
        "kind": "pairs or mesh",
        "family": "the spec without its swept axis (hit rate of pairs, triangle count of meshes)",
        "label": "what varies inside the family, in words",
        "summary": "the spec's one-line summary",
        "dtype": "precision of the workload's arrays",
        "triangles": "triangles of the workload (count)",
        "rays": "rays of the workload (count)",
        "tests_per_pass": "ray-triangle tests of one pass (count)",
        "test_hit_rate": "achieved per-test hit rate: tests that hit / tests (fraction; empty where undefined)",
        "ray_hit_rate": "achieved per-ray hit rate: rays that hit any triangle / rays (fraction)",
        "source": "where the analysis got the workload: the cache, rebuilt from its spec, or why it could not",
    },
    WORKLOAD_FIGURES: {
        "workload_id": "workload identifier",
        "figure": "name of the figure (nested figures joined by dots), as Workload.compare gives it",
        "target": "the spec's target for it, as JSON text (null: not a target)",
        "achieved": "the figure the generated workload reached, as JSON text",
    },
    CORRECTNESS: {
        "kernel": "kernel name",
        "workload_id": "workload identifier",
        "batches": "batches of the kernel on the workload (count, warm-up included)",
        "ref_hits": "hits of one pass by the float64 reference (empty: workload not available to the analysis)",
        "hits_per_pass_min": "fewest hits per pass of a batch (hits / loops)",
        "hits_per_pass_max": "most hits per pass of a batch",
        "hit_difference": "largest |hits per pass - ref_hits| over the batches (count)",
        "ambiguous_rays": "rays near an edge (1e-5 barycentric, or 8 epsilons of rounding): "
        "a correct kernel may answer either way (count)",
        "t_sum_rel_diff": "largest relative difference of a batch's sum of t per pass from the reference's",
        "agrees": "True when hit_difference <= ambiguous_rays and every batch has the same hits per pass",
    },
    PER_PROCESS: {
        "kernel": "kernel name",
        "workload_id": "workload identifier",
        "process": "index of the worker process",
        "ns_per_test": "median ns per test of the process's timed batches (stats.per_process)",
        "n_rounds": "timed batches behind that median (count)",
    },
    BATCH_LABELS: {
        "process": "index of the worker process (with the next five columns, the key of a row of batches.csv)",
        "attempt": "worker attempt of this process index",
        "workload_id": "workload identifier",
        "kernel": "kernel name",
        "round": "round inside the process; negative for warm-up rounds",
        "position": "position of the kernel inside its round",
        "warmup": "True for a warm-up batch",
        "ns_per_test": "elapsed_ns / tests of the batch, ns",
        "outlier": "True beyond the Tukey fences (1.5 IQR) of its kernel, workload and process (kept, never dropped)",
        "far_out": "True beyond 3 IQR",
        "rel_to_median": "ns_per_test / its process's timed median for that kernel and workload",
        "t_in_process_s": "seconds since the process's first batch",
    },
    CROSSOVERS: {
        "family": "pair workload family (see workloads.csv)",
        "kernel_a": "first kernel",
        "kernel_b": "second kernel",
        "hit_rate": "per-test hit rate where log(time_b / time_a) crosses 0 (empty: no crossing in the range)",
        "ci_low": "lower end of its 95% confidence interval (fraction)",
        "ci_high": "upper end of that interval (fraction)",
        "slope": "change of log(time_b / time_a) per unit of per-test hit rate",
        "n": "processes paired across the family's workloads (count)",
        "confidence": "confidence level of the interval",
    },
    SLOPES: {
        "family": "mesh workload family (see workloads.csv)",
        "kernel": "kernel name",
        "slope": "log-log slope of ns per test against triangle count (0: cost per test independent of size)",
        "ci_low": "lower end of its 95% confidence interval",
        "ci_high": "upper end of that interval",
        "n": "processes paired across the triangle counts (count)",
        "sizes": "triangle counts in the family (count)",
    },
    DRIFT: {
        "workload_id": "workload identifier",
        "label": "the workload in words (see workloads.csv)",
        "kernel": "kernel compared with the baseline",
        "baseline_slope": "the baseline's log ns/test per second in the process (stats.drift)",
        "ratio_slope": "the log speedup's change per second in the process",
        "ratio_p": "p-value of ratio_slope against 0",
        "ratio_change": "the log speedup's move across one process",
        "confound_bias": "what unequal timing of the two kernels on a drifting machine adds to the log speedup",
        "confound_p": "p-value of confound_bias against 0",
        "flagged": "True when the drift may bias the ratio",
        "reason": "why it is flagged, or why the comparison could not be tested",
        "n": "processes behind the test (count)",
    },
    VARIANCE: {
        "workload_id": "workload identifier",
        "label": "the workload in words",
        "kernel": "kernel name",
        "mean_ns": "mean ns per test of the balanced processes x rounds matrix",
        "round_sd_pct": "between-round standard deviation inside a process, % of the mean (Kalibera-Jones)",
        "process_sd_pct": "between-process standard deviation, % of the mean",
        "n_processes": "processes of the matrix (count)",
        "n_rounds": "rounds of the matrix (count)",
    },
    OUTLIERS: {
        "workload_id": "workload identifier",
        "kernel": "kernel name",
        "batches": "timed batches (count)",
        "outliers": "of those, Tukey outliers (1.5 IQR, per process; count)",
        "far_out": "of those, beyond 3 IQR (count)",
        "worst_rel": "largest ns/test over its process median",
        "label": "the workload in words",
    },
    WARMUP: {
        "workload_id": "workload identifier",
        "kernel": "kernel name",
        "warmup_rel": "median of warm-up ns/test over its process's timed median (empty: no warm-up batch)",
        "warmup_batches": "warm-up batches (count)",
        "label": "the workload in words",
    },
    KERNELS: {
        "kernel": "kernel name",
        "form": "scalar, or N lanes for a wide kernel (? for a kernel this build lacks)",
        "isa": "instruction sets the kernel's batches ran with",
        "family": "workload family",
        "dtype": "precision of the family",
        "bytes_per_triangle": "bytes of prepared data per triangle at that precision (empty: unknown to this build)",
        "workloads": "workloads of the family the kernel ran on (count)",
        "ops_per_test": "the kernel's arithmetic operations per test",
        "peak_fraction_median": "median over the family's workloads of the fraction of the arithmetic bound",
        "ns_per_test_median": "median over the family's workloads of ns_per_test (estimates.csv)",
        "ns_per_test_min": "lowest of them, ns",
        "ns_per_test_max": "highest of them, ns",
        "ratio_median": "median of the speedups over the baseline on the family's workloads (empty: the baseline)",
        "ratio_min": "lowest of them",
        "ratio_max": "highest of them",
        "verdicts": "the family's workloads counted by verdict",
    },
    RANKING: {
        "workload_id": "workload identifier",
        "family": "workload family",
        "label": "what varies inside the family, in words",
        "dtype": "precision of the workload",
        "rank": "1 = the lowest ns_per_test on this workload, then in order",
        "kernel": "kernel name",
        "algorithm": "the clean scalar kernel whose algorithm the kernel is a form of (tribench.ext.kernel_info)",
        "ns_per_test": "ns per test (estimates.csv)",
        "ns_per_test_ci_low": "lower end of its 95% confidence interval",
        "ns_per_test_ci_high": "upper end of that interval",
        "vs_fastest": (
            "time_kernel / time_fastest, paired by process (1 for the fastest; above 1: slower than it); unitless"
        ),
        "vs_fastest_ci_low": (
            "lower end of its simultaneous confidence interval (Bonferroni over the workload's other kernels)"
        ),
        "vs_fastest_ci_high": "upper end of that interval",
        "tied_with_fastest": (
            "True when the interval reaches down to 1 + margin: the data cannot tell this kernel from the fastest"
        ),
        "speedup": "speedup over the baseline, time_baseline / time_kernel (speedups.csv; 1 for the baseline)",
        "speedup_ci_low": "lower end of its interval (speedups.csv)",
        "speedup_ci_high": "upper end of that interval",
        "baseline": "the baseline kernel",
        "watertight": "True when the kernel's paper promises no crack on shared edges (tribench validate holds it)",
        "culls_back_faces": "True when the kernel skips back faces (it answers a different question)",
        "bytes_per_triangle": "bytes of prepared data per triangle at that precision (empty: unknown to this build)",
        "form": "scalar, or N lanes for a wide kernel",
        "cracks_per_million": "validate.csv's shared_edges test at the workload's precision: rays at an exact shared "
        "edge hitting nothing, per million (empty: no validate.csv)",
        "shared_edge_rays": "the rays of that test",
        "sphere_misses_per_million": "validate.csv's inside_sphere test (Embree's) at the workload's precision: rays "
        "from inside a far-off closed sphere that hit nothing, per million (empty: no validate.csv)",
        "sphere_rays": "the rays of that test",
    },
    ALGORITHMS: {
        "workload_id": "workload identifier",
        "family": "workload family",
        "label": "what varies inside the family, in words",
        "dtype": "precision of the workload",
        "algorithm": "the faster algorithm of the pair (by point estimate): a clean scalar kernel's name",
        "kernel": "its fastest form on this workload (ranking.csv)",
        "other_algorithm": "the other algorithm of the pair",
        "other_kernel": "its fastest form on this workload",
        "ratio": "time_other_kernel / time_kernel, paired by process (above 1: algorithm is faster); unitless",
        "ratio_ci_low": "lower end of its simultaneous confidence interval (Bonferroni over the workload's pairs)",
        "ratio_ci_high": "upper end of that interval",
        "n_processes": "paired processes (count)",
        "confidence": "per-comparison confidence level actually used (Bonferroni-adjusted)",
        "verdict": "faster, equivalent or inconclusive (stats.verdict with the run's margin)",
    },
    BANDS: {
        "dtype": "precision of the band's workloads",
        "band": "the band: pairs by achieved per-test hit rate (low < 35% <= mid < 65% <= high), meshes by accel",
        "workloads": "workloads in the band (count)",
        "rank": "1 = the lowest ns_per_test in the band, then in order",
        "kernel": "kernel name (only kernels timed on every workload of the band)",
        "algorithm": "the clean scalar kernel whose algorithm the kernel is a form of (tribench.ext.kernel_info)",
        "form": "scalar, or N lanes for a wide kernel",
        "ns_per_test": (
            "per process the geometric mean over the band's workloads of its median ns per test, then the mean "
            "over processes"
        ),
        "ns_per_test_ci_low": "lower end of its 95% Student-t interval over processes, on the log scale",
        "ns_per_test_ci_high": "upper end of that interval",
        "vs_fastest": "time_kernel / time_fastest on those per-process values, paired (1 for the fastest); unitless",
        "vs_fastest_ci_low": "lower end of its simultaneous interval (Bonferroni over the band's other kernels)",
        "vs_fastest_ci_high": "upper end of that interval",
        "tied_with_fastest": "True when the interval reaches down to 1 + margin: not told apart from the fastest",
        "speedup": "time_baseline / time_kernel on the same per-process values, paired (1 for the baseline)",
        "speedup_ci_low": "lower end of its simultaneous interval (Bonferroni over the band's other kernels)",
        "speedup_ci_high": "upper end of that interval",
        "baseline": "the baseline kernel",
        "n_processes": "processes that ran every workload of the band with the kernel (count)",
        "watertight": "True when the kernel's paper promises no crack on shared edges (tribench.ext.kernel_info)",
        "culls_back_faces": "True when the kernel skips back faces (it answers a different question)",
        "bytes_per_triangle": "bytes of prepared data per triangle at that precision (empty: unknown to this build)",
        "promises_checked": "validate.csv's judged tests of the kernel at this precision "
        "(count; empty: no validate.csv)",
        "broken_promises": "of those, failed (count; empty: no validate.csv)",
        "cracks_per_million": "validate.csv's shared_edges test: rays at an exact shared edge hitting nothing, "
        "per million",
        "shared_edge_rays": "the rays of that test",
        "sphere_misses_per_million": "validate.csv's inside_sphere test (Embree's): rays from inside a far-off closed "
        "sphere that hit nothing, per million",
        "sphere_rays": "the rays of that test",
    },
    BVH: {
        "workload_id": "workload identifier (a BVH workload)",
        "family": "workload family",
        "label": "what varies inside the family, in words",
        "dtype": "precision of the workload",
        "rays_kind": "camera or hit_rate rays (the spec's rays)",
        "triangles": "triangles of the mesh (count)",
        "kernel": "kernel name (the BVH's leaf test)",
        "algorithm": "the clean scalar kernel whose algorithm the kernel is a form of (tribench.ext.kernel_info)",
        "rays_per_s": "rays per second end to end (traversal and leaf tests): geometric mean over processes of "
        "each process's median of loops x rays / elapsed",
        "rays_per_s_ci_low": "lower end of its 95% confidence interval (t interval of the logs)",
        "rays_per_s_ci_high": "upper end of that interval",
        "n_processes": "processes behind it (count)",
        "nodes_per_ray": "nodes entered per ray, inner nodes and leaves",
        "box_tests_per_ray": "ray-box tests per ray",
        "leaves_per_ray": "leaves entered per ray",
        "triangle_tests_per_ray": "triangle tests per ray",
        "null_nodes_per_ray": "nodes per ray of the null-leaf traversal the leaf share is measured against",
        "leaf_share": (
            "share of trace time in the leaf tests, 1 - null / real: per process the median over its batches of "
            "null_elapsed_ns / elapsed_ns, geometric mean over processes (traversals.csv)"
        ),
        "leaf_share_ci_low": "lower end of its 95% confidence interval (paired per-process ratios)",
        "leaf_share_ci_high": "upper end of that interval",
        "baseline": "the kernel the speedups are against on this workload (the run's baseline's BVH-capable form)",
        "speedup": "end-to-end speedup in the BVH: rays/s of the kernel / rays/s of the baseline, paired by process",
        "speedup_ci_low": "lower end of its simultaneous confidence interval (Bonferroni over the workload's kernels)",
        "speedup_ci_high": "upper end of that interval",
        "verdict": "faster, slower, equivalent or inconclusive (stats.verdict with the run's margin)",
        "brute_workload_id": "the brute-force twin (same rays and mesh, every ray against every triangle) "
        "if in the run",
        "brute_speedup": "the same kernel's speedup over the same baseline in brute force on the twin (ns per test)",
        "brute_speedup_ci_low": "lower end of its simultaneous confidence interval",
        "brute_speedup_ci_high": "upper end of that interval",
    },
    PEER_RATES: {
        "contender": "tribench, tribench_call, tribench_packets, a native Embree call (embree...), embreex or trimesh",
        "implementation": "what ran, with its version",
        "rays": "rays per call (count)",
        "rays_per_s": "geometric mean over processes of rays per second (each process's own geometric mean)",
        "ci_low": "lower end of its 95% t interval (log scale)",
        "ci_high": "upper end of that interval",
        "n_processes": "processes behind it (count)",
        "cpu_share": "median of process CPU time / wall time (1 on one core)",
        "setup_ms": "median one-off set-up, ms",
        "differ": "rays whose closest triangle differs from the float64 reference's (count)",
        "differ_ambiguous": "of those, ambiguous rays (near an edge: see `ambiguous_rays`) (count)",
    },
    PEER_RATIOS: {
        "contender": "the contender whose rays per second are divided",
        "over": "the contender it is divided by",
        "ratio": "rays/s of contender over rays/s of over, paired by process (>1: contender is faster)",
        "ci_low": "lower end of its 95% confidence interval",
        "ci_high": "upper end of that interval",
        "n_processes": "paired processes (count)",
    },
    BUILDS: {
        "workload_id": "workload identifier",
        "family": "the workload's family (pairs, a mesh's name...)",
        "label": "the workload's short label",
        "kernel": "the kernel of the pair faster under the first build (its estimate)",
        "other_kernel": "the other kernel of the pair",
        "build": "the build this row's ratio was measured under (its own processes)",
        "ratio": "time of other_kernel over time of kernel under this build, paired by process (>1: kernel is faster)",
        "ratio_ci_low": "lower end of its interval, simultaneous over the workload's pairs (Bonferroni)",
        "ratio_ci_high": "upper end of that interval",
        "verdict": "faster, slower, equivalent or undecided under this build (the build's own margin)",
        "order": "holds (kernel faster under every build), differs (faster under one, slower under another) "
        "or undecided",
        "confidence": "the simultaneous confidence level of the interval",
    },
    REPLICATION: {
        "conclusion": "against the baseline (speedups.csv), order of two (two kernels on a workload) "
        "or place in its band",
        "where": "the workload (family: label), or the band (precision, band)",
        "workload_id": "the workload's id (empty for a band)",
        "kernel": "the kernel the conclusion is about",
        "other_kernel": "the kernel it is measured against: the baseline, the other of the two, or the band's fastest",
        "original_ratio": "in the original run: the speedup, time_other / time_kernel, or time over the band's fastest",
        "original_ci_low": "lower end of its interval, as the original run's table gives it",
        "original_ci_high": "upper end of that interval",
        "original_verdict": "the original run's verdict (faster, slower, equivalent, fastest, behind the fastest, "
        "inconclusive)",
        "replicated_ratio": "the same ratio measured here",
        "replicated_ci_low": "lower end of its interval",
        "replicated_ci_high": "upper end of that interval",
        "replicated_verdict": "the verdict here",
        "word": "holds, reversed (another decided verdict), now inconclusive, now decided or still inconclusive",
    },
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
