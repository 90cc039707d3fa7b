"""``tribench export``: a run's estimates and speedups with CIs and its machine, for other tools and for papers."""

from __future__ import annotations

import argparse
import sys

from ..common import write_text
from . import flags

__all__ = ["add_parser", "run"]


FORMATS = ("gbench", "bmf", "latex", "methods")


def add_parser(sub) -> None:
    p = sub.add_parser(
        "export",
        help="the run's estimates and speedups with CIs, as Google Benchmark JSON, Bencher's format, LaTeX tables "
        "or a methods paragraph",
        description="Reads a run folder's tables (as `tribench report` does: missing or stale ones are refused "
        "with the `tribench stats` command that makes them) and prints them in one of four forms. gbench "
        "(default): every estimate and speedup with its confidence interval, and the machine record, in Google "
        "Benchmark's JSON format (its tools/compare.py reads it; the analysis step writes the same file as "
        "RUN_DIR/google_benchmark.json). bmf: Bencher's Metric Format, each estimate and speedup with its "
        "interval as lower and upper values. latex: booktabs tables of the first screen's ranking, per precision "
        "and band, with intervals and verdicts, then the methods paragraph. methods: the machine, build, design, "
        "statistics and workloads as one Markdown paragraph, every number read from the run.",
    )
    p.add_argument("run_dir", metavar="RUN_DIR", type=flags.existing_folder)
    p.add_argument("--format", choices=FORMATS, default="gbench", help="what to write (default gbench)")
    p.add_argument("--out", metavar="FILE", type=flags.output_file, help="file to write (default: standard output)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Print (or write to ``--out``) the run's estimates and speedups in the form ``--format`` names."""
    from ..reports import paper
    from ..reports.rundata import load_run
    from ..reports.tables import export

    data = load_run(args.run_dir)
    if args.format == "gbench":
        margin = {"value": data.margin, "source": data.margin_source}
        text = export.dumps(export.google_benchmark(data.run, data.tables | data.every_build, data.baseline, margin))
    elif args.format == "bmf":
        text = export.dumps(paper.bencher(data))
    elif args.format == "latex":
        text = paper.latex_tables(data) + "\n" + paper.methods(data, latex=True)
    else:
        text = paper.methods(data)
    if args.out:
        write_text(args.out, text)
        print(f"wrote {args.out}", file=sys.stderr)
    else:
        sys.stdout.write(text)
    return 0
