"""The main job (``tribench run``): the default sweep, then its peers and the robustness suite.

It measures; the caller makes the tables and the report from the folder."""

from __future__ import annotations

import sys
from collections.abc import Sequence
from pathlib import Path
from typing import TextIO

import pandas as pd

from ...common import UserError
from .. import duration, plan, runfolder, runner
from .kernel_check import load_checked
from .sweep import measure_robustness, run_sweep

__all__ = ["resume", "run"]


def _say(log: TextIO | None, text: str) -> None:
    print(text, file=sys.stderr if log is None else log)


def run(
    out: str | Path,
    quick: bool = False,
    progress: bool | None = None,
    peers: bool = True,
    log: TextIO | None = None,
    kernel_files: Sequence[str] = (),
    builds: Sequence[str] = (),
) -> str:
    """Measure the main job into the new folder ``out``; what the robustness suite's step said.

    :func:`tribench.harness.plan.default_sweep` through :func:`~.sweep.run_sweep`, then the peers when installed
    (their failure never stops the job), then the robustness suite. ``log`` takes the one-line notes (default
    stderr). Ctrl-C raises :class:`~tribench.harness.runner.SweepInterrupted` naming ``tribench run --resume``."""
    load_checked(kernel_files)  # first: the default sweep gives their kernels roles
    sweep = plan.default_sweep(quick=quick, kernel_files=kernel_files, builds=builds)
    with runner.resumed_with(out, f"tribench run --resume {out}"):
        done = run_sweep(
            sweep,
            out,
            say=lambda line: _say(log, line),
            progress=progress,
            extra={"main_job": {"quick": quick}},
            announce=lambda sweep: _announce(sweep, out),
        )
    return _complete(Path(out), done, quick, progress, peers, log)


def resume(out: str | Path, progress: bool | None = None, peers: bool = True, log: TextIO | None = None) -> str:
    """Finish an interrupted main job in ``out`` as :func:`run` would have (peers unless ``peers.csv`` is complete).

    Raises UserError when ``out`` is not a main job's folder, or another process writes it."""
    out = Path(out)
    main_job = runfolder.read_run(out).main_job
    if main_job is None:
        raise UserError(
            f"{out} is not a main job's run folder (tribench run); finish a sweep with tribench sweep --resume"
        )
    quick = bool(main_job.get("quick"))
    _say(log, f"tribench run --resume: finishing the main job in {out}")
    with runner.resumed_with(out, f"tribench run --resume {out}"):
        done = runner.resume(out, progress=progress)
    return _complete(out, done, quick, progress, peers and not _peers_done(out, quick), log)


def _peers_done(out: Path, quick: bool) -> bool:
    """Whether ``peers.csv`` holds every process of the job's peer design (an interrupted one does not)."""
    from . import peers

    design = peers.PeerDesign.quick() if quick else peers.PeerDesign()
    try:
        done = pd.read_csv(out / runfolder.PEERS, usecols=["process"])["process"].nunique()
    except (OSError, ValueError, pd.errors.ParserError):
        return False
    return bool(done >= design.processes)


def _complete(
    out: Path, done: runner.RunResult, quick: bool, progress: bool | None, peers: bool, log: TextIO | None
) -> str:
    """After the sweep: the peers and the robustness suite; what the suite's step said."""
    _say(log, f"{done.batches_run} batches run in {done.elapsed_s:.1f} s -> {done.run_dir}")
    if peers:
        _run_peers(out, quick=quick, progress=progress, log=log)
    note = measure_robustness(out, quick=quick)  # quick: the suite at its quick sizes
    path = out / runfolder.VALIDATE  # a line on what the suite found, or why it could not run
    val = pd.read_csv(path) if path.is_file() else None
    if val is None or val.empty:
        _say(log, f"validate: {note}")
    else:
        broken, checked = int((val.verdict == "fail").sum()), int((val.verdict != "measured").sum())
        _say(log, f"validate: {broken} of {checked} promises broken -> {path}")
    return note


def _announce(sweep, out: str | Path) -> str:
    """What the job runs, and how long its sweep is expected to take, before it starts."""
    head = f"tribench run: {', '.join(sweep.kernels)} on {len(sweep.workloads)} workloads -> {out}\n"
    then = "then the peers, the robustness suite and the tables"
    if sweep.sequential is None:
        return f"{head}{duration.estimate(sweep).line('for the sweep')}, {then}"
    design = sweep.sequential
    # the budget exactly below a minute and a half (15 s), else in format_duration's words
    budget = f"{design.budget_s:.0f} s" if design.budget_s < 90 else duration.format_duration(design.budget_s)
    return (
        f"{head}expected for the sweep: about {budget} at most: "
        f"stages of {design.stage} processes "
        f"x {sweep.rounds} rounds, each kernel stopped once its speedup is known within "
        f"±{100 * design.target:g}%; {then}"
    )


def _run_peers(out: str | Path, quick: bool, progress: bool | None, log: TextIO | None = None) -> None:
    """The report's peers, when one is installed; their failure never stops the run."""
    from . import peers

    if not any(peers.available().values()):
        _say(log, f"peers: none installed ({peers.INSTALL}); the report has no peers")
        return
    design = peers.PeerDesign.quick() if quick else peers.PeerDesign()
    _say(
        log,
        f"peers: tribench's fastest brute-force kernel against Embree's BVH (native and embreex) and trimesh "
        f"on Suzanne {design.width}x{design.height}, "
        f"{design.processes} processes x {design.reps} repetitions...",
    )
    try:
        frame = peers.measure(out, design, progress=progress)
    except KeyboardInterrupt:
        raise runner.SweepInterrupted(
            f"interrupted during the peers: the sweep is kept in {out}; `tribench run --resume {out}` "
            f"times the peers again and finishes the job"
        ) from None
    except RuntimeError as exc:
        _say(log, f"peers: not measured: {exc}")
        return
    _say(log, f"peers: {frame['contender'].nunique()} contenders measured -> {peers.peers_path(out)}")
