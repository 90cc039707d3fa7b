"""``tribench sweep``: time kernels x workloads in fresh worker processes; write and analyse a run folder."""

from __future__ import annotations

import argparse
import dataclasses
import sys

from ..common import UserError
from ..workloads.spec import ACCELS, DTYPES
from . import flags
from .options import (
    DESIGN_FLAGS,
    add_builds,
    add_design_flags,
    add_kernel_files,
    add_no_progress,
    add_resume,
    add_run_out,
)

__all__ = ["add_parser", "run"]

DEFAULT_CAMERA = (64, 64)

#: The flags that make the workload grid (a sweep file has its own): metavar, type and help of each.
_WORKLOAD_FLAGS = {
    "hit_rates": ("H,..", flags.float_list(0, 1), "per-test hit rates of pair workloads, each in [0, 1] (default 0.5)"),
    "pairs": ("N", flags.positive_int, "pairs per pair workload (default 10000)"),
    "mesh": ("NAME,..", flags.name_list, "mesh workloads (suzanne, icosphere, ... or a file)"),
    "triangles": ("K,..", flags.int_list(1, flags.MAX_COUNT), "triangle counts of the meshes (default: base mesh)"),
    "camera": ("WxH", flags.camera, "camera rays of mesh workloads (default {}x{})".format(*DEFAULT_CAMERA)),
    "rays": (
        "FILE.npz,..",
        flags.name_list,
        "your own rays for the mesh workloads instead of the camera: .npz files of origins and directions, "
        "each (N, 3), and optionally t_max (N,) (docs/own-rays.md)",
    ),
    "accel": (
        "brute,bvh",
        flags.choice_list(ACCELS),
        "how kernels run the mesh workloads: every ray against every triangle (brute, the default) or "
        "through a BVH with the kernel as its leaf test (bvh: only the kernels of ext.bvh_kernel_names())",
    ),
    "max_leaf": (
        "N,..",
        flags.int_list(1, 1024),
        "the most triangles in a BVH leaf, one workload per value (with --accel bvh; default ext.DEFAULT_MAX_LEAF, 32)",
    ),
    "dtype": ("float32,float64", flags.choice_list(DTYPES), "precisions (default float64)"),
}
#: The flags that describe a new sweep: --resume takes none of them (the run's own sweep is used).
_NEW_SWEEP_FLAGS = ("file", "kernels", *_WORKLOAD_FLAGS, *DESIGN_FLAGS, "cpu", "out", "kernel_files", "builds")


def add_parser(sub) -> None:
    p = sub.add_parser(
        "sweep",
        help="time kernels x workloads in fresh worker processes; write a run folder",
        description="Time every kernel on every workload: replicates are fresh worker processes "
        "pinned to one CPU, rounds run every kernel once in a random order, every batch's checksum "
        "is checked. Workloads come from a TOML file (--file) or from the flags: pairs at each "
        "hit rate and precision, and with --mesh, camera rays (or --rays, your own) on each mesh, "
        "triangle count and precision. Results: RUN_DIR/batches.csv (one row per batch, appended as it finishes), "
        "processes.csv, run.json.",
    )
    add_run_out(p)
    add_resume(p, "the missing batches of an interrupted run")
    p.add_argument(
        "--file",
        metavar="SWEEP.toml",
        type=flags.existing_file,
        help="sweep file (flags given too override its values)",
    )
    p.add_argument(
        "--kernels", metavar="A,B", type=flags.name_list, help="kernels (default: all of `tribench info`, and yours)"
    )
    add_kernel_files(p)
    add_builds(p)
    for dest, (metavar, kind, text) in _WORKLOAD_FLAGS.items():
        p.add_argument(f"--{dest.replace('_', '-')}", metavar=metavar, type=kind, help=text)
    add_design_flags(p)
    p.add_argument("--cpu", type=flags.cpu, help="CPU to pin workers to (default: the last usable one)")
    add_no_progress(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ..harness import runfolder, runner

    if args.resume:
        if any(getattr(args, k) is not None for k in _NEW_SWEEP_FLAGS):
            raise UserError("--resume takes no other sweep options: the run's own sweep is used")
        result = runner.resume(args.resume, progress=args.progress)
    else:
        from ..harness import duration
        from ..harness.jobs.kernel_check import load_checked
        from ..harness.jobs.sweep import run_sweep

        load_checked(args.kernel_files or ())  # first: --kernels may name their kernels
        sweep = _sweep_from_args(args)
        out = args.out or runfolder.default_run_dir()

        def announce(sweep) -> str:
            builds = sweep.build_names
            per_build = f" ({len(builds)} builds in turn: {'; '.join(builds)})" if len(builds) > 1 else ""
            return (
                f"sweep: {len(sweep.kernels)} kernels x {len(sweep.workloads)} workloads, "
                f"{sweep.processes} processes{per_build} x {sweep.rounds} rounds (+{sweep.warmup} warm-up): "
                f"{sweep.n_batches} batches -> {out}\n{duration.estimate(sweep).line()}"
            )

        result = run_sweep(
            sweep,
            out,
            say=lambda line: print(line, file=sys.stderr),
            cpu=args.cpu,
            progress=args.progress,
            announce=announce,
        )
    print(
        f"{result.batches_run} batches run in {result.elapsed_s:.1f} s; "
        f"{result.batches_done}/{result.batches_total} in {result.run_dir}",
        file=sys.stderr,
    )
    if result.batches_done == result.batches_total:  # the robustness suite, then every table the report reads
        from ..harness.jobs.sweep import measure_robustness
        from ..reports import tables

        try:
            tables.write_all(result.run_dir, validate_note=measure_robustness(result.run_dir))
        except KeyboardInterrupt:
            raise runner.SweepInterrupted(
                f"interrupted after the sweep: every batch is saved in {result.run_dir}; "
                f"make its tables with: tribench stats {result.run_dir}"
            ) from None
        print(f"next: tribench report {result.run_dir}", file=sys.stderr)
    else:
        print(f"next: tribench stats {result.run_dir}", file=sys.stderr)
    return 0


def _workloads_from_flags(args: argparse.Namespace) -> list:
    """The workload grid of the sweep flags (see `tribench sweep --help`)."""
    from ..workloads.spec import MeshSpec, PairSpec

    dtypes = args.dtype or ["float64"]
    specs: list = []
    if not args.mesh or args.pairs is not None or args.hit_rates is not None:
        for h in args.hit_rates or [0.5]:
            specs += [PairSpec(n=10_000 if args.pairs is None else args.pairs, hit_rate=h, dtype=d) for d in dtypes]
    width, height = args.camera or DEFAULT_CAMERA
    for flag in ("accel", "rays", "max_leaf", "triangles", "camera"):
        if getattr(args, flag) and not args.mesh:
            raise UserError(f"--{flag.replace('_', '-')} applies to mesh workloads: give --mesh too")
    if args.max_leaf and "bvh" not in (args.accel or []):
        raise UserError("--max-leaf is the size of a BVH's leaves: give --accel bvh too")
    if args.rays and args.camera:
        raise UserError("--camera and --rays both give the rays of the mesh workloads: give one")
    for mesh in args.mesh or []:
        for triangles in args.triangles or [None]:
            for rays in args.rays or ["camera"]:
                w, h = (width, height) if rays in ("camera", "bounce") else (None, None)  # a file has its own rays
                for accel in args.accel or ["brute"]:
                    for leaf in (args.max_leaf or [None]) if accel == "bvh" else [None]:
                        specs += [
                            MeshSpec(mesh, triangles, rays, width=w, height=h, dtype=d, accel=accel, max_leaf=leaf)
                            for d in dtypes
                        ]
    return specs


def _sweep_from_args(args: argparse.Namespace):
    from .. import ext
    from ..harness.plan import Sweep
    from ..harness.sweep_file import load_sweep_file

    design = {k: getattr(args, k) for k in DESIGN_FLAGS}
    ignored = [f"--{k.replace('_', '-')}" for k in _WORKLOAD_FLAGS if getattr(args, k) is not None]
    if args.file and ignored:
        raise UserError(
            f"{', '.join(ignored)} describe workloads, which the sweep file gives: "
            f"put them in {args.file}'s [[workloads]] tables, or leave out --file"
        )
    if args.file:
        given = {"kernels": args.kernels, "kernel_files": args.kernel_files, "builds": args.builds}
        return load_sweep_file(args.file, {**design, **given})
    sweep = Sweep(
        tuple(args.kernels or ext.kernel_names()),
        tuple(_workloads_from_flags(args)),
        **{k: v for k, v in design.items() if v is not None},  # the rest: Sweep's defaults, which --help names
        kernel_files=tuple(args.kernel_files or ()),
        builds=tuple(args.builds or ()),
    )
    if args.kernels:  # named: each must run some workload (the one sweep path refuses one that runs none)
        return sweep
    idle = sweep.idle_kernels()  # every kernel: those that run these workloads
    return dataclasses.replace(sweep, kernels=tuple(k for k in sweep.kernels if k not in idle))
