"""Reports: from a run folder's files to answers. Never measures.

:mod:`.tables` derives every table from the measured files (``tribench stats``); the rest reads those tables and
writes pages (:mod:`.html`, :mod:`.compare`) and terminal tables. Missing or stale tables are refused with the
command that makes them. It may import ``common``, ``ext``, ``workloads`` and ``harness``; never ``cli``."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

__all__ = ["load", "write_report", "write_compare", "format_tables", "format_compare", "RunError", "REPORT"]

from ..harness.runfolder import FIGURES_DIR, REPORT, SWEEP_FILE

if TYPE_CHECKING:
    from .rundata import RunData


def load(run_dir: str | Path | RunData, baseline: str | None = None) -> RunData:
    """Read a run folder's tables once, for :func:`write_report` and :func:`format_tables` both (an already read
    ``run_dir`` is returned as it is)."""
    from .rundata import RunData, load_run

    if isinstance(run_dir, RunData):
        if baseline is not None and baseline != run_dir.baseline:
            return load_run(run_dir.run_dir, baseline=baseline)  # refused there, naming `tribench stats --baseline`
        return run_dir
    return load_run(run_dir, baseline=baseline)


def write_report(run_dir: str | Path | RunData, baseline: str | None = None) -> Path:
    """Write ``RUN_DIR/report.html`` and its main charts as SVG and PDF in ``figures/``; return the page's path.

    ``run_dir`` may be :func:`load`'s result; ``baseline``: the one the tables must compare against (default:
    theirs). Raises RunError, one line naming ``tribench stats``, when the folder or its tables are missing,
    unreadable or stale."""
    from ..common import write_text
    from .about import sweep_toml
    from .charts import collecting, write_figures
    from .html import render

    data = load(run_dir, baseline)
    with collecting() as specs:
        page = render(data, SWEEP_FILE)
    write_figures(specs, data.run_dir / FIGURES_DIR)
    write_text(data.run_dir / SWEEP_FILE, sweep_toml(data.run.sweep.to_dict()))
    out = data.run_dir / REPORT
    write_text(out, page)
    return out


def write_compare(*run_dirs: str | Path, out: str | Path | None = None) -> Path:
    """Write the comparison page of N >= 2 runs (default ``LAST_RUN/compare.html``) and return its path."""
    from ..common import write_text
    from .compare import compare, render_compare

    runs = [load(r) for r in run_dirs]
    many, pair = compare(runs)
    path = Path(out) if out is not None else runs[-1].run_dir / "compare.html"
    write_text(path, render_compare(runs, many, pair))
    return path


def format_tables(run_dir: str | Path | RunData) -> str:
    """Compact terminal tables of a run's estimates and speedups with CIs and verdicts."""
    from .ranking import format_run

    return format_run(load(run_dir))


def format_compare(*run_dirs: str | Path) -> str:
    """The comparison of N >= 2 runs, for the terminal."""
    from .compare import compare, format_compare_text

    runs = [load(r) for r in run_dirs]
    return format_compare_text(runs, *compare(runs))


def __getattr__(name: str):
    # RunError is defined in rundata (so that module has no import cycle); expose the same class.
    if name == "RunError":
        from .rundata import RunError as _RunError

        return _RunError
    raise AttributeError(name)
