"""``tribench seed``: the seed's two renders replayed through the harness, beside the paper's table.

Each render's ray stream is cut into its kinds, each a workload
(:class:`~tribench.workloads.seed.workload.SeedSpec`) timed by the ordinary runner, and per process

    render_s = sum over ray kinds of  ns_per_test x tests_per_pass x stream_tests / sample_tests

with a Student-t interval over processes and a ratio to ``moller_seed`` paired per process. Only the
triangle tests are replayed, so the seconds are smaller than the paper's and the ratio is the kernels' own
(docs/decisions.md, "The seed replay's model"). The files' columns: :data:`COLUMNS`."""

from __future__ import annotations

import sys
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from ...common import UserError
from ...workloads import cache
from ...workloads.seed.scene import load_scene
from ...workloads.spec import workload_id
from .. import runfolder
from ..plan import DEFAULT_BASELINE, Sweep
from ..runfolder.seed_files import MISS_STAGES as MISS_STAGES  # reports.seed's, as before

__all__ = [
    "BASELINE",
    "COLUMNS",
    "FULL",
    "PAPER",
    "QUICK",
    "Design",
    "make_pictures",
    "run_seed",
    "seed_kernels",
]

#: The seed's table: Unix ``time`` of the whole 512 x 512 render, seconds
#: (2.3 GHz Core i9; Vitse 2022, "Performances").
PAPER = {
    "scene02": {"curless_seed": {"real": 4.131, "user": 2.029}, "moller_seed": {"real": 3.544, "user": 1.704}},
    "scene03": {"curless_seed": {"real": 96.438, "user": 94.305}, "moller_seed": {"real": 57.970, "user": 55.691}},
}
#: How far the object forms' render times and Curless/Moller ratio may stand from the seed's own program
#: on the same machine, beyond timing noise: what the replay leaves out (the floor, shading, output, about
#: 1% of the program's time by perf record) and what differs between machines. On the Zen 5 of the
#: measurement the replay misses by 3.0% at most (the ratio; its paired interval reaches 4%); on a Zen 4 the Curless
#: form ran 6-10% under the program before the fix that added 2.5% on the Zen 5, so up to 5% may remain
#: there. Measured with bench/seed_program.py beside tribench seed: docs/decisions.md, "The seed replay's model".
MODEL_ERROR = 0.05
BASELINE = DEFAULT_BASELINE  # the seed's Möller: the paper's ratio is Curless over it
PAIR = ("curless_seed", "moller_seed")
#: The seed's two tests as its program pays for them (objects, calls and scene loop: ext/kernels/seed_objects.h),
#: the render times the paper's are set beside.
PROGRAM = ("curless_seed_object", "moller_seed_object")
#: The seed's two kernels and their clean scalar forms: the seed's algorithms at the seed's form, flaws and no flaws.
FIRST_KERNELS = (*PROGRAM, "curless_seed", "moller_seed", "curless", "moller_trumbore")
#: The pictures are rendered as the seed computed them: float triangle tests.
PICTURE_DTYPE = "float32"
#: A differing pixel is explained when one of its rays passes within this
#: (barycentric) distance of a triangle's boundary: float32 rounding and the
#: seed kernels' absolute epsilons decide such rays differently.
EDGE_TOLERANCE = 5e-3
#: ... or when its colours differ by less than this (an 8-bit truncation flipped).
LAST_BIT = 1e-5

#: The achieved figures of a seed workload that seed_workloads.csv keeps as they are.
STREAM_FIGURES = (
    "triangles",
    "stream_rays",
    "stream_tests",
    "sample_rays",
    "sample_tests",
    "test_hit_rate",
    "ray_hit_rate",
    "ambiguous_rays",
)


SEED_CSV = runfolder.SEED
KINDS_CSV = runfolder.SEED_KINDS
WORKLOADS_CSV = runfolder.SEED_WORKLOADS
PICTURES_CSV = runfolder.SEED_PICTURES

#: Every file this module writes, with its columns and their units (defined in :mod:`~tribench.harness.runfolder`).
COLUMNS: dict[str, dict[str, str]] = runfolder.SEED_FILES


@dataclass(frozen=True)
class Design:
    """How much ``tribench seed`` measures."""

    processes: int
    rounds: int
    warmup: int
    target_ms: float
    sample: int
    size: int


# 2 ms batches, about one native kernel's pass over a sample (a longer pass is a
# batch of its own); 6 rounds and 12 processes: a render time's CI of about +-2%,
# inside the replay's 3% model error, in about 7 minutes on 2 cores with the
# object forms' passes of 0.1-0.35 s (20 x 8 took 11). The measurements and the
# arithmetic: docs/decisions.md, "The seed replay's design".
FULL = Design(processes=12, rounds=6, warmup=1, target_ms=2.0, sample=4096, size=512)
# 5 processes, not 3: a t-interval over 3 is t(2) / sqrt(3) = 2.5 standard deviations
# wide each side, over 5 t(4) / sqrt(5) = 1.2, for a few seconds more (about 20 s in all).
QUICK = Design(processes=5, rounds=2, warmup=1, target_ms=1.0, sample=256, size=128)


def seed_kernels(all_kernels: bool = False) -> tuple[str, ...]:
    """The kernels ``tribench seed`` times: :data:`FIRST_KERNELS`, then the native form (each algorithm's fastest)
    of every algorithm that tests both faces, as the seed's renderer needs (``all_kernels``: every public
    kernel); built-in only, as the replay's workers load no kernel file.

    >>> seed_kernels()[:6] == FIRST_KERNELS and len(seed_kernels()) < len(seed_kernels(all_kernels=True))
    True
    """
    from ... import ext

    names = [k for k in ext.kernel_names() if ext.kernel_info(k).source == "built-in"]
    first = [k for k in FIRST_KERNELS if k in ext.kernel_names(internal=True)]
    info = {k: ext.kernel_info(k) for k in names}
    two_sided = [k for k in names if not info[k].culls_back_faces]
    widest: dict[str, int] = {}  # per algorithm, the most lanes of its forms
    for k in two_sided:
        widest[info[k].algorithm] = max(widest.get(info[k].algorithm, 1), info[k].lanes)
    best = [k for k in two_sided if 1 < info[k].lanes == widest[info[k].algorithm]]
    rest = names if all_kernels else best
    return (*first, *(k for k in rest if k not in FIRST_KERNELS))


def _labels(scenes: Sequence[str]) -> dict[str, str]:
    """A short unique name per scene (file stems; a repeated stem gets -2, -3...)."""
    out: dict[str, str] = {}
    for s in scenes:
        base = Path(s).stem if s not in PAPER else s
        label, n = base, 1
        while label in out.values():
            n += 1
            label = f"{base}-{n}"
        out[s] = label
    return out


# ------------------------------------------------------------------ running


def run_seed(
    out: str | Path,
    scenes: Sequence[str] | None = None,
    quick: bool = False,
    size: int | None = None,
    sample: int | None = None,
    all_kernels: bool = False,
    progress: bool | None = None,
    command: str | None = None,
) -> float:
    """Make the workloads, run the sweep into ``out`` and draw the pictures; the seconds it took.

    ``scenes``: built-in names or scene files (default scene02 and scene03); ``size`` and ``sample`` override
    the image side and the rays per kind. The tables are :func:`tribench.reports.tables.seed.write_seed_tables`'."""
    from ...workloads.seed.workload import SeedSpec
    from .sweep import run_sweep

    t0 = time.monotonic()
    design = QUICK if quick else FULL
    size, sample = size or design.size, sample or design.sample
    out = Path(out)
    runfolder.check_new_run_dir(out)
    scenes = [str(s) for s in (scenes or tuple(PAPER))]
    resolved = [SeedSpec(s, sample=sample, width=size, height=size).scene for s in scenes]
    labels = _labels(resolved)
    specs, info = _workloads(resolved, labels, size, sample)
    sweep = Sweep(
        seed_kernels(all_kernels),
        tuple(specs),
        processes=design.processes,
        rounds=design.rounds,
        warmup=design.warmup,
        target_ms=design.target_ms,
    )
    print(
        f"sweep: {len(sweep.kernels)} kernels x {len(specs)} workloads, {sweep.processes} processes x "
        f"{sweep.rounds} rounds: {sweep.n_batches} batches -> {out}",
        file=sys.stderr,
    )
    replay = {
        "scenes": [labels[s] for s in resolved],
        "quick": quick,
        "all_kernels": all_kernels,
        "width": size,
        "height": size,
        "sample": sample,
        "paper": PAPER,
        "workloads": info,
    }
    run_sweep(
        sweep,
        out,
        say=lambda line: print(line, file=sys.stderr),
        progress=progress,
        extra={"command": command, "seed_replay": replay},
        announce=lambda sweep: _expected(sweep, info, size),
    )

    pictures = []
    for scene in resolved:
        if any(v["scene"] == labels[scene] for v in info.values()):
            print(f"pictures: {labels[scene]}, curless_seed and moller_seed at {size}x{size}", file=sys.stderr)
            pictures.append(make_pictures(scene, labels[scene], size, out))
    runfolder.write_csv(pd.DataFrame(pictures, columns=list(COLUMNS[PICTURES_CSV])), out / PICTURES_CSV)
    return time.monotonic() - t0


def _workloads(
    resolved: list[str], labels: dict[str, str], size: int, sample: int
) -> tuple[list, dict[str, dict[str, Any]]]:
    """Every scene's ray streams as workloads (traced the first time, then cached), and what each is:
    its scene's label, the paper's scene it replays, its ray kind and its stream's figures."""
    from ...workloads.seed.workload import RAY_KINDS, EmptyStream, SeedSpec, trace_forecast
    from ..duration import format_duration

    specs: list = []
    info: dict[str, dict[str, Any]] = {}
    for scene in resolved:
        kinds = [SeedSpec(scene, rays, sample=sample, width=size, height=size) for rays in RAY_KINDS]
        if not any(cache.cached(spec) for spec in kinds):  # one trace makes them all: said (or refused) first
            print(
                f"tracing {labels[scene]}: expected about {format_duration(trace_forecast(kinds[0]))}", file=sys.stderr
            )
        for spec in kinds:
            print(f"workload: {spec.summary()}", file=sys.stderr)
            try:
                w = cache.make(spec)  # the first time, traces the scene (seconds at 512 x 512)
            except EmptyStream as exc:
                print(f"  skipped: {exc}", file=sys.stderr)
                continue
            specs.append(spec)
            a = w.achieved
            info[workload_id(spec)] = {
                "scene": labels[scene],
                "paper": scene if scene in PAPER else None,
                "rays": spec.rays,
                "mode": spec.mode,
                **{k: a[k] for k in (*STREAM_FIGURES, "miss_mix")},
            }
    if not specs:
        raise UserError("no scene shoots a ray that tests a triangle: nothing to replay")
    return specs, info


#: The pictures' tracer does about this share of a render's triangle tests (it skips some), plus its own
#: NumPy work per pixel; read off finished renders: docs/decisions.md, "The seed replay's design".
PICTURE_TEST_SHARE = 0.6
PICTURE_S_PER_PIXEL = 1e-5
TABLES_S = 10.0


def _expected(sweep: Any, info: Mapping[str, Mapping[str, Any]], size: int) -> str:
    """The line said before the sweep: its forecast (:mod:`..duration`), then the pictures'."""
    from ..duration import format_duration, measure_passes, model

    tests, pass_s, _ = measure_passes(sweep)  # the seed's workloads are brute force
    sweep_estimate = model(sweep, tests, pass_s)
    after = TABLES_S
    for wid in sweep.workload_ids:  # one pass over the sample, scaled to the render as render_per_process does
        render = info[wid]["stream_tests"] / info[wid]["sample_tests"]
        after += sum(PICTURE_TEST_SHARE * pass_s[(k, wid)] * render for k in PAIR)
    after += len({info[wid]["scene"] for wid in sweep.workload_ids}) * len(PAIR) * PICTURE_S_PER_PIXEL * size**2
    return (
        f"expected: about {format_duration(sweep_estimate.seconds + after)} in all; "
        f"{sweep_estimate.line('for the sweep').removeprefix('expected ')}, "
        f"then the pictures and tables about {format_duration(after)}"
    )


def make_pictures(scene: str, label: str, size: int, out: Path) -> dict[str, Any]:
    """Render ``scene`` with both seed kernels, save the PNGs and the difference mask; count the differences."""
    from ...workloads.seed.trace import (
        difference_mask,
        pixel_edge_margins,
        save_mask_png,
        trace,
    )

    s = load_scene(scene)
    traces = {k: trace(s, k, PICTURE_DTYPE, size, size) for k in PAIR}
    row: dict[str, Any] = {"scene": label, "width": size, "height": size, "dtype": PICTURE_DTYPE}
    for k, tr in traces.items():
        row[f"{k}_png"] = tr.to_png(out / f"{label}_{k}.png").name
    a, b = traces["curless_seed"], traces["moller_seed"]
    mask, count = difference_mask(a, b)
    row["difference_png"] = save_mask_png(mask, out / f"{label}_difference.png", b.to_uint8()).name
    margin = np.minimum(pixel_edge_margins(a, mask), pixel_edge_margins(b, mask))
    near = margin < EDGE_TOLERANCE
    tiny = np.abs(a.image - b.image)[mask].max(axis=1) < LAST_BIT
    row.update(
        differing_pixels=count,
        near_edge_pixels=int(near.sum()),
        last_bit_pixels=int((~near & tiny).sum()),
        other_pixels=int((~near & ~tiny).sum()),
        edge_tolerance=EDGE_TOLERANCE,
    )
    return row
