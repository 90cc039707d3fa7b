"""The stages of a sequential sweep (:class:`tribench.harness.plan.Sequential`): what each runs, and why it stopped.

A stage runs the keys of the largest design's plan whose comparison is still open, so ``batches.csv`` is checked as
any sweep's. Each stage is decided from the stages before and recorded in ``stages.json`` before its first process,
so a resumed sweep finishes the recorded stages as decided, then decides the rest the same way."""

from __future__ import annotations

import json
import math
import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import pandas as pd

from ..common import UserError, write_text
from . import runfolder, stats
from .plan import DEFAULT_BASELINE as BASELINE
from .plan import BatchKey, Sweep

__all__ = ["StageRecord", "decide", "keys_of", "read_stages", "write_stages"]


#: One stage as stages.json holds it: ``{"stage", "first_process", "last_process",
#: "open": {workload id: [kernels]}, "seconds_before"}``.
StageRecord = dict[str, Any]


def read_stages(run_dir: str | Path) -> dict[str, Any]:
    """``stages.json`` of a run (``{"stages": [], "end": None}`` before the first stage)."""
    path = Path(run_dir) / runfolder.STAGES
    if not os.path.lexists(path):
        return {"stages": [], "end": None}
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise UserError(f"{path}: not a stages record ({exc}); a truncated or edited file?") from None
    if not isinstance(data, dict) or not isinstance(data.get("stages"), list):
        raise UserError(f"{path}: not a stages record (expected an object with a 'stages' list)")
    return data


def write_stages(run_dir: str | Path, data: Mapping[str, Any]) -> None:
    """Write ``stages.json`` atomically."""
    write_text(Path(run_dir) / runfolder.STAGES, json.dumps(data, indent=1, sort_keys=True) + "\n")


def keys_of(stage: StageRecord, keys: Sequence[BatchKey]) -> list[BatchKey]:
    """The keys of the plan ``keys`` that ``stage`` runs, in plan order."""
    first, last = stage["first_process"], stage["last_process"]
    open_ = {(w, k) for w, ks in stage["open"].items() for k in ks}
    return [key for key in keys if first <= key.process <= last and (key.workload_id, key.kernel) in open_]


def _block_seconds(batches: pd.DataFrame, processes: range) -> dict[str, float]:
    """Per workload, the wall seconds one kernel of it cost a process of the last stage (its block
    over its kernels, the mean over processes; a process's first block counted from its first batch)."""
    b = batches.loc[batches["process"].isin(processes)].copy()
    if b.empty:
        return {}
    b["end_ns"] = b["start_ns"] + b["elapsed_ns"]
    cost: dict[str, list[float]] = {}
    for _, g in b.groupby(["process", "attempt"]):
        blocks = g.groupby("workload_id").agg(
            begin=("start_ns", "min"), end=("end_ns", "max"), kernels=("kernel", "nunique")
        )
        blocks = blocks.sort_values("end")
        previous = blocks["end"].shift(1).fillna(blocks["begin"])
        for wid, seconds, n in zip(blocks.index, (blocks["end"] - previous) / 1e9, blocks["kernels"], strict=True):
            cost.setdefault(str(wid), []).append(float(seconds) / int(n))
    return {wid: sum(v) / len(v) for wid, v in cost.items()}


def decide(
    sweep: Sweep, run_dir: str | Path, done: Sequence[StageRecord], seconds: float, last_stage_s: float | None
) -> tuple[StageRecord | None, str]:
    """The next stage of ``sweep``, or None and why the sweep ends.

    ``done`` are the stages run so far, ``seconds`` the sweep's wall time so far. The next stage runs every
    comparison not yet narrow under every build, with its reference; it is not started past the budget (foreseen
    from the last stage's costs) nor past ``sweep.processes``."""
    design = sweep.sequential
    assert design is not None  # only sequential sweeps have stages
    first = 0 if not done else done[-1]["last_process"] + 1
    if first >= sweep.processes:
        return None, f"all {sweep.processes} processes ran"
    candidates = {w: list(sweep.kernels_for(s)) for w, s in zip(sweep.workload_ids, sweep.workloads, strict=True)}
    references = {wid: sweep.reference_of(sweep.spec_of(wid), BASELINE) for wid in sweep.workload_ids}
    if done:
        batches = runfolder.read_batches(run_dir)
        # narrow under every build: each build's interval is its own processes' (they take the builds in turn)
        narrow = set.intersection(
            *(
                stats.narrow_comparisons(
                    stats.per_process(batches.loc[batches["build"] == b]), references, design.target
                )
                for b in sweep.build_names
            )
        )
        open_: dict[str, list[str]] = {}
        for wid, kernels in candidates.items():
            wanted = [k for k in kernels if k != references[wid] and (wid, k) not in narrow]
            if wanted:  # the reference runs with them: they are compared with it
                open_[wid] = [k for k in kernels if k == references[wid] or k in wanted]
        if not open_:
            return None, f"every comparison is within ±{100 * design.target:g}%"
    else:
        batches, open_ = None, candidates
    last = min(first + design.stage, sweep.processes) - 1
    if batches is not None and last_stage_s is not None:
        previous = done[-1]
        cost = _block_seconds(batches, range(previous["first_process"], previous["last_process"] + 1))
        per_process = sum(cost.get(wid, math.inf) * len(ks) for wid, ks in open_.items())
        foreseen = (last - first + 1) * per_process if cost else last_stage_s
        if seconds + foreseen > design.budget_s:
            n = sum(len(ks) - 1 for ks in open_.values())
            return None, (
                f"the time budget ({design.budget_s:.0f} s): {n} comparisons still wider than "
                f"±{100 * design.target:g}% after {first} processes"
            )
    return {
        "stage": len(done),
        "first_process": first,
        "last_process": last,
        "open": open_,
        "seconds_before": seconds,
    }, ""
