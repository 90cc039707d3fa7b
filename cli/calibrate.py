"""``tribench calibrate``: an A/A calibration (a kernel against its copy) that sets the equivalence margin."""

from __future__ import annotations

import argparse
import sys

from . import flags
from .options import DESIGN_FLAGS, add_design_flags, add_no_progress, add_run_out

__all__ = ["add_parser", "run"]


def add_parser(sub) -> None:
    p = sub.add_parser(
        "calibrate",
        help="A/A calibration: a kernel against its identical copy; sets the equivalence margin",
        description="Times KERNEL against its copy compiled under another name, in EXPERIMENTS "
        "groups of PROCESSES processes; reports the coverage of 1, the A/A p-values and the noise "
        "floor, and saves the margin that later sweeps on this CPU use.",
    )
    p.add_argument("--kernel", default="moller_trumbore", help="kernel with an A/A copy (moller_trumbore)")
    p.add_argument("--workload", metavar="ID", help="cached workload id or prefix (default: 10000 pairs, hit rate 0.5)")
    p.add_argument("--experiments", type=flags.positive_int, help="number of A/A comparisons (default 10)")
    add_run_out(p, "runs/calibrate-<date-time>")
    p.add_argument("--no-save", action="store_true", help="do not update the user-level calibration")
    add_no_progress(p)
    add_design_flags(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ..harness.jobs.calibrate import calibrate, user_calibration_path
    from ..harness.runfolder import default_run_dir

    workloads: tuple = ()
    if args.workload:
        from ..workloads import cache

        workloads = (cache.load(cache.resolve_id(args.workload)).spec,)
    out = args.out or default_run_dir("calibrate")
    given = {k: getattr(args, k) for k in (*DESIGN_FLAGS, "experiments")}
    cal = calibrate(
        out,
        kernel=args.kernel,
        workloads=workloads,
        save=not args.no_save,
        progress=args.progress,
        **{k: v for k, v in given.items() if v is not None},
    )
    print(
        f"A/A: {cal['kernel']} vs {cal['copy']}, {cal['experiments']} comparisons of "
        f"{cal['processes_per_experiment']} processes each"
    )
    print(f"  coverage of 1          {100 * cal['coverage']:.0f}%  (intervals are 95%)")
    print(f"  false positives        {100 * cal['false_positive_rate']:.0f}%  (expected 5%)")
    print(f"  p-values vs uniform    KS {cal['ks_statistic']:.3f}, p = {cal['ks_p_value']:.3f}")
    print(f"  noise floor            {cal['noise_floor']:.4f} (log), margin {100 * cal['margin']:.2f}%")
    saved = "" if args.no_save else f" and {user_calibration_path()}"
    print(f"wrote {out}/calibration.json{saved}", file=sys.stderr)
    return 0
