"""The ``tribench`` command: one console script, subcommands, heavy imports deferred.

Each subcommand's handler imports what it needs when it runs, so
``tribench --help`` stays fast. Handlers return an exit code; a user error
prints one line to stderr and exits 2, without a traceback.
"""

from __future__ import annotations

import argparse
import functools
import os
import signal
import sys
import threading
import warnings

from tribench.common import Notice, UserError

from . import flags


def _info(args: argparse.Namespace) -> int:
    from tribench import ext
    from tribench.harness.machine import machine_record

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
    # the registry's declarations (ext/kernels/list.h): faces tested, watertight promise, seed replay or clean
    print(
        f"{'kernel':<{width}}{'form':<8}{'bytes/tri f32':>14}{'bytes/tri f64':>14}  {'faces':<6}{'watertight':<11}"
        f"{'code':<6} ISA (* = runs here, > = chosen)"
    )
    for name in ext.kernel_names():
        info = ext.kernel_info(name)
        form = "scalar" if info.lanes == 1 else f"{info.lanes} lanes"
        isas = (
            " ".join(("> " if i == info.isa else "* " if ok else "  ") + i for i, ok in info.isas.items())
            if info.lanes > 1
            else "baseline build"
        )
        faces = "front" if info.culls_back_faces else "both"
        watertight = "yes" if info.watertight != "none" else "-"
        code = "seed" if info.seed_replay else "clean"
        print(
            f"{name:<{width}}{form:<8}{info.bytes_per_triangle['float32']:>14}"
            f"{info.bytes_per_triangle['float64']:>14}  {faces:<6}{watertight:<11}{code:<6} {isas}"
        )
    if args.peak:
        _print_peak(width)
    return 0


def _print_peak(width: int) -> None:
    from tribench.harness.peak import camera_fractions

    print(
        "\nmeasuring the FMA peak and every kernel on the in-cache camera workload "
        "(Suzanne 968 triangles, 64x64 rays, closest hit)...",
        file=sys.stderr,
    )
    gflops, isa, rate_isa, rates, table = camera_fractions()
    print(f"\nthroughput probes ({rate_isa}, widest vector), lane-ops per ns:")
    for dtype, r in rates.items():
        print(f"  {dtype:<8}" + "  ".join(f"{c} {v:.1f}" for c, v in r.items()))
    print(
        "bound = the port model over each kernel's operation mix (rules: tribench.harness.peak); % = bound / measured"
    )
    print(f"8-lane FMA peak {gflops:.1f} GFLOP/s ({isa}): the old bound, ops / {gflops / 2:.1f}, shown as '% 8-lane'")
    for dtype, g in table.groupby("dtype", sort=False):
        print(
            f"\n{dtype:<{width}}{'form':<18}{'ops/test':>9}{'bound ns':>10}{'ns/test':>10}"
            f"{'% of bound':>12}{'% 8-lane':>10}"
        )
        for r in g.itertuples(index=False):
            print(
                f"{r.kernel:<{width}}{r.form:<18}{r.ops_per_test:>9}{r.bound_ns_per_test:>10.3f}"
                f"{r.ns_per_test:>10.3f}{100 * r.fraction:>11.1f}%{100 * r.fraction_8lane:>9.1f}%"
            )


# ------------------------------------------------------------------ sweep


def _default_run_dir(kind: str = "") -> str:
    """The run folder a command writes when --out is not given: runs/[KIND-]<date-time>."""
    from tribench.harness.records import default_run_dir

    return default_run_dir(kind)


def _new_run_folder(text: str) -> str:
    """A run folder to create: writable, and new or empty (the runner's own check, run up front)."""
    from tribench.harness.records import check_new_run_dir

    out = flags.output_folder(text)
    try:
        check_new_run_dir(out)
    except UserError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None
    return out


def _add_no_progress(parser: argparse.ArgumentParser) -> None:
    """--no-progress, stored as the library's ``progress`` argument: False, or None (a bar on a terminal,
    plain lines elsewhere)."""
    parser.add_argument(
        "--no-progress",
        dest="progress",
        action="store_const",
        const=False,
        default=None,
        help="no progress: neither the bar on a terminal nor the plain lines elsewhere "
        "(every $TRIBENCH_PROGRESS_SECONDS, default 10, and every tenth of the work)",
    )


def _add_run_out(parser: argparse.ArgumentParser, default: str = "runs/<date-time>") -> None:
    """--out RUN_DIR of a command that creates a run folder (refused up front if it cannot be one)."""
    parser.add_argument("--out", metavar="RUN_DIR", type=_new_run_folder, help=f"new run folder (default {default})")


#: Precisions of the workloads (workloads.spec.DTYPES, kept here so --help imports nothing heavy).
_DTYPES = ("float32", "float64")
_DEFAULT_CAMERA = (64, 64)


def _workloads_from_flags(args: argparse.Namespace) -> list:
    """The workload grid of the sweep flags (see `tribench sweep --help`)."""
    from tribench.workloads.spec import MeshSpec, PairSpec

    dtypes = args.dtype or ["float64"]
    specs: list = []
    if not args.mesh or args.pairs is not None or args.hit_rates is not None:
        for h in args.hit_rates or [0.5]:
            specs += [PairSpec(n=10_000 if args.pairs is None else args.pairs, hit_rate=h, dtype=d) for d in dtypes]
    width, height = args.camera or _DEFAULT_CAMERA
    if args.accel and not args.mesh:
        raise UserError("--accel applies to mesh workloads: give --mesh too")
    for mesh in args.mesh or []:
        for triangles in args.triangles or [None]:
            for accel in args.accel or ["brute"]:
                specs += [
                    MeshSpec(mesh, triangles=triangles, width=width, height=height, dtype=d, accel=accel)
                    for d in dtypes
                ]
    return specs


def _sweep_from_args(args: argparse.Namespace):
    from tribench import ext
    from tribench.harness.plan import (
        DEFAULT_PROCESSES,
        DEFAULT_ROUNDS,
        DEFAULT_TARGET_MS,
        DEFAULT_WARMUP,
        Sweep,
        load_sweep_file,
    )

    design = {
        "processes": args.processes,
        "rounds": args.rounds,
        "warmup": args.warmup,
        "target_ms": args.target_ms,
        "seed": args.seed,
    }
    if args.file:
        return load_sweep_file(args.file, {**design, "kernels": args.kernels})
    defaults = {
        "processes": DEFAULT_PROCESSES,
        "rounds": DEFAULT_ROUNDS,
        "warmup": DEFAULT_WARMUP,
        "target_ms": DEFAULT_TARGET_MS,
        "seed": 0,
    }
    design = {k: defaults[k] if v is None else v for k, v in design.items()}
    kernels = tuple(args.kernels or ext.kernel_names())
    return Sweep(kernels, tuple(_workloads_from_flags(args)), **design)


def _report_run(result, stream=sys.stderr) -> None:
    print(
        f"{result.batches_run} batches run in {result.elapsed_s:.1f} s; "
        f"{result.batches_done}/{result.batches_total} in {result.run_dir}",
        file=stream,
    )


def _sweep(args: argparse.Namespace) -> int:
    from tribench.harness import duration, records, runner

    progress = args.progress
    if args.resume:
        if any(getattr(args, k) is not None for k in _SWEEP_DESIGN_FLAGS):
            raise UserError("--resume takes no other sweep options: the run's own sweep is used")
        result = runner.resume(args.resume, progress=progress)
    else:
        sweep = _sweep_from_args(args)
        out = args.out or _default_run_dir()
        print(
            f"sweep: {len(sweep.kernels)} kernels x {len(sweep.workloads)} workloads, "
            f"{sweep.processes} processes x {sweep.rounds} rounds (+{sweep.warmup} warm-up): "
            f"{sweep.n_batches} batches -> {out}",
            file=sys.stderr,
        )
        records.check_new_run_dir(out)  # before the estimate, which builds the workloads
        print(duration.estimate(sweep).line(), file=sys.stderr)
        result = runner.start(sweep, out, cpu=args.cpu, progress=progress)
    _report_run(result)
    if result.batches_done == result.batches_total:  # the analysis step: every table the report reads
        from tribench.harness.analysis import write_all

        write_all(result.run_dir)
        print(f"next: tribench report {result.run_dir}", file=sys.stderr)
    else:
        print(f"next: tribench stats {result.run_dir}", file=sys.stderr)
    return 0


_SWEEP_DESIGN_FLAGS = (
    "file",
    "kernels",
    "hit_rates",
    "pairs",
    "mesh",
    "triangles",
    "camera",
    "accel",
    "dtype",
    "processes",
    "rounds",
    "warmup",
    "target_ms",
    "seed",
    "cpu",
    "out",
)


def _add_design_flags(p: argparse.ArgumentParser) -> None:
    from tribench.harness.plan import (
        DEFAULT_PROCESSES,
        DEFAULT_ROUNDS,
        DEFAULT_TARGET_MS,
        DEFAULT_WARMUP,
    )

    p.add_argument(
        "--processes", type=flags.positive_int, help=f"worker processes, the replicates (default {DEFAULT_PROCESSES})"
    )
    p.add_argument(
        "--rounds", type=flags.positive_int, help=f"timed rounds per workload per process (default {DEFAULT_ROUNDS})"
    )
    p.add_argument(
        "--warmup",
        type=flags.int_in(0, flags.MAX_COUNT),
        help=f"warm-up rounds per workload per process (default {DEFAULT_WARMUP})",
    )
    p.add_argument(
        "--target-ms",
        type=flags.float_in(0.01, 1000),
        help=f"wanted length of one batch in ms, 0.01 to 1000 (default {DEFAULT_TARGET_MS:g})",
    )
    p.add_argument("--seed", type=flags.seed, help="seed of the plan and the layout randomisation (default 0)")


# -------------------------------------------------------------------- run


def _run(args: argparse.Namespace) -> int:
    from tribench.harness.main_job import run
    from tribench.reports import format_tables, write_report

    out = args.out or _default_run_dir("quick" if args.quick else "")
    run(out, quick=args.quick, progress=args.progress)
    report = write_report(out)
    print(format_tables(out))
    print(f"\nreport: {report}")
    return 0


def _peers(args: argparse.Namespace) -> int:
    from dataclasses import replace

    from tribench.harness import peers, runfolder

    design = peers.PeerDesign.quick() if args.quick else peers.PeerDesign()
    changes = {
        k: v
        for k, v in {
            "processes": args.processes,
            "reps": args.reps,
            "triangles": args.triangles,
            "seed": args.seed,
            "accel": args.accel,
        }.items()
        if v is not None
    }
    if args.camera:
        changes["width"], changes["height"] = args.camera
    if args.mesh is not None:
        changes["mesh"] = args.mesh
        if args.mesh != "suzanne" and args.triangles is None:
            changes["triangles"] = None  # the mesh's own count (968 is Suzanne's, the seed's)
    design = replace(design, **changes)
    if args.kernel is not None:
        from tribench import ext

        if args.kernel not in ext.kernel_names(internal=True) or "closest" not in ext.kernel_info(args.kernel).modes:
            raise UserError(f"--kernel {args.kernel!r} is not a kernel with a closest-hit mode (see tribench info)")
        if design.accel == "bvh" and args.kernel not in ext.bvh_kernel_names():
            raise UserError(
                f"--kernel {args.kernel!r} cannot be a BVH's leaf test with --accel bvh; "
                f"these can: {', '.join(ext.bvh_kernel_names())}"
            )
    path = peers.peers_path(args.out or ".")
    try:
        frame = peers.measure(path, design, kernel=args.kernel, cpu=args.cpu, progress=args.progress)
    except RuntimeError as exc:
        print(f"tribench peers: error: {exc}", file=sys.stderr)
        return 1
    print(peers.format_summary(*peers.summarise(frame)))
    print(f"wrote {path}", file=sys.stderr)
    run_dir = path.parent
    if path.name == runfolder.PEERS and (run_dir / runfolder.ANALYSIS).is_file():
        # An analysed run folder: redo the analysis step now, so its peer tables (and the
        # peers.csv digest in analysis.json) match the new peers.csv and the report can show them.
        import json

        from tribench.harness.analysis import write_all

        try:
            record = json.loads((run_dir / runfolder.ANALYSIS).read_text(encoding="utf-8"))
            kept = {
                "baseline": record["baseline"],  # keep the choices of the last `tribench stats`
                "margin": record["margin"]["value"] if record["margin"]["source"] == "--margin" else None,
            }
        except (OSError, UnicodeDecodeError, ValueError, TypeError, KeyError):
            kept = {}  # unreadable: the analysis step's defaults, as `tribench stats` would use
        try:
            derived = write_all(run_dir, **kept)
        except UserError as exc:
            raise UserError(f"wrote {path}, but the analysis step of {run_dir} failed: {exc}") from None
        print(
            f"wrote {', '.join(derived.tables)}, {runfolder.GOOGLE_BENCHMARK} and {runfolder.ANALYSIS} into "
            f"{run_dir} (the analysis step, as tribench stats)",
            file=sys.stderr,
        )
    return 0


# ------------------------------------------------------------------- seed


def _seed(args: argparse.Namespace) -> int:
    import shlex

    from tribench.harness.seed import KINDS_CSV, SEED_CSV, WORKLOADS_CSV, format_table, run_seed
    from tribench.reports.seed import write_seed_report

    out = args.out or _default_run_dir("seed-quick" if args.quick else "seed")
    words = [
        "tribench",
        "seed",
        *[w for s in args.scene or [] for w in ("--scene", s)],
        *(["--quick"] if args.quick else []),
        "--out",
        out,
        *[w for k in ("size", "sample") if getattr(args, k) for w in (f"--{k}", str(getattr(args, k)))],
    ]
    result = run_seed(
        out,
        scenes=args.scene,
        quick=args.quick,
        size=args.size,
        sample=args.sample,
        progress=args.progress,
        command=shlex.join(words),
    )
    report = write_seed_report(out)
    print(format_table(result.tables[SEED_CSV], result.tables[WORKLOADS_CSV]))
    print(f"\n{result.elapsed_s:.0f} s; tables: {out}/{SEED_CSV}, {KINDS_CSV}, {WORKLOADS_CSV}; report: {report}")
    return 0


# ------------------------------------------------------------------ stats


def _stats(args: argparse.Namespace) -> int:
    from tribench.harness.analysis import write_all
    from tribench.reports import format_tables

    derived = write_all(args.run_dir, baseline=args.baseline, margin=args.margin)
    print(format_tables(args.run_dir))
    print(
        f"wrote {', '.join(derived.tables)}, google_benchmark.json, the workload pictures and analysis.json "
        f"into {args.run_dir}",
        file=sys.stderr,
    )
    return 0


# -------------------------------------------------------------- calibrate


def _calibrate(args: argparse.Namespace) -> int:
    from tribench.harness.calibration import calibrate, user_calibration_path

    workloads: tuple = ()
    if args.workload:
        from tribench.workloads import cache

        workloads = (cache.load(cache.resolve_id(args.workload)).spec,)
    out = args.out or _default_run_dir("calibrate")
    kwargs = {
        k: v
        for k, v in {
            "rounds": args.rounds,
            "warmup": args.warmup,
            "target_ms": args.target_ms,
            "seed": args.seed,
            "processes": args.processes,
            "experiments": args.experiments,
        }.items()
        if v is not None
    }
    cal = calibrate(
        out,
        kernel=args.kernel,
        workloads=workloads,
        save=not args.no_save,
        progress=args.progress,
        **kwargs,
    )
    print(
        f"A/A: {cal['kernel']} vs {cal['copy']}, {cal['experiments']} comparisons of "
        f"{cal['processes_per_experiment']} processes each"
    )
    print(f"  coverage of 1          {100 * cal['coverage']:.0f}%  (intervals are 95%)")
    print(f"  false positives        {100 * cal['false_positive_rate']:.0f}%  (expected 5%)")
    print(f"  p-values vs uniform    KS {cal['ks_statistic']:.3f}, p = {cal['ks_p_value']:.3f}")
    print(f"  noise floor            {cal['noise_floor']:.4f} (log), margin {100 * cal['margin']:.2f}%")
    saved = "" if args.no_save else f" and {user_calibration_path()}"
    print(f"wrote {out}/calibration.json{saved}", file=sys.stderr)
    return 0


# --------------------------------------------------------------- validate


def _validate_out(text: str) -> str:
    """validate --out: the CSV to write; a folder means FILE/validate.csv."""
    from pathlib import Path

    return flags.output_file(str(Path(text) / "validate.csv") if text.strip() and Path(text).is_dir() else text)


def _peers_out(text: str) -> str:
    """peers --out: a .csv names the file, anything else a folder (as peers.peers_path reads it)."""
    from pathlib import Path

    return flags.output_file(text) if Path(text).suffix.lower() == ".csv" else flags.output_folder(text)


def _validate(args: argparse.Namespace) -> int:
    from pathlib import Path

    from tribench.harness import validate
    from tribench.harness.records import write_csv

    # each --kernels/--dtype word may itself be a comma list
    kernels = [k for words in args.kernels for k in words] if args.kernels else None
    dtypes = [d for words in args.dtype for d in words] if args.dtype else validate.DTYPES
    df = validate.run(kernels, dtypes, quick=args.quick, seed=args.seed, progress=args.progress)
    out = Path(args.out or _validate_out("validate.csv"))
    write_csv(df, out)
    print(validate.format_table(df))
    print(f"{len(df)} rows in {df.attrs['seconds']:.1f} s; wrote {out}", file=sys.stderr)
    return 0


def build_parser() -> argparse.ArgumentParser:
    from tribench.harness.machine import version
    from tribench.workloads.spec import ACCELS

    parser = flags.Parser(
        prog="tribench",
        description="Statistical benchmarking of ray-triangle intersection algorithms.",
    )
    parser.add_argument("--version", action="version", version=f"tribench {version()}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    info = sub.add_parser("info", help="version, build flags, CPU and SIMD features, kernel list")
    info.add_argument(
        "--peak",
        action="store_true",
        help="also measure the FMA peak and each kernel's ns/test on the in-cache camera "
        "workload, as a fraction of its arithmetic bound (about 10 s)",
    )
    info.set_defaults(func=_info)

    sweep = sub.add_parser(
        "sweep",
        help="time kernels x workloads in fresh worker processes; write a run folder",
        description="Time every kernel on every workload: replicates are fresh worker processes "
        "pinned to one CPU, rounds run every kernel once in a random order, every batch's checksum "
        "is checked. Workloads come from a TOML file (--file) or from the flags: pairs at each "
        "hit rate and precision, and with --mesh, camera rays on each mesh, triangle count and "
        "precision. Results: RUN_DIR/batches.csv (one row per batch, appended as it finishes), "
        "processes.csv, run.json.",
    )
    _add_run_out(sweep)
    sweep.add_argument(
        "--resume",
        metavar="RUN_DIR",
        type=flags.existing_folder,
        help="finish the missing batches of an interrupted run",
    )
    sweep.add_argument(
        "--file",
        metavar="SWEEP.toml",
        type=flags.existing_file,
        help="sweep file (flags given too override its values)",
    )
    sweep.add_argument(
        "--kernels", metavar="A,B", type=flags.name_list, help="kernels (default: all of `tribench info`)"
    )
    sweep.add_argument(
        "--hit-rates",
        metavar="H,..",
        type=flags.float_list(0, 1),
        help="per-test hit rates of pair workloads, each in [0, 1] (default 0.5)",
    )
    sweep.add_argument("--pairs", type=flags.positive_int, metavar="N", help="pairs per pair workload (default 10000)")
    sweep.add_argument(
        "--mesh", metavar="NAME,..", type=flags.name_list, help="mesh workloads (suzanne, icosphere, ... or a file)"
    )
    sweep.add_argument(
        "--triangles",
        metavar="K,..",
        type=flags.int_list(1, flags.MAX_COUNT),
        help="triangle counts of the meshes (default: base mesh)",
    )
    sweep.add_argument(
        "--camera",
        metavar="WxH",
        type=flags.camera,
        help="camera rays of mesh workloads (default {}x{})".format(*_DEFAULT_CAMERA),
    )
    sweep.add_argument(
        "--accel",
        metavar="brute,bvh",
        type=flags.choice_list(ACCELS),
        help="how kernels run the mesh workloads: every ray against every triangle (brute, the default) or "
        "through a BVH with the kernel as its leaf test (bvh: only the kernels of ext.bvh_kernel_names())",
    )
    sweep.add_argument(
        "--dtype", metavar="float32,float64", type=flags.choice_list(_DTYPES), help="precisions (default float64)"
    )
    _add_design_flags(sweep)
    sweep.add_argument("--cpu", type=flags.cpu, help="CPU to pin workers to (default: the last usable one)")
    _add_no_progress(sweep)
    sweep.set_defaults(func=_sweep)

    st = sub.add_parser(
        "stats", help="every table the report reads: estimates.csv, speedups.csv and the rest (never times anything)"
    )
    st.add_argument("run_dir", metavar="RUN_DIR", type=flags.existing_folder)
    st.add_argument("--baseline", metavar="NAME", help="baseline kernel (default moller_seed, else the first)")
    st.add_argument(
        "--margin", type=flags.float_in(0, 1), help="equivalence margin, in [0, 1] (default: the one run.json records)"
    )
    st.set_defaults(func=_stats)

    cal = sub.add_parser(
        "calibrate",
        help="A/A calibration: a kernel against its identical copy; sets the equivalence margin",
        description="Times KERNEL against its copy compiled under another name, in EXPERIMENTS "
        "groups of PROCESSES processes; reports the coverage of 1, the A/A p-values and the noise "
        "floor, and saves the margin that later sweeps on this CPU use.",
    )
    cal.add_argument("--kernel", default="moller_trumbore", help="kernel with an A/A copy (moller_trumbore)")
    cal.add_argument(
        "--workload", metavar="ID", help="cached workload id or prefix (default: 10000 pairs, hit rate 0.5)"
    )
    cal.add_argument("--experiments", type=flags.positive_int, help="number of A/A comparisons (default 10)")
    _add_run_out(cal, "runs/calibrate-<date-time>")
    cal.add_argument("--no-save", action="store_true", help="do not update the user-level calibration")
    _add_no_progress(cal)
    _add_design_flags(cal)
    cal.set_defaults(func=_calibrate)

    run = sub.add_parser(
        "run",
        help="the main job: the default sweep (about 5 minutes), its statistics and its HTML report",
        description="Runs the default sweep (tribench.harness.plan.default_sweep: the seed's two kernels "
        "and the clean Moller-Trumbore over per-test hit rates 0..1 and Suzanne at three triangle "
        "counts), writes estimates.csv and speedups.csv, prints them, runs the robustness suite "
        "(validate.csv) and, when a peer is installed, tribench peers (peers.csv, about 40 s), and "
        "writes report.html.",
    )
    run.add_argument("--quick", action="store_true", help="the same shape in under a minute (wide intervals)")
    _add_run_out(run, "runs/[quick-]<date-time>")
    _add_no_progress(run)
    run.set_defaults(func=_run)

    pe = sub.add_parser(
        "peers",
        help="rays/s of tribench's fastest kernel against trimesh and Embree on the seed's camera, as ratios with CIs",
        description="Times tribench's fastest closest-mode kernel (chosen on a sample of the rays), trimesh's "
        "intersector and Embree through embreex on Suzanne (or --mesh) through a pinhole camera (512x512, float32, "
        "closest hit): fresh worker processes pinned to one CPU with one BLAS thread, every contender once per "
        "repetition in a random order. Prints rays/s with 95% CIs and tribench's ratios over each peer, "
        "paired by process, and writes peers.csv (into a run folder, the report shows it). Needs "
        "pip install 'tribench[peers]' (embreex, and rtree for trimesh's intersector). About 40 s.",
    )
    from tribench.harness.peers import PeerDesign

    full, quick = PeerDesign(), PeerDesign.quick()
    pe.add_argument(
        "--out", metavar="RUN_DIR|FILE.csv", type=_peers_out, help="where peers.csv goes (default ./peers.csv)"
    )
    pe.add_argument(
        "--quick",
        action="store_true",
        help=f"a {quick.width}x{quick.height} camera, {quick.processes} processes x {quick.reps} repetitions (seconds)",
    )
    pe.add_argument(
        "--camera", metavar="WxH", type=flags.camera, help=f"camera rays (default {full.width}x{full.height})"
    )
    pe.add_argument(
        "--mesh",
        metavar="NAME|FILE",
        help="the mesh: suzanne (default), another built-in mesh, or any mesh file trimesh reads (OBJ, PLY, STL, ...)",
    )
    pe.add_argument(
        "--triangles",
        type=flags.positive_int,
        help=f"the mesh's triangle count (default: {full.triangles} for Suzanne, the seed's mesh; "
        "any other mesh keeps its own)",
    )
    pe.add_argument(
        "--processes", type=flags.positive_int, help=f"worker processes, the replicates (default {full.processes})"
    )
    pe.add_argument("--reps", type=flags.positive_int, help=f"repetitions per process (default {full.reps})")
    pe.add_argument(
        "--accel",
        choices=ACCELS,
        help="tribench's rays brute force (default) or through its BVH with the fastest kernel that can be "
        "a leaf test (bvh: the peer is Embree alone; the BVH's build is its set-up, as Embree's is)",
    )
    pe.add_argument("--kernel", help="tribench's kernel (default: the fastest on this workload)")
    pe.add_argument("--cpu", type=flags.cpu, help="CPU to pin the workers to (default: the last usable one)")
    pe.add_argument("--seed", type=flags.seed, help="seed of the ray samples and orders (default 0)")
    _add_no_progress(pe)
    pe.set_defaults(func=_peers)

    val = sub.add_parser(
        "validate",
        help="robustness suite: cracks at shared edges and vertices, Embree's sphere, extreme input, per kernel",
        description="Asks every kernel, at each precision, rays aimed exactly at shared edges and vertices of "
        "exactly coplanar meshes, rays from inside a finely tessellated sphere far from the origin (Embree's "
        "test), and pairs at scales 1e-8 to 1e8, tiny and needle triangles, grazing and parallel rays, "
        "degenerate triangles, NaN and Inf (see tribench.harness.validate). Prints one row per kernel and "
        "precision, one column per test, and writes the tidy CSV: kernel, dtype, isa, test, rays, failures, "
        "rate, expected, verdict, detail. Exits 0 even where a promise is broken.",
    )
    val.add_argument(
        "--kernels", nargs="+", metavar="K", type=flags.name_list, help="kernels (default: all of `tribench info`)"
    )
    val.add_argument(
        "--dtype", nargs="+", metavar="D", type=flags.choice_list(_DTYPES), help="float32 and/or float64 (default both)"
    )
    val.add_argument(
        "--out",
        metavar="FILE.csv",
        type=_validate_out,
        help="the CSV (default ./validate.csv; in a directory: validate.csv)",
    )
    val.add_argument("--quick", action="store_true", help="small sets, a few seconds (the tests' size)")
    val.add_argument("--seed", type=flags.seed, default=0, help="seed of every test's rays (default 0)")
    _add_no_progress(val)
    val.set_defaults(func=_validate)

    seed = sub.add_parser(
        "seed",
        help="replay the seed's renders (scene02, scene03) through the harness, beside the paper's table",
        description="Traces each scene as the seed's ray tracer does, times every kernel on a sample of each "
        "kind of ray (primary, reflected, shadow) in fresh worker processes, scales to one render's "
        "time with 95% CIs, and sets it beside the paper's Unix times. Writes the run folder, "
        "seed.csv (the table), seed_kinds.csv, seed_workloads.csv (per-test hit rate, miss-stage mix), "
        "both seed kernels' pictures with their difference mask, and seed.html.",
    )
    seed.add_argument(
        "--scene",
        action="append",
        metavar="FILE",
        type=flags.existing_file,
        help="a scene file in the seed's format, instead of scene02 and scene03 (repeatable)",
    )
    seed.add_argument("--quick", action="store_true", help="the same shape in under a minute (128x128, wide intervals)")
    _add_run_out(seed, "runs/seed-[quick-]<date-time>")
    _add_no_progress(seed)
    seed.add_argument("--size", type=flags.positive_int, help=argparse.SUPPRESS)  # image side, for tests
    seed.add_argument("--sample", type=flags.positive_int, help=argparse.SUPPRESS)  # rays sampled per kind, for tests
    seed.set_defaults(func=_seed)

    from .reports import add_parser as add_reports
    from .workloads import add_parser as add_workloads

    add_workloads(sub)
    add_reports(sub)
    return parser


def _ctrl_c(signum: int, frame) -> None:
    """SIGINT (and its retry, SIGALRM): KeyboardInterrupt, but never inside an import.

    trimesh's imports catch BaseException around its optional dependencies,
    so a Ctrl-C during ``import trimesh`` was swallowed and the command ran
    on for seconds. An interrupt that lands in an import is retried 50 ms later.
    """
    while frame is not None:
        if frame.f_code.co_filename.startswith("<frozen importlib"):
            signal.setitimer(signal.ITIMER_REAL, 0.05)
            return
        frame = frame.f_back
    raise KeyboardInterrupt


def main(argv: list[str] | None = None) -> int:
    """Run one subcommand; map its failures to exit codes, one line on stderr.

    See :func:`_run_command`; Ctrl-C is deferred past imports (:func:`_ctrl_c`).
    """
    if threading.current_thread() is not threading.main_thread():
        return _run_command(argv)
    before = {sig: signal.signal(sig, _ctrl_c) for sig in (signal.SIGINT, signal.SIGALRM)}
    try:
        with warnings.catch_warnings():
            shown = warnings.showwarning
            warnings.showwarning = functools.partial(_show_notice, shown)
            return _run_command(argv)
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        for sig, handler in before.items():
            signal.signal(sig, handler)


def _show_notice(shown, message, category, filename, lineno, file=None, line=None) -> None:
    """tribench's own notices in one line; any other warning as Python shows it (it may point at a bug)."""
    if issubclass(category, Notice):
        print(f"tribench: {message}", file=sys.stderr)
    else:
        shown(message, category, filename, lineno, file, line)


def _run_command(argv: list[str] | None) -> int:
    """Run one subcommand; map its failures to exit codes, one line on stderr.

    2: a user error (:class:`~tribench.common.UserError`) or an error of the
    environment (an ``OSError``: a missing file, a full disk); 1: a
    measurement failed (a kernel disagreed with the reference, a worker
    died); 130: interrupted (Ctrl-C), every finished batch kept. Any other
    exception is a bug in tribench and keeps its traceback.
    """
    prog = "tribench"
    try:
        args = build_parser().parse_args(argv)
        prog = f"tribench {args.command}"
        from tribench.harness.runner import SweepError, SweepInterrupted, progress_seconds

        if getattr(args, "progress", False) is not False:
            progress_seconds()  # a bad $TRIBENCH_PROGRESS_SECONDS fails first, like a bad flag
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
    sys.exit(main())
