"""Every kernel side by side on the same ray-triangle pairs, in one process.

A quick look, not the harness's protocol (one process, so no CI across
processes): rounds interleave the kernels in a fresh random order, each batch
timed in C, and the median ns/test per kernel is printed with its ratio to
moller_seed. Run: python bench/kernels_side_by_side.py [--pairs N] [--rounds R] [--internal]
"""

import argparse
import sys
from pathlib import Path

import numpy as np

from tribench import ext
from tribench.harness.machine import describe

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from conftest import safe_pairs  # noqa: E402  (the tests' safe-margin pairs)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--pairs", type=int, default=2000, help="pairs per workload (2000 fits in L1/L2)")
    ap.add_argument("--rounds", type=int, default=30)
    ap.add_argument("--hit-rates", default="0,0.5,1")
    ap.add_argument("--internal", action="store_true", help="the internal kernels too (the seed's object forms)")
    args = ap.parse_args()
    print(describe())
    rng = np.random.default_rng(0)
    kernels = [
        k for k in ext.kernel_names(internal=args.internal) if "pairs" in ext.kernel_info(k).modes
    ]  # native kernels have no pairs
    width = max(17, *(len(k) + 1 for k in kernels))  # a column per kernel, as wide as its name
    head = "".join(f"{k:>{width}}" for k in kernels)
    print(f"{'dtype':<8}{'hit':>5}  {head}   (ns/test, x = speed vs moller_seed)")
    for dtype in (np.float32, np.float64):
        for h in map(float, args.hit_rates.split(",")):
            o, d, t = (np.ascontiguousarray(a, dtype) for a in safe_pairs(args.pairs, seed=1, hit_rate=h))
            jobs = {k: ext.make_job(k, o, d, t, "pairs") for k in kernels}
            loops = max(1, int(2e6 / (20 * args.pairs)))  # ~2 ms batches at ~20 ns/test
            times = {k: [] for k in kernels}
            for _ in range(args.rounds):
                for k in rng.permutation(kernels):
                    times[k].append(ext.time_batch(jobs[k], loops).ns_per_test)
            med = {k: float(np.median(v)) for k, v in times.items()}
            cells = "".join(f"{med[k]:>{width - 7}.2f} {med['moller_seed'] / med[k]:>5.2f}x" for k in kernels)
            print(f"{np.dtype(dtype).name:<8}{h:>5.2f}  {cells}")


if __name__ == "__main__":
    main()
