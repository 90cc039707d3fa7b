"""A run folder's measured files, read once and validated: what every derived table is a pure function of."""

from __future__ import annotations

import hashlib
import os
import stat
import sys
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import pandas as pd

from ...harness import runfolder
from ...harness.plan import rows_of_build

__all__ = ["Measured", "file_digest", "has_columns", "load", "read_documented"]


def file_digest(path: str | Path) -> str | None:
    """SHA-256 of a file's bytes: how the report knows a table is stale. None where there is no regular
    file (a FIFO in its place would block; the readers refuse it, naming it)."""
    try:
        if not stat.S_ISREG(os.lstat(path).st_mode):
            return None
        return hashlib.sha256(Path(path).read_bytes()).hexdigest()
    except FileNotFoundError:
        return None


@dataclass(frozen=True)
class Measured:
    """Everything measured about one run, as its files hold it."""

    run_dir: Path
    run: runfolder.Run
    batches: pd.DataFrame
    processes: pd.DataFrame
    traversals: pd.DataFrame
    #: ``validate.csv`` in today's columns, else None (the bands table then has no robustness)
    validate: pd.DataFrame | None
    #: ``peers.csv`` in today's columns, else None, and a sentence on why not
    peers: pd.DataFrame | None
    peers_note: str
    #: SHA-256 of ``batches.csv`` and ``peers.csv`` as read (``analysis.json`` records them)
    batches_sha256: str | None
    peers_sha256: str | None

    @property
    def specs(self) -> dict[str, dict[str, Any]]:
        """Workload id -> its spec dict, in sweep order."""
        return self.run.specs

    @property
    def kernels(self) -> list[str]:
        """The sweep's kernels that have batches, in sweep order."""
        present = set(self.batches["kernel"])
        return [k for k in self.run.sweep.kernels if k in present]

    @property
    def workload_ids(self) -> list[str]:
        """The sweep's workloads that have batches, in sweep order."""
        present = set(self.batches["workload_id"])
        return [w for w in self.run.sweep.workload_ids if w in present]

    @property
    def builds(self) -> list[str]:
        """The builds of the run's processes, in turn (``--builds``; else the installed build alone)."""
        return list(self.run.sweep.build_names)

    def of_build(self, build: str) -> Measured:
        """The run as its processes of ``build`` measured it (the processes take the builds in turn)."""
        return replace(
            self,
            batches=rows_of_build(self.batches, self.batches, build),
            processes=rows_of_build(self.processes, self.batches, build),
            traversals=rows_of_build(self.traversals, self.batches, build),
        )


def load(run_dir: str | Path) -> Measured:
    """Read a run folder's measured files once, each validated (a UserError names ``file:line``)."""
    run_dir = Path(run_dir)
    batches_sha256 = file_digest(run_dir / runfolder.BATCHES)  # before reading: a live sweep may append
    run = runfolder.read_run(run_dir)
    batches = runfolder.read_batches(run_dir, run)
    writer = runfolder.live_writer(run_dir)
    if writer is not None:
        print(
            f"tribench: note: {run_dir} is still being written by {writer}; these tables cover "
            f"{len(batches)} of its {run.n_batches} batches",
            file=sys.stderr,
        )
    peers, peers_note = read_documented(run_dir / runfolder.PEERS)
    return Measured(
        run_dir=run_dir,
        run=run,
        batches=batches,
        processes=runfolder.read_processes(run_dir, run),
        traversals=runfolder.read_traversals(run_dir, run),
        validate=read_documented(run_dir / runfolder.VALIDATE)[0],
        peers=peers,
        peers_note=peers_note,
        batches_sha256=batches_sha256,
        peers_sha256=file_digest(run_dir / runfolder.PEERS) if peers is not None else None,
    )


def has_columns(path: Path, name: str) -> bool:
    """True if the CSV's header is exactly the documented columns of the run folder's file ``name``."""
    try:
        with open(path, encoding="utf-8") as f:
            return f.readline(65536).rstrip("\r\n").split(",") == list(runfolder.FILES[name])
    except (OSError, UnicodeDecodeError):
        return False


def read_documented(path: Path) -> tuple[pd.DataFrame | None, str]:
    """An optional file of the run folder in exactly its documented columns, and "read"; else None and why."""
    name = path.name
    if not path.is_file():
        return None, f"no {name}"
    if not has_columns(path, name):
        return None, f"{name} is not in today's columns (an older tribench wrote it)"
    try:
        return pd.read_csv(path), "read"
    except (OSError, UnicodeDecodeError, pd.errors.ParserError, ValueError) as exc:
        return None, f"{name} cannot be used ({type(exc).__name__}: {exc})"
