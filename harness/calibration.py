"""A/A calibration: how large a speedup this machine shows between identical code.

``tribench calibrate`` times a kernel against its ``_aa`` copy (the same
source compiled under another name, see ``ext/kernels/moller_trumbore_aa.h``)
in the normal protocol. Its processes are split into ``experiments`` disjoint
groups of ``processes`` each; each group gives one A/A speedup with its
interval, exactly as a sweep of that many processes would. From those,
:func:`tribench.harness.stats.aa_summary` gives the coverage of 1, the
distribution of the p-values (KS test against uniform) and the noise floor,
whose relative form is the equivalence margin later verdicts use.

The result goes to ``RUN_DIR/calibration.json`` and to a user-level file
(:func:`user_calibration_path`); a sweep on the same CPU model takes its margin
from there, else ``stats.DEFAULTS.margin``, and records which in ``run.json``.
"""

from __future__ import annotations

import datetime as _dt
import json
import math
import os
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

from tribench.common import UserError, write_text

from .plan import DEFAULT_PROCESSES, DEFAULT_ROUNDS, DEFAULT_TARGET_MS, DEFAULT_WARMUP
from .stats import DEFAULTS, MAX_MARGIN, check_margin

__all__ = ["AA_COPIES", "MAX_MARGIN", "Margin", "check_margin", "aa_speedups", "calibrate", "latest_margin", "user_calibration_path"]

#: Kernels that have an A/A copy, and its name.
AA_COPIES = {"moller_trumbore": "moller_trumbore_aa"}

CALIBRATION = "calibration.json"


_FIX = "run `tribench calibrate` again, or delete the file to use the default margin"


@dataclass(frozen=True)
class Margin:
    """An equivalence margin (relative, 0.01 = 1 %) and where it came from.

    The value is checked here, so every margin a verdict uses -- a
    calibration file's, one recorded in ``run.json``, ``--margin`` -- is a
    finite number in ``[0, MAX_MARGIN]``."""

    value: float
    source: str

    def __post_init__(self) -> None:
        object.__setattr__(self, "value", check_margin(self.value, f"margin of {self.source}"))


def user_calibration_path() -> Path:
    """The latest calibration of this user: next to the workload cache.

    ``$TRIBENCH_CACHE/../calibration.json`` when ``TRIBENCH_CACHE`` is set,
    else ``~/.cache/tribench/calibration.json``.
    """
    cache = os.environ.get("TRIBENCH_CACHE")
    base = Path(cache).expanduser().parent if cache else Path("~/.cache/tribench").expanduser()
    return base / CALIBRATION


def latest_margin(cpu_model: str | None = None) -> Margin:
    """The latest calibration's margin, if it was measured on ``cpu_model``; else the default.

    No calibration file: the default. A file that is there but unusable
    (not JSON, no margin, a margin that is not a number in ``[0, MAX_MARGIN]``)
    is a UserError naming the file and the key, raised before a sweep
    measures anything: falling back silently would give verdicts the user
    takes for calibrated ones, and the fix is one command.

    >>> m = latest_margin("no such cpu")
    >>> m.value == DEFAULTS.margin and m.source.startswith("default")
    True
    """
    path = user_calibration_path()
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        return Margin(DEFAULTS.margin, "default (stats.DEFAULTS.margin: no calibration found)")
    except (OSError, UnicodeDecodeError) as exc:
        raise UserError(f"{path}: cannot read the calibration file ({exc}); {_FIX}") from None
    try:
        cal = json.loads(text)
    except (ValueError, RecursionError):
        raise UserError(f"{path}: not a calibration file (not valid JSON); {_FIX}") from None
    if not isinstance(cal, dict) or "margin" not in cal:
        raise UserError(f"{path}: not a calibration file (no 'margin' key); {_FIX}")
    try:
        value = check_margin(cal["margin"], f"{path}: key 'margin'")
    except UserError as exc:
        raise UserError(f"{exc}; {_FIX}") from None
    if not isinstance(cal.get("cpu_model"), (str, type(None))):
        raise UserError(f"{path}: key 'cpu_model' must be a string, got {cal['cpu_model']!r:.40}; {_FIX}")
    if cpu_model is not None and cal.get("cpu_model") != cpu_model:
        return Margin(DEFAULTS.margin, f"default (stats.DEFAULTS.margin: {path} is for another CPU)")
    created, run = str(cal.get("created", "?"))[:40], str(cal.get("run_dir", "?"))[:200]
    return Margin(value, f"calibration {path} ({created}, run {run})")


def _nan_to_none(value: Any) -> Any:
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {k: _nan_to_none(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_nan_to_none(v) for v in value]
    return value


def aa_speedups(batches: Any, kernel: str, copy: str, processes: int) -> list:
    """One A/A :class:`~tribench.harness.stats.Speedup` per group of ``processes``
    consecutive process indices and per workload (incomplete groups are left out)."""
    from . import stats

    table = stats.per_process(batches)
    out = []
    for _, group in table.groupby("workload_id", sort=True):
        wide = group.pivot(index="process", columns="kernel", values="ns_per_test").dropna()
        wide = wide.assign(experiment=wide.index // processes)
        for _, exp in wide.groupby("experiment"):
            if len(exp) == processes:
                out.append(stats.speedup(exp[kernel], exp[copy]))
    return out


def calibrate(
    run_dir: str | Path,
    *,
    kernel: str = "moller_trumbore",
    workloads: tuple = (),
    processes: int = DEFAULT_PROCESSES,
    experiments: int = 10,
    rounds: int = DEFAULT_ROUNDS,
    warmup: int = DEFAULT_WARMUP,
    target_ms: float = DEFAULT_TARGET_MS,
    seed: int = 0,
    progress: bool | None = None,
    save: bool = True,
) -> dict[str, Any]:
    """Run an A/A calibration into ``run_dir`` and return its record.

    Parameters
    ----------
    kernel : str
        A kernel of :data:`AA_COPIES`.
    workloads : tuple of specs
        Default: 10 000 pairs at hit rate 0.5, float64.
    processes, rounds, warmup, target_ms
        The design of each A/A comparison; the defaults are the sweeps'
        (``plan.DEFAULT_*``), so the margin measured is that of the default
        protocol. Use your sweeps' values if they differ.
    experiments : int
        Number of A/A comparisons (``processes * experiments`` processes run).
    save : bool
        Also write the user-level calibration file.
    """
    from tribench.workloads.spec import PairSpec

    from . import records, runner
    from .machine import cpu_model
    from .plan import Sweep
    from .stats import aa_summary

    if kernel not in AA_COPIES:
        raise UserError(f"no A/A copy of {kernel!r}; kernels with one: {', '.join(AA_COPIES)}")
    if processes < 2 or experiments < 1:
        raise UserError("an A/A calibration needs processes >= 2 and experiments >= 1")
    copy = AA_COPIES[kernel]
    sweep = Sweep((kernel, copy), tuple(workloads) or (PairSpec(n=10_000, hit_rate=0.5),),
                  processes=processes * experiments, rounds=rounds, warmup=warmup,
                  target_ms=target_ms, seed=seed)
    run_dir = Path(run_dir)
    # an A/A run records the default margin: the margin is what it measures
    runner.start(sweep, run_dir, margin=Margin(DEFAULTS.margin, "default (this is a calibration run)"),
                 progress=progress, extra={"calibration": {"kernel": kernel, "copy": copy,
                                                            "processes_per_experiment": processes}})
    results = aa_speedups(records.read_batches(run_dir), kernel, copy, processes)
    summary = aa_summary(results)
    record = {
        "created": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
        "cpu_model": cpu_model(),
        "kernel": kernel,
        "copy": copy,
        "processes_per_experiment": processes,
        "experiments": len(results),
        "run_dir": str(run_dir.resolve()),
        **asdict(summary),
        "ratios": [r.ratio for r in results],
        "p_values": [r.p_value for r in results],
    }
    # the run keeps its record whatever it measured (NaN as null: JSON has no NaN)
    text = json.dumps(_nan_to_none(record), indent=2, allow_nan=False) + "\n"
    write_text(run_dir / CALIBRATION, text)
    if save:
        # only a usable margin becomes the margin of later sweeps
        check_margin(record["margin"], f"the A/A calibration in {run_dir / CALIBRATION} (not saved as the "
                                      f"user-level calibration; the default margin stays in use)")
        write_text(user_calibration_path(), text)
    return record
