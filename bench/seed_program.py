"""The seed's own program, built from its public code and timed: the figures ``tribench seed`` must predict.

The seed's renderer (github.com/Weamix/InitiationALaRecherche, ``LR/``) is
not part of tribench: point ``--source`` at a checkout's ``LR`` folder. It
is built twice with ``g++ -O2 -std=c++11`` into a temporary folder, as the
paper's two programs: as published (``#define MOLLER`` in ``Triangle.cpp``)
and with that line removed (Curless). Each pair renders one scene with
both, in alternating order, pinned to one CPU; the user CPU time of each
render (``getrusage`` of the child) is the paper's "user" figure.

Printed: each program's mean user time with a 95% t interval over the
pairs, and Curless / Moller paired per pair on the log scale (t interval).

With ``--replay``, each pair also times tribench's object forms
(``moller_seed_object``, ``curless_seed_object``) on the same CPU, right
after the programs: one render's time as ``tribench seed`` makes it (a pass
over each ray kind's 4096-ray sample, scaled by the render's tests of that
kind over the sample's). The machine's speed drifts by a quarter over
minutes here (shared hosts), so the figure that holds is replay / program
paired within each pair, which the script prints with its interval.

    python bench/seed_program.py --source PATH/TO/LR [--scene scene03] [--pairs 6] [--cpu 1] [--replay]
"""

from __future__ import annotations

import argparse
import os
import resource
import shutil
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np

from tribench.harness import layout, stats
from tribench.harness.machine import describe

PROGRAMS = ("moller", "curless")
REPLAY = {"moller": "moller_seed_object", "curless": "curless_seed_object"}


def replay_jobs(scene: str) -> list[tuple[dict, float]]:
    """Per object form and ray kind, a timing job and the render's tests over the sample's."""
    from tribench import ext
    from tribench.workloads import cache
    from tribench.workloads.seed.workload import RAY_KINDS, SeedSpec

    jobs = []
    for rays in RAY_KINDS:
        w = cache.make(SeedSpec(scene, rays, sample=4096, width=512, height=512))
        scale = w.achieved["stream_tests"] / w.achieved["sample_tests"]
        made = {
            k: ext.make_job(k, w.origins, w.directions, w.triangles, w.mode, t_max=w.t_max) for k in REPLAY.values()
        }
        jobs.append((made, scale))
    return jobs


def replay_render(jobs: list[tuple[dict, float]], kernel: str, cpu: int) -> float:
    """One render's seconds by ``kernel``: the median of three passes per ray kind, scaled."""
    from tribench import ext

    layout.pin(cpu)
    total = 0.0
    for made, scale in jobs:
        job = made[kernel]
        ext.time_batch(job, 1)  # warm-up
        total += float(np.median([ext.time_batch(job, 1).elapsed_ns for _ in range(3)])) * 1e-9 * scale
    return total


def build(source: Path, out: Path) -> dict[str, Path]:
    """Both programs from the seed's sources, compiled side by side; returns their paths."""
    binaries = {}
    jobs = []
    for name in PROGRAMS:
        src = out / name
        shutil.copytree(source / "Src", src)
        if name == "curless":
            tri = src / "Triangle.cpp"
            text = tri.read_text()
            if "#define MOLLER" not in text:
                raise SystemExit(f"{tri}: no '#define MOLLER' line: not the seed's Triangle.cpp")
            tri.write_text(text.replace("#define MOLLER", "", 1))
        binaries[name] = out / f"lr_{name}"
        cmd = ["g++", "-O2", "-std=c++11", *sorted(str(p) for p in src.glob("*.cpp")), "-o", str(binaries[name])]
        jobs.append(subprocess.Popen(cmd))
    if any(job.wait() for job in jobs):
        raise SystemExit("the seed's program did not compile")
    return binaries


def render(binary: Path, scene: Path, cpu: int, workdir: Path) -> tuple[float, float]:
    """User CPU seconds and wall seconds of one render (the image goes to ``workdir``)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN).ru_utime
    start = time.perf_counter()
    subprocess.run(
        ["taskset", "-c", str(cpu), str(binary), str(scene)], cwd=workdir, check=False, stdout=subprocess.DEVNULL
    )
    wall = time.perf_counter() - start
    return resource.getrusage(resource.RUSAGE_CHILDREN).ru_utime - before, wall


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--source", type=Path, required=True, help="the seed's LR folder (holds Src/ and Scenes/)")
    ap.add_argument("--scene", default="scene03")
    ap.add_argument("--pairs", type=int, default=6)
    ap.add_argument("--cpu", type=int, default=os.cpu_count() - 1)
    ap.add_argument("--replay", action="store_true", help="also time tribench's object forms in each pair")
    args = ap.parse_args()
    print(describe())
    jobs = replay_jobs(args.scene) if args.replay else []
    replay: dict[str, list[float]] = {name: [] for name in PROGRAMS}
    scene = (args.source / "Scenes" / f"{args.scene}.txt").resolve()
    with tempfile.TemporaryDirectory(prefix="tribench-seed-program-") as tmp:
        binaries = build(args.source, Path(tmp))
        user: dict[str, list[float]] = {name: [] for name in PROGRAMS}
        for pair in range(args.pairs):
            order = PROGRAMS if pair % 2 == 0 else PROGRAMS[::-1]
            for name in order:
                u, wall = render(binaries[name], scene, args.cpu, Path(tmp))
                user[name].append(u)
                line = f"pair {pair + 1}: {name:8s} user {u:7.2f} s  wall {wall:7.2f} s"
                if jobs:
                    replay[name].append(replay_render(jobs, REPLAY[name], args.cpu))
                    line += f"  replay {replay[name][-1]:7.2f} s"
                print(line, flush=True)
    print(f"\n{args.scene}, g++ -O2, {args.pairs} alternating pairs on CPU {args.cpu}:")
    for name in PROGRAMS:
        e = stats.estimate(np.array(user[name]))
        print(f"  {name:8s} user {stats.format_estimate(e.mean, e.ci_low, e.ci_high, ' s')}")
    ratio = stats.geometric_mean(np.array(user["curless"]) / np.array(user["moller"]))
    print(f"  curless / moller {stats.format_estimate(ratio.mean, ratio.ci_low, ratio.ci_high)}")
    if jobs:
        print("tribench's object forms in the same pairs, replay / program (paired, 95% t interval):")
        for name in PROGRAMS:
            r = stats.geometric_mean(np.array(replay[name]) / np.array(user[name]))
            print(f"  {REPLAY[name]:20s} {stats.format_estimate(r.mean, r.ci_low, r.ci_high)}")
        mine = np.array(replay["curless"]) / np.array(replay["moller"])
        r = stats.geometric_mean(mine / (np.array(user["curless"]) / np.array(user["moller"])))
        print(f"  Curless / Moller, replay's over program's {stats.format_estimate(r.mean, r.ci_low, r.ci_high)}")


if __name__ == "__main__":
    main()
