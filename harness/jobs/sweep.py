"""The one way a sweep is measured: ``tribench sweep``, the notebook's ``tribench.sweep`` and the main job.

Nothing here analyses: the tables are :mod:`tribench.reports.tables`'s, made from the folder afterwards."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

from ... import ext
from ...common import UserError
from .. import duration, runfolder, runner
from ..plan import Sweep
from . import validate
from .kernel_check import check_builds, load_checked

__all__ = ["measure_robustness", "robustness_command", "run_sweep", "with_file_kernels"]


def run_sweep(
    sweep: Sweep,
    out: str | Path,
    *,
    say: Callable[[str], None],
    cpu: int | None = None,
    progress: bool | None = None,
    extra: Mapping[str, Any] | None = None,
    announce: Callable[[Sweep], str] | None = None,
) -> runner.RunResult:
    """Measure ``sweep`` into the new folder ``out``: kernel files checked (their kernels join: a user
    who brings a kernel wants it ranked), the folder claimed, each build checked, then the workers.
    ``say`` gets one line on what runs before the first batch (default: the expected duration)."""
    sweep = with_file_kernels(sweep, load_checked(sweep.kernel_files), say)
    idle = sweep.idle_kernels()
    if idle:  # a kernel that runs none of the sweep's workloads would be dropped without a word: refused
        why = "; ".join(_why_idle(k) for k in idle)
        raise UserError(f"{', '.join(idle)} would run none of the sweep's workloads ({why}): drop or give them some")
    out = Path(out)
    runfolder.check_new_run_dir(out)  # before the estimate, which builds the workloads
    checks = check_builds(sweep)
    say(announce(sweep) if announce else duration.estimate(sweep).line())
    return runner.start(
        sweep, out, cpu=cpu, progress=progress, extra=dict(extra) if extra else None, build_checks=checks
    )


def _why_idle(kernel: str) -> str:
    if "pairs" not in ext.kernel_info(kernel).modes:
        return f"{kernel} has no pairs mode: it runs meshes (--mesh)"
    if kernel not in ext.bvh_kernel_names():
        return f"{kernel} is no BVH's leaf test"
    return f"no workload lists {kernel}"


def with_file_kernels(sweep: Sweep, file_kernels: Sequence[str], say: Callable[[str], None]) -> Sweep:
    """``sweep`` with its kernel files' kernels joined (unless workloads name their own), saying which joined."""
    missing = tuple(k for k in file_kernels if k not in sweep.kernels)
    if not missing or sweep.workload_kernels:
        return sweep
    say(f"the kernel files' {', '.join(missing)} join the sweep's kernels")
    return dataclasses.replace(sweep, kernels=(*sweep.kernels, *missing))


def measure_robustness(run_dir: str | Path, quick: bool = False) -> str:
    """``validate.csv`` for the run's kernels and precisions, made if missing; a sentence on where it came from.

    A failure of the suite never stops the job: the sentence says why."""
    run_dir = Path(run_dir)
    path = run_dir / runfolder.VALIDATE
    if path.is_file():
        return f"Read from {runfolder.VALIDATE} in the run folder."
    kernels, dtypes = _kernels_and_dtypes(run_dir)
    known = [k for k in kernels if k in ext.kernel_names(internal=True)]
    try:
        if not known:
            raise UserError("none of the run's kernels is in this build of the extension")
        df = validate.run(known, dtypes, quick=quick, progress=False)  # a quiet step
    except Exception as exc:  # the suite must never stop the job: the report shows why
        return f"The robustness suite could not run: {type(exc).__name__}: {exc}"
    runfolder.write_csv(df, path)
    return (
        f"Read from {runfolder.VALIDATE} in the run folder, made by the robustness suite ({df.attrs['size']} "
        f"sizes, RNG seed {df.attrs['rng_seed']}, {df.attrs['seconds']:.1f} s)."
    )


def robustness_command(run_dir: str | Path) -> str:
    """The command that measures a run folder's missing ``validate.csv`` (the analysis never does)."""
    kernels, dtypes = _kernels_and_dtypes(run_dir)
    out = Path(run_dir) / runfolder.VALIDATE
    return f"tribench validate --kernels {','.join(kernels)} --dtype {','.join(dtypes)} --out {out}"


def _kernels_and_dtypes(run_dir: str | Path) -> tuple[list[str], list[str]]:
    """The run's kernels and the precisions of its workloads, which its robustness suite covers."""
    sweep = runfolder.read_run(run_dir).sweep
    return list(sweep.kernels), sorted({w.dtype for w in sweep.workloads})
