"""The run folder: what a sweep writes and every later stage reads.

::

    RUN_DIR/run.json        written once at the start: sweep, plan seeds, machine,
                            build, versions, git revision, equivalence margin used
    RUN_DIR/batches.csv     one row per batch (:data:`BATCH_COLUMNS`), appended and
                            flushed as each batch finishes
    RUN_DIR/processes.csv   one row per FMA peak probe of a worker process
                            (:data:`PROCESS_COLUMNS`): at its start and its end
    RUN_DIR/checks.csv      one row per kernel, workload and process: its answers
                            against the reference (:data:`CHECK_COLUMNS`)
    RUN_DIR/estimates.csv, speedups.csv   written by ``tribench stats``

Rows are appended with one ``write`` each on a file opened in append mode,
so a process killed at any moment leaves at most one partial last line; the
readers here drop such a line (:func:`repair_csv` cuts it off the file before
a resume appends to it).
"""

from __future__ import annotations

import csv
import io
import json
import os
from collections.abc import Mapping, Sequence
from dataclasses import astuple, dataclass, fields
from pathlib import Path
from typing import Any

from tribench.common import UserError

__all__ = [
    "BATCH_COLUMNS",
    "CHECK_COLUMNS",
    "PROCESS_COLUMNS",
    "BatchRow",
    "CheckRow",
    "ProcessRow",
    "RowWriter",
    "read_batches",
    "read_checks",
    "read_processes",
    "read_run",
    "repair_csv",
    "write_csv",
    "write_run",
]

BATCHES = "batches.csv"
PROCESSES = "processes.csv"
CHECKS = "checks.csv"
RUN = "run.json"


@dataclass(frozen=True)
class BatchRow:
    """One timed batch, as stored (columns in this order).

    ``round < 0`` and ``warmup`` mark warm-up batches; ``attempt`` counts the
    worker processes that ran batches of this ``process`` index (0 unless the
    run was resumed in the middle of that process). ``steal_ticks`` is the
    machine's steal time during the batch, from ``/proc/stat`` (-1 when not
    readable).
    """

    run_id: str
    process: int
    round: int
    position: int
    kernel: str
    workload_id: str
    dtype: str
    mode: str
    warmup: bool
    loops: int
    tests: int
    elapsed_ns: int
    start_ns: int
    invol_ctx_switches: int
    hits: int
    t_sum: float
    cpu: int
    isa: str
    attempt: int
    steal_ticks: int


@dataclass(frozen=True)
class ProcessRow:
    """One FMA peak probe of one worker process (``phase`` is start or end).

    The layout fields record how this process's memory layout was varied:
    ``env_pad_bytes`` of environment padding and ``dummy_allocs`` small
    allocations made before the workload's arrays were copied.
    """

    run_id: str
    process: int
    attempt: int
    phase: str
    pid: int
    cpu: int
    seed: int
    env_pad_bytes: int
    dummy_allocs: int
    peak_gflops: float
    peak_flops: float
    peak_elapsed_ns: int
    peak_isa: str
    start_ns: int


@dataclass(frozen=True)
class CheckRow:
    """How one kernel's answers on one workload compare with the reference.

    Written once per kernel, workload and worker process, before any batch:
    ``disagreements`` counts rays answered differently from the float64
    reference, of which ``ambiguous_disagreements`` fall on the
    ``ambiguous_rays`` a finite-precision kernel may answer either way.
    ``hits`` and ``t_sum`` are the kernel's own one-pass checksum.
    """

    run_id: str
    process: int
    attempt: int
    workload_id: str
    kernel: str
    rays: int
    ambiguous_rays: int
    disagreements: int
    ambiguous_disagreements: int
    hits: int
    t_sum: float


BATCH_COLUMNS: tuple[str, ...] = tuple(f.name for f in fields(BatchRow))
CHECK_COLUMNS: tuple[str, ...] = tuple(f.name for f in fields(CheckRow))
PROCESS_COLUMNS: tuple[str, ...] = tuple(f.name for f in fields(ProcessRow))


def _csv_line(values: Sequence[Any]) -> str:
    buf = io.StringIO()
    csv.writer(buf, lineterminator="\n").writerow(values)
    return buf.getvalue()


class RowWriter:
    """Appends rows of one dataclass type to a CSV file, one ``write`` per row.

    The header is written when the file is new or empty. Each row goes to
    the OS at once (unbuffered), so a killed process loses no finished row.
    """

    def __init__(self, path: str | Path, columns: Sequence[str]) -> None:
        self.path = Path(path)
        self._fd = os.open(self.path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o666)
        if os.fstat(self._fd).st_size == 0:
            os.write(self._fd, _csv_line(columns).encode())

    def append(self, row: Any) -> None:
        os.write(self._fd, _csv_line(astuple(row)).encode())

    def close(self) -> None:
        if self._fd >= 0:
            os.close(self._fd)
            self._fd = -1

    def __enter__(self) -> "RowWriter":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def repair_csv(path: str | Path) -> bool:
    """Cut a partial last line (no final newline) off ``path``; True if one was cut."""
    path = Path(path)
    if not path.exists():
        return False
    data = path.read_bytes()
    if not data or data.endswith(b"\n"):
        return False
    with open(path, "r+b") as f:
        f.truncate(data.rfind(b"\n") + 1)
    return True


def _read_csv(path: Path, columns: Sequence[str], dtypes: Mapping[str, Any]):
    import pandas as pd

    text = path.read_text()
    if text and not text.endswith("\n"):
        text = text[: text.rfind("\n") + 1]  # a partial last line: a batch that did not finish
    if not text:
        return pd.DataFrame({c: pd.Series(dtype=dtypes.get(c, object)) for c in columns})
    frame = pd.read_csv(io.StringIO(text), dtype=dict(dtypes))
    missing = [c for c in columns if c not in frame.columns]
    if missing:
        raise UserError(f"{path}: missing columns {missing}")
    return frame


def read_batches(run_dir: str | Path):
    """``batches.csv`` of a run as a DataFrame (a partial last line is ignored)."""
    path = Path(run_dir) / BATCHES
    if not path.is_file():
        raise FileNotFoundError(f"no {BATCHES} in {run_dir}")
    dtypes = {"warmup": bool, "kernel": str, "workload_id": str, "run_id": str, "isa": str,
              "dtype": str, "mode": str}
    return _read_csv(path, BATCH_COLUMNS, dtypes)


def read_checks(run_dir: str | Path):
    """``checks.csv`` of a run (empty frame if the run has none yet)."""
    import pandas as pd

    path = Path(run_dir) / CHECKS
    if not path.is_file():
        return pd.DataFrame(columns=list(CHECK_COLUMNS))
    return _read_csv(path, CHECK_COLUMNS, {"kernel": str, "workload_id": str, "run_id": str})


def read_processes(run_dir: str | Path):
    """``processes.csv`` of a run (empty frame if the run has none yet)."""
    import pandas as pd

    path = Path(run_dir) / PROCESSES
    if not path.is_file():
        return pd.DataFrame(columns=list(PROCESS_COLUMNS))
    return _read_csv(path, PROCESS_COLUMNS, {"phase": str, "peak_isa": str, "run_id": str})


def write_csv(frame: Any, path: str | Path) -> None:
    """Write a DataFrame to ``path`` atomically (temporary file, then rename): no reader sees half a file."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(path.suffix + ".tmp")
    frame.to_csv(tmp, index=False)
    os.replace(tmp, path)


def write_run(run_dir: str | Path, record: Mapping[str, Any]) -> None:
    """Write ``run.json`` atomically (temporary file, then rename)."""
    path = Path(run_dir) / RUN
    tmp = path.with_suffix(".json.tmp")
    tmp.write_text(json.dumps(record, indent=2, sort_keys=True, allow_nan=False) + "\n")
    os.replace(tmp, path)


def read_run(run_dir: str | Path) -> dict[str, Any]:
    """``run.json`` of a run."""
    path = Path(run_dir) / RUN
    if not Path(run_dir).is_dir():
        raise FileNotFoundError(f"no run directory {run_dir}")
    if not path.is_file():
        raise FileNotFoundError(f"{run_dir} is not a run directory (no {RUN})")
    try:
        return json.loads(path.read_text())
    except json.JSONDecodeError as exc:
        raise UserError(f"{path} is not valid JSON ({exc})") from None
