"""The documented columns of a run folder's CSVs, for the report and for readers.

The names and columns are defined once, in :mod:`tribench.harness.runfolder`
(file names, column lists in file order, what each column means, who writes
each file); this module only gives the report short names for them and
renders them (:func:`describe`). The report never changes a file it reads.
"""

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
