"""How long the protocol needs for a +-1% CI on a speedup, and the defaults that follow.

A pilot sweep through the real harness (``runner.start``: fresh pinned worker
processes, checks, calibration, warm-up) of ``moller_trumbore`` against
``moller_seed`` on the camera workload (Suzanne, 968 triangles, the seed's
camera at 48x48, float32, closest hit), at each batch length of
``--target-ms``. From its batches:

* the ratio of the two kernels per process and round (they run in the same
  round, in a random order) as a processes x rounds matrix, split by
  Kalibera & Jones's variance components (``stats.variance_components``):
  T1^2 between rounds of a process, T2^2 between processes;
* the cost of a round ``c1`` (wall time between round starts) and of a
  process beyond its rounds ``c2`` (start-up, checks, calibration, warm-up,
  peak probes: the sweep's wall time less its rounds, per process);
* ``stats.suggest_design``: the rounds per process that spend time where the
  variance is, ``ceil(sqrt(c2/c1 * T1^2/T2^2))``, and the processes for a
  95% CI of +-1% on the speedup, with the wall time that takes;
* the same for the current defaults (``plan.DEFAULT_ROUNDS`` rounds): the
  processes and time the default protocol needs for +-1%.

Per process tribench summarises rounds by their median (noisier than the
mean for Gaussian rounds), so the processes are a lower bound.

    python bench/protocol_design.py [--target-ms 2,5] [--processes 10] [--rounds 12] [--cpu N]
"""

from __future__ import annotations

import argparse
import math
import shutil
import tempfile

import numpy as np

from tribench.harness import runfolder, runner, stats
from tribench.harness.plan import DEFAULT_ROUNDS, Sweep
from tribench.workloads.spec import MeshSpec

KERNELS = ("moller_seed", "moller_trumbore")
WORKLOAD = MeshSpec("suzanne", triangles=968, width=48, height=48, dtype="float32")
TARGET = 0.01  # relative half-width of the 95% CI


def pilot(target_ms: float, processes: int, rounds: int, root: str, cpu):
    sweep = Sweep(KERNELS, (WORKLOAD,), processes=processes, rounds=rounds, warmup=1, target_ms=target_ms)
    result = runner.start(sweep, f"{root}/pilot-{target_ms:g}ms", cpu=cpu, progress=False)
    batches = runfolder.read_batches(result.run_dir)
    timed = batches.loc[~batches["warmup"]].assign(ns=lambda f: f["elapsed_ns"] / f["tests"])
    per_round = timed.pivot_table(index=["process", "round"], columns="kernel", values="ns")
    ratio = (per_round[KERNELS[0]] / per_round[KERNELS[1]]).unstack("round").to_numpy()
    # a round's wall time: from its first batch's start to the next round's (same process)
    starts = timed.groupby(["process", "round"])["start_ns"].min().unstack("round").to_numpy()
    c1 = float(np.nanmedian(np.diff(starts, axis=1))) / 1e9
    c2 = max(result.elapsed_s / processes - rounds * c1, 0.0)
    # the batches as run: a batch is at least one pass over the rays, which may outlast target_ms
    batch_ms, one_pass = float(timed["elapsed_ns"].median()) / 1e6, bool((timed["loops"] == 1).all())
    return ratio, c1, c2, result.elapsed_s, batch_ms, one_pass


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--target-ms", default="2,5", help="batch lengths to pilot, comma-separated")
    ap.add_argument("--processes", type=int, default=10)
    ap.add_argument("--rounds", type=int, default=12)
    ap.add_argument("--cpu", type=int, help="CPU for the workers (default: the harness's, the last)")
    args = ap.parse_args()
    cpu = runner.default_cpu() if args.cpu is None else args.cpu
    print(
        f"pilot: {KERNELS[1]} against {KERNELS[0]} on {WORKLOAD.summary()}; "
        f"{args.processes} processes x {args.rounds} rounds; target: 95% CI of +-{100 * TARGET:g}% on the speedup"
    )
    root = tempfile.mkdtemp(prefix="tribench-design-")
    try:
        for target_ms in (float(t) for t in args.target_ms.split(",")):
            ratio, c1, c2, elapsed, batch_ms, one_pass = pilot(target_ms, args.processes, args.rounds, root, cpu)
            vc = stats.variance_components(ratio)
            best = stats.suggest_design(vc, round_cost=c1, process_cost=c2, target_rel_halfwidth=TARGET)
            default = stats.suggest_design(
                vc, round_cost=c1, process_cost=c2, target_rel_halfwidth=TARGET, rounds=DEFAULT_ROUNDS
            )
            ran = f"{batch_ms:.1f} ms run" + (" (one pass over the rays: no shorter batch)" if one_pass else "")
            print(
                f"\nbatches of {target_ms:g} ms asked, {ran}: pilot {elapsed:.1f} s; speedup {vc.mean:.4f}; "
                f"sd between rounds {100 * math.sqrt(vc.between_round) / vc.mean:.2f}%, "
                f"between processes {100 * math.sqrt(vc.between_process) / vc.mean:.2f}%; "
                f"c1 (a round) {1e3 * c1:.1f} ms, c2 (a process beyond its rounds) {c2:.2f} s"
            )
            print(
                f"  suggested: {best.rounds_per_process} rounds x {best.processes} processes -> "
                f"+-{100 * best.rel_halfwidth:.2f}% in about "
                f"{best.processes * (c2 + best.rounds_per_process * c1):.0f} s"
            )
            print(
                f"  defaults ({DEFAULT_ROUNDS} rounds): {default.processes} processes -> "
                f"+-{100 * default.rel_halfwidth:.2f}% in about {default.processes * (c2 + DEFAULT_ROUNDS * c1):.0f} s"
            )
    finally:
        shutil.rmtree(root)


if __name__ == "__main__":
    main()
