"""Peers: tribench's fastest kernel, brute force or in its BVH, against trimesh and Embree, in rays/s.

The contenders, workload and design: docs/results.md, "Against peers"; ``peers.csv``'s columns:
:data:`COLUMNS`. Every contender runs on the same arrays in the one worker protocol, each repetition in a
random order after a 0.1 s pause (the previous call's helper threads go idle). Each worker has one BLAS
thread: OpenBLAS starts its threads at NumPy's import, before pinning, and they spun on the other CPU during
trimesh's work. :func:`summarise` makes the figures (geometric means, t intervals, ratios paired by process)."""

from __future__ import annotations

import functools
import json
import math
import os
import sys
import time
import warnings
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
import pandas as pd

from ...common import Notice, UserError
from ...workloads import cache
from ...workloads.spec import ACCELS, MESH_NAMES, MeshSpec
from .. import layout, protocol, runfolder
from ..runfolder.rows import PeerRow

__all__ = [
    "PEERS",
    "COLUMNS",
    "CONTENDERS",
    "PEER_NAMES",
    "HEADLINE_PEERS",
    "NATIVE_EMBREE",
    "PAUSE_S",
    "INSTALL",
    "PeerDesign",
    "available",
    "camera_spec",
    "candidate_kernels",
    "choose_kernel",
    "measure",
    "peers_path",
]

#: Contender -> what is timed (the report's and the printout's words).
CONTENDERS = {
    "tribench": "tribench, kernel loop timed in C",
    "tribench_call": "tribench, wall time of ext.intersect (BVH.intersect in a BVH)",
    "tribench_packets": "tribench, the BVH walked by packets of 16 rays, loop timed in C",
    "embree": "native Embree, rtcIntersect1 at its fastest ISA here, loop timed in C",
    "embree_16": "native Embree, rtcIntersect16 over packets of 16 rays at its fastest ISA, loop timed in C",
    "embree_robust": "native Embree, robust (watertight) mode, rtcIntersect1",
    "embree_robust_16": "native Embree, robust (watertight) mode, rtcIntersect16",
    "embreex": "Embree via embreex, called from Python (secondary)",
    "trimesh": "trimesh ray_triangle (NumPy, rtree)",
}
#: Native Embree's contenders: rtcIntersect1 and rtcIntersect16, plain and robust.
NATIVE_EMBREE = ("embree", "embree_16", "embree_robust", "embree_robust_16")
#: The peers, in the order of the ratios.
PEER_NAMES = ("embree", "embree_16", "embree_robust", "embree_robust_16", "embreex", "trimesh")
#: The peers a headline names: native Embree's two calls (and trimesh, where it ran); embreex stays in the table.
HEADLINE_PEERS = ("embree", "embree_16", "trimesh")

#: The file in a run folder.
PEERS = runfolder.PEERS

#: How to install the peers (embreex, and rtree for trimesh's intersector).
INSTALL = "pip install 'tribench[peers]'"

#: Pause before each timed call, seconds.
PAUSE_S = 0.1


@dataclass(frozen=True)
class PeerDesign:
    """What :func:`measure` runs: the workload and the replicates."""

    width: int = 512
    height: int = 512
    #: Suzanne's 968 is the seed's mesh; None keeps the mesh's own triangles
    triangles: int | None = 968
    #: a built-in mesh name or the path of a mesh file trimesh reads (stored absolute)
    mesh: str = "suzanne"
    processes: int = 5
    reps: int = 3
    trimesh_rays: int = 8192
    choice_rays: int = 8192
    choice_rounds: int = 7
    rng_seed: int = 0
    accel: str = "brute"

    #: At most this many timed repetitions (processes x reps): at about a second each
    #: on the default camera, a few hours; more is a typo, not a design.
    MAX_REPETITIONS: ClassVar[int] = 10_000

    def __post_init__(self) -> None:
        for name in (
            "width",
            "height",
            *(("triangles",) if self.triangles is not None else ()),
            "processes",
            "reps",
            "trimesh_rays",
            "choice_rays",
            "choice_rounds",
        ):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                raise UserError(f"{name} must be a positive integer, got {value!r}")
        if not isinstance(self.mesh, str) or not self.mesh:
            raise UserError(f"mesh must be a built-in mesh name or a file path, got {self.mesh!r:.80}")
        if self.mesh not in MESH_NAMES:  # the workers read it from another process: absolute
            object.__setattr__(self, "mesh", os.path.abspath(os.path.expanduser(self.mesh)))
        if self.accel not in ACCELS:
            raise UserError(f"accel must be one of {', '.join(ACCELS)}, got {self.accel!r:.80}")
        if self.processes * self.reps > self.MAX_REPETITIONS:
            raise UserError(
                f"processes x reps must be at most {self.MAX_REPETITIONS:,} (about a second "
                f"each: hours of measuring), got {self.processes:,} x {self.reps:,}"
            )

    @classmethod
    def quick(cls) -> PeerDesign:
        """The same shape in about ten seconds (a 256x256 camera, wide intervals)."""
        return cls(width=256, height=256, processes=3, reps=2, trimesh_rays=2048, choice_rays=2048, choice_rounds=3)


#: Columns of ``peers.csv``, in file order (its row type: runfolder.rows.PeerRow).
COLUMNS = tuple(runfolder.FILES[runfolder.PEERS])


def available() -> dict[str, str | None]:
    """Each peer's version when it can run here, else None: trimesh's intersector (it needs rtree),
    native Embree (:func:`tribench.ext.embree.version`) and Embree through embreex."""
    from importlib import metadata

    from ...ext import embree

    found: dict[str, str | None] = {}
    for peer, modules in (("trimesh", ("trimesh", "rtree")), ("embreex", ("trimesh", "embreex"))):
        try:
            for module in modules:
                __import__(module)
            found[peer] = " ".join(f"{m} {metadata.version(m)}" for m in modules)
        except Exception:  # ImportError, or a binary wheel that cannot load here
            found[peer] = None
    found["embree"] = embree.version()
    return found


def camera_spec(design: PeerDesign):
    """The peers' workload: the design's mesh (Suzanne by default) through a pinhole camera, float32, closest hit."""
    return MeshSpec(
        design.mesh,
        triangles=design.triangles,
        rays="camera",
        width=design.width,
        height=design.height,
        dtype="float32",
        accel=design.accel,
    )


def candidate_kernels(accel: str) -> list[str]:
    """The kernels tribench's row may run: public closest-mode kernels that test both faces, as every
    peer does (a culling kernel gives the same answers on a closed mesh without the same work), and
    in a BVH only those that can be its leaf test."""
    from ... import ext

    kernels = [
        k
        for k in ext.kernel_names()
        if "closest" in ext.kernel_info(k).modes and not ext.kernel_info(k).culls_back_faces
    ]
    return [k for k in kernels if k in ext.bvh_kernel_names()] if accel == "bvh" else kernels


def choose_kernel(workload: Any, n_rays: int, rounds: int, rng_seed: int = 0) -> str:
    """The fastest of :func:`candidate_kernels` on a random subset of the rays (through its BVH on a BVH workload).

    Judged by the median CPU time per ray, kernels interleaved: on a shared core, wall time
    also counts other processes' slices, which can reorder close kernels."""
    from ... import ext
    from ...workloads import bvh_cache

    rng = np.random.default_rng([rng_seed, 1])
    bvh = workload.spec.accel == "bvh"
    kernels = candidate_kernels(workload.spec.accel)
    rows = np.sort(rng.choice(len(workload.origins), size=min(n_rays, len(workload.origins)), replace=False))
    o, d = np.ascontiguousarray(workload.origins[rows]), np.ascontiguousarray(workload.directions[rows])
    calls: dict[str, Callable[[], Any]] = {}
    for k in kernels:
        if bvh:
            calls[k] = functools.partial(bvh_cache.cached_bvh(k, workload.triangles)[0].time, o, d, "closest", 1)
        else:
            calls[k] = functools.partial(ext.time_batch, ext.make_job(k, o, d, workload.triangles, "closest"), 1)
    cpu: dict[str, list[float]] = {k: [] for k in kernels}
    for _ in range(rounds):
        for k in rng.permutation(kernels):
            t0 = time.thread_time_ns()
            calls[k]()
            cpu[k].append((time.thread_time_ns() - t0) / len(o))
    return min(kernels, key=lambda k: float(np.median(cpu[k])))  # the first of equals, in registry order


def measure(
    out: str | Path,
    design: PeerDesign = PeerDesign(),
    *,
    kernel: str | None = None,
    cpu: int | None = None,
    progress: bool | None = None,
) -> pd.DataFrame:
    """Run the peers' processes one after another into ``peers.csv`` (:func:`peers_path`), rewritten after each.
    Raises RuntimeError when no peer is installed or a worker fails. With a BVH the peer is Embree alone (without it,
    tribench's rows are still measured, with a Notice), and ``kernel`` must be one of ``ext.bvh_kernel_names()``."""
    from ... import ext
    from ...ext import embree
    from ..runner import default_cpu, progress_ticks

    bvh = design.accel == "bvh"
    if bvh and kernel is not None and kernel not in ext.bvh_kernel_names():  # a user's choice may cull
        raise UserError(
            f"kernel {kernel!r} cannot be a BVH's leaf test; these can: {', '.join(ext.bvh_kernel_names())}"
        )
    found = available()
    peers = [p for p, v in found.items() if v is not None and (p != "trimesh" or not bvh)]
    if not peers and not bvh:
        raise RuntimeError(f"no peer is installed ({INSTALL}: embreex and rtree; native Embree: {embree.INSTALL})")
    if found["embree"] is None:
        alone = ": tribench's BVH is timed alone" if bvh and not peers else ""
        why = embree.missing() or f"native Embree is not available; {embree.INSTALL}"
        warnings.warn(f"{why}{alone}", Notice, stacklevel=2)
    path = peers_path(out)
    workload = cache.make(camera_spec(design))  # built once here; the workers read the cache
    if kernel is None:
        kernel = choose_kernel(workload, design.choice_rays, design.choice_rounds, design.rng_seed)
    cpu = default_cpu() if cpu is None else cpu
    # one BLAS thread, set before the worker imports NumPy (see the module's docstring)
    blas = {**os.environ, **{v: "1" for v in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")}}
    rows: list[dict[str, Any]] = []
    frame = pd.DataFrame(rows, columns=list(COLUMNS))
    with progress_ticks(progress, design.processes, unit="processes", label="peers") as advance:
        for process in range(design.processes):
            job = {
                "design": asdict(design),
                "kernel": kernel,
                "process": process,
                "peers": peers,
                "cpu": -1 if cpu is None else cpu,
            }
            name = f"peers worker of process {process}"
            try:
                protocol.run_worker(
                    WORKER,
                    json.dumps(job),
                    layout.padded_env(design.rng_seed, process, blas),
                    {"peer": rows.append},
                    name,
                )
            except protocol.WorkerError as exc:
                raise RuntimeError(f"{name}: {exc}" if exc.said else str(exc)) from None
            frame = pd.DataFrame(rows, columns=list(COLUMNS))
            runfolder.write_csv(frame, path)
            advance()
    return frame


def peers_path(out: str | Path) -> Path:
    """Where ``peers.csv`` goes: ``out`` itself if it names a .csv file, else a file in the folder ``out``.

    >>> peers_path("runs/x").as_posix(), peers_path("mine.csv").as_posix()
    ('runs/x/peers.csv', 'mine.csv')
    """
    out = Path(out)
    return out if out.suffix.lower() == ".csv" else out / PEERS


#: The peers' worker, in the one worker protocol.
WORKER = (sys.executable, "-m", "tribench.harness.jobs.peers")


@dataclass(frozen=True)
class _Contender:
    """A contender of one worker: its label, the rays it runs (all, or trimesh's subset), the timed
    call, its one-off set-up time in ns, and whether the call returns its own time, read in C."""

    label: str
    rows: np.ndarray | slice
    call: Callable[[], Any]
    setup_ns: int
    timed_in_c: bool = False


def _worker(text: str) -> None:
    """One replicate: build every contender once, then time them ``reps`` times; rows go to stdout."""
    job = json.loads(text)
    design = PeerDesign(**job["design"])
    cpu = job["cpu"]
    layout.pin(cpu)  # cpu -1: not pinned, and the rows say so, as the sweep worker's do
    # the sweep worker's layout randomisation: its environment was padded, then small allocations and
    # the arrays every contender reads in fresh buffers at random offsets
    rng = np.random.default_rng([design.rng_seed, 4, job["process"]])
    dummies = layout.dummy_allocations(rng)
    w = cache.make(camera_spec(design))
    o, d, tris = (layout.fresh_copy(a, rng) for a in (w.origins, w.directions, w.triangles))
    w = replace(w, origins=o, directions=d, triangles=tris)
    ambiguous = w.ambiguous()

    def disagreements(index: np.ndarray, rows: np.ndarray | slice) -> tuple[int, int]:
        assert w.ref_index is not None  # a camera workload has closest hits
        wrong = np.asarray(index) != w.ref_index[rows]
        return int(wrong.sum()), int((wrong & ambiguous[rows]).sum())

    contenders, closest = _tribench_contenders(job["kernel"], design.accel, w)
    # the C-timed loops return counts only: each tribench contender's answers, from its untimed twin
    differ = {name: disagreements(index, slice(None)) for name, index in closest.items()}
    natives, native_answers = _embree_contenders(job["peers"], w)
    contenders.update(natives)
    differ.update({name: disagreements(index, slice(None)) for name, index in native_answers.items()})
    contenders.update(_peer_contenders(job["peers"], design, w))
    rng = np.random.default_rng([design.rng_seed, 2, job["process"]])
    for rep in range(design.reps):
        for position, name in enumerate(rng.permutation(list(contenders))):
            c = contenders[name]
            rays = len(w.origins[c.rows])
            time.sleep(PAUSE_S)
            t0, c0 = time.perf_counter_ns(), time.process_time_ns()
            answer = c.call()
            wall, used = time.perf_counter_ns() - t0, time.process_time_ns() - c0
            elapsed = answer.elapsed_ns if c.timed_in_c else wall  # the loop alone, timed in C
            if name not in differ:
                differ[name] = disagreements(answer, c.rows)
            row = PeerRow(
                process=job["process"],
                rep=rep,
                position=position,
                contender=name,
                implementation=c.label,
                kernel=job["kernel"],
                workload_id=w.workload_id,
                workload=w.spec.summary(),
                rays=rays,
                elapsed_ns=int(elapsed),
                wall_ns=int(wall),
                cpu_ns=int(used),
                rays_per_s=rays / elapsed * 1e9,
                setup_ns=c.setup_ns,
                differ=differ[name][0],
                differ_ambiguous=differ[name][1],
                cpu=cpu,
            )
            protocol.emit("peer", row)
    del dummies  # kept alive until the last call: they shift every later heap address


def _tribench_contenders(kernel: str, accel: str, w: Any) -> tuple[dict[str, _Contender], dict[str, np.ndarray]]:
    """tribench's contenders (C-timed loop, Python call and, through the BVH, packets of 16 rays) and each
    one's closest triangle per ray; a BVH's build time is the set-up, as Embree's is."""
    from ... import ext
    from ...workloads import bvh_cache
    from ..machine import version

    o, d, tris = w.origins, w.directions, w.triangles
    info = ext.kernel_info(kernel)
    form = f"x{info.lanes} {info.isa}" if info.lanes > 1 else "scalar"
    timed: Callable[[], Any]  # returns a batch with elapsed_ns, timed in C
    closest: Callable[[], np.ndarray]
    t0 = time.perf_counter_ns()
    if accel == "bvh":
        label = f"tribench {version()} bvh {kernel} ({form})"
        bvh, setup_ns = bvh_cache.cached_bvh(kernel, tris)
        timed = functools.partial(bvh.time, o, d, "closest", 1)
        closest, closest_name = (lambda: bvh.intersect(o, d).hits.index), "BVH.intersect"
    else:
        label = f"tribench {version()} {kernel} ({form})"
        timed = functools.partial(ext.time_batch, ext.make_job(kernel, o, d, tris, "closest"), 1)
        closest, closest_name = (lambda: ext.intersect(kernel, o, d, tris, "closest").index), "ext.intersect"
        setup_ns = time.perf_counter_ns() - t0
    contenders = {
        "tribench": _Contender(label, slice(None), timed, setup_ns, timed_in_c=True),
        "tribench_call": _Contender(f"{label}, {closest_name}", slice(None), closest, 0),
    }
    answers = {"tribench": closest(), "tribench_call": closest()}
    if accel == "bvh":  # packets: the same tree and leaf test; for Embree's rtcIntersect16
        packets = functools.partial(bvh.time, o, d, "closest", 1, layout="packets")
        contenders["tribench_packets"] = _Contender(
            f"{label}, packets of 16 rays", slice(None), packets, setup_ns, True
        )
        answers["tribench_packets"] = bvh.intersect(o, d, layout="packets").hits.index
    return contenders, answers


def _embree_contenders(peers: Sequence[str], w: Any) -> tuple[dict[str, _Contender], dict[str, np.ndarray]]:
    """Native Embree's four contenders, each scene built once, with their closest hits, each at its fastest ISA here."""
    from ...ext import embree

    if "embree" not in peers:
        return {}, {}
    o, d = w.origins, w.directions
    contenders: dict[str, _Contender] = {}
    answers: dict[str, np.ndarray] = {}
    for robust in (False, True):
        scenes = {isa: embree.EmbreeScene(w.triangles, robust, isa) for isa in embree.isas_here()}
        for width in embree.WIDTHS:
            name = NATIVE_EMBREE[2 * robust + (width == 16)]
            isa = _fastest_isa(scenes, o, d, width)
            scene = scenes[isa]
            call = "rtcIntersect16, packets of 16 rays" if width == 16 else "rtcIntersect1"
            mode = ", robust" if robust else ""
            held = ", held to AVX2 (its fastest here)" if isa else ""
            contenders[name] = _Contender(
                f"native {embree.version()} {call}{mode}{held}",
                slice(None),
                functools.partial(scene.trace, o, d, None, width, 1),
                scene.build_ns,
                timed_in_c=True,
            )
            answers[name] = scene.intersect(o, d, width=width)[0]
    return contenders, answers


def _fastest_isa(scenes: dict[str | None, Any], o: np.ndarray, d: np.ndarray, width: int) -> str | None:
    """The ISA whose scene traces the rays fastest at ``width`` (least of three alternating passes each):
    the peer is Embree at its best here (on a Zen 5 AVX2's rtcIntersect1 beats AVX-512's by 3-7%)."""
    best: dict[str | None, float] = {isa: math.inf for isa in scenes}
    for _ in range(3):
        for isa, scene in scenes.items():
            best[isa] = min(best[isa], scene.trace(o, d, None, width, 1).elapsed_ns)
    return min(best, key=best.__getitem__)


def _peer_contenders(peers: Sequence[str], design: PeerDesign, w: Any) -> dict[str, _Contender]:
    """The installed Python peers asked for: trimesh's intersector on a fixed random subset of the rays
    (it is slow), Embree through embreex on every ray; each built (rtree, BVH) by one first call, its set-up."""
    import trimesh

    if not {"trimesh", "embreex"} & set(peers):
        return {}
    o, d, n = w.origins, w.directions, len(w.origins)
    versions = available()
    mesh = trimesh.Trimesh(**trimesh.triangles.to_kwargs(w.triangles.astype(np.float64)), process=False)
    out: dict[str, _Contender] = {}
    if "trimesh" in peers:
        from trimesh.ray import ray_triangle

        subset = np.sort(
            np.random.default_rng([design.rng_seed, 3]).choice(n, size=min(design.trimesh_rays, n), replace=False)
        )
        o_sub, d_sub = o[subset].astype(np.float64), d[subset].astype(np.float64)
        t0 = time.perf_counter_ns()
        slow = ray_triangle.RayMeshIntersector(mesh)
        slow.intersects_first(o_sub[:1], d_sub[:1])  # builds the rtree
        setup = time.perf_counter_ns() - t0
        out["trimesh"] = _Contender(
            f"trimesh ray_triangle ({versions['trimesh']})", subset, lambda: slow.intersects_first(o_sub, d_sub), setup
        )
    if "embreex" in peers:
        from trimesh.ray import ray_pyembree

        t0 = time.perf_counter_ns()
        fast = ray_pyembree.RayMeshIntersector(mesh)
        fast.intersects_first(o[:1], d[:1])  # builds the BVH
        setup = time.perf_counter_ns() - t0
        out["embreex"] = _Contender(
            f"Embree via trimesh ray_pyembree, from Python ({versions['embreex']})",
            slice(None),
            lambda: fast.intersects_first(o, d),
            setup,
        )
    return out


def main() -> int:
    """The worker's entry point: ``python -m tribench.harness.jobs.peers``, its job on stdin."""
    return protocol.serve(_worker)


if __name__ == "__main__":
    sys.exit(main())
