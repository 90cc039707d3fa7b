"""``tribench stats``: the analysis step, every table the report reads (never measures anything)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from ..harness.stats.defaults import MAX_MARGIN
from . import flags

__all__ = ["add_parser", "run"]


def add_parser(sub) -> None:
    p = sub.add_parser(
        "stats", help="every table the report reads: estimates.csv, speedups.csv and the rest (never times anything)"
    )
    p.add_argument("run_dir", metavar="RUN_DIR", type=flags.existing_folder)
    p.add_argument("--baseline", metavar="NAME", help="baseline kernel (default moller_seed, else the first)")
    p.add_argument(
        "--margin",
        type=flags.float_in(0, MAX_MARGIN),
        help=f"equivalence margin, in [0, {MAX_MARGIN:g}] (default: the one run.json records)",
    )
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ..harness import runfolder
    from ..harness.jobs.sweep import robustness_command
    from ..reports import format_tables, tables

    derived = tables.write_all(args.run_dir, baseline=args.baseline, margin=args.margin)
    if not (Path(args.run_dir) / runfolder.VALIDATE).is_file():
        print(
            f"no {runfolder.VALIDATE}: the robustness suite has not run on this folder, so its tables have no "
            f"robustness; measure it with: {robustness_command(args.run_dir)}",
            file=sys.stderr,
        )
    print(format_tables(args.run_dir))
    print(
        f"wrote {', '.join(derived.tables)}, google_benchmark.json, the workload pictures and analysis.json "
        f"into {args.run_dir}",
        file=sys.stderr,
    )
    return 0
