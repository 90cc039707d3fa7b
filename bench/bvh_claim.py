"""Baldwin & Weber's end-to-end claim, in a BVH: 1-6% more rays/s in a complete tracer?

Baldwin & Weber (JCGT 5(3), 2016) report that their transformation tests make
pbrt 1-6% faster end to end than Moller-Trumbore. This runs a real sweep
through the harness (fresh pinned processes, interleaved rounds, checked
checksums, every batch paired with the same traversal under a null leaf test)
of their two algorithms' native forms against ``moller_trumbore_fma`` (and
``woop_fma``) as the leaf test of tribench's BVH, on Suzanne at
``--triangles`` (default 300,000), camera rays and hit-rate rays, float32.
Why not 250,000: there both Baldwin-Weber forms name another triangle than
the float64 reference on one ray of 65,536 camera rays (baldwin_weber_9_fma
also on one hit-rate ray), by brute force as in the BVH: two surfaces within
float32 rounding in t (ray 21049: t 4.6663623 against the reference's
4.6663626), which the workload's ambiguous rays (near an edge) do not cover,
so the harness's check stops the sweep. At 300,000 every kernel passes.
The analysis step then writes ``bvh.csv``, from which this prints each
kernel's rays/s, its end-to-end speedup over ``moller_trumbore_fma`` with a
simultaneous 95% CI, the leaf tests' share of trace time, and what that says
of the 1-6% claim (``tribench.reports.bvh.claim_answer``); ``tribench report
RUN_DIR`` shows the same in its "In a BVH" section. Not a test: it prints what
this machine says. Timing: run it alone.

    flock /tmp/tribench-timing.lock python bench/bvh_claim.py [RUN_DIR] [--processes N] [--rounds N]
        [--triangles N] [--camera WxH] [--rays N]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time

import pandas as pd

from tribench.harness import runfolder, runner
from tribench.harness.jobs.sweep import measure_robustness
from tribench.harness.plan import Sweep
from tribench.harness.stats import format_interval
from tribench.reports import tables
from tribench.reports.bvh import CLAIMANTS, claim_answer
from tribench.workloads.spec import MeshSpec

BASELINE = "moller_trumbore_fma"
KERNELS = (BASELINE, "baldwin_weber_12_fma", "baldwin_weber_9_fma", "woop_fma")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("run_dir", nargs="?", help="run folder (default: a temporary one)")
    parser.add_argument("--processes", type=int, default=8)
    parser.add_argument("--rounds", type=int, default=6)
    parser.add_argument("--triangles", type=int, default=300_000)
    parser.add_argument("--camera", default="256x256", help="camera rays, WxH (default 256x256)")
    parser.add_argument("--rays", type=int, default=16384, help="hit-rate rays (per-ray hit rate 0.5)")
    parser.add_argument("--kernels", default=",".join(KERNELS))
    args = parser.parse_args(argv)

    width, height = (int(x) for x in args.camera.split("x"))
    mesh = {"mesh": "suzanne", "triangles": args.triangles, "dtype": "float32", "accel": "bvh"}
    workloads = (
        MeshSpec(**mesh, width=width, height=height),
        MeshSpec(**mesh, rays="hit_rate", hit_rate=0.5, n_rays=args.rays),
    )
    kernels = tuple(args.kernels.split(","))
    sweep = Sweep(kernels, workloads, processes=args.processes, rounds=args.rounds)
    run_dir = args.run_dir or f"{tempfile.mkdtemp(prefix='tribench-bvh-claim-')}/run"
    t0 = time.monotonic()
    result = runner.start(sweep, run_dir)
    print(f"{result.batches_run} batches, {sweep.processes} processes, {result.elapsed_s:.0f} s; {result.run_dir}")
    tables.write_all(
        result.run_dir,
        baseline=BASELINE if BASELINE in kernels else None,
        validate_note=measure_robustness(result.run_dir, quick=True),
    )
    bvh = pd.read_csv(result.run_dir / runfolder.BVH)
    print(f"analysed in {time.monotonic() - t0 - result.elapsed_s:.0f} s; {result.run_dir / runfolder.BVH}\n")

    def ci(value: float, low: float, high: float, unit: str = "", scale: float = 1.0) -> str:
        return format_interval(value * scale, low * scale, high * scale, unit=unit)

    for (label, family), g in bvh.groupby(["label", "family"], sort=False):
        print(f"{family} · {label}: speedup over {g['baseline'].iloc[0]} end to end, simultaneous 95% CI")
        for r in g.itertuples(index=False):
            speed = "(baseline)" if r.kernel == r.baseline else ci(r.speedup, r.speedup_ci_low, r.speedup_ci_high, "×")
            print(
                f"  {r.kernel:<22} {ci(r.rays_per_s, r.rays_per_s_ci_low, r.rays_per_s_ci_high, '', 1e-6):>28} M rays/s"
                f"  {speed:>28}  leaf share {ci(r.leaf_share, r.leaf_share_ci_low, r.leaf_share_ci_high, '%', 100)}"
                f"  nodes/ray {r.nodes_per_ray:.1f}  tests/ray {r.triangle_tests_per_ray:.1f}"
            )
        for r in g.loc[g["algorithm"].isin(CLAIMANTS) & (g["baseline"] == BASELINE)].itertuples(index=False):
            print(f"  claim (1-6% faster), {r.kernel}: {claim_answer(r.speedup_ci_low, r.speedup_ci_high)}")
        print()
    return 0


if __name__ == "__main__":
    sys.exit(main())
