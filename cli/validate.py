"""``tribench validate``: the robustness suite, per kernel and precision, as a table and a tidy CSV."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from ..workloads.spec import DTYPES
from . import flags
from .options import add_kernel_files, add_no_progress, add_rng_seed

__all__ = ["add_parser", "run"]


def _out(text: str) -> str:
    """validate --out: the CSV to write; a folder means FILE/validate.csv. A run folder's own validate.csv, the
    robustness suite measured with the run, is never written over: one missing or removed is measured anew."""
    from ..harness.runfolder import RUN, VALIDATE

    out = Path(flags.output_file(str(Path(text) / VALIDATE) if text.strip() and Path(text).is_dir() else text))
    if out.name == VALIDATE and (out.parent / RUN).is_file() and out.exists():
        raise argparse.ArgumentTypeError(
            f"{str(out)!r} is the robustness suite of the run in {str(out.parent)!r}: write elsewhere, "
            "or remove it first to measure it again"
        )
    return str(out)


def add_parser(sub) -> None:
    p = sub.add_parser(
        "validate",
        help="robustness suite: cracks at shared edges and vertices, Embree's sphere, extreme input, per kernel",
        description="Asks every kernel, at each precision, rays aimed exactly at shared edges and vertices of "
        "exactly coplanar meshes, rays from inside a finely tessellated sphere far from the origin (Embree's "
        "test), and pairs at scales 1e-8 to 1e8, tiny and needle triangles, grazing and parallel rays, "
        "degenerate triangles, NaN and Inf (see tribench.harness.jobs.validate). Prints one row per kernel and "
        "precision, one column per test, and writes the tidy CSV: kernel, dtype, isa, test, rays, failures, "
        "rate, expected, verdict, detail. Exits 0 even where a promise is broken.",
    )
    p.add_argument(
        "--kernels", nargs="+", metavar="K", type=flags.name_list, help="kernels (default: all of `tribench info`)"
    )
    p.add_argument(
        "--dtype", nargs="+", metavar="D", type=flags.choice_list(DTYPES), help="float32 and/or float64 (default both)"
    )
    p.add_argument(
        "--out", metavar="FILE.csv", type=_out, help="the CSV (default ./validate.csv; in a directory: validate.csv)"
    )
    p.add_argument("--quick", action="store_true", help="small sets, a few seconds (the tests' size)")
    add_rng_seed(p, "every test's rays", default=0)
    add_kernel_files(p, "then validated with the others")
    add_no_progress(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from .. import ext
    from ..harness.jobs import validate
    from ..harness.jobs.kernel_check import refuse_crashing
    from ..harness.runfolder import write_csv

    file_kernels: list[str] = []
    for path in args.kernel_files or ():  # what fails is this command's table; only a crash is refused first
        file_kernels += ext.load_kernels(path)
        refuse_crashing(path)
    # each --kernels/--dtype word may itself be a comma list
    kernels = [k for words in args.kernels for k in words] if args.kernels else None
    if kernels is not None and (missing := [k for k in dict.fromkeys(file_kernels) if k not in kernels]):
        print(f"the kernel files' {', '.join(missing)} join the kernels validated", file=sys.stderr)
        kernels += missing
    dtypes = [d for words in args.dtype for d in words] if args.dtype else validate.DTYPES
    df = validate.run(kernels, dtypes, quick=args.quick, rng_seed=args.rng_seed, progress=args.progress)
    out = Path(args.out or _out("validate.csv"))
    write_csv(df, out)
    print(validate.format_table(df))
    print(f"{len(df)} rows in {df.attrs['seconds']:.1f} s; wrote {out}", file=sys.stderr)
    return 0
