"""tribench's BVH against native Embree, side by side: issue #28's targets.

Suzanne at --triangles (default 250,000 and 1,000,000), float32, closest hit,
one core; two ray sets: the seed's camera (--camera, default 256x256) and one
diffuse bounce from each camera hit (MeshSpec rays="bounce": incoherent).
Contenders on the same arrays:

  tribench   every BVH leaf kernel but the culling ones (--kernels) through ext.build_bvh's default
             (wide) tree, on its own ISA and held to AVX2 (isa="avx2"), the same through the
             binary tree it is collapsed from (layout="binary", named "... binary"), and the wide
             tree walked by packets of 16 consecutive rays (layout="packets", "... packets");
  embree     native Embree 3 (tribench.ext.embree, its C API): rtcIntersect1,
             rtcIntersect16 over packets of 16 consecutive rays, both in
             robust (watertight) mode, and both held to AVX2 (its device's max_isa)
             where the CPU has AVX-512: tribench's avx2 forms are set beside these too.

Every loop is timed in C around it. Each round runs every contender once in
a fresh random order, each batch ``loops`` passes (about --batch-ms). Printed
per mesh and ray set: each contender's rays/s (median over rounds); the
best single-ray form's ratio over each Embree call and over its own binary tree, and the best
packet form's over Embree's packets (rtcIntersect16) and its own single rays: the geometric mean over
rounds of the per-round ratio with its 95% t interval (rounds paired: one
process, so the interval covers round-to-round noise, not process layout).
Answers are checked first: a contender is timed only where its closest
triangle agrees with the float64 reference but on ambiguous rays.

--before CORE sets another build of the extension (its _core*.so, say from the commit
before a change to the C) beside this one in the same rounds: each tribench form is
timed in both, and its ratio (this build over the other) is printed, the lowest first.
Run it alone:

    flock /tmp/tribench-timing.lock python bench/embree_native.py [--quick] [--before CORE]
"""

from __future__ import annotations

import argparse
import importlib
import shutil
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from tribench import ext
from tribench.ext import embree
from tribench.harness import layout, stats
from tribench.harness.machine import describe
from tribench.harness.runner import default_cpu
from tribench.workloads import bvh_cache, make
from tribench.workloads.spec import MeshSpec

RAYS = ("camera", "bounce")
EMBREE = {
    "rtcIntersect1": (False, 1, None),
    "rtcIntersect16": (False, 16, None),
    "robust 1": (True, 1, None),
    "robust 16": (True, 16, None),
    "rtcIntersect1 avx2": (False, 1, "avx2"),  # Embree held to AVX2, the peer of tribench's avx2 forms
    "rtcIntersect16 avx2": (False, 16, "avx2"),
}


BEFORE = " (before)"  # the suffix of the other build's forms


def other_build(core: Path):
    """The installed package again, as ``tribench_before``, around another build of its extension (its
    imports are relative, so the copy is a package of its own, with its own ``_core``)."""
    root, module = Path(ext.__file__).parents[1], Path(ext._core.__file__).name
    copy = Path(tempfile.mkdtemp()) / "tribench_before"
    skip = shutil.ignore_patterns(".*", "build", "tests", "docs", "bench", "examples", "*.so")
    shutil.copytree(root, copy, ignore=skip)
    shutil.copy(core, copy / "ext" / module)
    sys.path.insert(0, str(copy.parent))
    return tuple(importlib.import_module(f"tribench_before.{m}") for m in ("ext", "workloads.bvh_cache"))


def contenders(tris: np.ndarray, kernels: list[str], before=None) -> dict[str, object]:
    """Name -> a call ``(o, d, loops) -> elapsed ns`` (timed in C), and each one's closest-hit call."""
    calls, answers = {}, {}
    builds = [("", ext, bvh_cache)] + ([(BEFORE, *before)] if before else [])
    for (suffix, build, cache), k in ((b, k) for k in kernels for b in builds):
        bvh = cache.cached_bvh(k, tris)[0]
        isas = [i for i, ok in build.kernel_info(k).isas.items() if ok and i in ("avx512", "avx2")]
        for isa, tree in ((i, t) for i in isas for t in build.LAYOUTS):
            name = f"{k} {isa}" + ("" if tree == "wide" else f" {tree}") + suffix
            calls[name] = lambda o, d, n, b=bvh, i=isa, t=tree: b.time(o, d, "closest", n, isa=i, layout=t).elapsed_ns
            answers[name] = lambda o, d, b=bvh, i=isa, t=tree: b.intersect(o, d, isa=i, layout=t).hits.index
    for name, (robust, width, isa) in EMBREE.items():
        if isa not in embree.isas_here():
            continue
        scene = embree.EmbreeScene(tris, robust, isa)
        calls[f"embree {name}"] = lambda o, d, n, s=scene, w=width: s.trace(o, d, None, w, n).elapsed_ns
        answers[f"embree {name}"] = lambda o, d, s=scene, w=width: s.intersect(o, d, width=w)[0]
    return {"calls": calls, "answers": answers}


def measure(w, named: dict, rounds: int, batch_ms: float, rng: np.random.Generator) -> dict[str, list[float]]:
    """Rays/s per contender per round; a contender whose answers differ from the reference is left out."""
    o, d = w.origins, w.directions
    calls = {}
    for name, answer in named["answers"].items():
        wrong = (answer(o, d) != w.ref_index) & ~w.ambiguous()
        if wrong.any():
            print(f"  left out: {name} differs from the reference on {int(wrong.sum())} unambiguous rays")
        else:
            calls[name] = named["calls"][name]
    loops = {n: max(1, round(batch_ms * 1e6 / max(call(o, d, 1), 1))) for n, call in calls.items()}
    rates: dict[str, list[float]] = {n: [] for n in calls}
    for _ in range(rounds):
        for n in rng.permutation(list(calls)):
            rates[n].append(loops[n] * len(o) / calls[n](o, d, loops[n]) * 1e9)
    return rates


def report_builds(rates: dict[str, list[float]]) -> None:
    """Each tribench form's speed in this build over the other's, paired by round, the lowest first."""
    pairs = [(n.removesuffix(BEFORE), n) for n in rates if n.endswith(BEFORE) and n.removesuffix(BEFORE) in rates]
    ratios = {now: stats.speedup(1 / np.array(rates[then]), 1 / np.array(rates[now])) for now, then in pairs}
    for n, s in sorted(ratios.items(), key=lambda item: item[1].ratio):
        print(f"  this build / before: {n:<34}{s.ratio:7.3f}  [{s.ci_low:.3f}, {s.ci_high:.3f}]")
    if ratios:
        mean = float(np.exp(np.mean([np.log(s.ratio) for s in ratios.values()])))
        print(f"  this build / before: geometric mean over {len(ratios)} forms {mean:.3f}")


def report(label: str, rates: dict[str, list[float]]) -> None:
    print(f"\n{label}")
    report_builds(rates)
    rates = {n: r for n, r in rates.items() if not n.endswith(BEFORE)}
    median = {n: float(np.median(r)) for n, r in rates.items()}
    for n in sorted(rates, key=median.__getitem__, reverse=True):
        print(f"  {n:<34}{median[n] / 1e6:8.2f} M rays/s")
    # single rays (the wide tree) face every Embree call; packets face Embree's packets
    for walk, suffix, widths in (("single rays", "", (1, 16)), ("packets", " packets", (16,))):
        for isa in ("avx512", "avx2"):
            held = [n for n in rates if n.endswith(f"{isa}{suffix}") and not n.startswith("embree")]
            if not held:
                continue
            top = max(held, key=median.__getitem__)
            embree_calls = {m: EMBREE[m.removeprefix("embree ")] for m in rates if m.startswith("embree")}
            peers = [m for m, (_, w, held_to) in embree_calls.items() if w in widths and (isa == "avx2" or not held_to)]
            for call in (f"rtcIntersect{w}" for w in widths):  # the target: Embree at its fastest ISA here
                forms = [m for m in rates if m in (f"embree {call}", f"embree {call} avx2")]
                fastest = max(forms, key=median.__getitem__, default=None)
                if fastest is not None and fastest not in peers:
                    peers.append(fastest)  # Embree held to AVX2 outran its own pick: the AVX-512 forms face it too
            own = [f"{top.removesuffix(suffix)} binary"] if not suffix else [top.removesuffix(suffix)]
            for n in peers + [m for m in own if m in rates]:
                s = stats.speedup(1 / np.array(rates[n]), 1 / np.array(rates[top]))
                print(f"  {walk}: {top} / {n:<24}{s.ratio:7.3f}  [{s.ci_low:.3f}, {s.ci_high:.3f}]")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--triangles", type=int, nargs="+", default=[250_000, 1_000_000])
    parser.add_argument("--camera", default="256x256", help="camera WxH of both ray sets (default 256x256)")
    # culling kernels answer the front-face question, Embree the two-sided one: not the same work
    parser.add_argument(
        "--kernels", nargs="+", default=[k for k in ext.bvh_kernel_names() if not ext.kernel_info(k).culls_back_faces]
    )
    parser.add_argument("--rounds", type=int, default=7)
    parser.add_argument("--batch-ms", type=float, default=30.0)
    parser.add_argument("--quick", action="store_true", help="20,000 triangles, 64x64, 3 rounds")
    parser.add_argument("--before", type=Path, help="another build's _core*.so, timed beside this one")
    args = parser.parse_args()
    if args.quick:
        args.triangles, args.camera, args.rounds = [20_000], "64x64", 3
    if (why := embree.missing()) is not None:
        raise SystemExit(why)
    layout.pin(default_cpu())  # one core, for tribench and Embree alike
    width, height = map(int, args.camera.split("x"))
    rng = np.random.default_rng(0)
    before = other_build(args.before) if args.before else None
    print(describe())
    print(f"{embree.version()}; tribench {ext.kernel_info(args.kernels[0]).isa} machine; one core, float32")
    for n in args.triangles:
        t0 = time.perf_counter()
        spec = {"width": width, "height": height, "dtype": "float32"}
        workloads = {r: make(MeshSpec("suzanne", n, rays=r, **spec)) for r in RAYS}
        named = contenders(workloads["camera"].triangles, args.kernels, before)
        print(f"Suzanne {len(workloads['camera'].triangles):,} triangles: ready in {time.perf_counter() - t0:.0f} s")
        for r in RAYS:
            w = workloads[r]
            report(f"{r}: {len(w.origins):,} rays", measure(w, named, args.rounds, args.batch_ms, rng))


if __name__ == "__main__":
    main()
