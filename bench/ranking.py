"""Every algorithm in its best form, ranked, at hit rates from 0 to 100%, in both precisions, with CIs.

Issue #18's questions, re-asked with the native forms: Baldwin & Weber's claim
(faster than Moller-Trumbore at every hit rate?), Curless against Moller, and
the order of all algorithms. A real sweep through the harness (fresh pinned
processes, interleaved rounds, checked answers), then its analysis and report:

* pairs at per-test hit rates 0, 25, 50, 75, 100% (4096 pairs: in L2): the
  scalar forms only (native forms have no pairs mode), so this is
  the algorithms' scalar cores, test by test;
* Suzanne at 1,280 triangles, brute force: the seed's camera (32 x 32 rays)
  and rays hitting the mesh at per-ray rates 0, 50 and 100% (1,024 rays): every
  form, scalar and native.

Printed: per workload, the algorithms from the fastest down (each by its
fastest form; its time over the fastest's with a simultaneous 95% CI), and the
head-to-head answers (algorithms.csv). The HTML report of the run folder
opens on the same ranking. Figures are this machine's: the CPU is printed.

    flock /tmp/tribench-timing.lock python bench/ranking.py RUN_DIR [--processes N] [--rounds N] [--quick]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import pandas as pd

from tribench import ext, reports
from tribench.harness import runfolder, runner
from tribench.harness.jobs.sweep import measure_robustness
from tribench.harness.plan import Sweep
from tribench.reports import tables
from tribench.reports.ranking import algorithm_order, question_rows
from tribench.workloads.spec import MeshSpec, PairSpec

DTYPES = ("float32", "float64")


def kernels() -> tuple[str, ...]:
    """Every public kernel this build has: the seed's two, the clean scalar forms, the native ones."""
    return tuple(ext.kernel_names())


def workloads(quick: bool) -> tuple:
    rates = (0.0, 1.0) if quick else (0.0, 0.25, 0.5, 0.75, 1.0)
    pairs = [PairSpec(n=1024 if quick else 4096, hit_rate=h, dtype=d) for d in DTYPES for h in rates]
    size = 16 if quick else 32
    meshes = [MeshSpec("suzanne", triangles=1280, width=size, height=size, dtype=d) for d in DTYPES]
    meshes += [
        MeshSpec("suzanne", triangles=1280, rays="hit_rate", hit_rate=h, n_rays=size * size, dtype=d)
        for d in DTYPES
        for h in ((0.0, 1.0) if quick else (0.0, 0.5, 1.0))
    ]
    return (*pairs, *meshes)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("run_dir", help="a new run folder")
    parser.add_argument("--processes", type=int, default=10)
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--quick", action="store_true", help="a smoke run: 3 processes, fewer workloads")
    args = parser.parse_args(argv)

    processes, rounds = (3, 2) if args.quick else (args.processes, args.rounds)
    sweep = Sweep(kernels(), workloads(args.quick), processes=processes, rounds=rounds, warmup=1)
    print(f"{len(sweep.kernels)} kernels, {len(sweep.workloads)} workloads, {sweep.n_batches} batches", flush=True)
    done = runner.start(sweep, args.run_dir)
    print(f"{done.batches_run} batches in {done.elapsed_s:.0f} s -> {done.run_dir}")
    tables.write_all(args.run_dir, validate_note=measure_robustness(args.run_dir, quick=True))
    report = reports.write_report(args.run_dir)
    machine = runner_machine(Path(args.run_dir))
    print(f"machine: {machine}\nreport: {report}\n")

    rank = pd.read_csv(Path(args.run_dir) / runfolder.RANKING)
    alg = pd.read_csv(Path(args.run_dir) / runfolder.ALGORITHMS)
    order = algorithm_order(rank).sort_values(["dtype", "workload"], kind="stable")
    for row in order.itertuples(index=False):
        print(f"{row.workload}\n    {row.order}")
    answers = question_rows(alg).sort_values(["dtype", "workload"], kind="stable").fillna("")
    for question in [c for c in answers.columns if c not in ("dtype", "workload")]:
        print(f"\n{question} (the faster one, its speedup [simultaneous 95% CI]):")
        for _, row in answers.iterrows():
            print(f"    {row['workload']:<72} {row[question]}")
    return 0


def runner_machine(run_dir: Path) -> str:
    m = runfolder.read_run(run_dir).machine
    return f"{m.get('cpu_model', '?')}; {m.get('build', {}).get('compiler', '?')}"


if __name__ == "__main__":
    sys.exit(main())
