"""``tribench run``: the main job (the default sweep, its statistics, peers, robustness suite, report)."""

from __future__ import annotations

import argparse

from ..common import UserError
from .options import add_builds, add_kernel_files, add_no_progress, add_resume, add_run_out

__all__ = ["add_parser", "run"]


def add_parser(sub) -> None:
    p = sub.add_parser(
        "run",
        help="the main job: the default sweep (about 5 minutes), its statistics and its HTML report",
        description="Runs the main job: the default sweep (tribench.harness.plan.default_sweep: every algorithm in "
        "its best form and the seed's two kernels, on pairs at per-test hit rates 0 to 1 in both precisions, on "
        "Suzanne brute force and on a 250,000-triangle Suzanne in a BVH), a sequential design within a 5-minute "
        "budget; then the peers when installed (peers.csv), the robustness suite (validate.csv) and the analysis "
        "step; prints the estimates and speedups and writes report.html.",
    )
    p.add_argument(
        "--quick",
        action="store_true",
        help="every kernel on fewer workloads with a 15 s sweep: about a minute (wide intervals)",
    )
    add_run_out(p, "runs/[quick-]<date-time>")
    add_resume(p, "an interrupted main job: the rest of its sweep, its peers, the robustness suite, the report")
    add_kernel_files(p)
    add_builds(p)
    add_no_progress(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ..harness.jobs import main as main_job
    from ..harness.runfolder import default_run_dir
    from ..reports import format_tables, load, tables, write_report

    if args.resume:
        if args.quick or args.out or args.kernel_files or args.builds:
            raise UserError(
                "--resume takes neither --quick, --out, --kernel-file nor --builds: the run's own job is finished "
                "in its folder"
            )
        out = args.resume
        note = main_job.resume(out, progress=args.progress)
    else:
        out = args.out or default_run_dir("quick" if args.quick else "")
        note = main_job.run(
            out,
            quick=args.quick,
            progress=args.progress,
            kernel_files=args.kernel_files or (),
            builds=args.builds or (),
        )
    tables.write_all(out, validate_note=note)
    data = load(out)  # the run folder's tables, read once for the page and the terminal
    report = write_report(data)
    print(f"report: {report}\n")
    print(format_tables(data))  # last: the report's answer in words
    return 0
