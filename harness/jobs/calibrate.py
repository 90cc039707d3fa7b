"""A/A calibration: how large a speedup this machine shows between identical code.

``tribench calibrate`` times a kernel against its ``_aa`` copy (the same source under another name) in the normal
protocol, split into ``experiments`` groups of ``processes``: each group gives one A/A speedup, exactly as a sweep
of that many processes would, and :func:`tribench.harness.stats.aa_summary` their noise floor, the margin later
verdicts on this CPU model use (:mod:`tribench.harness.margin`)."""

from __future__ import annotations

import datetime as _dt
import json
from dataclasses import asdict
from pathlib import Path
from typing import Any

from ... import ext
from ...common import UserError, write_text
from ...workloads.spec import PairSpec

# reading the margin is below the runner, which uses it; calibrating is above it
from ..margin import AA_TWINS, CALIBRATION, Margin, latest_margin, user_calibration_path
from ..plan import DEFAULT_PROCESSES, DEFAULT_ROUNDS, DEFAULT_TARGET_MS, DEFAULT_WARMUP, MAX_PROCESSES, Sweep, is_bvh
from ..stats import DEFAULTS, MAX_MARGIN, aa_summary, check_margin, per_process, speedup

__all__ = [
    "AA_COPIES",
    "MAX_MARGIN",
    "Margin",
    "check_margin",
    "aa_speedups",
    "calibrate",
    "latest_margin",
    "user_calibration_path",
]

#: Kernels that have an A/A copy, and its name.
AA_COPIES = AA_TWINS


def aa_speedups(batches: Any, kernel: str, copy: str, processes: int) -> list:
    """One A/A :class:`~tribench.harness.stats.Speedup` per full group of ``processes`` processes and workload."""
    table = per_process(batches)
    out = []
    for _, group in table.groupby("workload_id", sort=True):
        wide = group.pivot(index="process", columns="kernel", values="ns_per_test").dropna()
        wide = wide.assign(experiment=wide.index // processes)
        for _, exp in wide.groupby("experiment"):
            if len(exp) == processes:
                out.append(speedup(exp[kernel], exp[copy]))
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
    rng_seed: int = 0,
    progress: bool | None = None,
    save: bool = True,
) -> dict[str, Any]:
    """Run an A/A calibration into ``run_dir`` and return its record.

    ``kernel`` is one of :data:`AA_COPIES`; ``workloads`` default to 10 000 pairs at hit rate 0.5, float64. The
    design defaults are the sweeps', so the margin is that of the default protocol: give your sweeps' values if they
    differ. ``processes * experiments`` processes run; ``save`` also writes the user-level file."""
    from .. import runfolder, runner

    if kernel not in AA_COPIES:
        raise UserError(f"no A/A copy of {kernel!r}; kernels with one: {', '.join(AA_COPIES)}")
    if processes < 2 or experiments < 1:
        raise UserError("an A/A calibration needs processes >= 2 and experiments >= 1")
    if processes * experiments > MAX_PROCESSES:
        # checked here: the sweep would blame its process count, a flag the user did not give
        raise UserError(
            f"{experiments:,} experiments of {processes:,} processes make {processes * experiments:,} "
            f"processes; a calibration runs at most {MAX_PROCESSES:,}: use fewer experiments"
        )
    if any(is_bvh(spec) for spec in workloads) and kernel not in ext.bvh_kernel_names():
        # checked here: the sweep would say to add a leaf kernel, which a calibration cannot
        raise UserError(
            f"{kernel} cannot be a BVH's leaf test, so it cannot run a BVH workload: calibrate on pairs or "
            "a brute-force mesh (--workload)"
        )
    copy = AA_COPIES[kernel]
    sweep = Sweep(
        (kernel, copy),
        tuple(workloads) or (PairSpec(n=10_000, hit_rate=0.5),),
        processes=processes * experiments,
        rounds=rounds,
        warmup=warmup,
        target_ms=target_ms,
        rng_seed=rng_seed,
    )
    run_dir = Path(run_dir)
    # an A/A run records the default margin: the margin is what it measures
    runner.start(
        sweep,
        run_dir,
        margin=Margin(DEFAULTS.margin, "default (this is a calibration run)"),
        progress=progress,
        extra={"calibration": {"kernel": kernel, "copy": copy, "processes_per_experiment": processes}},
    )
    record = _record(
        run_dir, kernel, copy, processes, aa_speedups(runfolder.read_batches(run_dir), kernel, copy, processes)
    )
    # the run keeps its record whatever it measured, NaN as null (JSON has no NaN: read back, it becomes None)
    nan_as_null = json.loads(json.dumps(record), parse_constant=lambda nan: None)
    text = json.dumps(nan_as_null, indent=2, allow_nan=False) + "\n"
    write_text(run_dir / CALIBRATION, text)
    if save:
        # only a usable margin becomes the margin of later sweeps
        check_margin(
            record["margin"],
            f"the A/A calibration in {run_dir / CALIBRATION} (not saved as the "
            f"user-level calibration; the default margin stays in use)",
        )
        write_text(user_calibration_path(), text)
    return record


def _record(run_dir: Path, kernel: str, copy: str, processes: int, results: list) -> dict[str, Any]:
    """calibration.json: the A/A comparisons' summary (coverage, p-values, noise floor, margin) and ratios."""
    from ..machine import cpu_model

    return {
        "created": _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
        "cpu_model": cpu_model(),
        "kernel": kernel,
        "copy": copy,
        "processes_per_experiment": processes,
        "experiments": len(results),
        "run_dir": str(run_dir.resolve()),
        **asdict(aa_summary(results)),
        "ratios": [r.ratio for r in results],
        "p_values": [r.p_value for r in results],
    }
