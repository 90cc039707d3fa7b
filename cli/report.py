"""``tribench report``: write RUN_DIR/report.html from a run folder's tables (never re-measures)."""

from __future__ import annotations

import argparse
import sys

from ..common import UserError
from . import flags

__all__ = ["add_parser", "run"]


def add_parser(sub) -> None:
    p = sub.add_parser(
        "report",
        help="write RUN_DIR/report.html: speedups, curves, diagnostics, workloads (never re-measures)",
        description="Reads a run folder (run.json, batches.csv and the tables `tribench stats` made from them) "
        "and writes one self-contained HTML page that opens offline, plus sweep.toml to run the sweep again. "
        "Prints the estimates and speedups. It only reads: missing or stale tables are refused with the "
        "`tribench stats` command that makes them.",
    )
    p.add_argument("run_dir", metavar="RUN_DIR", type=flags.existing_folder)
    p.add_argument(
        "--baseline",
        metavar="NAME",
        help="the baseline the tables must compare against (refused, naming `tribench stats "
        "--baseline NAME`, if they compare against another)",
    )
    p.add_argument("--open", action="store_true", help="open the report in a web browser")
    p.add_argument("--quiet", action="store_true", help="do not print the tables")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Write RUN_DIR/report.html, print the compact tables, optionally open the page."""
    from ..reports import format_tables, load, write_report

    try:
        data = load(args.run_dir, baseline=args.baseline)  # read once for the page and the terminal
        path = write_report(data)
        if not args.quiet:
            print(format_tables(data))
    except FileNotFoundError as exc:
        raise UserError(str(exc)) from None
    print(f"wrote {path}", file=sys.stderr)
    if args.open:
        import webbrowser

        webbrowser.open(path.resolve().as_uri())
    return 0
