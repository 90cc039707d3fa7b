"""The runner: starts worker processes one at a time and keeps every batch they time.

:func:`start` makes a run folder and runs the whole plan, :func:`resume` finishes an interrupted one; both
hold the folder's writer lock. Every batch is appended to ``batches.csv`` as it arrives, so a kill loses at
most the batch in flight, and a full disk stops the sweep with one line saying how to resume. The plan is a
pure function of ``run.json``'s sweep, so the missing batches are the planned keys absent from
``batches.csv``. A process cut off half-way keeps its batches; the rest run in a new worker with the same
``process`` and ``attempt`` + 1 (which lets an analysis find the two halves), warm-ups not repeated."""

from __future__ import annotations

import dataclasses
import datetime as _dt
import functools
import hashlib
import json
import os
import secrets
import sys
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import ExitStack, contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TextIO

from .. import ext
from ..common import UserError, seconds_from_env
from ..workloads import mesh_files
from ..workloads.spec import MeshSpec
from . import runfolder
from .duration import format_duration
from .plan import BatchKey, Sweep, plan, process_seed
from .protocol import WorkerError, run_worker
from .runfolder import (
    BATCH_COLUMNS,
    CHECK_COLUMNS,
    PROCESS_COLUMNS,
    TRAVERSAL_COLUMNS,
    BatchRow,
    CheckRow,
    ProcessRow,
    RowWriter,
    TraversalRow,
)

__all__ = [
    "PROGRESS_VARIABLE",
    "Progress",
    "RunResult",
    "SweepError",
    "SweepInterrupted",
    "default_cpu",
    "done_keys",
    "missing_keys",
    "progress_seconds",
    "resume",
    "start",
]

WORKER = (sys.executable, "-m", "tribench.harness.worker")
#: The measured files by the type of the worker's lines: file, row type, columns.
_MEASURED_ROWS: dict[str, tuple[str, Any, Sequence[str]]] = {
    "batch": (runfolder.BATCHES, BatchRow, BATCH_COLUMNS),
    "process": (runfolder.PROCESSES, ProcessRow, PROCESS_COLUMNS),
    "check": (runfolder.CHECKS, CheckRow, CHECK_COLUMNS),
    "traversal": (runfolder.TRAVERSALS, TraversalRow, TRAVERSAL_COLUMNS),
}


class SweepError(Exception):
    """A sweep stopped: a kernel failed its checks, or a worker died."""


class SweepInterrupted(Exception):
    """Ctrl-C: the sweep stopped cleanly; every finished batch is on disk."""


@contextmanager
def resumed_with(out: str | Path, command: str) -> Iterator[None]:
    """Ctrl-C in a job's sweep: the message names ``command``, the job's way to finish, not ``sweep --resume``."""
    try:
        yield
    except SweepInterrupted as exc:
        raise SweepInterrupted(str(exc).replace(f"tribench sweep --resume {out}", command)) from None


@dataclass(frozen=True)
class RunResult:
    """What one invocation of the runner did."""

    run_dir: Path
    batches_total: int
    batches_done: int
    batches_run: int
    elapsed_s: float


#: Seconds between plain progress lines off a terminal (default :data:`PROGRESS_SECONDS`).
PROGRESS_VARIABLE = "TRIBENCH_PROGRESS_SECONDS"
PROGRESS_SECONDS = 10.0


def progress_seconds() -> float:
    """The interval of plain progress lines: ``$TRIBENCH_PROGRESS_SECONDS``, else :data:`PROGRESS_SECONDS`."""
    return seconds_from_env(PROGRESS_VARIABLE, PROGRESS_SECONDS, "seconds between progress lines")


class Progress:
    """Progress with an estimate of the time left, on ``stream`` (default stderr): on a terminal (or with
    ``force``) a bar redrawn in place, elsewhere a plain line once both :func:`progress_seconds` and a tenth of
    the work have passed. The rate is this invocation's only, so a resume is not misled by batches it did not run."""

    def __init__(
        self,
        total: int,
        done: int,
        stream: TextIO | None = None,
        force: bool = False,
        unit: str = "batches",
        label: str = "sweep",
    ) -> None:
        self.total, self.done, self._start_done, self.unit, self.label = total, done, done, unit, label
        self.stream = stream if stream is not None else sys.stderr
        self.bar = force or (hasattr(self.stream, "isatty") and self.stream.isatty())
        self._interval = 0.0 if self.bar else progress_seconds()
        self._t0 = time.monotonic()
        self._last, self._last_done = self._t0, done

    def advance(self, n: int = 1) -> None:
        self.done += n
        now = time.monotonic()
        if self.bar:
            if now - self._last > 0.1 or self.done == self.total:
                self._last = now
                self.stream.write("\r" + self.line(now - self._t0))
                self.stream.flush()
        elif now - self._last >= self._interval and (
            10 * (self.done - self._last_done) >= self.total or self.done == self.total
        ):
            self._last, self._last_done = now, self.done
            self.stream.write(self.plain_line(now - self._t0) + "\n")
            self.stream.flush()

    def _left(self, elapsed: float) -> float | None:
        ran = self.done - self._start_done
        return None if ran == 0 else elapsed / ran * (self.total - self.done)

    def line(self, elapsed: float) -> str:
        """The bar's text after ``elapsed`` seconds."""
        frac = self.done / self.total if self.total else 1.0
        bar = "#" * int(30 * frac) + "-" * (30 - int(30 * frac))
        left = self._left(elapsed)
        shown = "?" if left is None else _clock(left)
        return f"[{bar}] {100 * frac:5.1f}% {self.done}/{self.total} {self.unit}, {shown} left "

    def plain_line(self, elapsed: float) -> str:
        """The plain line after ``elapsed`` seconds.

        >>> p = Progress(5000, 0, unit="batches")
        >>> p.plain_line(1.0)
        'tribench sweep: 0/5000 batches (0%), 1 s elapsed'
        >>> p.done = 1250
        >>> p.plain_line(40.0)
        'tribench sweep: 1250/5000 batches (25%), 40 s elapsed, about 2 min left'
        """
        frac = self.done / self.total if self.total else 1.0
        left = self._left(elapsed)
        text = (
            f"tribench {self.label}: {self.done}/{self.total} {self.unit} ({int(100 * frac)}%)"  # 100% only at the end
        )
        text += f", {round(elapsed)} s elapsed"
        return text if left is None or self.done == self.total else f"{text}, about {format_duration(left)} left"

    def close(self) -> None:
        if self.bar:
            self.stream.write("\n")
            self.stream.flush()


@contextmanager
def progress_ticks(
    progress: bool | None, total: int, done: int = 0, unit: str = "batches", label: str = "sweep"
) -> Iterator[Callable[[], None]]:
    """:meth:`Progress.advance` of a bar shown for the body and closed after it (``progress`` True: forced,
    None: as :class:`Progress` decides, False: none, and a callable that does nothing)."""
    if progress is False:
        yield lambda: None
        return
    bar = Progress(total, done, force=bool(progress), unit=unit, label=label)
    try:
        yield bar.advance
    finally:
        bar.close()


def _clock(seconds: float) -> str:
    s = int(round(seconds))
    return f"{s // 3600}:{s % 3600 // 60:02d}:{s % 60:02d}"


def default_cpu() -> int | None:
    """The CPU workers are pinned to: the last usable one (CPU 0 takes most interrupts)."""
    if not hasattr(os, "sched_getaffinity"):
        return None
    return max(os.sched_getaffinity(0))


def _plan_digest(keys: Sequence[BatchKey]) -> str:
    return hashlib.sha256(json.dumps([k.to_list() for k in keys]).encode()).hexdigest()


def _key(row: Any) -> BatchKey:
    return BatchKey(int(row.process), str(row.workload_id), int(row.round), int(row.position), str(row.kernel))


def done_keys(run_dir: str | Path, run: runfolder.Run | None = None) -> list[BatchKey]:
    """Keys of the batches in ``batches.csv``, validated (a partial last line is ignored)."""
    frame = runfolder.read_batches(run_dir, run)
    return [_key(r) for r in frame.itertuples(index=False)]


def missing_keys(sweep: Sweep, done: Sequence[BatchKey]) -> list[BatchKey]:
    """Planned keys not in ``done``, in plan order."""
    have = set(done)
    return [k for k in plan(sweep) if k not in have]


# ------------------------------------------------------------------- running


def start(
    sweep: Sweep,
    run_dir: str | Path,
    *,
    margin: Any = None,
    cpu: int | None = None,
    progress: bool | None = None,
    worker: Sequence[str] = WORKER,
    extra: dict[str, Any] | None = None,
    build_checks: Mapping[str, Mapping[str, Sequence[str]]] | None = None,
) -> RunResult:
    """Create ``run_dir`` (new, or empty but for a failed start's lock file) and run every batch of ``sweep``.

    ``margin`` defaults to the latest calibration's, else ``stats.DEFAULTS.margin``; ``worker`` runs a worker
    (tests substitute a faulty one); ``build_checks``: per build, what each kernel got wrong when checked again
    under it (a build without it is recorded as not checked). Raises SweepError, SweepInterrupted, or UserError
    when ``run_dir`` is not empty, is locked, or cannot be written."""
    from .machine import machine_record
    from .margin import latest_margin
    from .peak import throughput_record
    from .worker import kernel_isa, silence_floor_s

    run_dir = Path(run_dir)
    runfolder.check_new_run_dir(run_dir)
    if progress is not False:
        progress_seconds()  # a bad $TRIBENCH_PROGRESS_SECONDS fails before the run folder exists
    silence_floor_s()  # and a bad $TRIBENCH_SILENCE_SECONDS
    machine = machine_record()
    margin = margin if margin is not None else latest_margin(machine["cpu_model"])
    keys = plan(sweep)
    checks = build_checks or {}
    builds = [  # each compiled here, once, before the run folder exists: the workers find it in the cache
        {**ext.build_record(b), "check": dict(checks[b]) if b in checks else None} for b in sweep.build_names
    ]
    try:
        run_dir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise UserError(f"cannot create the run folder {run_dir}: {exc.strerror or exc}") from None
    with runfolder.writer_lock(run_dir):
        runfolder.check_new_run_dir(run_dir)  # again, under the lock: another start may have been faster
        record = {
            "run_id": _dt.datetime.now().strftime("%Y%m%dT%H%M%S-") + secrets.token_hex(3),
            "created": _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
            "sweep": sweep.to_dict(),
            "n_batches": len(keys),
            "plan_sha256": _plan_digest(keys),
            "process_seeds": [process_seed(sweep.rng_seed, p) for p in range(sweep.processes)],
            "cpu": default_cpu() if cpu is None else cpu,
            "isa": {k: kernel_isa(k) for k in sweep.kernels},
            "margin": {"value": margin.value, "source": margin.source},
            "machine": machine,
            "throughput": throughput_record(),
            "python_executable": sys.executable,
            "batch_columns": list(BATCH_COLUMNS),
            "process_columns": list(PROCESS_COLUMNS),
            "builds": builds,
            **(extra or {}),
        }
        runfolder.write_run(run_dir, record)
        run = runfolder.Run.from_record(record, run_dir, sweep)
        for spec in sweep.workloads:  # a run folder carries the mesh and ray files it used (those that fit)
            if isinstance(spec, MeshSpec) and spec.mesh_sha256 is not None:
                mesh_files.copy_into_run(run_dir, spec.mesh, spec.mesh_sha256)
            if isinstance(spec, MeshSpec) and spec.rays_sha256 is not None:
                mesh_files.copy_into_run(run_dir, spec.rays, spec.rays_sha256, mesh_files.RAYS_FOLDER)
        texts = {f.path: f.text for f in ext.loaded_kernel_files()}
        for f in record["sweep"].get("kernel_files", ()):  # the C its kernels were compiled from, headers and all
            mesh_files.copy_into_run(run_dir, texts[f["path"]], f["sha256"], mesh_files.KERNELS_FOLDER)
        if sweep.sequential is not None:
            return _execute_stages(run, keys, progress, worker)
        return _execute(run, keys, 0, progress, worker)


def resume(run_dir: str | Path, *, progress: bool | None = None, worker: Sequence[str] = WORKER) -> RunResult:
    """Run the batches of ``run_dir``'s plan that ``batches.csv`` lacks, after cutting a measured file's partial
    last line. Raises UserError when another process writes ``run_dir``, its files are not valid, or a file
    cannot be written."""
    run_dir = Path(run_dir)
    run = runfolder.read_run(run_dir)
    keys = plan(run.sweep)
    if _plan_digest(keys) != run.plan_sha256:
        raise UserError(f"{run_dir}: the plan of its sweep changed (another tribench version?); cannot resume")
    usable = sorted(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else None
    if run.cpu is not None and usable is not None and run.cpu not in usable:
        # a folder copied from a machine with more CPUs: its workers go on on this machine's choice
        print(
            f"tribench: CPU {run.cpu} of the run is not usable here; workers run on CPU {usable[-1]}",
            file=sys.stderr,
        )
        run = dataclasses.replace(run, cpu=usable[-1], raw={**run.raw, "cpu": usable[-1]})
    with runfolder.writer_lock(run_dir):
        for name, _, _ in _MEASURED_ROWS.values():
            try:
                cut = runfolder.repair_csv(run_dir / name)
            except OSError as exc:
                raise UserError(f"cannot repair {run_dir / name}: {exc.strerror or exc}") from None
            if cut:
                print(f"tribench: dropped a partial last line of {run_dir / name}", file=sys.stderr)
        if run.sweep.sequential is not None:
            return _execute_stages(run, keys, progress, worker)
        done = done_keys(run_dir, run) if os.path.lexists(run_dir / runfolder.BATCHES) else []
        todo = missing_keys(run.sweep, done)
        return _execute(run, todo, len(keys) - len(todo), progress, worker)


def _attempts(run: runfolder.Run) -> dict[int, int]:
    """The next attempt number of every process that has started before."""
    out: dict[int, int] = {}
    for frame in (
        runfolder.read_processes(run.folder, run),
        runfolder.read_batches(run.folder, run) if os.path.lexists(run.folder / runfolder.BATCHES) else None,
    ):
        if frame is None or frame.empty:
            continue
        for p, a in frame.groupby("process")["attempt"].max().items():
            out[int(p)] = max(out.get(int(p), 0), int(a) + 1)
    return out


def _execute_stages(
    run: runfolder.Run,
    keys: Sequence[BatchKey],
    progress: bool | None,
    worker: Sequence[str],
) -> RunResult:
    """A sequential sweep (:mod:`tribench.harness.stages`): finish the stages ``stages.json`` records
    (a resume), then decide and run one after another until :func:`~tribench.harness.stages.decide` ends it."""
    from . import stages

    def say(text: str) -> None:
        if progress is not False:
            print(f"tribench sweep: {text}", file=sys.stderr)

    run_dir, sweep = run.folder, run.sweep
    t0 = time.monotonic()
    data = stages.read_stages(run_dir)
    have = set(done_keys(run_dir, run)) if os.path.lexists(run_dir / runfolder.BATCHES) else set()
    ran, seconds, last_s = 0, 0.0, None
    try:
        for stage in data["stages"]:  # recorded: decided before, finished (or cut short) since
            todo = [k for k in stages.keys_of(stage, keys) if k not in have]
            if todo:
                ran += _execute(run, todo, 0, progress, worker, len(todo)).batches_run
            seconds = stage["seconds_before"] + time.monotonic() - t0
        while data.get("end") is None:
            t_stage = time.monotonic()
            stage, why = stages.decide(sweep, run_dir, data["stages"], seconds, last_s)
            if stage is None:
                data["end"] = why
                stages.write_stages(run_dir, data)
                break
            data["stages"].append(stage)
            stages.write_stages(run_dir, data)  # decided before it runs: a resume runs the same
            todo = stages.keys_of(stage, keys)
            say(
                f"stage {stage['stage'] + 1}: processes {stage['first_process'] + 1}-{stage['last_process'] + 1} "
                f"of at most {sweep.processes}, {sum(len(k) for k in stage['open'].values())} kernel-workload "
                f"pairs, {len(todo):,} batches"
            )
            ran += _execute(run, todo, 0, progress, worker, len(todo)).batches_run
            last_s = time.monotonic() - t_stage
            seconds += last_s
    except SweepInterrupted:
        raise SweepInterrupted(
            f"interrupted in stage {len(data['stages'])}: every finished batch is saved in {run_dir}; "
            f"finish with: tribench sweep --resume {run_dir}"
        ) from None
    say(f"stopped: {data['end']}")
    done = len(done_keys(run_dir, run))
    if run.n_batches != done:
        # the stages are over: what they ran is the run's whole plan now (a reader that
        # compares n_batches with batches.csv sees a finished run), the most it could have run beside it
        most = run.raw.get("n_batches_most", run.n_batches)
        runfolder.write_run(run_dir, {**run.raw, "n_batches": done, "n_batches_most": most})
    return RunResult(run_dir, done, done, ran, time.monotonic() - t0)


def _execute(
    run: runfolder.Run,
    todo: Sequence[BatchKey],
    done_before: int,
    progress: bool | None,
    worker: Sequence[str],
    total: int | None = None,
) -> RunResult:
    """Run ``todo``; the progress shows ``done_before`` + its batches of ``total`` (default the plan's)."""
    run_dir = run.folder
    t0 = time.monotonic()
    total = run.n_batches if total is None else total
    by_process: dict[int, list[BatchKey]] = {}
    for k in todo:
        by_process.setdefault(k.process, []).append(k)
    attempts = _attempts(run)
    ran = 0
    try:
        with progress_ticks(progress, total, done_before) as advance, ExitStack() as files:
            writers = {
                kind: files.enter_context(RowWriter(run_dir / name, columns))
                for kind, (name, _, columns) in _MEASURED_ROWS.items()
            }

            def keep(kind: str, row: Any) -> None:
                nonlocal ran
                writers[kind].append(row)
                if kind == "batch":
                    ran += 1
                    advance()

            for p, keys in by_process.items():
                _run_process(run, p, attempts.get(p, 0), keys, worker, keep)
    except (KeyboardInterrupt, SweepError, OSError) as exc:  # what is kept, and how to go on
        saved = f"{done_before + ran} of {total} batches saved in {run_dir}"
        finish = f"finish with: tribench sweep --resume {run_dir}"
        if isinstance(exc, KeyboardInterrupt):
            raise SweepInterrupted(f"interrupted: {saved}; {finish}") from None
        if isinstance(exc, SweepError):  # a worker died: go on once its cause is fixed
            raise SweepError(f"{exc}; {saved}; once the cause is fixed, {finish}") from None
        # a full disk, mostly; the writers left whole lines only
        raise UserError(
            f"cannot write {exc.filename or run_dir}: {exc.strerror or exc}; {saved}; make room, then {finish}"
        ) from None
    return RunResult(run_dir, total, done_before + ran, ran, time.monotonic() - t0)


def _run_process(
    run: runfolder.Run,
    process: int,
    attempt: int,
    keys: Sequence[BatchKey],
    worker: Sequence[str],
    keep: Callable[[str, Any], None],
) -> None:
    """One worker process: send its job, ``keep(type, row)`` each row (batch, process, check, traversal), raise
    on its error."""
    from .layout import padded_env
    from .worker import WorkerJob

    sweep, seed = run.sweep, run.process_seeds[process]
    env = padded_env(seed, attempt)  # moves the worker's initial stack: part of the layout randomisation
    wids = sorted({k.workload_id for k in keys})
    job = WorkerJob(
        run.run_id,
        process,
        attempt,
        seed,
        run.cpu,
        sweep.target_ms,
        tuple(tuple(k.to_list()) for k in keys),
        {w: sweep.spec_of(w).to_dict() for w in wids},
        sweep.kernel_files,
        sweep.build_of(process),
    )
    planned, expected = frozenset(keys), set(keys)

    def on_line(kind: str, message: dict[str, Any]) -> None:
        row = _MEASURED_ROWS[kind][1](**message)
        key = _key(row) if kind in ("batch", "traversal") else None  # a batch comes once, a traversal is a batch's
        if key is not None and key not in (expected if kind == "batch" else planned):
            raise SweepError(f"worker of process {process} sent an unplanned {kind} {key}")
        if kind == "batch":
            expected.discard(key)
        keep(kind, row)

    handlers = {kind: functools.partial(on_line, kind) for kind in _MEASURED_ROWS}
    try:
        run_worker(worker, job.to_json(), env, handlers, f"worker of process {process}")
    except WorkerError as exc:
        raise SweepError(str(exc)) from None
    if expected:
        raise SweepError(f"worker of process {process} ended with {len(expected)} of its batches not run")
