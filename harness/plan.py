"""What a sweep measures, and in which order: the sweep spec and its batch plan.

:func:`plan` expands a :class:`Sweep` into its batches in execution order, a pure function of the sweep, so a
resumed run knows exactly which batches are missing. In each process the workloads come in a random order (a block
of rounds each, so the kernels share its buffers), warm-up rounds (``-warmup .. -1``, kept and labelled) before the
timed ones, every kernel once per round in a fresh order; every choice comes from :func:`process_seed`."""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

import numpy as np

from ..common import UserError
from ..common.renamed import renamed
from ..workloads.kinds import spec_from_dict
from ..workloads.spec import MeshSpec, Spec, file_sha256, workload_id
from .margin import AA_TWINS

__all__ = [
    "BatchKey",
    "MAX_BATCHES",
    "Sequential",
    "Sweep",
    "default_sweep",
    "is_bvh",
    "plan",
    "process_seed",
]

# Defaults of a sweep, in one place; why these: docs/decisions.md, "Defaults of a sweep".
DEFAULT_PROCESSES = 10
DEFAULT_ROUNDS = 10
DEFAULT_WARMUP = 1
DEFAULT_TARGET_MS = 8.0
#: The kernel every speedup is measured against where it ran: the seed's own Möller-Trumbore, the
#: historical baseline (the analysis's default, the main job's comparisons, the seed replay's ratio).
DEFAULT_BASELINE = "moller_seed"

#: The design of a sweep, beside its kernels and workloads: the fields the command line's flags set too.
DESIGN = ("processes", "rounds", "warmup", "target_ms", "rng_seed")

# Bounds of a sweep, so a typo (--rounds 1000000000) is refused before anything is allocated:
# a million batches (the main job plans at most 18,864) is about 150 MB of plan and 2.2 hours
# of timed batches; past that, a study is several sweeps.
MAX_BATCHES = 1_000_000
MAX_PROCESSES = 10_000  # each process costs about 5 s of start-up and checks: 14 hours
MAX_ROUNDS = 100_000
MAX_WARMUP = 1_000
MAX_WORKLOADS = 1_000  # each is generated, cached and calibrated in every process (the main job has 13)
_WHY = {
    "processes": " (each process costs about 5 s of start-up and checks)",
    "batches": f" (about {MAX_BATCHES * DEFAULT_TARGET_MS / 3.6e6:.1f} hours of timed batches at the "
    f"default {DEFAULT_TARGET_MS:g} ms each, and about 150 MB of plan)",
}


def check_workload_count(n: int) -> None:
    """Refuse more than :data:`MAX_WORKLOADS` workloads (before any is built)."""
    if n > MAX_WORKLOADS:
        raise UserError(
            f"the sweep has {n:,} workloads; at most {MAX_WORKLOADS:,} (each is generated, cached "
            f"and calibrated in every process; the main job has 13): split it into several sweeps"
        )


def is_bvh(spec: Spec) -> bool:
    """Whether the workload runs through a BVH (a mesh spec's ``accel``)."""
    return isinstance(spec, MeshSpec) and spec.accel == "bvh"


@dataclass(frozen=True, order=True)
class BatchKey:
    """The identity of one batch, unique within a run; ``round < 0`` is a warm-up round."""

    process: int
    workload_id: str
    round: int
    position: int
    kernel: str

    def to_list(self) -> list:
        """Compact JSON form, as the worker receives it."""
        return [self.process, self.workload_id, self.round, self.position, self.kernel]


@dataclass(frozen=True)
class Sequential:
    """A sequential design: processes in stages, each comparison stopped once its 95% interval is narrow.

    ``target`` is a relative half-width; ``processes`` is then the most the sweep may run, and it also ends when the
    next stage would end past ``budget_s``. Only the width decides, so the intervals keep their coverage
    (docs/methodology.md, "The main job's sequential design")."""

    #: Processes per stage (the first stage included).
    stage: int
    #: Relative half-width of a narrow comparison (0.02: within about 2%).
    target: float
    #: Seconds of sweep the stages may take (the runner's wall time).
    budget_s: float

    def __post_init__(self) -> None:
        if isinstance(self.stage, bool) or not isinstance(self.stage, (int, np.integer)) or not 1 <= self.stage:
            raise UserError(f"sequential.stage must be a positive number of processes, got {self.stage!r:.80}")
        for name, hi in (("target", 1.0), ("budget_s", 7 * 24 * 3600.0)):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
                raise UserError(f"sequential.{name} must be a number, got {value!r:.80}")
            if not 0 < value <= hi:
                raise UserError(f"sequential.{name} must be in (0, {hi:g}], got {value!r:.80}")
        object.__setattr__(self, "stage", int(self.stage))

    def to_dict(self) -> dict[str, Any]:
        return {"stage": self.stage, "target": float(self.target), "budget_s": float(self.budget_s)}


@dataclass(frozen=True)
class Sweep:
    """A grid of kernels x workloads and the design that measures it.

    ``kernels`` may be internal (the harness's checks use them); ``loops`` is calibrated per kernel, workload and
    process to ``target_ms``; ``rng_seed`` drives every random choice, layout included. ``workload_kernels``: per
    workload, the kernels that run it (empty: :meth:`kernels_for`). ``kernel_files`` are loaded here and by every
    worker (checked by :mod:`tribench.harness.jobs.kernel_check`). ``builds`` (:func:`tribench.ext.parse_builds`;
    empty: the installed one) are taken in turn by the processes: 10 processes and 2 builds are 5 of each."""

    kernels: tuple[str, ...]
    workloads: tuple[Spec, ...]
    processes: int = DEFAULT_PROCESSES
    rounds: int = DEFAULT_ROUNDS
    warmup: int = DEFAULT_WARMUP
    target_ms: float = DEFAULT_TARGET_MS
    rng_seed: int = 0
    workload_kernels: tuple[tuple[str, ...], ...] = ()
    sequential: Sequential | None = None
    kernel_files: tuple[str, ...] = ()
    builds: tuple[str, ...] = ()
    workload_ids: tuple[str, ...] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        from .. import ext
        from ..workloads.seed.workload import SeedSpec
        from ..workloads.spec import PairSpec

        put = object.__setattr__  # frozen: normalise once, here
        # sizes first, arithmetically: nothing is expanded before the plan is known to be bounded
        for name, lo, hi in (
            ("processes", 1, MAX_PROCESSES),
            ("rounds", 1, MAX_ROUNDS),
            ("warmup", 0, MAX_WARMUP),
            ("rng_seed", 0, 2**63 - 1),
        ):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
                raise UserError(f"{name} must be an integer, got {value!r:.80}")
            if not lo <= value <= hi:
                raise UserError(f"{name} must be between {lo} and {hi:,}, got {value:,}{_WHY.get(name, '')}")
            put(self, name, int(value))
        if (
            isinstance(self.target_ms, bool)
            or not isinstance(self.target_ms, (int, float, np.integer, np.floating))
            or not 0.01 <= self.target_ms <= 1000
        ):
            raise UserError(f"target_ms must be a number between 0.01 and 1000, got {self.target_ms!r:.80}")
        put(self, "target_ms", float(self.target_ms))
        for name in ("kernels", "workloads"):
            value = getattr(self, name)
            if isinstance(value, (str, bytes, Mapping)) or not isinstance(value, Sequence):
                raise UserError(f"{name} must be a list, got {value!r:.80}")
            put(self, name, tuple(value))
        if not self.kernels:
            raise UserError("a sweep needs at least one kernel")
        self._load_kernel_files()
        put(self, "builds", ext.check_builds(self.builds) if self.builds != () else ())
        if len(self.build_names) > 1 and self.processes < 2 * len(self.build_names):
            raise UserError(
                f"{len(self.build_names)} builds need at least {2 * len(self.build_names)} processes "
                f"(the processes take the builds in turn, and an interval needs two of each), got {self.processes}"
            )
        known = ext.kernel_names(internal=True)
        for k in self.kernels:
            if not isinstance(k, str) or k not in known:
                raise UserError(f"unknown kernel {k!r:.80}; known kernels: {', '.join(ext.kernel_names())}")
        if len(set(self.kernels)) != len(self.kernels):
            raise UserError(f"kernels listed twice: {', '.join(self.kernels)}")
        if not self.workloads:
            raise UserError("a sweep needs at least one workload")
        check_workload_count(len(self.workloads))
        for spec in self.workloads:
            if not isinstance(spec, (PairSpec, MeshSpec, SeedSpec)):
                raise UserError(f"a workload must be a PairSpec, MeshSpec or SeedSpec, got {type(spec).__name__}")
        ids = tuple(workload_id(s) for s in self.workloads)
        if len(set(ids)) != len(ids):
            twice = sorted({s.summary() for s, i in zip(self.workloads, ids, strict=True) if ids.count(i) > 1})
            raise UserError(f"a workload is listed twice (two flags or tables make the same one): {'; '.join(twice)}")
        put(self, "workload_ids", ids)
        self._check_workload_kernels()
        if self.sequential is not None and not isinstance(self.sequential, Sequential):
            raise UserError(f"sequential must be a Sequential design, got {type(self.sequential).__name__}")
        for spec in self.workloads:
            if not self.kernels_for(spec):
                if is_bvh(spec):
                    raise UserError(
                        f"no kernel of the sweep can be a BVH's leaf test ({spec.summary()}): "
                        f"add one of {', '.join(ext.bvh_kernel_names())}, or make the workload with accel brute"
                    )
                raise UserError(
                    f"no kernel of the sweep runs mode {spec.mode!r} ({spec.summary()}): "
                    f"native kernels have no pairs mode"
                )
        per_round = self.n_batches // (self.processes * (self.warmup + self.rounds))
        if self.n_batches > MAX_BATCHES:
            raise UserError(
                f"the sweep has {self.n_batches:,} batches ({self.processes:,} processes x "
                f"{self.warmup + self.rounds:,} rounds with warm-up x {per_round:,} kernel-workload pairs); "
                f"a plan holds at most {MAX_BATCHES:,}{_WHY['batches']}: use fewer processes, rounds or "
                f"workloads, or split the study into several sweeps"
            )

    def _load_kernel_files(self) -> None:
        from .. import ext

        files = self.kernel_files
        listed = not isinstance(files, (str, bytes, Mapping)) and isinstance(files, Sequence)
        if not listed or not all(isinstance(f, (str, os.PathLike)) for f in files):
            raise UserError(f"kernel_files must be a list of paths, got {files!r:.80}")
        object.__setattr__(self, "kernel_files", tuple(str(Path(f).expanduser().resolve()) for f in files))
        for f in self.kernel_files:
            ext.load_kernels(f)

    def _check_workload_kernels(self) -> None:
        value = self.workload_kernels
        if isinstance(value, (str, bytes, Mapping)) or not isinstance(value, Sequence):
            raise UserError(f"workload_kernels must be a list of kernel lists, got {value!r:.80}")
        if value and len(value) != len(self.workloads):
            raise UserError(
                f"workload_kernels has {len(value)} lists for {len(self.workloads)} workloads: give one per workload"
            )
        lists = []
        for i, names in enumerate(value):
            if isinstance(names, (str, bytes)) or not isinstance(names, Sequence):
                raise UserError(f"workload_kernels[{i}] must be a list of kernel names, got {names!r:.80}")
            unknown = [k for k in names if k not in self.kernels]
            if unknown:
                raise UserError(f"workload_kernels[{i}]: {unknown[0]!r:.80} is not one of the sweep's kernels")
            lists.append(tuple(names))
        object.__setattr__(self, "workload_kernels", tuple(lists))

    def kernels_for(self, spec: Spec) -> tuple[str, ...]:
        """The sweep's kernels that run ``spec``, in sweep order: its ``workload_kernels``
        (all without), that have its mode, and on a BVH workload can be its leaf test."""
        from .. import ext

        chosen = self.workload_kernels[self.workloads.index(spec)] if self.workload_kernels else self.kernels
        leaf = ext.bvh_kernel_names() if is_bvh(spec) else self.kernels
        return tuple(k for k in self.kernels if k in chosen and spec.mode in ext.kernel_info(k).modes and k in leaf)

    def idle_kernels(self) -> tuple[str, ...]:
        """The kernels that run none of the workloads (:meth:`kernels_for`), in sweep order."""
        return tuple(k for k in self.kernels if not any(k in self.kernels_for(w) for w in self.workloads))

    def reference_of(self, spec: Spec, baseline: str) -> str:
        """The kernel the others of ``spec`` are compared with in a sequential sweep:
        ``baseline`` where it runs, else the first kernel (a BVH workload has no scalar baseline)."""
        kernels = self.kernels_for(spec)
        return baseline if baseline in kernels else kernels[0]

    @property
    def build_names(self) -> tuple[str, ...]:
        """The builds the processes run, in turn: ``builds``, or the installed build alone."""
        from ..ext import INSTALLED

        return self.builds or (INSTALLED,)

    def build_of(self, process: int) -> str:
        """The build process ``process`` runs: the builds in turn (its batches record it)."""
        return self.build_names[process % len(self.build_names)]

    @property
    def n_batches(self) -> int:
        per_round = sum(len(self.kernels_for(w)) for w in self.workloads)
        return self.processes * (self.warmup + self.rounds) * per_round

    def spec_of(self, wid: str) -> Spec:
        return self.workloads[self.workload_ids.index(wid)]

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready form; :meth:`from_dict` inverts it."""
        return {
            "kernels": list(self.kernels),
            "workloads": [s.to_dict() for s in self.workloads],
            "workload_ids": list(self.workload_ids),
            **{k: getattr(self, k) for k in DESIGN},
            # only when used, so the run.json of an ordinary sweep is what it always was
            **({"workload_kernels": [list(k) for k in self.workload_kernels]} if self.workload_kernels else {}),
            **({"sequential": self.sequential.to_dict()} if self.sequential is not None else {}),
            **(
                {"kernel_files": [{"path": f, "sha256": _loaded_file(f).sha256} for f in self.kernel_files]}
                if self.kernel_files
                else {}
            ),
            **({"builds": list(self.builds)} if self.builds else {}),
        }

    @classmethod
    def from_dict(cls, d: Mapping[str, Any], run_dir: str | Path | None = None) -> Sweep:
        """The sweep of :meth:`to_dict`'s form. Its kernel files are the run folder's copies where
        ``run_dir`` has them, else the files at their recorded paths, if their content is unchanged."""
        d = renamed(d)  # a run before #52 wrote its RNG seed as "seed" (its workloads': spec_from_dict)
        unknown = sorted(set(d) - _SWEEP_FIELDS)
        if unknown:  # a newer tribench's part of the plan: run without it, the run would be another one
            raise UserError(f"unknown sweep field(s): {', '.join(map(str, unknown))} (a run of a newer tribench?)")
        return cls(
            kernels=tuple(d["kernels"]),
            workloads=tuple(spec_from_dict(w) for w in d["workloads"]),
            **{k: d[k] for k in DESIGN},
            workload_kernels=tuple(tuple(k) for k in d.get("workload_kernels", ())),
            sequential=Sequential(**d["sequential"]) if d.get("sequential") is not None else None,
            kernel_files=tuple(_kernel_file(f, run_dir) for f in d.get("kernel_files", ())),
            builds=tuple(d.get("builds", ())),
        )


#: What :meth:`Sweep.to_dict` may write: the sweep's own fields (``workload_ids`` checked by the run folder's reader).
_SWEEP_FIELDS = frozenset(f.name for f in fields(Sweep))


def _loaded_file(path: str) -> Any:
    """The record of a loaded kernel file: the sha256 of what was compiled (with its local headers)."""
    from .. import ext

    return next(f for f in ext.loaded_kernel_files() if f.path == path)


def _kernel_file(recorded: Mapping[str, Any], run_dir: str | Path | None) -> str:
    """The file holding a recorded kernel file's content: the run folder's copy, else the file itself."""
    from ..workloads.mesh_files import KERNELS_FOLDER, source

    path, sha = recorded["path"], recorded["sha256"]
    copy = Path(run_dir or "") / KERNELS_FOLDER / f"{sha}{Path(path).suffix.lower()}"
    if run_dir is None or not copy.is_file():
        return str(source(path, sha, KERNELS_FOLDER))
    if file_sha256(copy) == sha:
        return str(copy)
    try:  # the recorded code elsewhere (the file itself, the cache's copy): never the edited copy
        return str(source(path, sha, KERNELS_FOLDER))
    except UserError:  # source's words would say no copy is kept, and send the user to this very folder
        raise UserError(
            f"{copy}: the run folder's copy of the kernel file {path} has changed since the run (its sha256 is "
            f"no longer {sha[:12]}...), and the file itself is gone or changed too: restore the copy from the "
            "original run"
        ) from None


#: The main job's sequential design (``tribench run``, ``--quick``); the budget leaves the rest of
#: about 10 minutes on 2 cores to the other steps: docs/decisions.md, "The main job's design".
MAIN_JOB_DESIGN = {
    False: Sequential(stage=2, target=0.02, budget_s=300.0),
    True: Sequential(stage=3, target=0.05, budget_s=15.0),
}
#: Triangles of the main job's BVH workload (issue #19: at least 250,000), and of ``--quick``'s.
MAIN_JOB_BVH_TRIANGLES = {False: 250_000, True: 10_000}


def default_sweep(quick: bool = False, kernel_files: Sequence[str] = (), builds: Sequence[str] = ()) -> Sweep:
    """The main job's sweep (``tribench run``): which intersector, on this machine.

    Its workloads, kernels and sequential design: docs/methodology.md, "The main job's sequential design"; why 3
    rounds per process: docs/decisions.md. The baseline's A/A twin gives the run its own margin
    (:mod:`tribench.reports.tables.margin`). ``kernel_files``' kernels join in their roles; with ``builds``, each
    stage and the bound on processes grow with their number, so the budget is shared among them."""
    from .. import ext
    from ..workloads.spec import MeshSpec, PairSpec

    for f in kernel_files:  # before the roles: their kernels have roles too
        ext.load_kernels(f)
    # the kernels by role, from the registry (never from their names): the seed's replays, every clean scalar
    # form (the only ones with a pairs mode) and every native form (also the BVH leaf tests)
    info = {k: ext.kernel_info(k) for k in ext.kernel_names()}
    paper = tuple(k for k, i in info.items() if i.seed_replay)
    scalar = tuple(k for k, i in info.items() if i.lanes == 1 and not i.seed_replay)
    native = tuple(k for k, i in info.items() if i.lanes > 1)
    # the baseline's A/A twin, timed wherever the baseline is: the run's own margin (reports/tables/margin.py)
    paper = (*paper, AA_TWINS[DEFAULT_BASELINE])
    kernels = (*paper, *scalar, *native)
    if quick:
        pairs = [PairSpec(n=1024, hit_rate=h, dtype="float32", winding="facing") for h in (0.0, 0.5, 1.0)]
        size, bvh_size, dtypes = 16, 32, ("float32", "float64")
    else:
        pairs = [
            PairSpec(n=4096, hit_rate=h, dtype=d, winding="facing")
            for d in ("float32", "float64")
            for h in (0.0, 0.25, 0.5, 0.75, 1.0)
        ]
        size, bvh_size, dtypes = 48, 64, ("float32", "float64")
    meshes = [MeshSpec("suzanne", triangles=968, width=size, height=size, dtype=d) for d in dtypes]
    bvh = MeshSpec(
        "suzanne",
        triangles=MAIN_JOB_BVH_TRIANGLES[quick],
        width=bvh_size,
        height=bvh_size,
        dtype="float32",
        accel="bvh",
    )
    sets = [(*paper, *scalar)] * len(pairs) + [(*paper, *native)] * len(meshes) + [native]
    n_builds = max(len(builds), 1)
    design = MAIN_JOB_DESIGN[quick]
    return Sweep(
        kernels,
        (*pairs, *meshes, bvh),
        processes=36 * n_builds,  # a bound the budget reaches first (docs/decisions.md, "A 300 s budget")
        rounds=2 if quick else 3,
        warmup=1,
        target_ms=1.0 if quick else DEFAULT_TARGET_MS,
        workload_kernels=tuple(sets),
        sequential=Sequential(design.stage * n_builds, design.target, design.budget_s),
        kernel_files=tuple(kernel_files),
        builds=tuple(builds),
    )


def rows_of_build(frame: Any, batches: Any, build: str) -> Any:
    """The rows of a per-process table measured by ``build``: those whose batches carry it (its one record)."""
    mine = frame["process"].isin(batches.loc[batches["build"] == build, "process"].unique())
    return frame.loc[mine].reset_index(drop=True)


def process_seed(rng_seed: int, process: int) -> int:
    """The seed of one process's random choices (kernel orders, layout), from the sweep's ``rng_seed``.

    >>> process_seed(0, 3) == process_seed(0, 3) != process_seed(0, 4)
    True
    """
    return int(np.random.SeedSequence([rng_seed, process]).generate_state(1, np.uint64)[0])


def plan(sweep: Sweep) -> list[BatchKey]:
    """Every batch of ``sweep``, in execution order.

    >>> from tribench.workloads.spec import PairSpec
    >>> s = Sweep(("moller_trumbore", "curless"), (PairSpec(n=10),), processes=2, rounds=2)
    >>> keys = plan(s)
    >>> len(keys) == s.n_batches == 2 * 1 * 3 * 2
    True
    >>> keys == plan(s), len(set(keys)) == len(keys)
    (True, True)
    >>> [k.round for k in keys[:6]]
    [-1, -1, 0, 0, 1, 1]
    """
    keys = []
    kernel_sets = [sweep.kernels_for(spec) for spec in sweep.workloads]  # once: it asks the registry
    for p in range(sweep.processes):
        rng = np.random.default_rng(process_seed(sweep.rng_seed, p))
        for w in rng.permutation(len(sweep.workloads)):
            wid = sweep.workload_ids[w]
            for r in range(-sweep.warmup, sweep.rounds):
                kernels = kernel_sets[w]
                order = rng.permutation(len(kernels))
                keys += [BatchKey(p, wid, r, pos, kernels[k]) for pos, k in enumerate(order)]
    return keys
