"""``tribench compare``: the same kernels on N runs (N machines), speedups with CIs, orders that hold on all."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from ..common import UserError, write_text
from . import flags

__all__ = ["add_parser", "run"]


def add_parser(sub) -> None:
    p = sub.add_parser(
        "compare",
        help="the same kernels on N runs (N machines): speedups with CIs, rankings that hold on every one",
        description="For N >= 2 runs with the same baseline (runs A, B, C... in the order given): per workload "
        "in every run, a machine x kernel table of speedups over the baseline with each run's confidence "
        "intervals, and which orders of two kernels hold on every machine (significant and the same in every "
        "run). For two runs, also the ratio of their speedups with a Welch interval (the runs are independent) "
        "and each kernel's time ratio. Prints the tables and writes an HTML page (default LAST_RUN/compare.html).",
    )
    p.add_argument("runs", metavar="RUN", nargs="+", type=flags.existing_folder, help="run folders, 2 to 26")
    p.add_argument(
        "--out", metavar="FILE", type=flags.output_file, help="HTML file to write (default LAST_RUN/compare.html)"
    )
    p.add_argument(
        "--fail-if-slower",
        action="store_true",
        help="for a CI gate, with two runs OLD NEW: exit 1 when a kernel is slower in NEW on a shared workload "
        "by more than the runs' margin, with an interval that excludes no change (one line names each)",
    )
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Print the comparison of N runs and write it as an HTML page."""
    from ..reports.compare import format_compare_text, render_compare
    from ..reports.rundata import load_run
    from ..reports.tables.compare import compare, run_tags, slower

    if args.fail_if_slower and len(args.runs) != 2:
        raise UserError(f"--fail-if-slower compares two runs, OLD NEW; got {len(args.runs)}")
    try:
        run_tags(len(args.runs))  # the count first, before reading any folder
        runs = [load_run(r) for r in args.runs]
    except FileNotFoundError as exc:
        raise UserError(str(exc)) from None
    many, pair = compare(runs)
    out = Path(args.out) if args.out else runs[-1].run_dir / "compare.html"
    print(format_compare_text(runs, many, pair))
    write_text(out, render_compare(runs, many, pair))
    print(f"wrote {out}", file=sys.stderr)
    if args.fail_if_slower and pair is not None:
        regressed = slower(pair)
        for r in regressed.itertuples(index=False):
            print(
                f"slower in {args.runs[1]}: {r.kernel} on {r.family}, {r.label}, takes {r.ratio:.3f}x the time "
                f"[{r.ratio_ci_low:.3f}, {r.ratio_ci_high:.3f}], past the margin of {pair.margin:.1%}",
                file=sys.stderr,
            )
        return 1 if len(regressed) else 0
    return 0
