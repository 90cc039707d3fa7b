"""Short names for the run folder's documented columns, which :mod:`tribench.harness.runfolder` defines."""

from __future__ import annotations

from ..harness import runfolder as _rf
from ..harness.runfolder import DERIVED, FILES, OPTIONAL, SEED_FILES, describe

__all__ = [
    "BATCHES",
    "CHECKS",
    "ESTIMATES",
    "SPEEDUPS",
    "PROCESSES",
    "VALIDATE",
    "PEERS",
    "FILES",
    "OPTIONAL",
    "SEED_FILES",
    "DERIVED",
    "describe",
]

#: Shorthands for the column dicts of the files the report reads most.
BATCHES = FILES[_rf.BATCHES]
PROCESSES = FILES[_rf.PROCESSES]
CHECKS = FILES[_rf.CHECKS]
ESTIMATES = FILES[_rf.ESTIMATES]
SPEEDUPS = FILES[_rf.SPEEDUPS]
VALIDATE = FILES[_rf.VALIDATE]
PEERS = FILES[_rf.PEERS]
