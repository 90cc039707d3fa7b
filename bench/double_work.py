"""Known-effect check: a kernel doing every test twice must cost 2.0x, within its CI.

``moller_trumbore_twice`` runs every timed pass twice (see its C header for
why the doubling is per pass), so its true cost ratio is 2.0 to within 1e-4.

A real short sweep through the harness (fresh pinned worker processes,
randomised rounds, checked checksums) of ``moller_trumbore`` against
``moller_trumbore_twice``, then the speedup of the first over the second with
its 95% interval. Not a test: timing depends on the machine; it prints the
figures and says whether 2.0 lies inside the interval.

    python bench/double_work.py [RUN_DIR] [--processes N] [--rounds N] [--dtype float32,float64]
"""

from __future__ import annotations

import argparse
import sys
import tempfile

from tribench.harness import runner
from tribench.harness.plan import Sweep
from tribench.reports import tables as analysis
from tribench.workloads.spec import PairSpec

KERNEL, TWICE = "moller_trumbore", "moller_trumbore_twice"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("run_dir", nargs="?", help="run folder (default: a temporary one)")
    parser.add_argument("--processes", type=int, default=10)
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--target-ms", type=float, default=2.0)
    # 1000 pairs stay in L2 and all-hit pairs branch the same way every time: the work is
    # then compute-bound and predictable, the case in which twice the work is twice the time
    parser.add_argument("--pairs", type=int, default=1000)
    parser.add_argument("--hit-rates", default="1.0")
    parser.add_argument("--dtype", default="float32,float64")
    args = parser.parse_args(argv)

    workloads = tuple(
        PairSpec(n=args.pairs, hit_rate=float(h), dtype=d)
        for h in args.hit_rates.split(",")
        for d in args.dtype.split(",")
    )
    sweep = Sweep((KERNEL, TWICE), workloads, processes=args.processes, rounds=args.rounds, target_ms=args.target_ms)
    run_dir = args.run_dir or tempfile.mkdtemp(prefix="tribench-double-work-")
    result = runner.start(sweep, f"{run_dir}/run" if not args.run_dir else run_dir)
    # speedup of the single kernel over the double one = cost of doing the work twice
    tables = analysis.analyse(result.run_dir, baseline=TWICE)
    print(f"{result.batches_run} batches, {sweep.processes} processes, {result.elapsed_s:.0f} s; {result.run_dir}")
    print(f"{'workload':<60}{'twice/once':>11}  95% CI            2.0 inside")
    inside = 0
    for r in tables.speedups.itertuples(index=False):
        ok = r.ratio_ci_low <= 2.0 <= r.ratio_ci_high
        inside += ok
        name = r.workload.replace(" shuffled sphere", "").split(" misses")[0] + " " + r.workload.split()[-2]
        print(f"{name:<60}{r.ratio:11.3f}  [{r.ratio_ci_low:.3f}, {r.ratio_ci_high:.3f}]  {'yes' if ok else 'NO'}")
    peak = tables.estimates["peak_gflops"].mean()
    print(f"FMA peak during the run: {peak:.1f} GFLOP/s per core")
    print(f"2.0 inside the interval on {inside} of {len(tables.speedups)} workloads")
    return 0


if __name__ == "__main__":
    sys.exit(main())
