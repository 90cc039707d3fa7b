"""``tribench seed``: replay the seed paper's renders through the harness, beside the paper's table."""

from __future__ import annotations

import argparse
import shlex

from . import flags
from .options import add_no_progress, add_run_out

__all__ = ["add_parser", "run"]


def add_parser(sub) -> None:
    p = sub.add_parser(
        "seed",
        help="replay the seed's renders (scene02, scene03) through the harness, beside the paper's table",
        description="Traces each scene as the seed's ray tracer does, times the kernels on a sample of each "
        "kind of ray (primary, reflected, shadow) in fresh worker processes, scales to one render's "
        "time with 95% CIs, and sets it beside the paper's Unix times. Writes the run folder, "
        "seed.csv (the table), seed_kinds.csv, seed_workloads.csv (per-test hit rate, miss-stage mix), "
        "both seed kernels' pictures with their difference mask, and seed.html.",
    )
    p.add_argument(
        "--scene",
        action="append",
        metavar="FILE",
        type=flags.existing_file,
        help="a scene file in the seed's format, instead of scene02 and scene03 (repeatable)",
    )
    p.add_argument("--quick", action="store_true", help="the same shape in under a minute (128x128, wide intervals)")
    p.add_argument(
        "--all-kernels",
        action="store_true",
        help="time every kernel (the whole zoo: about twice as long), not only the seed's two, their clean "
        "scalar forms and the native form of every algorithm that tests both faces",
    )
    add_run_out(p, "runs/seed-[quick-]<date-time>")
    add_no_progress(p)
    p.add_argument("--size", type=flags.positive_int, help=argparse.SUPPRESS)  # image side, for tests
    p.add_argument("--sample", type=flags.positive_int, help=argparse.SUPPRESS)  # rays sampled per kind, for tests
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ..harness.jobs.seed import KINDS_CSV, SEED_CSV, WORKLOADS_CSV, run_seed
    from ..harness.runfolder import default_run_dir
    from ..reports.seed import format_table, write_seed_report
    from ..reports.tables.seed import write_seed_tables

    out = args.out or default_run_dir("seed-quick" if args.quick else "seed")
    words = [
        "tribench",
        "seed",
        *[w for s in args.scene or [] for w in ("--scene", s)],
        *(["--quick"] if args.quick else []),
        *(["--all-kernels"] if args.all_kernels else []),
        "--out",
        out,
        *[w for k in ("size", "sample") if getattr(args, k) for w in (f"--{k}", str(getattr(args, k)))],
    ]
    elapsed = run_seed(
        out,
        scenes=args.scene,
        quick=args.quick,
        size=args.size,
        sample=args.sample,
        all_kernels=args.all_kernels,
        progress=args.progress,
        command=shlex.join(words),
    )
    tables = write_seed_tables(out)
    report = write_seed_report(out)
    print(format_table(tables[SEED_CSV], tables[WORKLOADS_CSV]))
    print(f"\n{elapsed:.0f} s; tables: {out}/{SEED_CSV}, {KINDS_CSV}, {WORKLOADS_CSV}; report: {report}")
    return 0
