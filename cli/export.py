"""``tribench export``: a run's estimates and speedups with CIs and its machine, as Google Benchmark JSON."""

from __future__ import annotations

import argparse
import sys

from ..common import write_text
from . import flags

__all__ = ["add_parser", "run"]


def add_parser(sub) -> None:
    p = sub.add_parser(
        "export",
        help="the run's estimates and speedups with CIs and the machine record, as Google Benchmark JSON",
        description="Reads a run folder's tables (as `tribench report` does: missing or stale ones are refused "
        "with the `tribench stats` command that makes them) and prints every estimate and speedup with its "
        "confidence interval, and the machine record, in Google Benchmark's JSON format (context + benchmarks; "
        "its tools/compare.py reads it). The analysis step writes the same file as RUN_DIR/google_benchmark.json.",
    )
    p.add_argument("run_dir", metavar="RUN_DIR", type=flags.existing_folder)
    p.add_argument("--out", metavar="FILE", type=flags.output_file, help="file to write (default: standard output)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Print (or write to ``--out``) the run's estimates and speedups in Google Benchmark's JSON format."""
    from ..reports.rundata import load_run
    from ..reports.tables import export

    data = load_run(args.run_dir)
    margin = {"value": data.margin, "source": data.margin_source}
    text = export.dumps(export.google_benchmark(data.run, data.tables, data.baseline, margin))
    if args.out:
        write_text(args.out, text)
        print(f"wrote {args.out}", file=sys.stderr)
    else:
        sys.stdout.write(text)
    return 0
