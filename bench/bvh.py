"""The BVH (ext/bvh.h): build rate, and rays/s and traversal counts for camera rays.

Meshes: Suzanne, placed as tribench places it, loop-subdivided 2-5 times
(trimesh; 15,488 / 61,952 / 247,808 / 991,232 triangles), float32.

Printed:
  build     per mesh, the best of --reps builds: the C build alone
            (binned SAH, tribench.ext._core.bvh_build) and the whole
            ext.build_bvh (C build + exact flat test + the kernel's records
            in leaf order), in triangles/s, with nodes, leaves, slots;
  trace     camera rays (the seed's camera, --camera WxH) against the
            247,808-triangle mesh (--trace-level), closest hit, single rays,
            one core: rays/s of each --kernels kernel in BVH mode (best and
            median of --reps batches of about --batch-ms, each timed in C;
            and by the process's CPU time), nodes, box tests,
            leaves and triangle tests per ray, and the same traversal with a
            null leaf test (t_max = each ray's closest hit, so it traverses
            as a ray that found its hit at once): the leaf test's share of
            trace time is 1 - null / real (median CPU times);

Against native Embree, side by side with intervals: bench/embree_native.py.

One process, no CIs: a quick look, not the harness's protocol. Run it alone:

    flock /tmp/tribench-timing.lock python bench/bvh.py [--quick] [--camera 512x512] [--reps 5] [--batch-ms 50]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from tribench import ext
from tribench.ext import _core
from tribench.harness import layout
from tribench.harness.machine import describe
from tribench.harness.runner import default_cpu
from tribench.workloads import meshes
from tribench.workloads.rays import camera_rays


def suzanne(level: int) -> np.ndarray:
    """Suzanne, placed, loop-subdivided ``level`` times: float64 (K, 3, 3)."""
    import trimesh

    v, f = meshes.base_mesh("suzanne")
    v, f = trimesh.remesh.subdivide_loop(meshes.place("suzanne", v), f, iterations=level)
    return np.asarray(v, np.float64)[np.asarray(f)]


def bench_build(tris: np.ndarray, reps: int) -> None:
    n = len(tris)
    nodes, order = np.empty((2 * n - 1, 8), tris.dtype), np.empty(n, np.int64)
    # the tree build_bvh makes: its default leaf size
    leaf = ext.DEFAULT_MAX_LEAF
    c_best = min(_timed(lambda: _core.bvh_build(tris.itemsize, tris, n, leaf, nodes, order)) for _ in range(reps))
    full_best = min(_timed(lambda: ext.build_bvh("moller_trumbore_fma", tris)) for _ in range(reps))
    bvh = ext.build_bvh("moller_trumbore_fma", tris)
    print(
        f"build  {n:>9,} tris  C {n / c_best:>12,.0f} tris/s ({c_best * 1e3:7.1f} ms)   "
        f"build_bvh {n / full_best:>12,.0f} tris/s ({full_best * 1e3:7.1f} ms)   "
        f"nodes {bvh.n_nodes:,}  leaves {len(bvh.leaves):,}  slots/tris {bvh.n_slots / n:.2f}"
    )


def _cpu(call, *args, **options) -> tuple:
    """The call's result and the process's CPU seconds during it: on a shared
    machine, time the process spends descheduled is not counted (wall time is)."""
    c0 = time.process_time()
    result = call(*args, **options)
    return result, time.process_time() - c0


def _timed(call) -> float:
    t0 = time.perf_counter()
    call()
    return time.perf_counter() - t0


def bench_trace(
    tris: np.ndarray, o: np.ndarray, d: np.ndarray, kernels: list[str], reps: int, batch_ms: float
) -> np.ndarray | None:
    """Prints rays/s and counts per kernel; returns the first kernel's closest indices.

    A batch is ``loops`` passes, enough for about ``batch_ms`` in C: the CPU time is taken around the
    call, which also checks the rays in Python (20-30 ns a ray, once per call), so one pass a call
    would count those checks in the trace and in the null traversal alike."""
    first = None
    for kernel in kernels:
        bvh = ext.build_bvh(kernel, tris)
        tr = bvh.intersect(o, d)
        first = tr.hits.index if first is None else first
        t_hit = np.where(tr.hits.hit, tr.hits.t * np.float32(1 + 1e-6), np.inf).astype(tris.dtype)
        warm = bvh.time(o, d, "closest", 1)  # warm-up: pages, caches, clock; sizes the batch
        loops = max(1, round(batch_ms * 1e6 / max(warm.elapsed_ns, 1)))
        real, null, real_cpu, null_cpu = [], [], [], []
        for _ in range(reps):
            for out, cpu, options in ((real, real_cpu, {}), (null, null_cpu, {"t_max": t_hit, "null_leaf": True})):
                batch, seconds = _cpu(bvh.time, o, d, "closest", loops, **options)
                out.append(batch)
                cpu.append(seconds)
        rate = sorted(b.rays_per_s for b in real)
        b, m = real[0], loops * len(o)  # counts are summed over every pass
        share = 1 - np.median(null_cpu) / np.median(real_cpu)
        print(
            f"trace  {kernel} ({ext.kernel_info(kernel).isa}): {rate[-1] / 1e6:6.2f} M rays/s best wall (timed in C), "
            f"{np.median(rate) / 1e6:6.2f} median; {m / min(real_cpu) / 1e6:6.2f} best by CPU time; "
            f"{loops} passes a batch"
        )
        print(
            f"       per ray: nodes {b.nodes / m:.1f}, box tests {b.box_tests / m:.1f}, leaves {b.leaves / m:.1f}, "
            f"triangle tests {b.triangle_tests / m:.1f}; hits {b.hits / m:.1%}"
        )
        print(
            f"       null leaf (t_max = the hit): {m / min(null_cpu) / 1e6:6.2f} M rays/s best by CPU time, "
            f"nodes {null[0].nodes / m:.1f}/ray; leaf test share of trace time (median CPU times) {share:.0%}"
        )
    return first


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--quick", action="store_true", help="meshes up to 61,952 triangles, 128x128 rays, 3 reps")
    parser.add_argument("--camera", default="256x256", help="camera rays WxH (default 256x256)")
    parser.add_argument("--reps", type=int, default=5)
    parser.add_argument("--trace-level", type=int, default=4, help="subdivisions of the traced mesh (4: 247,808)")
    parser.add_argument("--kernels", nargs="+", default=["moller_trumbore_fma", "moller_trumbore_fma_exit"])
    parser.add_argument("--batch-ms", type=float, default=50.0, help="passes a batch for about this long (C-timed)")
    args = parser.parse_args()
    print(describe())
    layout.pin(default_cpu())  # one core
    levels = [2, 3] if args.quick else [2, 3, 4, 5]
    width, height = (128, 128) if args.quick else map(int, args.camera.split("x"))
    reps = 3 if args.quick else args.reps
    trace_level = min(args.trace_level, levels[-1])
    traced = None
    for level in levels:
        tris = np.ascontiguousarray(suzanne(level), np.float32)
        bench_build(tris, reps)
        if level == trace_level:
            traced = tris
    assert traced is not None
    o, d = (np.ascontiguousarray(a, np.float32) for a in camera_rays(width, height))
    print(f"camera {width}x{height} rays, Suzanne {len(traced):,} triangles, float32, one thread")
    bench_trace(traced, o, d, args.kernels, reps, args.batch_ms)


if __name__ == "__main__":
    main()
