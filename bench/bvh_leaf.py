"""The BVH's leaf size: rays/s at max_leaf 4, 8, 16, 32 and 64, per lane width.

Suzanne at --triangles (default 250,000), float32, closest hit; two ray sets:
the seed's camera (--camera, default 128x128) and one diffuse bounce from
each camera hit (MeshSpec rays="bounce": incoherent). Every native kernel
(ext.bvh_kernel_names(), or --kernels) on every runnable ISA (AVX-512: 16
float lanes, AVX2: 8, the SSE baseline: 4): the lane width is what a leaf's
triangles are tested in, so the best leaf may differ per ISA. The trees come
from the BVH cache (workloads/bvh_cache.py; built on the first run).

Each configuration (rays, ISA, kernel, max_leaf) is timed in --rounds rounds,
every round all configurations once in a fresh random order, each batch
``loops`` passes over the rays (about --batch-ms). Its rate is the median over
rounds of rays / the thread's CPU time (a shared machine's descheduled time
is not counted). Printed per ray set and ISA: each kernel's rays/s at each
leaf size over its rays/s at 16, side by side, then the geometric mean over
kernels, and per ray the nodes and triangle tests of the first kernel. One
process, no CIs: a quick look at a design choice, not the harness's protocol.

    flock /tmp/tribench-timing.lock python bench/bvh_leaf.py [--quick]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from tribench import ext
from tribench.harness import layout
from tribench.harness.machine import describe
from tribench.harness.runner import default_cpu
from tribench.workloads import bvh_cache, make
from tribench.workloads.spec import MeshSpec

LEAVES = (4, 8, 16, 32, 64)
BASE = 16  # the leaf the ratios are over
RAYS = ("camera", "bounce")


def _lanes(isa: str) -> int:
    return {"avx512": 16, "avx2": 8}.get(isa, 4)  # float32 lanes per vector


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--triangles", type=int, default=250_000)
    parser.add_argument("--camera", default="128x128", help="camera WxH of both ray sets (default 128x128)")
    parser.add_argument("--kernels", nargs="+", default=list(ext.bvh_kernel_names()))
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--batch-ms", type=float, default=10.0)
    parser.add_argument("--quick", action="store_true", help="20,000 triangles, 64x64, 3 rounds")
    args = parser.parse_args()
    print(describe())
    if args.quick:
        args.triangles, args.camera, args.rounds = 20_000, "64x64", 3
    layout.pin(default_cpu())
    width, height = map(int, args.camera.split("x"))
    workloads = {
        r: make(MeshSpec("suzanne", args.triangles, rays=r, width=width, height=height, dtype="float32")) for r in RAYS
    }
    tris = workloads["camera"].triangles
    t0 = time.perf_counter()
    bvhs = {(k, leaf): bvh_cache.cached_bvh(k, tris, leaf)[0] for k in args.kernels for leaf in LEAVES}
    camera, bounce = workloads["camera"], workloads["bounce"]
    print(
        f"Suzanne {len(tris):,} triangles float32; camera {width}x{height} ({len(camera.origins):,} rays), "
        f"bounces {len(bounce.origins):,} rays ({bounce.achieved['ray_hit_rate']:.0%} hit); "
        f"trees ready in {time.perf_counter() - t0:.1f} s"
    )
    isas = [i for i, ok in ext.kernel_info(args.kernels[0]).isas.items() if ok]
    configs = [(r, isa, k, leaf) for r in RAYS for isa in isas for k in args.kernels for leaf in LEAVES]
    loops = {}
    for c in configs:  # a first pass: warm-up, and loops for a batch of about --batch-ms
        r, isa, k, leaf = c
        w = workloads[r]
        t = time.thread_time_ns()
        bvhs[k, leaf].time(w.origins, w.directions, "closest", 1, isa=isa)
        loops[c] = max(1, round(args.batch_ms * 1e6 / max(time.thread_time_ns() - t, 1)))
    rates: dict[tuple, list[float]] = {c: [] for c in configs}
    rng = np.random.default_rng(0)
    for _ in range(args.rounds):
        for i in rng.permutation(len(configs)):
            r, isa, k, leaf = c = configs[i]
            w = workloads[r]
            t = time.thread_time_ns()
            bvhs[k, leaf].time(w.origins, w.directions, "closest", loops[c], isa=isa)
            rates[c].append(loops[c] * len(w.origins) / (time.thread_time_ns() - t) * 1e9)
    rate = {c: float(np.median(v)) for c, v in rates.items()}

    head = "  ".join(f"{leaf:>6}" for leaf in LEAVES)
    for r in RAYS:
        w = workloads[r]
        for isa in isas:
            print(f"\n{r} rays, {isa} ({_lanes(isa)} lanes): rays/s over max_leaf {BASE}'s   [M rays/s at {BASE}]")
            print(f"  {'kernel':<26}{head}")
            ratios = []
            for k in args.kernels:
                row = [rate[r, isa, k, leaf] / rate[r, isa, k, BASE] for leaf in LEAVES]
                ratios.append(row)
                cells = "  ".join(f"{x:>6.3f}" for x in row)
                print(f"  {k:<26}{cells}   [{rate[r, isa, k, BASE] / 1e6:.2f}]")
            gm = np.exp(np.log(np.array(ratios)).mean(axis=0))
            print(f"  {'geometric mean':<26}" + "  ".join(f"{x:>6.3f}" for x in gm))
        counts = [bvhs[args.kernels[0], leaf].intersect(w.origins, w.directions).counts.mean(axis=0) for leaf in LEAVES]
        print(f"  per ray ({args.kernels[0]}): nodes " + " / ".join(f"{c[0]:.1f}" for c in counts), end="")
        print(", triangle tests " + " / ".join(f"{c[3]:.1f}" for c in counts))


if __name__ == "__main__":
    main()
