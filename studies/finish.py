"""The end of every study that sweeps: the robustness suite's measurement, then the analysis step.

``tribench sweep``, ``tribench stats``, ``tribench run`` and the notebook's
``tribench.sweep`` all end here, so a run folder is completed the same way
whichever made it: ``validate.csv`` is measured when the folder has none
(the robustness suite is a measurement, so it is not part of the analysis),
then :func:`tribench.analysis.write_all` derives every table.
"""

from __future__ import annotations

from pathlib import Path

from tribench import analysis
from tribench.common import UserError
from tribench.harness import runfolder

__all__ = ["finish", "measure_robustness"]


def measure_robustness(run_dir: str | Path, quick: bool = False) -> str:
    """``validate.csv`` for the run's kernels and precisions, made if missing; a sentence on where it came from.

    A failure of the suite never stops the study: the sentence says why, and
    the report shows it.
    """
    from tribench import ext

    from . import validate

    run_dir = Path(run_dir)
    path = run_dir / runfolder.VALIDATE
    if path.is_file():
        return f"Read from {runfolder.VALIDATE} in the run folder."
    sweep = runfolder.read_run(run_dir)["sweep"]
    dtypes = sorted({w["dtype"] for w in sweep["workloads"] if "dtype" in w})
    known = [k for k in sweep["kernels"] if k in ext.kernel_names(internal=True)]
    try:
        if not known:
            raise UserError("none of the run's kernels is in this build of the extension")
        df = validate.run(known, dtypes, quick=quick, progress=False)  # a quiet step
    except Exception as exc:  # the suite must never stop the study: the report shows why
        return f"The robustness suite could not run: {type(exc).__name__}: {exc}"
    runfolder.write_csv(df, path)
    return (
        f"Read from {runfolder.VALIDATE} in the run folder, made by the robustness suite ({df.attrs['size']} "
        f"sizes, seed {df.attrs['seed']}, {df.attrs['seconds']:.1f} s)."
    )


def finish(
    run_dir: str | Path, baseline: str | None = None, margin: float | None = None, quick: bool = False
) -> analysis.Derived:
    """Measure what the run folder lacks (``validate.csv``; quick sizes with ``quick``), then analyse it."""
    note = measure_robustness(run_dir, quick=quick)
    return analysis.write_all(run_dir, baseline=baseline, margin=margin, validate_note=note)
