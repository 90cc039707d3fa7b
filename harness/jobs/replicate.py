"""``tribench replicate``'s measuring half: a run folder's plan, measured again on this machine: the same
workloads (by spec and RNG seed; files from the folder's copies), kernels (kernel files from its copies) and
design, with the builds whose compiler is here; what this machine cannot run is left out and said. Comparing
the runs is :mod:`tribench.reports.tables.replication`'s."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from pathlib import Path

from ... import ext
from ...common import UserError
from ...ext.builds import toolchain_of
from ...workloads import mesh_files
from .. import runfolder, runner
from ..plan import Sweep
from .sweep import run_sweep

__all__ = ["replication_plan", "measure"]


def replication_plan(run_dir: str | Path) -> tuple[Sweep, list[str], runfolder.Run]:
    """The sweep of ``run_dir`` as this machine can run it, one line per thing it leaves out, and its record."""
    run_dir = Path(run_dir)
    original = runfolder.read_run(run_dir)
    mesh_files.adopt(run_dir)  # the folder's mesh and ray copies: its workloads rebuild without the originals
    sweep = original.sweep
    for path in sweep.kernel_files:
        ext.load_kernels(path)  # their kernels join the registry (run_sweep checks their answers)
    notes = []
    builds = []
    for build in sweep.builds:
        try:
            toolchain_of(build)
            builds.append(build)
        except ext.BuildError as e:
            notes.append(f"left out: {e}")
    known = set(ext.kernel_names(internal=True))
    gone = [k for k in sweep.kernels if k not in known]
    if gone:
        notes.append(f"left out: {', '.join(gone)}, which this machine's build cannot run")
    kernels = tuple(k for k in sweep.kernels if k in known)
    if not kernels:
        raise UserError(f"none of {run_dir}'s kernels runs on this machine: nothing to replicate")
    per_workload = tuple(tuple(k for k in ks if k in known) for ks in sweep.workload_kernels)
    return (
        dataclasses.replace(sweep, kernels=kernels, workload_kernels=per_workload, builds=tuple(builds)),
        notes,
        original,
    )


def measure(
    run_dir: str | Path,
    out: str | Path,
    *,
    say: Callable[[str], None],
    cpu: int | None = None,
    progress: bool | None = None,
) -> runner.RunResult:
    """Measure ``run_dir``'s plan into the new folder ``out``; its ``run.json`` names the original."""
    sweep, notes, original = replication_plan(run_dir)
    for line in notes:
        say(line)
    replicates = {
        "run_dir": str(Path(run_dir).resolve()),
        "run_id": original.run_id,
        "machine": dict(original.machine),
        "left_out": notes,
    }
    with runner.resumed_with(out, f"tribench replicate {run_dir} --resume {out}"):
        return run_sweep(sweep, out, say=say, cpu=cpu, progress=progress, extra={"replicates": replicates})
