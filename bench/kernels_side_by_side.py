"""Every kernel side by side on the same ray-triangle pairs, in one process.

A quick look, not the harness's protocol (one process, so no CI across
processes): rounds interleave the kernels in a fresh random order, each batch
timed in C, and the median ns/test per kernel is printed with its ratio to
moller_seed. Run: python bench/kernels_side_by_side.py [--pairs N] [--rounds R] [--internal]

--before CORE times every brute-force form instead, in this build and in another
build of the extension (its _core*.so, say compiled with other flags) in the same
rounds: each kernel on the pairs (scalar kernels) and over Suzanne in closest
mode (every kernel), both precisions; the kernels both builds have. Printed: each form's
speed in this build over the other's, paired by round, with its 95% t interval, the lowest first.
"""

import argparse
import sys
from pathlib import Path

import numpy as np
from embree_native import BEFORE, other_build  # the other build, loaded as embree_native loads it

from tribench import ext
from tribench.harness import stats
from tribench.harness.machine import describe
from tribench.workloads import make
from tribench.workloads.spec import MeshSpec

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from conftest import safe_pairs  # noqa: E402  (the tests' safe-margin pairs)


def side_by_side(args, kernels: list[str], rng: np.random.Generator) -> None:
    """The table: each kernel's median ns/test on the pairs, and its speed over moller_seed's."""
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


def two_builds(args, rng: np.random.Generator) -> None:
    """Every brute-force form in this build and the other, the same rounds; this build's speed over the other's."""
    before = other_build(args.before)[0]
    mesh = make(MeshSpec("suzanne", 968, rays="camera", width=32, height=32, dtype="float64"))
    pairs = safe_pairs(args.pairs, seed=1, hit_rate=0.5)
    kernels = [k for k in ext.kernel_names(internal=args.internal) if k in before.kernel_names(internal=True)]
    forms = {}  # name -> (the build's time_batch, its job)
    for dtype in (np.float32, np.float64):
        on_pairs = [np.ascontiguousarray(a, dtype) for a in pairs] + ["pairs"]
        on_mesh = [np.ascontiguousarray(a, dtype) for a in (mesh.origins, mesh.directions, mesh.triangles)]
        for build, suffix in ((ext, ""), (before, BEFORE)):
            for k in kernels:
                for where, arrays in (("pairs", on_pairs), ("suzanne closest", on_mesh + ["closest"])):
                    if arrays[-1] in build.kernel_info(k).modes:
                        name = f"{k} {np.dtype(dtype).name} {where}{suffix}"
                        forms[name] = (build.time_batch, build.make_job(k, *arrays))
    batch_ns = args.batch_ms * 1e6
    loops = {n: max(1, round(batch_ns / max(time(job, 1).elapsed_ns, 1))) for n, (time, job) in forms.items()}
    times: dict[str, list[float]] = {n: [] for n in forms}
    for _ in range(args.rounds):
        for n in rng.permutation(list(forms)):
            time, job = forms[n]
            times[n].append(time(job, loops[n]).ns_per_test)
    ratios = {n: stats.speedup(times[n + BEFORE], times[n]) for n in forms if n + BEFORE in forms}  # in both
    for n, s in sorted(ratios.items(), key=lambda item: item[1].ratio):
        print(f"this build / before: {n:<52}{s.ratio:7.3f}  [{s.ci_low:.3f}, {s.ci_high:.3f}]")
    mean = float(np.exp(np.mean([np.log(s.ratio) for s in ratios.values()])))
    print(f"this build / before: geometric mean over {len(ratios)} forms {mean:.3f}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--pairs", type=int, default=2000, help="pairs per workload (2000 fits in L1/L2)")
    ap.add_argument("--rounds", type=int, default=30)
    ap.add_argument("--hit-rates", default="0,0.5,1")
    ap.add_argument("--internal", action="store_true", help="the internal kernels too (the seed's object forms)")
    ap.add_argument("--before", type=Path, help="another build's _core*.so: time every form in both")
    ap.add_argument("--batch-ms", type=float, default=5.0, help="with --before: each batch's length")
    args = ap.parse_args()
    print(describe())
    rng = np.random.default_rng(0)
    if args.before:
        two_builds(args, rng)
        return
    kernels = [
        k for k in ext.kernel_names(internal=args.internal) if "pairs" in ext.kernel_info(k).modes
    ]  # native kernels have no pairs
    side_by_side(args, kernels, rng)


if __name__ == "__main__":
    main()
