"""Against peers: rays/s of tribench's best brute-force kernel vs trimesh and Embree.

The same camera workload for all (Suzanne, 968 triangles, 512x512 pinhole
camera, closest hit, float32 arrays): tribench's fastest registered kernel
(picked here by timing every public kernel with a closest mode on a random
subset of the rays), trimesh's own intersector
(``trimesh.ray.ray_triangle.RayMeshIntersector``: NumPy with an rtree broad
phase, so it needs ``rtree``), and Embree through ``embreex``
(``trimesh.ray.ray_pyembree.RayMeshIntersector``; ``pip install
'tribench[peers]'``). Repetitions interleave the contenders (A B C A B C ...);
medians of rays/s are printed with 95% t intervals of the geometric mean over
repetitions, and the ratios of paired repetitions likewise.

What is timed: tribench once in C (``ext.time_batch``, the kernel loop only),
once as the wall time of that call, and once as the wall time of
``ext.intersect`` (checks, preparing the records, the run and the output
arrays: the like of a peer's one call). The peers: the wall time of
``intersects_first`` (Embree's BVH is built once before, and its build time
printed apart). trimesh is slow, so it runs on a fixed random subset of the
rays (``--trimesh-rays``), scaled to rays/s. Every contender gets one core:
the process is pinned to one CPU, the first (the harness's workers,
anyone's, pin to the last), and runs one BLAS thread (OpenBLAS starts its
threads at NumPy's import, unpinned, and they spun on the second CPU during
trimesh's NumPy work: the Embree contender showed 180% CPU). Each call
follows a 0.1 s pause. The process's CPU time over wall time is printed per
contender (100% at most; below: other processes took the core), and rays
per CPU-second, which such sharing does not lower. Each peer's closest triangle is
compared with tribench's on the rays it ran (shared edges make a few
legitimate differences; those on the workload's ambiguous rays are counted).

    python bench/peers.py [--width 512] [--height 512] [--reps 15] [--trimesh-rays 8192] [--pin CPU]
"""

from __future__ import annotations

import argparse
import os
import time

# One BLAS thread: OpenBLAS starts its threads when NumPy is imported, before
# the process is pinned, so they would keep both CPUs and spin on the second
# during trimesh's NumPy work (the Embree contender measured 180% CPU).
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402  (after the thread settings)
from scipy import stats  # noqa: E402

from tribench import ext  # noqa: E402
from tribench.workloads import cache  # noqa: E402
from tribench.workloads.spec import MeshSpec  # noqa: E402


def geo_ci(x) -> tuple[float, float, float]:
    """Geometric mean and its 95% t interval (ratios and rates are multiplicative)."""
    logs = np.log(np.asarray(x, dtype=float))
    if len(logs) < 2 or np.ptp(logs) == 0:
        return (float(np.exp(logs.mean())),) * 3
    lo, hi = stats.t.interval(0.95, len(logs) - 1, loc=logs.mean(), scale=stats.sem(logs))
    return float(np.exp(logs.mean())), float(np.exp(lo)), float(np.exp(hi))


def pick_kernel(w, n_subset: int, rounds: int, rng) -> str:
    """Time every public closest-mode kernel on a ray subset, interleaved; print and return the fastest.

    Judged by the thread's CPU time per test: on a shared core, wall time also
    counts other processes' time slices, which can reorder close kernels."""
    kernels = [k for k in ext.kernel_names() if "closest" in ext.kernel_info(k).modes]
    sub = np.sort(rng.choice(len(w.origins), size=min(n_subset, len(w.origins)), replace=False))
    o, d = np.ascontiguousarray(w.origins[sub]), np.ascontiguousarray(w.directions[sub])
    jobs = {k: ext.make_job(k, o, d, w.triangles, "closest") for k in kernels}
    times, cpu = {k: [] for k in kernels}, {k: [] for k in kernels}
    for _ in range(rounds):
        for k in rng.permutation(kernels):
            t0 = time.thread_time_ns()
            b = ext.time_batch(jobs[k], 1)
            cpu[k].append((time.thread_time_ns() - t0) / b.tests)
            times[k].append(b.ns_per_test)
    med = {k: float(np.median(v)) for k, v in cpu.items()}
    best = min(med, key=med.get)
    print(f"kernel choice: {len(sub)} random rays x {len(w.triangles)} triangles, closest, "
          f"{rounds} interleaved rounds; median ns/test by CPU time (and C-timed wall)")
    for k in kernels:
        info = ext.kernel_info(k)
        form = f"x{info.lanes}/{info.isa}" if info.lanes > 1 else "scalar"
        print(f"  {k:<25}{form:<10}{med[k]:8.3f} ({np.median(times[k]):7.3f})  {med[k] / med[best]:5.2f}x"
              f"{'  <- fastest' if k == best else ''}")
    return best


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--width", type=int, default=512)
    ap.add_argument("--height", type=int, default=512)
    ap.add_argument("--triangles", type=int, default=968, help="Suzanne's triangle count (968 is the seed's mesh)")
    ap.add_argument("--reps", type=int, default=15, help="interleaved repetitions of every contender")
    ap.add_argument("--trimesh-rays", type=int, default=8192, help="random rays trimesh runs (it is slow)")
    ap.add_argument("--pick-rays", type=int, default=8192, help="random rays for choosing the kernel")
    ap.add_argument("--kernel", help="skip the choice and use this kernel")
    ap.add_argument("--pin", type=int, metavar="CPU", default=min(os.sched_getaffinity(0)),
                    help="pin the process to this CPU (default: the first; -1: do not pin)")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()

    if args.pin >= 0:
        os.sched_setaffinity(0, {args.pin})
    print(f"CPUs: {sorted(os.sched_getaffinity(0))}; load average {os.getloadavg()[0]:.2f}")
    rng = np.random.default_rng(args.seed)
    spec = MeshSpec("suzanne", triangles=args.triangles, rays="camera", width=args.width,
                    height=args.height, dtype="float32")
    w = cache.make(spec)
    o, d, tris = w.origins, w.directions, w.triangles
    n = len(o)
    print(f"workload: {spec.summary()}: {n} rays, {len(tris)} triangles, "
          f"{(w.ref_index >= 0).mean():.1%} of rays hit")

    kernel = args.kernel or pick_kernel(w, args.pick_rays, 7, rng)
    job = ext.make_job(kernel, o, d, tris, "closest")

    import trimesh
    from trimesh.ray import ray_triangle

    mesh = trimesh.Trimesh(**trimesh.triangles.to_kwargs(tris.astype(np.float64)), process=False)
    sub = np.sort(rng.choice(n, size=min(args.trimesh_rays, n), replace=False))
    o_sub, d_sub = o[sub].astype(np.float64), d[sub].astype(np.float64)
    try:
        import rtree  # noqa: F401  (trimesh's intersector needs it for its broad phase)
        slow = ray_triangle.RayMeshIntersector(mesh)
    except ImportError:
        slow = None
        print("trimesh's ray_triangle needs rtree, not installed (pip install rtree): trimesh skipped")
    try:
        from trimesh.ray import ray_pyembree
    except ImportError:
        embree = None
        print("embreex not installed (pip install 'tribench[peers]')")
    else:
        import embreex

        embree = ray_pyembree.RayMeshIntersector(mesh)
        t0 = time.perf_counter()
        embree.intersects_first(o[:1], d[:1])  # builds and caches the BVH
        print(f"embreex {getattr(embreex, '__version__', '?')}: BVH built in "
              f"{(time.perf_counter() - t0) * 1e3:.1f} ms (not in the figures)")

    rates = {name: [] for name in ("c", "call", "intersect", "trimesh", "embree")}
    share = {name: [] for name in rates}  # process CPU time / wall time per call
    cpu_rates = {name: [] for name in rates}  # rays per CPU-second of the process
    answers = {}

    def timed(name, rays, call):
        time.sleep(0.1)  # lets the previous contender's helper threads go idle
        t0, c0 = time.perf_counter_ns(), time.process_time_ns()
        out = call()
        wall, used = time.perf_counter_ns() - t0, time.process_time_ns() - c0
        rates[name].append(rays / wall * 1e9)
        share[name].append(used / wall)
        cpu_rates[name].append(rays / max(used, 1) * 1e9)
        return out

    for _ in range(args.reps):
        # tribench: the C-timed batch and its call's wall time, then the whole intersect call
        batch = timed("call", n, lambda: ext.time_batch(job, 1))
        rates["c"].append(n / batch.elapsed_ns * 1e9)
        share["c"].append(share["call"][-1])
        cpu_rates["c"].append(cpu_rates["call"][-1])
        hits = timed("intersect", n, lambda: ext.intersect(kernel, o, d, tris, "closest"))
        answers.setdefault("tribench", hits.index)
        if slow is not None:
            answers.setdefault("trimesh", timed("trimesh", len(sub), lambda: slow.intersects_first(o_sub, d_sub)))
        if embree is not None:
            answers.setdefault("embree", timed("embree", n, lambda: embree.intersects_first(o, d)))

    mine = answers["tribench"]
    ambiguous = w.ambiguous()
    labels = {
        "c": (f"tribench {kernel} (C-timed)", n),
        "call": ("tribench (wall, time_batch)", n),
        "intersect": ("tribench (wall, ext.intersect)", n),
        "trimesh": ("trimesh ray_triangle (wall)", len(sub)),
        "embree": ("Embree/embreex via trimesh (wall)", n),
    }
    print(f"\n{args.reps} interleaved repetitions; rays/s: median, geometric mean and its 95% t CI; "
          f"CPU: process CPU time / wall time; rays/CPU-s: rays per second of the process's CPU time (medians)")
    print(f"{'contender':<40}{'rays':>8}{'median':>11}{'geo-mean':>11}   {'95% CI':<24}{'CPU':>5}"
          f"{'rays/CPU-s':>12}   closest triangle agrees with")
    for key, (label, rays) in labels.items():
        if not rates[key]:
            continue
        gm, lo, hi = geo_ci(rates[key])
        agree = ""
        if key == "c":  # tribench against the workload's float64 reference
            diff = mine != w.ref_index
            agree = f"reference: {1 - diff.mean():.5f} ({diff.sum()} differ, {(diff & ambiguous).sum()} ambiguous)"
        elif key in answers:
            rows = sub if key == "trimesh" else slice(None)
            diff = answers[key] != mine[rows]
            agree = f"tribench: {1 - diff.mean():.5f} ({diff.sum()} differ, {(diff & ambiguous[rows]).sum()} ambiguous)"
        ci = f"[{lo:.4g}, {hi:.4g}]"
        print(f"{label:<40}{rays:>8}{np.median(rates[key]):>11.4g}{gm:>11.4g}   {ci:<24}"
              f"{np.median(share[key]):>5.0%}{np.median(cpu_rates[key]):>12.4g}   {agree}")

    print("\nratios of rays/s, paired by repetition (>1: the first is faster): median, geo-mean, its 95% t CI")
    pairs = [("c", "trimesh"), ("intersect", "trimesh"), ("c", "embree"), ("intersect", "embree"),
             ("embree", "trimesh"), ("c", "intersect")]
    for a, b in pairs:
        if not rates[a] or not rates[b]:
            continue
        r = np.asarray(rates[a]) / np.asarray(rates[b])
        gm, lo, hi = geo_ci(r)
        print(f"  {labels[a][0]:<40} / {labels[b][0]:<34}{np.median(r):>9.3f}{gm:>9.3f}   [{lo:.3f}, {hi:.3f}]")
    if slow is not None:
        print(f"(trimesh ran {len(sub)} of the {n} rays, a uniform random sample: its rays/s is scaled from those)")


if __name__ == "__main__":
    main()
