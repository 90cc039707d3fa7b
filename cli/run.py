"""``tribench run``: the main job (the default sweep, its statistics, peers, robustness suite, report)."""

from __future__ import annotations

import argparse

from .options import add_no_progress, add_run_out, default_run_dir

__all__ = ["add_parser", "run"]


def add_parser(sub) -> None:
    p = sub.add_parser(
        "run",
        help="the main job: the default sweep (about 5 minutes), its statistics and its HTML report",
        description="Runs the default sweep (tribench.harness.plan.default_sweep: the seed's two kernels "
        "and the clean Moller-Trumbore over per-test hit rates 0..1 and Suzanne at three triangle "
        "counts), writes estimates.csv and speedups.csv, prints them, runs the robustness suite "
        "(validate.csv) and, when a peer is installed, tribench peers (peers.csv, about 40 s), and "
        "writes report.html.",
    )
    p.add_argument("--quick", action="store_true", help="the same shape in under a minute (wide intervals)")
    add_run_out(p, "runs/[quick-]<date-time>")
    add_no_progress(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from tribench.reports import format_tables, write_report
    from tribench.studies.main import run as main_job

    out = args.out or default_run_dir("quick" if args.quick else "")
    main_job(out, quick=args.quick, progress=args.progress)
    report = write_report(out)
    print(format_tables(out))
    print(f"\nreport: {report}")
    return 0
