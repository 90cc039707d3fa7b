"""The seed's question across builds (#27.4): how much faster is Moller-Trumbore than Curless, per compiler and flags?

The seed paper timed its two tests in one build of its program. The answer
depends on the build: this runs the seed's two kernels, as its code wrote
them (``curless_seed``, ``moller_seed``), under gcc and clang at ``-O2``,
``-O3`` and ``-O3 -march=native`` on this machine, in one sweep
(``tribench.sweep(builds=...)``: every build compiled once, its kernels
checked against the reference again, the worker processes taking the builds
in turn so a drift of the machine touches every build alike). The workload
is the seed's mesh seen by the seed's camera: Suzanne, 968 triangles, closest
hit, float32 (the seed's Vecteur holds float).

Printed per build: the Curless / Moller time ratio (the seed's 1.7x is that
ratio for whole renders) with its 95% interval, paired by process, and the
Moller ns/test with its interval. The run folder's report.html has the same
in its "Across builds" section, with every order of two kernels tested under
each build (builds.csv). A build whose compiler is missing is left out, and
said so.

    python bench/seed_builds.py [--processes-per-build 6] [--rounds 4] [--size 48] [--out DIR]
"""

from __future__ import annotations

import argparse
import shutil
import sys
import tempfile
from pathlib import Path

import tribench
from tribench.harness import stats
from tribench.harness.machine import describe
from tribench.reports import write_report
from tribench.workloads.spec import MeshSpec

BUILDS = [f"{cc} {flags}" for cc in ("gcc", "clang") for flags in ("-O2", "-O3", "-O3 -march=native")]
KERNELS = ("moller_seed", "curless_seed")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--processes-per-build", type=int, default=6)
    ap.add_argument("--rounds", type=int, default=4)
    ap.add_argument("--size", type=int, default=48, help="camera side in pixels (default 48, the main job's)")
    ap.add_argument("--out", help="run folder to keep (default: a temporary one, removed)")
    args = ap.parse_args()
    print(describe())
    builds = [b for b in BUILDS if shutil.which(b.split()[0])]
    for b in sorted(set(BUILDS) - set(builds)):
        print(f"left out: {b} (no {b.split()[0]} here)", file=sys.stderr)
    spec = MeshSpec("suzanne", triangles=968, width=args.size, height=args.size, dtype="float32")
    tmp = None if args.out else tempfile.mkdtemp(prefix="seed-builds-")
    out = Path(args.out or Path(tmp or ".") / "run")
    try:
        r = tribench.sweep(
            KERNELS,
            [spec],
            out,
            processes=args.processes_per_build * len(builds),
            rounds=args.rounds,
            builds=builds,
            baseline="moller_seed",
            progress=False,
        )
        write_report(out)
        pp = r.tables["per_process.csv"]
        print(f"{spec.summary()}; {args.processes_per_build} processes per build x {args.rounds} rounds")
        print(f"{'build':<26} {'curless / moller (time)':<30} {'moller_seed ns/test':<26}")
        for build in builds:
            per = pp.loc[pp["build"] == build].pivot(index="process", columns="kernel", values="ns_per_test")
            ratio = stats.speedup(per["curless_seed"], per["moller_seed"])  # time_curless / time_moller
            moller = stats.estimate(per["moller_seed"])
            print(
                f"{build:<26} {stats.format_interval(ratio.ratio, ratio.ci_low, ratio.ci_high, '.3f', 'x'):<30} "
                f"{stats.format_interval(moller.mean, moller.ci_low, moller.ci_high, '.2f'):<26}"
            )
        print(f"report: {out / 'report.html'}" if args.out else "(--out DIR keeps the run folder and its report)")
    finally:
        if tmp:
            shutil.rmtree(tmp, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
