"""``tribench peers``: rays/s of tribench's fastest kernel against trimesh and Embree, as ratios with CIs."""

from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from pathlib import Path

from ..common import UserError
from . import flags
from .options import add_no_progress, add_rng_seed

__all__ = ["add_parser", "run"]


def _out(text: str) -> str:
    """peers --out: a .csv names the file, anything else a folder (as peers.peers_path reads it)."""
    return flags.output_file(text) if Path(text).suffix.lower() == ".csv" else flags.output_folder(text)


def add_parser(sub) -> None:
    from ..harness.jobs.peers import PeerDesign
    from ..workloads.spec import ACCELS

    p = sub.add_parser(
        "peers",
        help="rays/s of tribench's fastest kernel against native Embree and trimesh on the seed's camera, with CIs",
        description="Times tribench's fastest closest-mode kernel (chosen on a sample of the rays), trimesh's "
        "intersector, native Embree (its C API: rtcIntersect1 and rtcIntersect16, plain and robust) and Embree "
        "through embreex on Suzanne (or --mesh) through a pinhole camera (512x512, float32, "
        "closest hit): fresh worker processes pinned to one CPU with one BLAS thread, every contender once per "
        "repetition in a random order. Prints rays/s with 95% CIs and tribench's ratios over each peer, "
        "paired by process, and writes peers.csv (into a run folder, the report shows it). Needs "
        "pip install 'tribench[peers]' (embreex, and rtree for trimesh's intersector); native Embree needs "
        "apt-get install libembree-dev. About 40 s.",
    )
    full, quick = PeerDesign(), PeerDesign.quick()
    p.add_argument("--out", metavar="RUN_DIR|FILE.csv", type=_out, help="where peers.csv goes (default ./peers.csv)")
    p.add_argument(
        "--quick",
        action="store_true",
        help=f"a {quick.width}x{quick.height} camera, {quick.processes} processes x {quick.reps} repetitions (seconds)",
    )
    p.add_argument(
        "--camera", metavar="WxH", type=flags.camera, help=f"camera rays (default {full.width}x{full.height})"
    )
    p.add_argument(
        "--mesh",
        metavar="NAME|FILE",
        help="the mesh: suzanne (default), another built-in mesh, or any mesh file trimesh reads (OBJ, PLY, STL, ...)",
    )
    p.add_argument(
        "--triangles",
        type=flags.positive_int,
        help=f"the mesh's triangle count (default: {full.triangles} for Suzanne, the seed's mesh; "
        "any other mesh keeps its own)",
    )
    p.add_argument(
        "--processes",
        type=flags.int_in(2, flags.MAX_COUNT),
        help=f"worker processes, the replicates: two at least, for an interval (default {full.processes})",
    )
    p.add_argument("--reps", type=flags.positive_int, help=f"repetitions per process (default {full.reps})")
    p.add_argument(
        "--accel",
        choices=ACCELS,
        help="tribench's rays brute force (default) or through its BVH with the fastest kernel that can be "
        "a leaf test (bvh: the peer is Embree alone; the BVH's build is its set-up, as Embree's is)",
    )
    p.add_argument("--kernel", help="tribench's kernel (default: the fastest on this workload)")
    p.add_argument("--cpu", type=flags.cpu, help="CPU to pin the workers to (default: the last usable one)")
    add_rng_seed(p, "the ray samples and orders")
    add_no_progress(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ..harness import runfolder
    from ..harness.jobs import peers
    from ..reports.tables.peers import format_summary, summarise

    design = _design(args, peers.PeerDesign.quick() if args.quick else peers.PeerDesign())
    if args.kernel is not None:
        _check_kernel(args.kernel, design.accel)
    path = peers.peers_path(args.out or ".")
    try:
        frame = peers.measure(path, design, kernel=args.kernel, cpu=args.cpu, progress=args.progress)
    except RuntimeError as exc:
        print(f"tribench peers: error: {exc}", file=sys.stderr)
        return 1
    print(format_summary(*summarise(frame)))
    print(f"wrote {path}", file=sys.stderr)
    run_dir = path.parent
    if path.name == runfolder.PEERS and (run_dir / runfolder.ANALYSIS).is_file():
        from ..reports.tables.pipeline import reanalyse

        try:
            derived = reanalyse(run_dir)
        except UserError as exc:
            raise UserError(f"wrote {path}, but the analysis step of {run_dir} failed: {exc}") from None
        print(
            f"wrote {', '.join(derived.tables)}, {runfolder.GOOGLE_BENCHMARK} and {runfolder.ANALYSIS} into "
            f"{run_dir} (the analysis step, as tribench stats)",
            file=sys.stderr,
        )
    return 0


def _design(args: argparse.Namespace, design):
    """The peer design of the flags given, over the full or quick default."""
    given = {k: getattr(args, k) for k in ("processes", "reps", "triangles", "rng_seed", "accel")}
    changes = {k: v for k, v in given.items() if v is not None}
    if args.camera:
        changes["width"], changes["height"] = args.camera
    if args.mesh is not None:
        changes["mesh"] = args.mesh
        if args.mesh != "suzanne" and args.triangles is None:
            changes["triangles"] = None  # the mesh's own count (968 is Suzanne's, the seed's)
    return replace(design, **changes)


def _check_kernel(kernel: str, accel: str) -> None:
    from .. import ext

    if kernel not in ext.kernel_names(internal=True) or "closest" not in ext.kernel_info(kernel).modes:
        raise UserError(f"--kernel {kernel!r} is not a kernel with a closest-hit mode (see tribench info)")
    if accel == "bvh" and kernel not in ext.bvh_kernel_names():
        raise UserError(
            f"--kernel {kernel!r} cannot be a BVH's leaf test with --accel bvh; "
            f"these can: {', '.join(ext.bvh_kernel_names())}"
        )
