"""The ``tribench`` command: one console script, one module per subcommand, heavy imports deferred.

Each subcommand module has ``add_parser(subparsers)`` and ``run(args)``, which imports what it needs when it runs,
so ``tribench --help`` stays fast. What each command does is docs/commands.md's."""

from __future__ import annotations

import argparse
import functools
import importlib
import os
import signal
import sys
import threading
import warnings

from ..common import Notice, UserError
from . import flags

#: The subcommands' modules, in the order of ``tribench --help``.
COMMANDS = (
    "info",
    "sweep",
    "stats",
    "calibrate",
    "run",
    "peers",
    "validate",
    "seed",
    "workloads",
    "cache",
    "report",
    "compare",
    "replicate",
    "export",
)


def build_parser() -> argparse.ArgumentParser:
    from ..harness.machine import version

    parser = flags.Parser(
        prog="tribench",
        description="Statistical benchmarking of ray-triangle intersection algorithms.",
    )
    parser.add_argument("--version", action="version", version=f"tribench {version()}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name in COMMANDS:
        importlib.import_module(f"{__package__}.{name}").add_parser(sub)
    return parser


def _ctrl_c(signum: int, frame) -> None:
    """SIGINT and SIGTERM (and their retry, SIGALRM): KeyboardInterrupt, but never inside an import or trimesh.

    SIGTERM (a stopped CI job) takes Ctrl-C's way out, so every batch is kept.
    trimesh catches BaseException in its imports and in its loaders (``trimesh.load`` turned a Ctrl-C during
    its ``os.path.isfile`` into "string is not a file"), so one that lands there is retried 50 ms later."""
    while frame is not None:
        module = frame.f_globals.get("__name__", "")
        if frame.f_code.co_filename.startswith("<frozen importlib") or module.partition(".")[0] == "trimesh":
            signal.setitimer(signal.ITIMER_REAL, 0.05)
            return
        frame = frame.f_back
    raise KeyboardInterrupt


def console() -> None:
    """The ``tribench`` command: :func:`main`, then exit with its status.

    A Ctrl-C while Python tears down its modules is ignored: the work is saved, and
    the signal would only turn a finished command into a signal death or a traceback."""
    sys.exit(main(leaving=True))


def main(argv: list[str] | None = None, *, leaving: bool = False) -> int:
    """Run one subcommand (:func:`_run_command`); ``leaving``: the process exits next, so a Ctrl-C is then ignored."""
    if threading.current_thread() is not threading.main_thread():
        return _run_command(argv)
    before = {sig: signal.signal(sig, _ctrl_c) for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGALRM)}
    try:
        with warnings.catch_warnings():
            shown = warnings.showwarning
            warnings.showwarning = functools.partial(_show_notice, shown, set())
            return _run_command(argv)
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        for sig, handler in before.items():
            signal.signal(sig, signal.SIG_IGN if leaving and sig != signal.SIGALRM else handler)


def _show_notice(shown, said: set[str], message, category, filename, lineno, file=None, line=None) -> None:
    """tribench's notices in one line, once a command; other warnings as Python shows them (they may be bugs)."""
    if issubclass(category, Notice):
        if str(message) not in said:
            said.add(str(message))
            print(f"tribench: {message}", file=sys.stderr)
    else:
        shown(message, category, filename, lineno, file, line)


def _run_command(argv: list[str] | None) -> int:
    """Run one subcommand; map its failures to exit codes, one line on stderr.

    2: a user error or an ``OSError`` (a missing file, a full disk); 1: a measurement failed; 130: interrupted,
    every finished batch kept. Any other exception is a bug in tribench and keeps its traceback."""
    prog = "tribench"
    try:
        args = build_parser().parse_args(argv)
        prog = f"tribench {args.command}"
        from ..harness.runner import SweepError, SweepInterrupted, progress_seconds
        from ..harness.worker import silence_floor_s

        if getattr(args, "progress", False) is not False:
            progress_seconds()  # a bad $TRIBENCH_PROGRESS_SECONDS fails first, like a bad flag
        silence_floor_s()  # and a bad $TRIBENCH_SILENCE_SECONDS
        try:
            return args.func(args)
        except SweepError as exc:
            print(f"{prog}: error: {exc}", file=sys.stderr)
            return 1
        except SweepInterrupted as exc:
            print(f"{prog}: {exc}", file=sys.stderr)
            return 130
    except KeyboardInterrupt:
        print(f"{prog}: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # `tribench info | head`: the reader left; say nothing more
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 1
    except UserError as exc:
        print(f"{prog}: error: {exc}", file=sys.stderr)
        return 2
    except OSError as exc:
        what = f"{exc.filename}: {exc.strerror}" if exc.filename and exc.strerror else str(exc)
        print(f"{prog}: error: {what}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    console()
