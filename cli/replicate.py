"""``tribench replicate``: a run's plan measured again here, and whether each of its conclusions holds."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from ..common import UserError
from . import flags
from .options import add_no_progress, add_resume, add_run_out

__all__ = ["add_parser", "run"]


def add_parser(sub) -> None:
    p = sub.add_parser(
        "replicate",
        help="measure a run's plan again on this machine; say which of its conclusions hold",
        description="Measures RUN_DIR's plan again into a new run folder: the same workloads (by spec and RNG "
        "seed, so the same ids; mesh, ray and kernel files from RUN_DIR's copies), the same kernels and design, "
        "and those of its builds whose compiler is here (what is left out is said). Then it analyses the new run "
        "against RUN_DIR's baseline and sets every conclusion of RUN_DIR (each kernel against the baseline, "
        "each order of two kernels per workload, each kernel's place in its band) beside the same measured "
        "here, both with their intervals: holds, reversed, now inconclusive, now decided or still inconclusive. "
        "Writes replication.csv and report.html (a Replication section) in the new folder.",
    )
    p.add_argument("run_dir", metavar="RUN_DIR", type=flags.existing_folder, help="an analysed run folder")
    add_run_out(p, "runs/replicate-<date-time>")
    add_resume(p, "an interrupted replication of RUN_DIR in NEW_DIR, then compare", "NEW_DIR")
    add_no_progress(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ..harness import runfolder, runner
    from ..harness.jobs import replicate
    from ..harness.jobs.sweep import measure_robustness
    from ..reports import load, tables, write_report
    from ..reports.replication import summary
    from ..reports.tables.replication import conclusions

    original = load(args.run_dir)  # first: a folder without its tables has no conclusions to replicate
    if args.resume:
        if args.out:
            raise UserError("--resume takes no --out: the replication is finished in its own folder")
        out = args.resume
        if (runfolder.read_run(out).replicates or {}).get("run_id") != original.run.run_id:
            raise UserError(f"{out} is no replication of {args.run_dir}")
        with runner.resumed_with(out, f"tribench replicate {args.run_dir} --resume {out}"):
            result = runner.resume(out, progress=args.progress)
    else:
        out = args.out or runfolder.default_run_dir("replicate")
        result = replicate.measure(
            args.run_dir, out, say=lambda line: print(line, file=sys.stderr), progress=args.progress
        )
    if result.batches_done != result.batches_total:
        print(f"next: tribench replicate {args.run_dir} --resume {out}", file=sys.stderr)
        return 1
    tables.write_all(out, baseline=original.baseline, validate_note=measure_robustness(out))
    new = load(out)  # read once, for the conclusions and the page
    table = conclusions(original, new)
    runfolder.write_csv(table, Path(out) / runfolder.REPLICATION)
    report = write_report(new)
    print(f"{summary(table)}\nreplication.csv and report: {report}")
    return 0
