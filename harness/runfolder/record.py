"""``run.json`` as one typed, checked value: what every reader of a run folder takes (:class:`Run`).

The runner writes the file as a JSON object (:func:`tribench.harness.runfolder.write_run`); readers get it from
:func:`tribench.harness.runfolder.read_run`. The records of facts (machine, ISAs, builds, probes, the seed replay's
and a replication's notes) stay mappings: they are shown as they are, never computed on."""

from __future__ import annotations

import json
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ...common import UserError
from ..margin import Margin
from ..plan import Sweep
from ..stats import check_margin

__all__ = ["Run"]


#: The fields every record has, and their types.
_REQUIRED: dict[str, type] = {
    "run_id": str,
    "sweep": dict,
    "n_batches": int,
    "plan_sha256": str,
    "process_seeds": list,
    "margin": dict,
}


def _field(raw: Mapping[str, Any], key: str, kind: type, required: bool = True) -> Any:
    value = raw.get(key)
    if value is None and not required:
        return None
    if not isinstance(value, kind) or isinstance(value, bool):
        raise UserError(f"{key!r} is missing or not a {kind.__name__}; not a tribench run record")
    return value


@dataclass(frozen=True)
class Run:
    """One run's record: its plan (:attr:`sweep`), seeds, margin and the facts of the machine that measured it."""

    folder: Path
    run_id: str
    #: When the run started (ISO 8601, UTC); empty in a record without it
    created: str
    sweep: Sweep
    #: Batches of the plan (a sequential run's: those its stages ran)
    n_batches: int
    plan_sha256: str
    #: The RNG seed of each process's random choices
    process_seeds: tuple[int, ...]
    margin: Margin
    #: The CPU the workers were pinned to (None: not pinned)
    cpu: int | None
    #: The command that made the run, where a job records it (the seed replay)
    command: str | None
    #: :func:`tribench.harness.machine.machine_record`
    machine: Mapping[str, Any]
    #: kernel -> the ISA of its loop in this build
    isa: Mapping[str, str]
    #: One record per build (:func:`tribench.ext.build_record` and its answers check)
    builds: tuple[Mapping[str, Any], ...]
    #: The probes' rates and FMA peak (:func:`tribench.harness.peak.throughput_record`), if measured
    throughput: Mapping[str, Any] | None
    #: The seed replay's scenes, sizes and workloads (``tribench seed``), if this is one
    seed_replay: Mapping[str, Any] | None
    #: The run this one replicates (``tribench replicate``), if it does
    replicates: Mapping[str, Any] | None
    #: The main job's options (``tribench run``), if this is one
    main_job: Mapping[str, Any] | None
    #: The A/A calibration's kernel, copy and processes per experiment (``tribench calibrate``), if this is one
    calibration: Mapping[str, Any] | None
    #: The file as written: for the runner, which updates it, and for nothing else
    raw: Mapping[str, Any]

    @property
    def specs(self) -> dict[str, dict[str, Any]]:
        """Workload id -> its spec dict, in sweep order."""
        return {wid: spec.to_dict() for wid, spec in zip(self.sweep.workload_ids, self.sweep.workloads, strict=True)}

    @classmethod
    def from_record(cls, raw: Mapping[str, Any], folder: str | Path, sweep: Sweep | None = None) -> Run:
        """Check ``raw`` (the JSON object of ``folder``'s ``run.json``); a UserError says what is wrong.
        ``sweep``: the one ``raw`` was written from (the runner's), rather than one made again from ``raw``."""
        folder = Path(folder)
        for key, kind in _REQUIRED.items():
            _field(raw, key, kind)
        try:
            sweep = sweep or Sweep.from_dict(raw["sweep"], folder)
        except UserError as exc:
            raise UserError(f"'sweep' is not valid: {exc}") from None
        except (KeyError, TypeError, ValueError, AttributeError) as exc:
            raise UserError(f"'sweep' is not valid ({type(exc).__name__}: {exc})") from None
        if raw["sweep"].get("workload_ids") != list(sweep.workload_ids):
            raise UserError("'sweep' workload_ids do not match its workloads (an edited file?)")
        seeds = raw["process_seeds"]
        if len(seeds) != sweep.processes or not all(isinstance(s, int) and not isinstance(s, bool) for s in seeds):
            raise UserError(f"'process_seeds' must be {sweep.processes} integers, one per process")
        margin = raw["margin"]
        if not isinstance(margin.get("source"), str):
            raise UserError(f"'margin' must be {{value: a number, source: text}}, got {json.dumps(margin)[:80]}")
        check_margin(margin.get("value"), "key 'margin.value'")
        if not isinstance(raw.get("cpu"), (int, type(None))) or isinstance(raw.get("cpu"), bool):
            raise UserError("'cpu' must be a CPU number")
        return cls(
            folder=folder,
            run_id=raw["run_id"],
            created=str(raw.get("created") or ""),
            sweep=sweep,
            n_batches=raw["n_batches"],
            plan_sha256=raw["plan_sha256"],
            process_seeds=tuple(seeds),
            margin=Margin(margin["value"], margin["source"]),
            cpu=raw.get("cpu"),
            command=_field(raw, "command", str, required=False),
            machine=_field(raw, "machine", dict, required=False) or {},
            isa=_field(raw, "isa", dict, required=False) or {},
            builds=tuple(_field(raw, "builds", list, required=False) or ()),
            throughput=_field(raw, "throughput", dict, required=False),
            seed_replay=_field(raw, "seed_replay", dict, required=False),
            replicates=_field(raw, "replicates", dict, required=False),
            main_job=_field(raw, "main_job", dict, required=False),
            calibration=_field(raw, "calibration", dict, required=False),
            raw=raw,
        )
