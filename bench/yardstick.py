"""The kernels beside a plain AVX2 intrinsics Moller-Trumbore, in one run: a yardstick.

``moller_trumbore_yardstick`` (an internal kernel: AVX2 intrinsics, 8 float
lanes, no FMA, edges recomputed, every lane through all the work, one
division per vector) is timed by the same C loop as the kernels, in the same
process, on the same rays. Rounds interleave every (kernel, ISA) in a fresh
random order; each batch is timed in C (about 2 ms). Printed per workload:
the median and the best (least disturbed: the machine is shared) ns/test,
the median over rounds of each one's ratio to the yardstick (>1: slower than
the yardstick) with the 10-90% range of those per-round ratios. One process,
so this is a quick look, not the harness's protocol (no CI across processes).

Workloads (float32 unless --dtype):
  camera   Suzanne subdivided to 1,280 triangles, 128 x 128 camera rays,
           closest hit (issue #18's workload);
  mesh h   the same mesh, rays of which a fraction h hit it (per ray);
  stack h  every ray through a stack of 1,280 unit triangles of which a
           fraction h (random, per test) contain its crossing point: the
           early exit's question per hit rate of the tests themselves.

    flock /tmp/tribench-timing.lock python bench/yardstick.py [--rounds N] [--dtype float32]
"""

from __future__ import annotations

import argparse

import numpy as np

from tribench import ext, workloads
from tribench.harness.machine import describe
from tribench.workloads.spec import MeshSpec

YARDSTICK = "moller_trumbore_yardstick"


def all_forms() -> list[tuple[str, str | None]]:
    """(kernel, ISA or None for its default): the scalar Moller form, every algorithm's native
    form (the registry's, ext.bvh_kernel_names), and the native Moller forms held to AVX2 as
    well (what an AVX2-only machine would run)."""
    return [
        (YARDSTICK, "avx2"),
        ("moller_trumbore", None),
        *((k, None) for k in ext.bvh_kernel_names()),
        ("moller_trumbore_fma", "avx2"),
        ("moller_trumbore_fma_exit", "avx2"),
    ]


def stack(n_tris: int, n_rays: int, hit_rate: float, dtype: type, rng_seed: int = 0) -> tuple:
    """Rays straight down through n_tris unit triangles at z = -1, -2, ...;
    a fraction hit_rate of them (random) contain the rays' crossing points,
    the others are shifted 2 along x (their u test fails first)."""
    rng = np.random.default_rng(rng_seed)
    unit = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], float)
    tris = np.tile(unit, (n_tris, 1, 1))
    tris[:, :, 2] = -1.0 - np.arange(n_tris)[:, None]
    missed = rng.permutation(n_tris) >= round(hit_rate * n_tris)
    tris[missed, :, 0] += 2.0
    o = np.column_stack([0.25 + 0.05 * rng.random(n_rays), 0.25 + 0.05 * rng.random(n_rays), np.ones(n_rays)])
    d = np.tile([0.0, 0.0, -1.0], (n_rays, 1))
    return (np.ascontiguousarray(a, dtype) for a in (o, d, tris))


def runnable(kernel: str, isa: str | None) -> bool:
    return isa is None or ext.kernel_info(kernel).isas.get(isa, False)


def bench(name: str, o: np.ndarray, d: np.ndarray, tris: np.ndarray, rounds: int, rng: np.random.Generator) -> None:
    forms = [f for f in all_forms() if runnable(*f)]
    jobs = {f: ext.make_job(f[0], o, d, tris, "closest", isa=f[1]) for f in forms}
    tests = len(o) * len(tris)
    loops = max(1, int(2e6 / tests))  # about 2 ms per batch at 1 ns/test
    times: dict[tuple, list[float]] = {f: [] for f in forms}
    for _ in range(rounds):
        for i in rng.permutation(len(forms)):
            times[forms[i]].append(ext.time_batch(jobs[forms[i]], loops).ns_per_test)
    base = np.array(times[(YARDSTICK, "avx2")])
    print(f"\n{name}: {len(tris)} triangles, {len(o)} rays, {o.dtype}, closest, {rounds} rounds x {loops} passes")
    print(f"  {'kernel':<26}{'isa':<9}{'median':>8}{'best':>8}{'/ yardstick':>13}{'10-90%':>16}")
    for f in forms:
        ratio = np.array(times[f]) / base
        lo, hi = np.percentile(ratio, [10, 90])
        isa = f[1] or ext.kernel_info(f[0]).isa
        ns = f"{np.median(times[f]):>8.3f}{min(times[f]):>8.3f}"
        print(f"  {f[0]:<26}{isa:<9}{ns}{np.median(ratio):>13.3f}  [{lo:.3f}, {hi:.3f}]")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=15)
    ap.add_argument("--dtype", default="float32", choices=["float32", "float64"])
    ap.add_argument("--hit-rates", default="0,0.5,1")
    ap.add_argument("--only", choices=["camera", "mesh", "stack"], help="one workload family")
    args = ap.parse_args(argv)
    if not ext.kernel_info(YARDSTICK).isas.get("avx2"):
        print("this CPU has no AVX2 + FMA: no yardstick to compare with")
        return 1
    rng = np.random.default_rng(0)
    dtype = np.dtype(args.dtype).type
    print(describe())
    if args.only in (None, "camera"):
        w = workloads.make(MeshSpec("suzanne", triangles=1280, width=128, height=128, dtype=args.dtype))
        bench("camera", w.origins, w.directions, w.triangles, args.rounds, rng)
    for h in map(float, args.hit_rates.split(",")):
        if args.only in (None, "mesh"):
            spec = MeshSpec("suzanne", triangles=1280, rays="hit_rate", hit_rate=h, n_rays=4096, dtype=args.dtype)
            w = workloads.make(spec)
            bench(f"mesh, rays hitting {h:.0%}", w.origins, w.directions, w.triangles, args.rounds, rng)
        if args.only in (None, "stack"):
            bench(f"stack, tests hitting {h:.0%}", *stack(1280, 512, h, dtype), args.rounds, rng)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
