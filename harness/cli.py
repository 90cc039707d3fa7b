"""The ``tribench`` command: one console script, subcommands, heavy imports deferred.

Each subcommand's handler imports what it needs when it runs, so
``tribench --help`` stays fast. Handlers return an exit code; a user error
prints one line to stderr and exits 2, without a traceback.
"""

from __future__ import annotations

import argparse
import sys


def _info(args: argparse.Namespace) -> int:
    from tribench import ext

    from .machine import machine_record

    rec = machine_record()
    build = rec["build"]
    print(f"tribench {rec['tribench']}" + (f" (git {rec['git_revision'][:12]})" if rec["git_revision"] else ""))
    print(f"python {rec['python']}, numpy {rec['numpy']}, {rec['platform']}")
    print()
    print(f"compiler  {build['compiler']}")
    print(f"flags     {build['flags']}")
    contract = "off" if "-ffp-contract=off" in build["flags"] else "compiler default (may fuse into FMA)"
    print(f"fp        fast-math {'ON' if build['fast_math'] else 'off'}, fp-contract {contract}; "
          f"clock resolution {build['clock_resolution_ns']} ns")
    print()
    print(f"cpu       {rec['cpu_model']} ({rec['logical_cpus']} logical CPUs, "
          f"{len(rec['usable_cpus'] or [])} usable)")
    print(f"simd      {' '.join(rec['simd_features']) or 'none reported'}")
    caches = ", ".join(f"{k} {v}" for k, v in rec["caches"].items())
    print(f"caches    {caches or 'unknown'}")
    print()
    print(f"{'kernel':<18}{'bytes/tri f32':>14}{'bytes/tri f64':>14}")
    for name in ext.kernel_names():
        print(f"{name:<18}{ext.bytes_per_triangle(name, 'float32'):>14}"
              f"{ext.bytes_per_triangle(name, 'float64'):>14}")
    return 0


def build_parser() -> argparse.ArgumentParser:
    from .machine import version

    parser = argparse.ArgumentParser(
        prog="tribench",
        description="Statistical benchmarking of ray-triangle intersection algorithms.",
    )
    parser.add_argument("--version", action="version", version=f"tribench {version()}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    info = sub.add_parser("info", help="version, build flags, CPU and SIMD features, kernel list")
    info.set_defaults(func=_info)
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except (ValueError, TypeError, FileNotFoundError) as exc:
        print(f"tribench {args.command}: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
