"""What a ray costs tribench's BVH and native Embree, counted by Valgrind: issue #28's "why".

The timing bench (bench/embree_native.py) says how fast each tracer is; on a machine without
hardware counters it cannot say where the time goes. This one counts it. Each contender traces
the same rays once inside Valgrind's callgrind, which collects only inside the C function that
walks them (tribench's ``tb_<kernel>_bvh_time_closest_<isa>_f32``, the Embree peer's
``scene_trace`` around rtcIntersect1 or rtcIntersect16), with its cache model set to this CPU's
L1 data cache and L2 (from sysfs; --l2 to set another) and its branch predictor model on.
Printed per ray: instructions, loads, stores, L1 and L2 load misses, conditional branches and
the model's mispredictions. For tribench, instructions and misses are also split by source file
between the walk (ext/bvh*), the leaf test (ext/kernels/, ext/native.h and fmaintrin.h: the
leaves' loads) and code either inlines (avxintrin.h, ext/core.h), beside tribench's own counts
of nodes entered and triangles tested; that split needs the extension's line tables, which a
default build leaves out (build it with TRIBENCH_LINE_TABLES=1, see setup.py). Embree's library
has no line tables, so its costs are one; but its single-ray walk tests a node with one 8-wide
mask (vmovmskps of a ymm register) and a block of four triangles with one 4-wide mask (the one
after the triangle test's products), so the executions of those instructions, found in its
disassembly (objdump), count its node tests and its triangle blocks a ray.
As in bench/embree_native.py, a contender is counted only where its closest triangles, traced
natively, are the float64 reference's (but on ambiguous rays): the same work on every side.

Read the misses as the cache lines a ray brings in, not as stalls: callgrind models no hardware
prefetcher and ignores prefetch instructions, and its branch predictor is 2004's (two-bit
counters indexed by address and recent history), not a modern one. Its models start empty at
the first ray, for every contender alike: the child runs uninstrumented (Valgrind's 4x, not its
50-100x) through Python's start and the tree's build, and turns instrumentation on just before
the pass. Instructions repeat exactly from run to run; misses move by a few percent (the
addresses differ). Counts are not timings, so this may run beside other work. Valgrind has no
AVX-512: every form counted is AVX2 or less, tribench's and Embree's alike.

    python bench/bvh_counts.py [--triangles 250000] [--rays N] [--packets]
"""

from __future__ import annotations

import argparse
import functools
import os
import re
import shutil
import subprocess
import sys
import tempfile
from collections import defaultdict
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

from tribench import ext
from tribench.ext import embree
from tribench.harness.machine import describe
from tribench.workloads import bvh_cache, make
from tribench.workloads.spec import MeshSpec

RAYS = ("camera", "bounce")
KERNELS = ["moller_trumbore_fma", "woop_fma", "baldwin_weber_12_fma", "havel_herout_fma"]
#: The keys that name things in callgrind's format, and the namespace each numbers its names in:
#: objects, source files and functions (a call's target's too: cob, cfi, cfl, cfn).
NAMESPACES = {
    **dict.fromkeys(("ob", "cob"), "ob"),
    **dict.fromkeys(("fl", "fi", "fe", "cfi", "cfl"), "fl"),
    **dict.fromkeys(("fn", "cfn"), "fn"),
}
#: The parts of tribench's trace that its costs are split between (:func:`part`).
PARTS = ("walk", "leaf test", "either")
#: callgrind's events, and the names they are printed under (per ray).
EVENTS = {
    "Ir": "instructions",
    "Dr": "loads",
    "Dw": "stores",
    "D1mr": "L1 load misses",
    "DLmr": "L2 load misses",
    "Bc": "cond. branches",
    "Bcm": "mispredicted",
}


def contenders(kernels: list[str], isa: str, packets: bool) -> dict[str, str]:
    """Name -> the function callgrind collects in."""
    suffix = " packets" if packets else ""
    named = {f"{k} {isa}{suffix}": f"tb_{k}_bvh_time_closest_{isa}_f32" for k in kernels}
    width = 16 if packets else 1
    named.update({f"embree rtcIntersect{width}": "scene_trace", f"embree robust {width}": "scene_trace"})
    return named


def tracer(name: str, triangles: np.ndarray):
    """``name``'s tracer over ``triangles`` (an Embree scene or the kernel's cached tree), and how it
    walks: Embree's ray width (1 or 16) or tribench's layout (wide or packets)."""
    if name.startswith("embree "):
        return embree.EmbreeScene(triangles, robust="robust" in name), 16 if name.endswith("16") else 1
    return bvh_cache.cached_bvh(name.split()[0], triangles)[0], "packets" if name.endswith(" packets") else "wide"


def trace_once(arrays: Path, name: str, isa: str) -> None:
    """The child under Valgrind: one pass of ``name`` over the saved rays."""
    with np.load(arrays) as saved:
        triangles, o, d = saved["triangles"], saved["origins"], saved["directions"]
    traced, walk = tracer(name, triangles)
    start_instrumentation()
    if name.startswith("embree "):
        traced.trace(o, d, None, walk, 1)
    else:
        traced.time(o, d, "closest", 1, isa=isa, layout=walk)
    os._exit(0)  # callgrind writes its profile; Python's teardown, instrumented, would take seconds


def start_instrumentation() -> None:
    """Have callgrind instrument this process from here on. Python's start, the imports and the tree's build ran
    uninstrumented, 5-10x faster; the cache and branch models start empty here, before the rays, alike for every
    contender. Valgrind's gdbserver reads callgrind_control's command while the process runs: poll, not wait."""
    control = subprocess.Popen(["callgrind_control", "--instr=on", str(os.getpid())], stdout=subprocess.PIPE)
    while control.poll() is None:
        pass
    if control.returncode != 0:
        raise SystemExit(f"callgrind_control could not start the instrumentation: {control.stdout.read()!r}")


def closest_hits(w, pick: np.ndarray, name: str, isa: str) -> tuple[np.ndarray, np.ndarray | None]:
    """``name``'s closest triangle for each ray picked, traced natively (which also caches a tree for
    the child); and for a tribench kernel, its tree's mean counts a ray
    (:data:`tribench.ext.bvh.COUNT_NAMES`; None for Embree)."""
    o, d = w.origins[pick], w.directions[pick]
    traced, walk = tracer(name, w.triangles)
    if name.startswith("embree "):
        return traced.intersect(o, d, width=walk)[0], None
    trace = traced.intersect(o, d, isa=isa, layout=walk)
    return trace.hits.index, trace.counts.mean(0)


def cache_option(level: int, kind: str) -> str:
    """``size,ways,line`` of this CPU's cache ``level`` of ``kind`` (Data or Unified), from sysfs."""
    for index in sorted(Path("/sys/devices/system/cpu/cpu0/cache").glob("index*")):
        fact = {f.name: f.read_text().strip() for f in index.iterdir() if f.is_file()}
        if fact.get("level") == str(level) and fact.get("type") == kind and "ways_of_associativity" in fact:
            kib = int(fact["size"][:-1]) * (1024 if fact["size"].endswith("M") else 1)
            return f"{kib * 1024},{fact['ways_of_associativity']},{fact['coherency_line_size']}"
    raise SystemExit(f"no level-{level} {kind} cache in sysfs: give --l1 and --l2")


def count(arrays: Path, name: str, function: str, args: argparse.Namespace) -> Path:
    """Run the child under callgrind; the path of its profile."""
    out = arrays.with_name(name.replace(" ", "_") + ".callgrind")
    valgrind = ["valgrind", "--tool=callgrind", "--cache-sim=yes", "--branch-sim=yes", f"--D1={args.l1}"]
    valgrind += [f"--LL={args.l2}", "--instr-atstart=no", "--collect-atstart=no", f"--toggle-collect={function}"]
    valgrind += ["--dump-instr=yes"] if name.startswith("embree ") else []  # its masks, by address
    child = [sys.executable, __file__, "--child", str(arrays), name, "--isa", args.isa]
    run = subprocess.run([*valgrind, f"--callgrind-out-file={out}", *child], capture_output=True, text=True)
    if run.returncode != 0:
        raise SystemExit(f"{name} under valgrind failed:\n{run.stderr[-2000:]}")
    return out


def cost_lines(profile: Path) -> tuple[list[str], list[tuple[str, str, int, list[int]]]]:
    """callgrind's events, and each line of self cost: its object, its source file (inlined code
    under its own file), its instruction's address (0 without ``--dump-instr=yes``) and its costs."""
    events: list[str] = []
    positions = ["line"]  # a cost line's leading columns: its line, or its instruction's address and line
    names: dict[tuple[str, str], str] = {}  # objects, files and functions are numbered apart
    obj = file = function_file = ""
    address, skip_next, rows = 0, False, []
    for line in profile.read_text().splitlines():
        key, _, value = line.partition("=")
        if line.startswith("positions:"):
            positions = line.split()[1:]
        elif line.startswith("events:"):
            events = line.split()[1:]
        elif key in NAMESPACES:
            if value.startswith("("):  # name compression: "(id) name" once, "(id)" after
                ident, _, given = value[1:].partition(")")
                value = names.setdefault((NAMESPACES[key], ident), given.strip())
            if key == "ob":
                obj = value
            elif key == "fl":
                file = function_file = value
            elif key == "fn":
                file = function_file
            elif key in ("fi", "fe"):
                file = value
        elif key == "calls":
            skip_next = True  # the cost line after calls= is the callee's inclusive cost
        elif line and (line[0].isdigit() or line[0] in "+-*"):
            fields = line.split()
            if positions[0] == "instr":  # absolute, relative to the last, or the same ("*")
                first = fields[0]
                address = address if first == "*" else address + int(first) if first[0] in "+-" else int(first, 16)
            if skip_next:
                skip_next = False
                continue
            rows.append((obj, file, address, [int(f) for f in fields[len(positions) :]]))
    return events, rows


def costs_by_file(events: list[str], rows: list) -> dict[str, np.ndarray]:
    """The self cost of each source file (inlined code under its own file), from :func:`cost_lines`."""
    by_file: dict[str, np.ndarray] = defaultdict(lambda: np.zeros(len(events)))
    for _, file, _, costs in rows:
        by_file[file] += np.array(costs + [0] * (len(events) - len(costs)))
    return by_file


def executions(events: list[str], rows: list, library: str) -> tuple[str, dict[int, int]]:
    """The path of the object whose name holds ``library``, and how many times each of its
    instructions ran (its Ir by address, from :func:`cost_lines` of a ``--dump-instr=yes`` profile)."""
    ir = events.index("Ir")
    found, ran = "", defaultdict(int)
    for obj, _, address, costs in rows:
        if library in obj and costs:
            found = obj
            ran[address] += costs[ir]
    return found, dict(ran)


@functools.cache
def mask_sites(library: str) -> list[tuple[int, bool, int]]:
    """Each vmovmskps in ``library``: its address, whether it is 8-wide (a ymm register), and the multiplies
    (vmul*, vfmadd*, vfmsub*, vfnm*) since the one before; one disassembly (13 s for Embree's), shared by
    every profile."""
    listing = subprocess.run(["objdump", "-d", "--no-show-raw-insn", library], capture_output=True, check=True)
    sites, products = [], 0
    for found in re.finditer(rb"^ *([0-9a-f]+):\s+(vmovmskps\s.*|v(?:fn?m|mul))", listing.stdout, re.M):
        if found[2].startswith(b"vmovmskps"):
            sites.append((int(found[1], 16), b"%ymm" in found[2], products))
            products = 0
        else:
            products += 1
    return sites


def embree_masks(library: str, ran: dict[int, int], rays: int) -> str:
    """Embree's node tests and triangle blocks a ray, from its mask instructions (see above) and
    :func:`executions` in its ``library``: the 8-wide masks are its node tests; of its 4-wide ones,
    the block test's is the one after the most multiplies (a ray's setup and a hit's update have
    masks of their own, with little arithmetic)."""
    if not ran or shutil.which("objdump") is None:
        return "its node tests not counted (no instruction costs in its library, or no objdump)"
    nodes, blocks = 0, (-1, 0)  # blocks: (products before the mask, its executions)
    for address, wide, products in mask_sites(library):
        n = ran.get(address, 0)
        if wide:
            nodes += n
        elif n and products > blocks[0]:
            blocks = (products, n)
    return f"{nodes / rays:.2f} node tests (8-wide masks), {blocks[1] / rays:.2f} blocks of 4 triangles a ray"


@functools.cache
def has_line_tables() -> bool:
    """Whether tribench's extension keeps line tables (built with TRIBENCH_LINE_TABLES=1): without
    them callgrind files all its code under "???", and the walk cannot be told from the leaf test."""
    return b".debug_line" in Path(ext._core.__file__).read_bytes()


def part(file: str) -> str:
    """Which part of tribench's trace a source file's code is: the walk, the leaf test, or either.
    The walk's vectors load through ext/bvh_trace.h and use no FMA, so fmaintrin.h (whose lines
    carry the loads folded into FMAs) is the leaf test's; avxintrin.h serves both."""
    if Path(file).name.startswith("bvh"):
        return "walk"
    leaf = "/kernels/" in file or file.endswith(("/native.h", "/fmaintrin.h"))
    return "leaf test" if leaf else "either"


def report(profiles: dict[str, Path], rays: int, counts: dict[str, np.ndarray | None]) -> None:
    print(f"  {'per ray':<34}" + "".join(f"{e:>16}" for e in EVENTS.values()))
    for name, profile in profiles.items():
        events, rows = cost_lines(profile)  # read once: the costs by file and, for Embree, by address
        by_file = costs_by_file(events, rows)
        total = sum(by_file.values(), np.zeros(len(events)))
        if total[events.index("Ir")] == 0:
            raise SystemExit(f"{name}: nothing collected (has the traced function's name changed?)")
        print(f"  {name:<34}" + "".join(f"{total[events.index(e)] / rays:16.1f}" for e in EVENTS))
        tree = counts[name]
        if tree is None:  # Embree: one function without line tables, not split; its masks counted
            if not name.endswith("16"):  # single rays (rtcIntersect16's masks are over rays)
                print(f"    {embree_masks(*executions(events, rows, 'libembree'), rays)}")
            continue
        split = "not split: the extension has no line tables (build it with TRIBENCH_LINE_TABLES=1)"
        if has_line_tables():
            parts = {p: np.zeros(len(events)) for p in PARTS}
            for file, cost in by_file.items():
                parts[part(file)] += cost / rays
            split = ", ".join(
                f"{EVENTS[e]} " + " | ".join(f"{parts[p][events.index(e)]:.1f}" for p in PARTS)
                for e in ("Ir", "D1mr", "DLmr")
            )
        nodes, _, leaves, tests = tree
        print(f"    walk | leaf test | either: {split}")
        print(f"    {nodes:.2f} nodes entered, {leaves:.2f} of them leaves, {tests:.1f} triangle tests a ray")


def positive(text: str) -> int:
    if not text.isdigit() or int(text) < 1:
        raise argparse.ArgumentTypeError(f"a whole number of at least 1, not {text!r}")
    return int(text)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--triangles", type=int, default=250_000)
    parser.add_argument("--camera", default="512x512", help="camera WxH of both ray sets (default 512x512)")
    parser.add_argument("--rays", type=positive, help="rays counted, consecutive, mid-set (default all)")
    parser.add_argument("--kernels", nargs="+", default=KERNELS)
    # valgrind runs no AVX-512: tribench's forms that it can count
    parser.add_argument("--isa", default="avx2", choices=["avx2", "baseline"], help="tribench's form (default avx2)")
    parser.add_argument("--packets", action="store_true", help="packet walks and rtcIntersect16, not single rays")
    parser.add_argument("--l1", help="size,ways,line of the L1 data cache modelled (default: this CPU's)")
    parser.add_argument("--l2", help="size,ways,line of the L2 modelled (default: this CPU's)")
    parser.add_argument("--child", nargs=2, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        return trace_once(Path(args.child[0]), args.child[1], args.isa)
    if unknown := sorted(set(args.kernels) - set(ext.bvh_kernel_names())):
        raise SystemExit(f"not BVH leaf kernels: {', '.join(unknown)}; these are: {', '.join(ext.bvh_kernel_names())}")
    if shutil.which("valgrind") is None or shutil.which("callgrind_control") is None:
        raise SystemExit("valgrind (with its callgrind_control) is not installed (apt-get install valgrind)")
    if (why := embree.missing()) is not None:
        raise SystemExit(why)
    args.l1, args.l2 = args.l1 or cache_option(1, "Data"), args.l2 or cache_option(2, "Unified")
    width, height = map(int, args.camera.split("x"))
    print(describe())
    print(f"{embree.version()}; callgrind's L1 {args.l1}, L2 {args.l2} (size,ways,line); float32")
    named = contenders(args.kernels, args.isa, args.packets)
    with tempfile.TemporaryDirectory() as tmp:
        for r in RAYS:
            w = make(MeshSpec("suzanne", args.triangles, rays=r, width=width, height=height, dtype="float32"))
            n = len(w.origins) if args.rays is None else min(args.rays, len(w.origins))
            pick = np.arange(n) + (len(w.origins) - n) // 2  # consecutive: neighbours share lines, as in a pass
            print(f"\n{r}: {n:,} of {len(w.origins):,} rays, {(w.ref_index[pick] >= 0).mean():.0%} hit, ", end="")
            print(f"Suzanne {len(w.triangles):,}")
            counted, counts = {}, {}
            for name, function in named.items():  # the same work: the reference's answers
                index, counts[name] = closest_hits(w, pick, name, args.isa)
                wrong = (index != w.ref_index[pick]) & ~w.ambiguous()[pick]
                if wrong.any():
                    print(f"  left out: {name} differs from the reference on {int(wrong.sum())} unambiguous rays")
                else:
                    counted[name] = function
            arrays = Path(tmp) / f"{r}.npz"
            np.savez(arrays, triangles=w.triangles, origins=w.origins[pick], directions=w.directions[pick])
            with ThreadPoolExecutor(2) as pool:  # two cores: counts do not depend on the load
                jobs = {name: pool.submit(count, arrays, name, f, args) for name, f in counted.items()}
                report({name: job.result() for name, job in jobs.items()}, n, counts)


if __name__ == "__main__":
    main()
