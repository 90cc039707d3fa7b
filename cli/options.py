"""Flags that several commands share, added with their help the same way everywhere."""

from __future__ import annotations

import argparse
import sys

from ..common import UserError
from ..harness.plan import DEFAULT_PROCESSES, DEFAULT_ROUNDS, DEFAULT_TARGET_MS, DEFAULT_WARMUP
from ..harness.plan import DESIGN as DESIGN_FLAGS  # the attributes add_design_flags sets on the parsed arguments
from . import flags

__all__ = [
    "add_builds",
    "add_rng_seed",
    "add_design_flags",
    "add_no_progress",
    "add_run_out",
    "DESIGN_FLAGS",
]


def _new_run_folder(text: str) -> str:
    """A run folder to create: writable, and new or empty (the runner's own check, run up front)."""
    from ..harness.runfolder import check_new_run_dir

    out = flags.output_folder(text)
    try:
        check_new_run_dir(out)
    except UserError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None
    return out


def usage(parser: argparse.ArgumentParser) -> int:
    """A command given without its subcommand: its help on stderr, exit status 2."""
    parser.print_help(sys.stderr)
    return 2


def add_no_progress(parser: argparse.ArgumentParser) -> None:
    """--no-progress, stored as the library's ``progress``: False, or None (a bar on a terminal, else plain lines)."""
    parser.add_argument(
        "--no-progress",
        dest="progress",
        action="store_const",
        const=False,
        default=None,
        help="no progress: neither the bar on a terminal nor the plain lines elsewhere "
        "(every $TRIBENCH_PROGRESS_SECONDS, default 10, and every tenth of the work)",
    )


def add_kernel_files(
    parser: argparse.ArgumentParser,
    what: str = "checked against the float64 reference, then known by the names it declares",
) -> None:
    """--kernel-file FILE.c, repeatable: kernels of the user's own; a command that times them checks them first
    (``load_checked``: exit 2, nothing timed, if one is refused)."""
    parser.add_argument(
        "--kernel-file",
        dest="kernel_files",
        action="append",
        metavar="FILE.c",
        type=flags.existing_file,
        help=f"a C file of your own kernels (docs/own-kernel.md; repeatable): compiled as the built-in ones, {what}",
    )


def add_builds(parser: argparse.ArgumentParser) -> None:
    """--builds "SPEC;SPEC": builds of the kernels to compare (docs/builds.md)."""
    parser.add_argument(
        "--builds",
        metavar='"CC FLAGS;.."',
        type=flags.builds,
        help="compare builds of the kernels: compilers and their flags, separated by ';' "
        "(\"gcc -O2;clang -O3 -march=native\"; 'installed' is pip's build, the default); "
        "each is compiled once and checked against the reference, and the processes take them in turn "
        "(docs/builds.md)",
    )


def add_rng_seed(
    parser: argparse.ArgumentParser | argparse._ArgumentGroup, what: str, default: int | None = None
) -> None:
    """--rng-seed N, stored as ``rng_seed``. --seed, its name before #52, still works but is not listed: "seed" is
    the 2022 paper now (``tribench seed``); both at once are refused (:class:`~.flags.Parser`)."""
    parser.add_argument("--rng-seed", type=flags.rng_seed, default=default, help=f"RNG seed of {what} (default 0)")
    parser.add_argument("--seed", dest="rng_seed", type=flags.rng_seed, default=default, help=argparse.SUPPRESS)


def add_resume(parser: argparse.ArgumentParser, what: str, metavar: str = "RUN_DIR") -> None:
    """--resume RUN_DIR: an existing folder whose interrupted ``what`` the command finishes."""
    parser.add_argument("--resume", metavar=metavar, type=flags.existing_folder, help=f"finish {what}")


def add_run_out(parser: argparse.ArgumentParser, default: str = "runs/<date-time>") -> None:
    """--out RUN_DIR of a command that creates a run folder (refused up front if it cannot be one)."""
    parser.add_argument("--out", metavar="RUN_DIR", type=_new_run_folder, help=f"new run folder (default {default})")


def add_design_flags(p: argparse.ArgumentParser) -> None:
    """The sweep design's flags (:data:`DESIGN_FLAGS`); None where not given."""
    for flag, kind, text, default in (
        ("--processes", flags.positive_int, "worker processes, the replicates", DEFAULT_PROCESSES),
        ("--rounds", flags.positive_int, "timed rounds per workload per process", DEFAULT_ROUNDS),
        ("--warmup", flags.int_in(0, flags.MAX_COUNT), "warm-up rounds per workload per process", DEFAULT_WARMUP),
        (
            "--target-ms",
            flags.float_in(0.01, 1000),
            "wanted length of one batch in ms, 0.01 to 1000",
            DEFAULT_TARGET_MS,
        ),
    ):
        p.add_argument(flag, type=kind, help=f"{text} (default {default:g})")
    add_rng_seed(p, "the plan and the layout randomisation")
