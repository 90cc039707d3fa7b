"""Coverage on this machine: how often the main job's 95% intervals hold a known truth.

``tests/test_stats.py`` checks the intervals' coverage on synthetic data. This
script checks it on real timings. Each of N runs is a short sequential sweep
with the main job's stopping rule (``Sequential``: stages of 2 processes, stop
a comparison at +/-2%, a budget of a few seconds), on a reduced grid: one pair
workload and Suzanne at 968 triangles through the seed's camera, float32. Each
run times ``moller_trumbore`` (the reference) against three kernels whose true
cost ratio is known or nominal:

* ``moller_trumbore_same``, the reference's own code under another name: 1
  exactly, so its coverage tests the harness;
* ``moller_trumbore_twice``, every timed pass done twice: 2 exactly;
* ``moller_trumbore_aa``, the same source compiled again: 1 nominally, off by
  whatever the code's own layout costs (what the run's margin absorbs).

The script then counts, over the runs and workloads, how often each
comparison's interval holds its truth:

* the per-comparison 95% interval (``stats.speedup`` on the paired
  per-process medians), the figure the 93-97% target is about;
* the report's interval (``speedups.csv``: simultaneous, Bonferroni over the
  workload's three comparisons), which should cover at least as often.

Not a test: it takes minutes and the figures depend on the machine. Run it
on a quiet machine (``uptime`` load under 1.5), under the timing lock:

    flock /tmp/tribench-timing.lock python bench/coverage.py [--runs 40] [--budget 6]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from scipy import stats as sps

from tribench.harness import runner, stats
from tribench.harness.plan import Sequential, Sweep
from tribench.reports.tables import measured
from tribench.reports.tables.pipeline import estimate
from tribench.workloads.spec import MeshSpec, PairSpec

REFERENCE, SAME, TWICE, AA = "moller_trumbore", "moller_trumbore_same", "moller_trumbore_twice", "moller_trumbore_aa"
#: Each comparison's true (for AA: nominal) cost ratio, the kernel's time over the reference's.
TRUTH = {SAME: 1.0, TWICE: 2.0, AA: 1.0}


def reduced_sweep(budget_s: float, rng_seed: int) -> Sweep:
    """The main job's design on one pair workload and one mesh: the stopping rule, shortened."""
    workloads = (
        PairSpec(n=4096, hit_rate=0.5, rng_seed=rng_seed),
        MeshSpec("suzanne", triangles=968, width=32, height=32, rng_seed=rng_seed),
    )
    return Sweep(
        (REFERENCE, SAME, TWICE, AA),
        workloads,
        processes=16,
        rounds=3,
        warmup=1,
        target_ms=4.0,
        rng_seed=rng_seed,
        sequential=Sequential(stage=2, target=0.02, budget_s=budget_s),
    )


def one_run(run_dir: Path, budget_s: float, rng_seed: int) -> list[dict]:
    """One run's intervals: per workload and comparison, both intervals of the cost ratio."""
    runner.start(reduced_sweep(budget_s, rng_seed), run_dir, progress=False)
    m = measured.load(run_dir)
    result = estimate(m, baseline=REFERENCE)
    per_process = stats.per_process(m.batches)
    rows = []
    for r in result.speedups.itertuples(index=False):
        group = per_process.loc[per_process["workload_id"] == r.workload_id]
        wide = group.pivot(index="process", columns="kernel", values="ns_per_test").dropna()
        # speedup = time_reference / time_kernel, so the cost ratio is its inverse
        plain = stats.speedup(wide[REFERENCE], wide[r.kernel])
        rows.append(
            {
                "kernel": r.kernel,
                "workload": r.workload_id,
                "processes": len(wide),
                "cost": 1 / plain.ratio,
                "plain": (1 / plain.ci_high, 1 / plain.ci_low),
                "simultaneous": (1 / r.ratio_ci_high, 1 / r.ratio_ci_low),
            }
        )
    return rows


def wilson(k: int, n: int) -> tuple[float, float]:
    """The 95% Wilson interval of a coverage k of n (scipy's)."""
    ci = sps.binomtest(k, n).proportion_ci(0.95, method="wilson")
    return ci.low, ci.high


def summary(rows: list[dict]) -> None:
    print(f"\n{'comparison':<26}{'truth':>6}{'intervals':>10}{'95% covers':>12}  (Wilson 95%)    report's covers")
    for kernel, truth in TRUTH.items():
        mine = [r for r in rows if r["kernel"] == kernel]
        n = len(mine)
        plain = sum(lo <= truth <= hi for lo, hi in (r["plain"] for r in mine))
        simul = sum(lo <= truth <= hi for lo, hi in (r["simultaneous"] for r in mine))
        lo, hi = wilson(plain, n)
        costs = np.array([r["cost"] for r in mine])
        print(
            f"{kernel:<26}{truth:6.1f}{n:10d}{plain / n:12.1%}  ({lo:.1%}-{hi:.1%})  {simul / n:8.1%}"
            f"   mean cost {costs.mean():.4f}, processes {np.mean([r['processes'] for r in mine]):.1f}"
        )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=40, help="sweeps to run (default 40)")
    parser.add_argument("--budget", type=float, default=6.0, help="seconds each sweep's stages may take")
    parser.add_argument("--out", help="folder for the runs (default: a temporary one)")
    args = parser.parse_args(argv)
    root = Path(args.out or tempfile.mkdtemp(prefix="tribench-coverage-"))
    rows: list[dict] = []
    start = time.monotonic()
    for i in range(args.runs):
        # a fresh RNG seed per run: new workloads and a new layout of the rounds, as separate experiments
        run = one_run(root / f"run{i:03d}", args.budget, rng_seed=i)
        rows += run
        missed = [
            f"{r['kernel']} {r['cost']:.3f}" for r in run if not r["plain"][0] <= TRUTH[r["kernel"]] <= r["plain"][1]
        ]
        print(
            f"run {i + 1}/{args.runs}, {time.monotonic() - start:.0f} s"
            + (f"; missed: {', '.join(missed)}" if missed else "")
        )
    summary(rows)
    print(f"runs in {root}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
