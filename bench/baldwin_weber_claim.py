"""Baldwin & Weber's claim, tested: faster than Moller-Trumbore at every hit rate?

Baldwin & Weber (JCGT 5(3), 2016) claim their transformation test is always
faster than the standard Moller-Trumbore and faster than a tuned one except
at very high hit rates. This runs a real sweep through the harness (fresh
pinned processes, interleaved rounds, checked checksums) over pair workloads
at per-test hit rates 0 to 1 and prints each Baldwin-Weber form's speedup
over ``moller_seed`` (the paper's standard form: divide first) and over
``moller_trumbore`` (late division, the tuned form) with 95% CIs and the
harness's verdict. Not a test: it prints what this machine says.

    python bench/baldwin_weber_claim.py [RUN_DIR] [--processes N] [--rounds N] [--dtype float32,float64]
"""

from __future__ import annotations

import argparse
import sys
import tempfile

from tribench.harness import runner
from tribench.harness.plan import Sweep
from tribench.reports import tables as analysis
from tribench.workloads.spec import PairSpec

CLAIMANTS = ("baldwin_weber_12", "baldwin_weber_9")
BASELINES = ("moller_seed", "moller_trumbore")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("run_dir", nargs="?", help="run folder (default: a temporary one)")
    parser.add_argument("--processes", type=int, default=10)
    parser.add_argument("--rounds", type=int, default=4)
    parser.add_argument("--pairs", type=int, default=4096)
    parser.add_argument("--hit-rates", default="0,0.25,0.5,0.75,1")
    parser.add_argument("--dtype", default="float32,float64")
    args = parser.parse_args(argv)

    workloads = tuple(
        PairSpec(n=args.pairs, hit_rate=float(h), dtype=d)
        for d in args.dtype.split(",")
        for h in args.hit_rates.split(",")
    )
    sweep = Sweep(CLAIMANTS + BASELINES, workloads, processes=args.processes, rounds=args.rounds)
    run_dir = args.run_dir or f"{tempfile.mkdtemp(prefix='tribench-bw-')}/run"
    result = runner.start(sweep, run_dir)
    print(f"{result.batches_run} batches, {sweep.processes} processes, {result.elapsed_s:.0f} s; {result.run_dir}")
    for baseline in BASELINES:
        spd = analysis.analyse(result.run_dir, baseline=baseline).speedups
        print(f"\nspeedup over {baseline} (> 1: Baldwin-Weber is faster), 95% CI, verdict")
        print(f"{'workload':<44}" + "".join(f"{k:>40}" for k in CLAIMANTS))
        # by precision, then hit rate
        for workload, rows in sorted(spd.groupby("workload"), key=lambda g: (g[0].split()[-2], g[0])):
            cells = {
                r.kernel: f"{r.ratio:.3f} [{r.ratio_ci_low:.3f}, {r.ratio_ci_high:.3f}] {r.verdict}"
                for r in rows.itertuples(index=False)
            }
            name = f"{workload.split(' shuffled')[0]} {workload.split()[-2]}"
            print(f"{name:<44}" + "".join(f"{cells.get(k, '-'):>40}" for k in CLAIMANTS))
    return 0


if __name__ == "__main__":
    sys.exit(main())
