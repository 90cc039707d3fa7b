"""tribench from Python: run a sweep or the main job, or read a run, and get pandas frames.

The ``tribench`` package itself, above its sub-packages (it may import them all; none imports it). Each function
makes or reads a run folder exactly as the ``tribench`` command does and returns its tables as :class:`Results`;
nothing is imported until a function is called, so ``import tribench.ext`` stays light.

>>> import tribench
>>> r = tribench.load(run_dir)
>>> list(r.speedups.columns[:4])
['build', 'workload_id', 'kernel', 'baseline']
>>> best = r.ranking.loc[r.ranking["rank"] == 1]
>>> set(best["kernel"]) <= set(r.estimates["kernel"]), bool(best["ns_per_test_ci_low"].le(best["ns_per_test"]).all())
(True, True)

A whole example, sweep included, is docs/notebook.md's (a test runs it).
"""

from __future__ import annotations

import os
import sys
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

# Nothing of the package is imported here at module level: pytest imports this file as a plain
# module when the checkout's folder is no Python name (a CI clone's), where a relative import fails.

if TYPE_CHECKING:
    import pandas as pd

    from .reports.tables.compare import MultiComparison
    from .workloads.spec import MeshSpec, PairSpec

__all__ = ["Results", "sweep", "run", "load", "compare", "PairSpec", "MeshSpec"]


@dataclass(frozen=True)
class Results:
    """A run folder and its tables, as the files have them (columns: :mod:`tribench.harness.runfolder`)."""

    #: The run folder: every file of the run, the report is ``tribench report RUN_DIR`` away.
    run_dir: Path
    #: ``estimates.csv``: ns per ray-triangle test with its 95% CI, per kernel and workload.
    estimates: pd.DataFrame
    #: ``speedups.csv``: every kernel against the baseline, per workload, with CIs and verdicts.
    speedups: pd.DataFrame
    #: Every derived table by file name (``ranking.csv``, ``per_process.csv``, ...).
    tables: dict[str, pd.DataFrame] = field(repr=False)

    @property
    def ranking(self) -> pd.DataFrame:
        """``ranking.csv``: per workload, every kernel from the fastest down, with CIs."""
        return self.tables["ranking.csv"]


def _user_error(kind: str, message: str) -> Exception:
    """tribench's UserTypeError (``kind`` "type") or UserError, imported when raised."""
    from .common import UserError, UserTypeError

    return UserTypeError(message) if kind == "type" else UserError(message)


def _default_out(out: str | Path | None) -> Path:
    from .harness.runfolder import default_run_dir

    return Path(default_run_dir()) if out is None else _path(out, "out")


def _names(value: Any, what: str) -> tuple[str, ...]:
    """A non-empty list of names (kernels): one string is refused, not read as a list of letters."""
    if isinstance(value, str):
        raise _user_error("type", f"{what} must be a list of names, not one string: give [{value!r}]")
    if not isinstance(value, Sequence) or not value or not all(isinstance(v, str) for v in value):
        raise _user_error("type", f"{what} must be a non-empty list of names, got {_shown(value)}")
    return tuple(value)


def _specs(value: Any) -> tuple:
    """A non-empty list of workload specs (PairSpec, MeshSpec): one spec alone is refused, naming the fix."""
    from .workloads.spec import MeshSpec, PairSpec

    if isinstance(value, (PairSpec, MeshSpec)):
        raise _user_error(
            "type", f"workloads must be a list of specs, not one spec: give [{type(value).__name__}(...)]"
        )
    if (
        isinstance(value, str)
        or not isinstance(value, Sequence)
        or not value
        or not all(isinstance(v, (PairSpec, MeshSpec)) for v in value)
    ):
        raise _user_error("type", f"workloads must be a non-empty list of PairSpec or MeshSpec, got {_shown(value)}")
    return tuple(value)


def _path(value: Any, what: str) -> Path:
    """A folder's path (str or os.PathLike)."""
    if not isinstance(value, (str, os.PathLike)):
        raise _user_error("type", f"{what} must be a folder's path (str or pathlib.Path), got {_shown(value)}")
    return Path(value)


def _builds(value: Any) -> tuple[str, ...]:
    """Build specs: a list of them, or one string of specs separated by ';' (as ``--builds`` takes)."""
    from .ext import check_builds, parse_builds

    return parse_builds(value) if isinstance(value, str) else check_builds(value)


def _flag(value: Any, what: str, none: bool = False) -> Any:
    """True or False, or None where ``none``: a string such as "no" is refused, never read as true."""
    if not isinstance(value, bool) and not (none and value is None):
        raise _user_error(
            "type", f"{what} must be True{', False or None' if none else ' or False'}, got {_shown(value)}"
        )
    return value


def _shown(value: Any) -> str:
    text = repr(value)
    return f"{type(value).__name__} {text if len(text) <= 40 else text[:37] + '...'}"


def sweep(
    kernels: Sequence[str],
    workloads: Sequence[PairSpec | MeshSpec],
    out: str | Path | None = None,
    *,
    processes: int | None = None,
    rounds: int | None = None,
    warmup: int | None = None,
    target_ms: float | None = None,
    rng_seed: int | None = None,
    baseline: str | None = None,
    progress: bool | None = None,
    kernel_files: Sequence[str | Path] = (),
    builds: Sequence[str] = (),
    seed: int | None = None,
) -> Results:
    """Time ``kernels`` on ``workloads`` into the new folder ``out``, analyse it and return its tables.

    ``tribench sweep`` then ``tribench stats`` (docs/commands.md); the design's defaults are
    :mod:`tribench.harness.plan`'s, ``baseline``'s ``moller_seed`` if swept, else the first kernel.
    ``kernel_files`` (docs/own-kernel.md) are checked before anything is timed; ``builds`` (docs/builds.md): specs,
    or one string as ``--builds`` takes; ``seed`` is ``rng_seed``'s name before #52. Raises UserError for a bad
    value, an ``out`` that is not a new folder, or a kernel file that does not compile or answers wrongly."""
    from .common.renamed import renamed
    from .harness import plan
    from .harness.jobs.kernel_check import load_checked
    from .harness.jobs.sweep import measure_robustness, run_sweep
    from .reports import tables

    load_checked(kernel_files)  # first: ``kernels`` may name their kernels
    progress = _flag(progress, "progress", none=True)
    seeds = {k: v for k, v in {"rng_seed": rng_seed, "seed": seed}.items() if v is not None}
    design: dict[str, Any] = {"processes": processes, "rounds": rounds, "warmup": warmup, "target_ms": target_ms}
    spec = plan.Sweep(
        _names(kernels, "kernels"),
        _specs(workloads),
        **{k: v for k, v in design.items() if v is not None},  # the rest: Sweep's defaults, plan.DEFAULT_*
        rng_seed=renamed(seeds).get("rng_seed", 0),
        kernel_files=tuple(map(str, kernel_files)),
        builds=_builds(builds),
    )
    if baseline is not None and baseline not in spec.kernels:  # refused before the sweep, not after it
        raise _user_error("value", f"baseline {baseline!r} is not one of the kernels swept: {', '.join(spec.kernels)}")
    folder = _default_out(out)
    run_sweep(
        spec, folder, say=lambda line: print(f"tribench.sweep: {line} -> {folder}", file=sys.stderr), progress=progress
    )
    derived = tables.write_all(folder, baseline=baseline, validate_note=measure_robustness(folder))
    return Results(folder, derived.estimates, derived.speedups, derived.tables)


def run(
    out: str | Path | None = None,
    *,
    quick: bool = False,
    peers: bool = True,
    progress: bool | None = None,
    kernel_files: Sequence[str | Path] = (),
    builds: Sequence[str] = (),
) -> Results:
    """The main job (``tribench run``) into the new folder ``out``: its tables.

    :mod:`tribench.harness.jobs.main`; ``quick=True`` takes seconds and gives wide intervals. ``kernel_files`` and
    ``builds``: as :func:`sweep`'s. The HTML report is ``tribench report RUN_DIR``."""
    from .harness.jobs import main as main_job
    from .harness.jobs.kernel_check import load_checked
    from .reports import tables

    load_checked(kernel_files)  # a bad value's message, before anything else
    quick, peers = _flag(quick, "quick"), _flag(peers, "peers")
    folder = _default_out(out)
    note = main_job.run(
        folder,
        quick=quick,
        progress=_flag(progress, "progress", none=True),
        peers=peers,
        kernel_files=tuple(map(str, kernel_files)),
        builds=_builds(builds),
    )
    derived = tables.write_all(folder, validate_note=note)
    return Results(folder, derived.estimates, derived.speedups, derived.tables)


def load(run_dir: str | Path) -> Results:
    """The tables of an analysed run folder, refused (one line naming ``tribench stats``) if missing or stale."""
    from .reports.rundata import load_run

    data = load_run(_path(run_dir, "run_dir"))
    # the files as they are, every build's rows and the baseline's A/A twin included (the report leaves it out)
    tables = {**data.tables, **data.every_build}
    return Results(data.run_dir, tables["estimates.csv"], tables["speedups.csv"], tables)


def compare(*run_dirs: str | Path) -> MultiComparison:
    """N >= 2 runs side by side (``tribench compare``): ``.speedups`` of every run, ``.orders`` that hold."""
    from .reports.rundata import load_run
    from .reports.tables.compare import compare_many

    if len(run_dirs) == 1 and isinstance(run_dirs[0], (list, tuple)):
        raise _user_error("type", "give the run folders as separate arguments: tribench.compare('run_a', 'run_b')")
    return compare_many([load_run(_path(r, "each run folder")) for r in run_dirs])


def __getattr__(name: str) -> Any:
    # the workload specs, imported on first use like everything here
    if name in ("PairSpec", "MeshSpec"):
        from .workloads import spec

        return getattr(spec, name)
    raise AttributeError(f"module 'tribench' has no attribute {name!r}")
