"""``tribench run`` as a library function: the default sweep, its peers and every derived table.

The command line (``tribench run``) calls :func:`run`, then writes the HTML
report from the run folder and prints the tables; a notebook calls
:func:`run` and gets the same run folder and its tables as pandas frames.
"""

from __future__ import annotations

import sys
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import TextIO

import pandas as pd

from tribench.harness import runfolder, runner

from .finish import finish

__all__ = ["MainResult", "resume", "run"]


@dataclass(frozen=True)
class MainResult:
    """What :func:`run` made: the run folder and its main tables, as the files have them."""

    #: The run folder (every file: :mod:`tribench.harness.runfolder`).
    run_dir: Path
    #: ``estimates.csv``: ns per test with 95% CIs, per kernel and workload.
    estimates: pd.DataFrame
    #: ``speedups.csv``: every kernel against the baseline, per workload, with verdicts.
    speedups: pd.DataFrame
    #: ``validate.csv``: the robustness suite on the run's kernels (empty if it could not run).
    validate: pd.DataFrame
    #: ``peers.csv`` rows, or None when no peer is installed or they were not measured.
    peers: pd.DataFrame | None
    #: What the runner did (batches run, seconds).
    sweep: runner.RunResult
    #: Every derived table by file name (:data:`tribench.harness.runfolder.DERIVED`).
    tables: dict[str, pd.DataFrame]


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
) -> MainResult:
    """Run the main job into the new folder ``out`` and return its tables.

    The default sweep (:func:`tribench.harness.plan.default_sweep`) in fresh
    pinned worker processes, then tribench's fastest kernel against its peers
    when one is installed (their failure never stops the job), then the
    analysis step (:func:`tribench.studies.finish.finish`): estimates,
    speedups, the robustness suite and every table the report reads. The HTML
    report is the reports package's job: ``tribench.reports.write_report(out)``.

    Parameters
    ----------
    out : path
        A new or empty folder for the run.
    quick : bool
        The same job in seconds, with wide intervals.
    progress : bool, optional
        Show the runner's progress bar (default: when stderr is a terminal).
    peers : bool
        Time the peers (trimesh, Embree) when installed.
    log : text stream, optional
        Where one-line notes go (default: ``sys.stderr`` when called; ``io.StringIO()`` keeps them).
    kernel_files : sequence of paths
        Kernel files of your own (``--kernel-file``): each is compiled and its
        kernels checked against the float64 reference before anything is
        timed (:mod:`tribench.studies.kernel_check`), then they join the job
        in their roles (a scalar kernel on the pairs, a native one on the meshes).
    builds : sequence of str
        Builds to compare (``--builds``: a compiler and its flags each;
        :func:`tribench.ext.parse_builds`): each is compiled and its kernels
        checked again (:func:`~tribench.studies.kernel_check.check_builds`), and
        the job's processes take them in turn, a stage holding as many of each.

    Returns
    -------
    MainResult
        The run folder and its estimates, speedups, robustness and peer tables.

    Raises
    ------
    UserError
        ``out`` cannot be a new run folder, or cannot be written.
    SweepInterrupted
        Ctrl-C: every finished batch is kept; ``tribench sweep --resume`` finishes it.

    Examples
    --------
    In a notebook (a minute or so with ``quick=True``)::

        from tribench.studies.main import run
        result = run("runs/notebook", quick=True)
        result.speedups.query("verdict == 'faster'")[["workload", "kernel", "ratio"]]
    """
    from tribench.harness.plan import default_sweep

    from .kernel_check import check_builds, load_checked

    load_checked(kernel_files)
    sweep = default_sweep(quick=quick, kernel_files=kernel_files, builds=builds)
    runfolder.check_new_run_dir(Path(out))  # before the estimate, which builds the workloads
    checks = check_builds(sweep)
    _announce(sweep, out, log)
    with _resumable(out):
        done = runner.start(sweep, out, progress=progress, extra={"main_job": {"quick": quick}}, build_checks=checks)
    return _complete(Path(out), done, quick, progress, peers, log)


def resume(out: str | Path, progress: bool | None = None, peers: bool = True, log: TextIO | None = None) -> MainResult:
    """Finish an interrupted main job in ``out``: the rest of its sweep, then its peers (unless
    ``peers.csv`` is there), the robustness suite and the analysis step, as :func:`run` would have.

    Raises
    ------
    UserError
        ``out`` is not a main job's run folder, or another process writes it.
    """
    from tribench.common import UserError

    out = Path(out)
    record = runfolder.read_run(out)
    if "main_job" not in record:
        raise UserError(
            f"{out} is not a main job's run folder (tribench run); finish a sweep with tribench sweep --resume"
        )
    quick = bool(record["main_job"].get("quick"))
    _say(log, f"tribench run --resume: finishing the main job in {out}")
    with _resumable(out):
        done = runner.resume(out, progress=progress)
    return _complete(out, done, quick, progress, peers and not _peers_done(out, quick), log)


def _peers_done(out: Path, quick: bool) -> bool:
    """Whether ``peers.csv`` holds every process of the job's peer design (an interrupted one does not)."""
    from tribench.studies import peers

    design = peers.PeerDesign.quick() if quick else peers.PeerDesign()
    try:
        done = pd.read_csv(out / runfolder.PEERS, usecols=["process"])["process"].nunique()
    except (OSError, ValueError, pd.errors.ParserError):
        return False
    return bool(done >= design.processes)


@contextmanager
def _resumable(out: str | Path) -> Iterator[None]:
    """Ctrl-C in the sweep: its message names ``tribench run --resume``, which finishes the whole job."""
    try:
        yield
    except runner.SweepInterrupted as exc:
        text = str(exc).replace(f"tribench sweep --resume {out}", f"tribench run --resume {out}")
        raise runner.SweepInterrupted(text) from None


def _complete(
    out: Path, done: runner.RunResult, quick: bool, progress: bool | None, peers: bool, log: TextIO | None
) -> MainResult:
    """After the sweep: the peers, the robustness suite and the analysis step; the job's tables."""
    _say(log, f"{done.batches_run} batches run in {done.elapsed_s:.1f} s -> {done.run_dir}")
    peer_rows = _run_peers(out, quick=quick, progress=progress, log=log) if peers else None
    derived = finish(out, quick=quick)  # quick: the robustness suite at its quick sizes
    val = _robustness(out, derived.record["validate"], log)
    return MainResult(out, derived.estimates, derived.speedups, val, peer_rows, done, derived.tables)


def _announce(sweep, out: str | Path, log: TextIO | None) -> None:
    """What the job runs, and how long its sweep is expected to take, before it starts."""
    from tribench.harness import duration

    _say(log, f"tribench run: {', '.join(sweep.kernels)} on {len(sweep.workloads)} workloads -> {out}")
    then = "then the peers, the robustness suite and the tables"
    if sweep.sequential is None:
        _say(log, f"{duration.estimate(sweep).line('for the sweep')}, {then}")
        return
    design = sweep.sequential
    _say(
        log,
        f"expected for the sweep: about {_seconds(design.budget_s)} at most: "
        f"stages of {design.stage} processes "
        f"x {sweep.rounds} rounds, each kernel stopped once its speedup is known within "
        f"±{100 * design.target:g}%; {then}",
    )


def _robustness(out: Path, note: str | None, log: TextIO | None) -> pd.DataFrame:
    """The run's ``validate.csv`` (empty if the suite could not run), and a line on what it found."""
    path = out / runfolder.VALIDATE
    val = pd.read_csv(path) if path.is_file() else pd.DataFrame(columns=list(runfolder.FILES[runfolder.VALIDATE]))
    if val.empty:
        _say(log, f"validate: {note}")
    else:
        broken, checked = int((val.verdict == "fail").sum()), int((val.verdict != "measured").sum())
        _say(log, f"validate: {broken} of {checked} promises broken -> {path}")
    return val


def _seconds(seconds: float) -> str:
    """A budget as said: ``15 s`` exactly below a minute and a half, else :func:`runner.about`'s words."""
    return f"{seconds:.0f} s" if seconds < 90 else runner.about(seconds)


def _run_peers(out: str | Path, quick: bool, progress: bool | None, log: TextIO | None = None) -> pd.DataFrame | None:
    """The report's peers, when one is installed; their failure never stops the run."""
    from tribench.harness.runner import SweepInterrupted
    from tribench.studies import peers

    if not any(peers.available().values()):
        _say(log, f"peers: none installed ({peers.INSTALL}); the report has no peers")
        return None
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
        raise SweepInterrupted(
            f"interrupted during the peers: the sweep is kept in {out}; `tribench run --resume {out}` "
            f"times the peers again and finishes the job"
        ) from None
    except RuntimeError as exc:
        _say(log, f"peers: not measured: {exc}")
        return None
    _, ratios = peers.summarise(frame)
    for r in ratios.itertuples(index=False):
        if r.contender == "tribench" and r.over in peers.HEADLINE_PEERS:
            interval = f"{r.ratio:.3g}x [{r.ci_low:.3g}, {r.ci_high:.3g}]"
            _say(log, f"peers: tribench brute force / {r.over}: {interval} rays/s")
    return frame
