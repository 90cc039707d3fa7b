"""docs/run-folder.md, made from the run folder's contract (:mod:`tribench.harness.runfolder`).

:func:`render`, a pure function, writes the page from the schema and the row dataclasses; only the sentence about
each file is written here. ``python -m tribench.harness.runfolder.doc [PATH]`` writes it, and tests/test_docs.py
fails when the page and :func:`render` differ."""

from __future__ import annotations

import sys
from dataclasses import fields

from ...common import write_text
from . import rows
from . import schema as rf

__all__ = ["COMMAND", "render"]

#: How to regenerate the page (run from the repository's root).
COMMAND = "python -m tribench.harness.runfolder.doc"

#: The row type of each measured CSV, whose fields give the column types.
_ROWS = {
    rf.BATCHES: rows.BatchRow,
    rf.PROCESSES: rows.ProcessRow,
    rf.CHECKS: rows.CheckRow,
    rf.TRAVERSALS: rows.TraversalRow,
    rf.PEERS: rows.PeerRow,
}

#: One sentence per file of a run folder: what it holds.
_ABOUT = {
    rf.RUN: "sweep, plan seeds, machine, build, versions, git revision, margin and throughput rates, written at the "
    "start (a sequential sweep rewrites it at its end: `n_batches` ran, of `n_batches_most` planned)",
    rf.LOCK: "held (`flock`) by the one process writing the folder; the kernel drops it if that process dies",
    rf.MESHES_DIR + "/": "a copy of each mesh file the sweep used (up to 32 MB), named by its SHA-256: the "
    "workloads rebuild on another machine, after the file moved or changed",
    rf.RAYS_DIR + "/": "a copy of each ray file (`--rays FILE.npz`) the sweep used (up to 32 MB), named by its "
    "SHA-256, for the same reason",
    rf.BATCHES: "one row per timed batch, appended and flushed as each batch finishes",
    rf.PROCESSES: "one row per FMA peak probe of a worker process, at its start and at its end",
    rf.CHECKS: "one row per kernel, workload and process: its answers against the float64 reference, before any batch",
    rf.TRAVERSALS: "per batch on a BVH workload, its traversal's counts and its null-leaf twin's time (else a header)",
    rf.STAGES: "a sequential sweep's stages (processes, open comparisons), each written before it runs; why it ended",
    rf.PEERS: "`tribench peers --out RUN_DIR` (and `tribench run`): rays/s of tribench, trimesh and Embree",
    rf.CALIBRATION: "an A/A calibration's record (`tribench calibrate --out RUN_DIR`)",
    rf.ESTIMATES: "ns per test per kernel and workload, with intervals and the fraction of the port model's bound",
    rf.SPEEDUPS: "every kernel against the baseline: ratio, simultaneous interval, p-values, verdict",
    rf.VALIDATE: "the robustness suite, every kernel at both precisions (measured after a sweep when it is missing)",
    rf.WORKLOADS: "each workload: kind, family, size, precision and achieved hit rates, and where the analysis got it",
    rf.WORKLOAD_FIGURES: "each workload's achieved figures beside its spec's targets",
    rf.CORRECTNESS: "each kernel's hits and sums of t per pass in its batches against the float64 reference",
    rf.PER_PROCESS: "each process's median ns per test, per kernel and workload",
    rf.BATCH_LABELS: "every batch with its ns per test and its outlier labels (kept, never dropped)",
    rf.CROSSOVERS: "the per-test hit rate where two kernels swap places, on a family of pair workloads",
    rf.SLOPES: "how ns per test grows with triangle count, on a family of mesh workloads",
    rf.DRIFT: "whether the machine drifted within processes enough to bias a speedup",
    rf.VARIANCE: "between-round and between-process variation (Kalibera & Jones)",
    rf.OUTLIERS: "Tukey outliers per kernel and workload",
    rf.WARMUP: "warm-up batches against the timed ones",
    rf.KERNELS: "per kernel and workload family: form, ISA, bytes per triangle, the spread of its times and speedups",
    rf.RANKING: "per workload, every kernel from the fastest down, each against the fastest with a paired interval",
    rf.ALGORITHMS: "per workload, every two algorithms, each in its fastest form, head to head",
    rf.BANDS: "per precision and hit-rate band, every kernel from the fastest down on its geometric mean over "
    "the band's workloads, with its speedup, bytes per triangle and robustness: the report's first table",
    rf.BVH: "per BVH workload and kernel: rays/s, the work per ray, the leaf tests' share of trace time, the "
    "speedup in the BVH beside the same in brute force (empty without a BVH workload)",
    rf.BUILDS: "a run of several builds (`--builds`): every order of two kernels per workload, tested under each "
    "build; whether it holds under every one (empty for one build)",
    rf.PEER_RATES: "rays/s of each contender of `peers.csv`, with intervals (only when the folder has `peers.csv`)",
    rf.PEER_RATIOS: "each contender over each other, paired by process (only when the folder has `peers.csv`)",
    rf.PICTURES_DIR + "/": "one PNG per workload (`<workload_id>.png`)",
    rf.GOOGLE_BENCHMARK: "estimates, speedups and the machine record as Google Benchmark JSON (docs/results.md)",
    rf.ANALYSIS: "written last: the SHA-256 of `batches.csv` and `peers.csv`, baseline, margin, tables, pictures",
    rf.REPORT: "the HTML report (`tribench report RUN_DIR`)",
    rf.FIGURES_DIR + "/": "the report's main charts as SVG and PDF, named by what they show, ready for a paper",
    rf.SWEEP_FILE: "the run's sweep as a file `tribench sweep --file` reads back (`tribench report`)",
    rf.REPLICATION: "`tribench replicate`: each conclusion of the original run beside the same measured here, "
    "with both intervals and a word: holds, reversed, now inconclusive, now decided or still inconclusive",
    rf.SEED: "`tribench seed`: per scene and kernel, one render's replayed time beside the paper's",
    rf.SEED_KINDS: "`tribench seed`: per scene, ray kind and kernel, ns per test and its share of the render",
    rf.SEED_WORKLOADS: "`tribench seed`: the sampled ray streams of each render, with their hit rates",
    rf.SEED_PICTURES: "`tribench seed`: the two seed kernels' renders and where their pixels differ",
}

_MEASURED = [
    rf.RUN,
    rf.BATCHES,
    rf.PROCESSES,
    rf.CHECKS,
    rf.TRAVERSALS,
    rf.STAGES,
    rf.PEERS,
    rf.LOCK,
    rf.MESHES_DIR + "/",
    rf.RAYS_DIR + "/",
]
_DERIVED = [*rf.DERIVED, rf.PICTURES_DIR + "/", rf.GOOGLE_BENCHMARK, rf.ANALYSIS]
_RENDERED = [rf.REPORT, rf.FIGURES_DIR + "/", rf.SWEEP_FILE]

_INTRO = f"""\
# The run folder

<!-- Generated from harness/runfolder/ (rows.py, schema.py) by `{COMMAND}`: edit the code, then regenerate. -->

A run folder (`runs/[KIND-]<date-time>` unless `--out` names one) is the only thing measuring hands to
reporting; `harness/runfolder/` names every file in it and every CSV's columns (`schema.py`; the measured
files' rows in `rows.py`), and this page is made from it. The sweep writes the measured files, and a study
may add `validate.csv` and `peers.csv`. The analysis step (`reports/tables/pipeline.py`, at the end of
`tribench run`, and `tribench stats RUN_DIR` on demand) derives every table from them and from the workloads
they name (from the cache, or rebuilt from the specs in `run.json`), never timing anything. `tribench report`
only reads: it never times a kernel, generates a workload or runs the robustness suite, so a folder copied to
another machine renders the same report. It refuses a folder whose tables are missing, in other columns, or
stale (made from another `batches.csv`, or against another baseline than asked), with one line naming
`tribench stats RUN_DIR`. `tribench peers --out RUN_DIR` on an analysed folder runs the analysis again.

Every CSV is tidy: one row per observation, snake_case names, raw units (nanoseconds, counts, fractions).
The columns below are in file order; tests hold every file a run writes to them exactly.
`python -c "from tribench.harness.runfolder import describe; print(describe('speedups.csv'))"` prints one
file's columns.
"""


def _cell(text: str) -> str:
    return text.replace("|", "\\|")


def _files(names: list[str]) -> list[str]:
    return ["| file | what it holds |", "|---|---|", *(f"| `{n}` | {_cell(_ABOUT[n])} |" for n in names), ""]


def _columns(name: str, columns: dict[str, str]) -> list[str]:
    """One CSV's section: its sentence, then its columns (with their types where a row dataclass gives them)."""
    typed = name in _ROWS
    types = {f.name: f" {f.type} |" for f in fields(_ROWS[name])} if typed else dict.fromkeys(columns, "")
    head = ["| column | type | meaning |", "|---|---|---|"] if typed else ["| column | meaning |", "|---|---|"]
    rows = [f"| `{c}` |{types[c]} {_cell(d)} |" for c, d in columns.items()]
    return [f"### `{name}`", "", _ABOUT[name][0].upper() + _ABOUT[name][1:] + ".", "", *head, *rows, ""]


def render() -> str:
    """The markdown of docs/run-folder.md.

    >>> page = render()
    >>> page.startswith("# The run folder") and "| `elapsed_ns` | int |" in page
    True
    """
    optional = ", ".join(f"`{n}`" for n in sorted(rf.OPTIONAL))
    lines = [_INTRO, "## Who writes what", "", "Measured, while the sweep runs (`peers.csv`: by the peers):", ""]
    lines += [*_files(_MEASURED), f"Also `{rf.CALIBRATION}`: {_ABOUT[rf.CALIBRATION]}.", ""]
    lines += ["Derived, by the analysis step, in this order:", "", *_files(_DERIVED)]
    lines += ["Rendered, by `tribench report`, which changes nothing above:", "", *_files(_RENDERED)]
    lines += ["Compared, by `tribench replicate` in the new run folder:", "", *_files([rf.REPLICATION])]
    lines += [f"Only sometimes there: {optional} (the peers need an installed peer; a replication has its table).", ""]
    sections = [
        ("The measured files' columns", [n for n in rf.FILES if n not in (*rf.DERIVED, rf.REPLICATION)], rf.FILES),
        ("The derived tables' columns", list(rf.DERIVED), rf.FILES),
        ("`tribench replicate`'s table", [rf.REPLICATION], rf.FILES),
        ("`tribench seed`'s tables, beside the files above", list(rf.SEED_FILES), rf.SEED_FILES),
    ]
    for title, names, schema in sections:
        lines += [f"## {title}", ""]
        for name in names:
            lines += _columns(name, schema[name])
    return "\n".join(lines).rstrip("\n") + "\n"


def main(argv: list[str]) -> int:
    write_text(path := argv[0] if argv else "docs/run-folder.md", render())
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
