"""How cost per test grows with triangle count and working set (L1 -> L2 -> L3 -> memory), float32 vs float64.

Closest mode, random rays through a cloud of K random small triangles, K
from 64 to about 4M in x4 steps. Every ray tests every triangle in order, so
a pass streams the prepared records (``Job.prepared.records``: K x
bytes_per_triangle) once per ray: they stay in L1, L2 or L3 or come from
memory depending on their size, read against this machine's cache sizes
(``harness.machine.cache_bytes``). The triangles are i.i.d., the first K of
one cloud, so the mix of hits and misses per test is the same at every K:
only the working set changes (the share of rays that hit something, which
grows with K, is printed).

The rays are the first ``max(--rays, --min-tests / K)`` of one fixed set: 64
from K = 16384 on, more below, so that a pass has at least about 1M tests.
With 64 rays x 64 triangles (4096 tests a pass, repeated ``loops`` times)
the CPU's branch predictor learns the scalar kernel's early-exit branches by
heart and it looks 3x faster "in L1" than on any longer pass (``--min-tests
0`` shows it). The extra rays are read once per pass, in order (24 or 48
bytes per K tests): the records stay the working set.

Per K, the jobs of every kernel and precision are timed in interleaved
rounds (``ext.time_batch``, a fresh random order each round); a batch runs
``loops`` passes for about ``--target-ms`` (one pass for big K). Printed per
kernel and precision: median ns/test with a 95% t interval over the rounds,
the same from the thread's CPU time (robust to other processes sharing the core),
the working set and the smallest cache it fits in, and the ratio to the cost
at the largest K that fits in L1.

    python bench/scaling.py [KERNEL ...] [--rays 64] [--min-tests 1048576] [--max-k 4194304]
                            [--rounds 5] [--target-ms 20] [--pin CPU]
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np
from scipy import stats

from tribench import ext
from tribench.harness import layout
from tribench.harness.machine import cache_bytes, describe

DEFAULT_KERNELS = ("moller_trumbore", "moller_trumbore_fma")


def level(nbytes: int, caches: dict[str, int]) -> str:
    for name in ("L1d", "L2", "L3"):
        if name in caches and nbytes <= caches[name]:
            return name
    return "memory"


def cloud(k: int, rng) -> np.ndarray:
    """k small random triangles (edges about 0.02) with centres uniform in [-1, 1]^3."""
    centres = rng.uniform(-1, 1, size=(k, 1, 3))
    return np.ascontiguousarray(centres + rng.normal(0, 0.01, size=(k, 3, 3)))


def rays(n: int, rng) -> tuple[np.ndarray, np.ndarray]:
    """Origins on a sphere of radius 4, aimed at random points of the cloud's middle."""
    o = rng.normal(size=(n, 3))
    o *= 4 / np.linalg.norm(o, axis=1, keepdims=True)
    d = rng.uniform(-0.5, 0.5, size=(n, 3)) - o
    return o, d / np.linalg.norm(d, axis=1, keepdims=True)


def t_ci(x) -> tuple[float, float]:
    x = np.asarray(x, dtype=float)
    if len(x) < 2 or np.ptp(x) == 0:
        return float(x.mean()), float(x.mean())
    return tuple(float(v) for v in stats.t.interval(0.95, len(x) - 1, loc=x.mean(), scale=stats.sem(x)))


def _parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("kernels", nargs="*", help=f"more kernels (always: {', '.join(DEFAULT_KERNELS)})")
    ap.add_argument("--rays", type=int, default=64, help="rays at large K (at least)")
    ap.add_argument(
        "--min-tests",
        type=int,
        default=1 << 20,
        help="tests per pass at least (more rays at small K; 0: always --rays)",
    )
    ap.add_argument("--min-k", type=int, default=64)
    ap.add_argument("--max-k", type=int, default=4 * 1024 * 1024)
    ap.add_argument("--dtypes", default="float32,float64")
    ap.add_argument("--rounds", type=int, default=5, help="interleaved rounds per K (3 when a pass is long)")
    ap.add_argument("--target-ms", type=float, default=20.0, help="wanted batch length")
    ap.add_argument(
        "--pin",
        type=int,
        metavar="CPU",
        help="pin to this CPU (default: not pinned; the harness's workers, everyone's, pin to the last CPU)",
    )
    ap.add_argument("--rng-seed", type=int, default=0)
    return ap


def main() -> None:
    ap = _parser()
    args = ap.parse_args()
    print(describe())

    kernels = list(dict.fromkeys([*DEFAULT_KERNELS, *args.kernels]))
    for k in kernels:
        if "closest" not in ext.kernel_info(k).modes:
            ap.error(f"{k} has no closest mode")
    dtypes = args.dtypes.split(",")
    layout.pin(args.pin)
    caches = cache_bytes()
    print(
        f"caches: {', '.join(f'{n} {s // 1024} KiB' for n, s in caches.items())}; "
        f"CPUs: {sorted(os.sched_getaffinity(0))}; load average {os.getloadavg()[0]:.2f}"
    )

    rng = np.random.default_rng(args.rng_seed)
    counts = []
    k = args.min_k
    while k <= args.max_k:
        counts.append(k)
        k *= 4
    tris64 = cloud(counts[-1], rng)
    tris = {"float64": tris64, "float32": tris64.astype(np.float32)}
    n_rays = {K: max(args.rays, -(-args.min_tests // K)) for K in counts}
    o64, d64 = rays(max(n_rays.values()), rng)
    ray_sets = {"float64": (o64, d64), "float32": (o64.astype(np.float32), d64.astype(np.float32))}
    print(f"closest mode; kernels: {', '.join(kernels)}; dtypes: {', '.join(dtypes)}")

    combos = [(k, dt) for k in kernels for dt in dtypes]
    results = {c: [] for c in combos}  # per combo: (K, records bytes, samples, cpu samples, hit rate)
    for K in counts:
        jobs, loops = {}, {}
        for c in combos:
            o, d = (a[: n_rays[K]] for a in ray_sets[c[1]])
            jobs[c] = ext.make_job(c[0], o, d, tris[c[1]][:K], "closest")
            guess = np.median(results[c][-1][3]) * n_rays[K] * K if results[c] else 0.0
            if guess > 2e6 * args.target_ms:
                loops[c] = 1  # a pass from memory: nothing to warm, and the longest part of the run
            else:
                first = ext.time_batch(jobs[c], 1)  # warms the records and sizes the batch
                loops[c] = max(1, round(args.target_ms * 1e6 / max(first.elapsed_ns, 1)))
        # long passes: fewer rounds keep the run within a few minutes
        rounds = args.rounds if min(loops.values()) > 1 else min(args.rounds, 3)
        samples, cpu, share = {c: [] for c in combos}, {c: [] for c in combos}, []
        hit_rate = {}
        for _ in range(rounds):
            for i in rng.permutation(len(combos)):
                c = combos[i]
                # this thread's CPU time too: on a shared core the batch's wall time
                # includes other processes' time slices, its CPU time does not
                t0 = time.thread_time_ns()
                b = ext.time_batch(jobs[c], loops[c])
                used = time.thread_time_ns() - t0
                samples[c].append(b.ns_per_test)
                cpu[c].append(used / b.tests)
                share.append(used / b.elapsed_ns)
                hit_rate[c] = b.hits / (b.loops * n_rays[K])
        for c in combos:
            results[c].append((K, jobs[c].prepared.records.nbytes, samples[c], cpu[c], hit_rate[c]))
        del jobs
        print(
            f"  K={K:>8}: {n_rays[K]:>6} rays, {rounds} rounds, loops {min(loops.values())}-{max(loops.values())}, "
            f"rays hitting: {hit_rate[combos[0]]:.0%}, CPU share of batches: median {np.median(share):.0%}, "
            f"min {min(share):.0%}",
            flush=True,
        )

    print_table(results, kernels, dtypes, counts, caches)


def print_table(results: dict, kernels: list[str], dtypes: list[str], counts: list[int], caches: dict) -> None:
    """ns/test per kernel, precision and K, against the largest K in L1; float64 over float32."""
    combos = list(results)
    print("\nns/test: median over rounds of the C-timed batches, 95% t CI; cpu: the same from this thread's CPU time")
    print(
        f"{'kernel':<20}{'dtype':<9}{'K':>9}{'records':>11}{'fits':>8}{'ns/test':>10}{'95% CI':>20}"
        f"{'x in-L1':>9}{'cpu ns/test':>13}{'x in-L1':>9}"
    )
    for c in combos:
        rows = results[c]
        in_l1 = [r for r in rows if r[1] <= caches.get("L1d", 0)] or rows[:1]
        # the largest K in L1: least per-ray overhead
        base, cpu_base = float(np.median(in_l1[-1][2])), float(np.median(in_l1[-1][3]))
        for K, nbytes, s, cs, _ in rows:
            lo, hi = t_ci(s)
            med, cmed = float(np.median(s)), float(np.median(cs))
            size = f"{nbytes / 1024:.0f} KiB" if nbytes < 1 << 20 else f"{nbytes / (1 << 20):.1f} MiB"
            print(
                f"{c[0]:<20}{c[1]:<9}{K:>9}{size:>11}{level(nbytes, caches):>8}{med:>10.3f}"
                f"{f'[{lo:.3f}, {hi:.3f}]':>20}{med / base:>9.2f}{cmed:>13.3f}{cmed / cpu_base:>9.2f}"
            )
        print()
    # the precision question at each K: float64's cost over float32's
    for kernel in kernels:
        if {"float32", "float64"} <= set(dtypes):
            f32, f64 = results[kernel, "float32"], results[kernel, "float64"]
            ratios = " ".join(f"{np.median(b[3]) / np.median(a[3]):.2f}" for a, b in zip(f32, f64, strict=True))
            print(f"{kernel}: float64 / float32 cpu ns/test by K ({', '.join(map(str, counts))}): {ratios}")


if __name__ == "__main__":
    main()
