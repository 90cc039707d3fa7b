"""``tribench info``: version, build flags, CPU and SIMD features, the kernel list; ``--peak`` their bounds."""

from __future__ import annotations

import argparse
import sys

from ..common import UserError
from .options import add_kernel_files

__all__ = ["add_parser", "run"]


def add_parser(sub) -> None:
    p = sub.add_parser("info", help="version, build flags, CPU and SIMD features, kernel list")
    p.add_argument(
        "--peak",
        action="store_true",
        help="also measure the FMA peak and each kernel's ns/test on the in-cache camera "
        "workload, as a fraction of its arithmetic bound (about 10 s)",
    )
    p.add_argument(
        "--isa",
        choices=("avx512", "avx2", "neon", "baseline"),
        help="with --peak: hold every native kernel to this instruction set and probe the pipes on it "
        "(default: the widest this CPU runs)",
    )
    add_kernel_files(
        p, "then listed with the others (with --peak, which times them: checked against the float64 reference first)"
    )
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from .. import ext
    from ..harness.jobs.kernel_check import load_checked
    from ..harness.machine import machine_record

    if args.isa and not args.peak:
        raise UserError("--isa chooses what --peak measures; add --peak")
    if args.peak:
        load_checked(args.kernel_files or ())  # --peak times them
        if args.isa and args.isa not in ext.probe_isas():
            raise UserError(f"--isa {args.isa}: this CPU runs only {', '.join(ext.probe_isas())}")
    for path in args.kernel_files or ():
        ext.load_kernels(path)
    rec = machine_record()
    build = rec["build"]
    print(f"tribench {rec['tribench']}" + (f" (git {rec['git_revision'][:12]})" if rec["git_revision"] else ""))
    print(f"python {rec['python']}, numpy {rec['numpy']}, {rec['platform']}")
    print()
    print(f"compiler  {build['compiler']}")
    print(f"flags     {build['flags']}")
    contract = "off" if "-ffp-contract=off" in build["flags"] else "compiler default (may fuse into FMA)"
    print(
        f"fp        fast-math {'ON' if build['fast_math'] else 'off'}, fp-contract {contract}; "
        f"clock resolution {build['clock_resolution_ns']} ns"
    )
    print()
    print(f"cpu       {rec['cpu_model']} ({rec['logical_cpus']} logical CPUs, {len(rec['usable_cpus'] or [])} usable)")
    print(f"simd      {' '.join(rec['simd_features']) or 'none reported'}")
    caches = ", ".join(f"{k} {v}" for k, v in rec["caches"].items())
    print(f"caches    {caches or 'unknown'}")
    print()
    width = max(map(len, ext.kernel_names())) + 2
    _print_kernels(ext, width)
    if args.peak:
        _print_peak(width, args.isa)
    return 0


def _print_kernels(ext, width: int) -> None:
    """The registry's declarations (ext/kernels/list.h): faces tested, watertight promise, the code's origin."""
    print(
        f"{'kernel':<{width}}{'form':<10}{'bytes/tri f32':>14}{'bytes/tri f64':>14}  {'faces':<6}{'watertight':<11}"
        f"{'code':<6} ISA (* = runs here, > = chosen)"
    )
    for name in ext.kernel_names():
        info = ext.kernel_info(name)
        form = "scalar" if info.lanes == 1 else f"{info.lanes}/block"  # triangles per record block, not vector lanes
        isas = (
            " ".join(("> " if i == info.isa else "* " if ok else "  ") + i for i, ok in info.isas.items())
            if info.lanes > 1
            else "baseline build"
        )
        faces = "front" if info.culls_back_faces else "both"
        watertight = "yes" if info.watertight != "none" else "-"
        code = "seed" if info.seed_replay else "file" if info.source != "built-in" else "clean"
        print(
            f"{name:<{width}}{form:<10}{info.bytes_per_triangle['float32']:>14}"
            f"{info.bytes_per_triangle['float64']:>14}  {faces:<6}{watertight:<11}{code:<6} {isas}"
        )


def _print_peak(width: int, isa: str | None) -> None:
    from ..harness.machine import cache_bytes
    from ..harness.peak import camera_fractions

    print(
        "\nmeasuring the FMA peak and every kernel on the in-cache camera workload "
        "(Suzanne 968 triangles, 64x64 rays, closest hit)...",
        file=sys.stderr,
    )
    gflops, peak_isa, rate_isa, rates, table = camera_fractions(isa=isa)
    held = "every native kernel held to it" if isa else "widest vector"
    print(f"\nthroughput probes ({rate_isa}, {held}), lane-ops per ns:")
    for dtype, r in rates.items():
        print(f"  {dtype:<8}" + "  ".join(f"{c} {v:.1f}" for c, v in r.items()))
    print(
        "bound = the port model over each kernel's operation mix (rules: tribench.harness.peak); % = bound / measured"
    )
    print(f"FMA peak {gflops:.1f} GFLOP/s ({peak_isa})")
    l1d = cache_bytes().get("L1d")
    for dtype, g in table.groupby("dtype", sort=False):
        print(
            f"\n{dtype:<{width}}{'form':<22}{'ops/test':>9}{'records':>10}{'bound ns':>10}{'ns/test':>10}"
            f"{'% of bound':>12}"
        )
        for r in g.itertuples(index=False):
            over = "*" if l1d and r.records_bytes > l1d else " "
            print(
                f"{r.kernel:<{width}}{r.form:<22}{r.ops_per_test:>9}{r.records_bytes / 1024:>6.0f} KiB{over}"
                f"{r.bound_ns_per_test:>9.3f}{r.ns_per_test:>10.3f}{100 * r.fraction:>11.1f}%"
            )
    if l1d:
        print(
            f"\n* records over this core's L1d ({l1d // 1024} KiB): every ray streams them from L2, which the "
            "port model does not count (docs/decisions.md, 'How near the bound')"
        )
