"""``tribench report``, ``tribench compare`` and ``tribench export``: subcommands for the harness's CLI.

:func:`add_parser` adds them to the ``tribench`` sub-parsers. Handlers import
the heavy modules when they run, return an exit code, and turn a user error
into one line on stderr and exit code 2.
"""

from __future__ import annotations

import argparse
import sys

from tribench.common import UserError, write_text

from . import flags

__all__ = ["add_parser", "report_main", "compare_main", "export_main"]


def _error(command: str, exc: BaseException) -> int:
    print(f"tribench {command}: error: {exc}", file=sys.stderr)
    return 2


def report_main(args: argparse.Namespace) -> int:
    """Write RUN_DIR/report.html, print the compact tables, optionally open the page."""
    from tribench.reports import format_tables, write_report

    try:
        path = write_report(args.run_dir, baseline=args.baseline)
        if not args.quiet:
            print(format_tables(args.run_dir))
    except (UserError, FileNotFoundError) as exc:
        return _error("report", exc)
    print(f"wrote {path}", file=sys.stderr)
    if args.open:
        import webbrowser

        webbrowser.open(path.resolve().as_uri())
    return 0


def compare_main(args: argparse.Namespace) -> int:
    """Print the comparison of N runs and write it as an HTML page."""
    from tribench.reports.compare import compare, format_compare_text, render_compare, run_tags
    from tribench.reports.rundata import load_run

    try:
        run_tags(len(args.runs))  # the count first, before reading any folder
        runs = [load_run(r) for r in args.runs]
        many, pair = compare(runs)
    except (UserError, FileNotFoundError) as exc:
        return _error("compare", exc)
    from pathlib import Path

    out = Path(args.out) if args.out else runs[-1].run_dir / "compare.html"
    print(format_compare_text(runs, many, pair))
    try:
        write_text(out, render_compare(runs, many, pair))
    except UserError as exc:
        return _error("compare", exc)
    print(f"wrote {out}", file=sys.stderr)
    return 0


def export_main(args: argparse.Namespace) -> int:
    """Print (or write to ``--out``) the run's estimates and speedups in Google Benchmark's JSON format."""
    from tribench.harness import export
    from tribench.reports.rundata import load_run

    try:
        data = load_run(args.run_dir)
        margin = {"value": data.margin, "source": data.margin_source}
        text = export.dumps(export.google_benchmark(data.run, data.tables, data.baseline, margin))
        if args.out:
            write_text(args.out, text)
    except UserError as exc:
        return _error("export", exc)
    if args.out:
        print(f"wrote {args.out}", file=sys.stderr)
    else:
        sys.stdout.write(text)
    return 0


def add_parser(subparsers) -> None:
    """Add ``report`` and ``compare`` to the ``tribench`` sub-parsers."""
    rep = subparsers.add_parser(
        "report",
        help="write RUN_DIR/report.html: speedups, curves, diagnostics, workloads (never re-measures)",
        description="Reads a run folder (run.json, batches.csv and the tables `tribench stats` made from them) "
        "and writes one self-contained HTML page that opens offline, plus sweep.toml to run the sweep again. "
        "Prints the estimates and speedups. It only reads: missing or stale tables are refused with the "
        "`tribench stats` command that makes them.",
    )
    rep.add_argument("run_dir", metavar="RUN_DIR", type=flags.existing_folder)
    rep.add_argument(
        "--baseline",
        metavar="NAME",
        help="the baseline the tables must compare against (refused, naming `tribench stats "
        "--baseline NAME`, if they compare against another)",
    )
    rep.add_argument("--open", action="store_true", help="open the report in a web browser")
    rep.add_argument("--quiet", action="store_true", help="do not print the tables")
    rep.set_defaults(func=report_main)

    cmp_ = subparsers.add_parser(
        "compare",
        help="the same kernels on N runs (N machines): speedups with CIs, rankings that hold on every one",
        description="For N >= 2 runs with the same baseline (runs A, B, C... in the order given): per workload "
        "in every run, a machine x kernel table of speedups over the baseline with each run's confidence "
        "intervals, and which orders of two kernels hold on every machine (significant and the same in every "
        "run). For two runs, also the ratio of their speedups with a Welch interval (the runs are independent) "
        "and each kernel's time ratio. Prints the tables and writes an HTML page (default LAST_RUN/compare.html).",
    )
    cmp_.add_argument("runs", metavar="RUN", nargs="+", type=flags.existing_folder, help="run folders, 2 to 26")
    cmp_.add_argument(
        "--out", metavar="FILE", type=flags.output_file, help="HTML file to write (default LAST_RUN/compare.html)"
    )
    cmp_.set_defaults(func=compare_main)

    exp = subparsers.add_parser(
        "export",
        help="the run's estimates and speedups with CIs and the machine record, as Google Benchmark JSON",
        description="Reads a run folder's tables (as `tribench report` does: missing or stale ones are refused "
        "with the `tribench stats` command that makes them) and prints every estimate and speedup with its "
        "confidence interval, and the machine record, in Google Benchmark's JSON format (context + benchmarks; "
        "its tools/compare.py reads it). The analysis step writes the same file as RUN_DIR/google_benchmark.json.",
    )
    exp.add_argument("run_dir", metavar="RUN_DIR", type=flags.existing_folder)
    exp.add_argument("--out", metavar="FILE", type=flags.output_file, help="file to write (default: standard output)")
    exp.set_defaults(func=export_main)


def main(argv: list[str] | None = None) -> int:
    """Stand-alone entry (``python -m tribench.cli.reports``): the same as ``tribench report``/``compare``."""
    parser = flags.Parser(prog="tribench")
    add_parser(parser.add_subparsers(dest="command", required=True, metavar="COMMAND"))
    args = parser.parse_args(argv)
    return args.func(args)


if __name__ == "__main__":
    sys.exit(main())
