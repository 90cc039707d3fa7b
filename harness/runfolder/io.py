"""The run folder's measured files: written row by row, read back validated.

The files and columns are :mod:`tribench.harness.runfolder`'s (docs/run-folder.md), the one-writer lock
:mod:`.lock`'s. Each row is one ``write`` in append mode, so a kill leaves at most one partial last line,
which readers drop and :func:`repair_csv` cuts before a resume appends; a failed write is undone. Every
reader validates in :func:`_read_table` (header, types, run id, the sweep's kernels and workloads, positive
counts and times, no batch twice or outside the plan), raising a UserError naming ``file:line``; a BOM and
CRLF line ends are accepted."""

from __future__ import annotations

import csv
import datetime as _dt
import errno
import io
import json
import os
import stat
from collections.abc import Callable, Mapping, Sequence
from dataclasses import astuple, fields
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from ...common import UserError, atomic_write, write_text
from ..plan import plan
from .lock import live_writer, writer_lock
from .record import Run
from .rows import BatchRow, CheckRow, ProcessRow, TraversalRow
from .schema import BATCHES, CHECKS, LOCK, PROCESSES, RUN, TRAVERSALS

__all__ = [
    "BATCH_COLUMNS",
    "CHECK_COLUMNS",
    "PROCESS_COLUMNS",
    "BatchRow",
    "CheckRow",
    "MAX_ROW_BYTES",
    "MissingRunFile",
    "ProcessRow",
    "RowWriter",
    "check_new_run_dir",
    "default_run_dir",
    "TRAVERSAL_COLUMNS",
    "TraversalRow",
    "live_writer",
    "read_batches",
    "read_checks",
    "read_processes",
    "read_traversals",
    "read_run",
    "Run",
    "repair_csv",
    "write_csv",
    "write_run",
    "writer_lock",
]


def default_run_dir(kind: str = "") -> str:
    """The run folder a command writes when none is given: ``runs/[KIND-]<date-time>``."""
    return f"runs/{kind + '-' if kind else ''}{_dt.datetime.now():%Y%m%d-%H%M%S}"


def check_new_run_dir(run_dir: str | Path) -> None:
    """A new run may go into ``run_dir``: it does not exist, or holds nothing but a lock file; else a UserError."""
    run_dir = Path(run_dir)
    if run_dir.exists() and not run_dir.is_dir():
        raise UserError(f"{run_dir} is a file, not a folder: a new run needs a new or empty folder")
    inside = next((p for p in run_dir.resolve().parents if (p / RUN).is_file()), None)
    if inside is not None:  # the outer run's folder is its record: a copy or replication of it would carry this one
        raise UserError(f"{run_dir} is inside the run folder {inside}: put the new run beside it, not in it")
    if run_dir.exists() and any(p.name != LOCK for p in run_dir.iterdir()):
        finish = _finish_command(run_dir)
        raise UserError(
            f"{run_dir} exists and is not empty: a new run needs a new or empty folder"
            + (f" ({finish} finishes an interrupted run)" if finish else "")
        )


def _finish_command(run_dir: Path) -> str | None:
    """The command that finishes the run in ``run_dir`` as its own job (a main job, a replication, a sweep);
    None for a folder that is no run, or a job with no way to resume (a seed replay, a calibration)."""
    try:
        run = read_run(run_dir)
    except UserError:
        return None
    if run.seed_replay or run.calibration:
        return None
    if run.main_job:
        return f"tribench run --resume {run_dir}"
    if run.replicates and run.replicates.get("run_dir"):
        return f"tribench replicate {run.replicates['run_dir']} --resume {run_dir}"
    return f"tribench sweep --resume {run_dir}"


#: No row tribench writes is longer; a file larger than its rows allow is not tribench's.
MAX_ROW_BYTES = 1024


class MissingRunFile(UserError, FileNotFoundError):
    """A run folder, or a file in it, is missing (a UserError, and a FileNotFoundError as before)."""


BATCH_COLUMNS: tuple[str, ...] = tuple(f.name for f in fields(BatchRow))
CHECK_COLUMNS: tuple[str, ...] = tuple(f.name for f in fields(CheckRow))
PROCESS_COLUMNS: tuple[str, ...] = tuple(f.name for f in fields(ProcessRow))
TRAVERSAL_COLUMNS: tuple[str, ...] = tuple(f.name for f in fields(TraversalRow))


def _csv_line(values: Sequence[Any]) -> str:
    buf = io.StringIO()
    csv.writer(buf, lineterminator="\n").writerow(values)
    return buf.getvalue()


class RowWriter:
    """Appends rows of one dataclass type to a CSV file (not a symbolic link), one unbuffered ``write`` per row; a
    row that cannot be written whole is cut off again before the ``OSError`` is raised."""

    def __init__(self, path: str | Path, columns: Sequence[str]) -> None:
        self.path = Path(path)
        try:
            self._fd = os.open(self.path, os.O_WRONLY | os.O_APPEND | os.O_CREAT | os.O_NOFOLLOW, 0o666)
        except OSError as exc:
            if exc.errno == errno.ELOOP:
                raise UserError(f"{self.path} is a symbolic link; a run folder's files are plain files") from None
            raise
        try:
            self._size = os.fstat(self._fd).st_size
            if self._size == 0:
                self._write(_csv_line(columns).encode())
        except BaseException:
            self.close()  # no writer is returned: its file would stay open
            raise

    def append(self, row: Any) -> None:
        self._write(_csv_line(astuple(row)).encode())

    def _write(self, data: bytes) -> None:
        try:
            done = 0
            while done < len(data):  # a short write: the disk filled in the middle of the row
                n = os.write(self._fd, data[done:])
                if n == 0:
                    raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
                done += n
        except OSError as exc:
            try:
                os.ftruncate(self._fd, self._size)  # leave no partial line (shrinking needs no space)
            except OSError:
                pass
            raise OSError(exc.errno, exc.strerror, str(self.path)) from None
        self._size += len(data)

    def close(self) -> None:
        if self._fd >= 0:
            os.close(self._fd)
            self._fd = -1

    def __enter__(self) -> RowWriter:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _cut_partial_line(path: Path, data: bytes) -> bytes:
    """``data`` without its partial last line: a row cut by a kill, so no longer than a row."""
    if not data or data.endswith(b"\n"):
        return data
    end = data.rfind(b"\n") + 1
    if len(data) - end > MAX_ROW_BYTES:
        line = data.count(b"\n") + 1
        raise UserError(f"{path}:{line}: {len(data) - end} bytes without a line end: not a row cut by a kill")
    return data[:end]


def repair_csv(path: str | Path) -> bool:
    """Cut a partial last line (no final newline) off ``path``; True if one was cut."""
    path = Path(path)
    if not os.path.lexists(path):
        return False
    _check_plain_file(path)
    data = path.read_bytes()
    if _cut_partial_line(path, data) == data:
        return False
    with open(path, "r+b") as f:
        f.truncate(data.rfind(b"\n") + 1)
    return True


# ------------------------------------------------------------ reading


def _check_plain_file(path: Path, max_bytes: int | None = None) -> None:
    """A run folder's file must be a regular file (not a link, a FIFO, a device), of a plausible size."""
    try:
        st = os.lstat(path)
    except FileNotFoundError:
        raise MissingRunFile(f"no {path.name} in {path.parent}") from None
    if stat.S_ISLNK(st.st_mode):
        raise UserError(f"{path} is a symbolic link; a run folder's files are plain files written by tribench")
    if not stat.S_ISREG(st.st_mode):
        raise UserError(f"{path} is not a regular file")
    if max_bytes is not None and st.st_size > max_bytes:
        raise UserError(
            f"{path} is {st.st_size} bytes, more than its run can write (at most {max_bytes}): not tribench's file"
        )


def _short(value: str) -> str:
    return repr(value if len(value) <= 40 else value[:37] + "...")


#: A rule on parsed rows: a function of the frame giving a bad-row mask, and the message for one bad row.
Rule = tuple[Callable[..., Any], Callable[..., str]]  # ...: the lambdas bind names as defaults


def _read_table(path: Path, cls: type, rules: Sequence[Rule], max_bytes: int | None):
    """``path`` as a DataFrame of ``cls``'s columns and types, every row checked; a partial last line dropped.

    Raises a UserError naming ``path:line`` for the first thing wrong."""
    columns = [f.name for f in fields(cls)]
    kinds = {f.name: f.type if isinstance(f.type, str) else f.type.__name__ for f in fields(cls)}
    text = _text(path, max_bytes)
    if not text:
        dtypes = {"int": "int64", "float": "float64", "bool": bool}
        return pd.DataFrame({c: pd.Series(dtype=dtypes.get(kinds[c], object)) for c in columns})
    raw, lines = _fields(path, text, columns)
    frame = pd.DataFrame(index=raw.index)
    for c in columns:
        frame[c] = _column(path, lines, raw[c], c, kinds[c])
    for bad, message in rules:
        _refuse(path, lines, bad(frame), lambda i, message=message: message(frame.iloc[i]))
    return frame


def _text(path: Path, max_bytes: int | None) -> str:
    """A measured file's text: a plain file of a plausible size, UTF-8 (BOM dropped), its partial last line cut off."""
    _check_plain_file(path, max_bytes)
    data = path.read_bytes()
    if data.startswith(b"\xef\xbb\xbf"):
        data = data[3:]
    data = _cut_partial_line(path, data)
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = data[: exc.start].count(b"\n") + 1
        raise UserError(f"{path}:{line}: not UTF-8 text") from None


def _fields(path: Path, text: str, columns: list[str]):
    """The rows as text fields and each row's line number; the header and every field count checked."""
    reader = csv.reader(io.StringIO(text))
    rows: list[list[str]] = []
    lines: list[int] = []
    try:
        header = next(reader)
        if header != columns:
            got = ",".join(header)
            raise UserError(
                f"{path}:1: the header is not {path.name}'s columns (another tribench version, or "
                f"not tribench's file): expected {','.join(columns)}, got {_short(got)}"
            )
        for row in reader:
            if len(row) != len(columns):
                what = "a blank line" if not row else f"{len(row)} fields, expected {len(columns)}"
                raise UserError(f"{path}:{reader.line_num}: {what}")
            rows.append(row)
            lines.append(reader.line_num)
    except csv.Error as exc:
        raise UserError(f"{path}:{reader.line_num}: not CSV ({exc})") from None
    return pd.DataFrame(rows, columns=columns, dtype=object), lines


def _refuse(path: Path, lines: list[int], bad: Any, message: Callable[..., str]) -> None:
    """A UserError naming the first bad row's line (``message(i)`` says what is wrong with row ``i``)."""
    bad = np.asarray(bad, dtype=bool)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise UserError(f"{path}:{lines[i]}: {message(i)}")


def _column(path: Path, lines: list[int], s: Any, c: str, kind: str) -> Any:
    """Column ``c``'s text fields as values of its type, each checked (``kind``: int, float, bool or str)."""

    def refuse(bad: Any, message: Callable[..., str]) -> None:
        _refuse(path, lines, bad, message)

    if kind == "int":
        refuse(~s.str.fullmatch(r"-?[0-9]{1,20}"), lambda i: f"{c} is {_short(s.iloc[i])}, not an integer")
        try:
            return s.astype(np.int64)
        except OverflowError:  # the layout seeds are unsigned 64-bit
            try:
                return s.astype(np.uint64)
            except (OverflowError, ValueError):
                big = s.map(lambda v: not -(2**63) <= int(v) < 2**64)
                refuse(big, lambda i: f"{c} is {_short(s.iloc[i])}, out of range")
                refuse(s.str.startswith("-"), lambda i: f"{c} mixes negative and unsigned 64-bit values")
                raise  # not reached: one of the two refusals holds
    if kind == "float":
        values = pd.to_numeric(s, errors="coerce").astype(float)
        refuse(~np.isfinite(values), lambda i: f"{c} is {_short(s.iloc[i])}, not a finite number")
        return values
    if kind == "bool":
        refuse(~s.isin(["True", "False"]), lambda i: f"{c} is {_short(s.iloc[i])}, not True or False")
        return s == "True"
    refuse(s == "", lambda i: f"{c} is empty")
    return s.astype(str)


def _positive(*names: str) -> list[Rule]:
    return [(lambda f, n=n: f[n] <= 0, lambda r, n=n: f"{n} is {r[n]}; must be positive") for n in names]


def _not_negative(*names: str) -> list[Rule]:
    return [(lambda f, n=n: f[n] < 0, lambda r, n=n: f"{n} is {r[n]}; must be 0 or more") for n in names]


def _unique(names: Sequence[str], what: str) -> Rule:
    return (
        lambda f: f.duplicated(subset=list(names), keep="first"),
        lambda r: f"{what} ({', '.join(f'{n} {r[n]}' for n in names)}) is written twice (two writers?)",
    )


def _run_rules(run: Run | None, keyed: bool) -> list[Rule]:
    """Rules that need ``run.json``: the run id, the process range and (``keyed``) the sweep's kernels and workloads."""
    if run is None:
        return []
    sweep = run.sweep
    rules: list[Rule] = [
        (
            lambda f: f["run_id"] != run.run_id,
            lambda r: f"run id {_short(r['run_id'])} is not this run's ({run.run_id}, in {RUN})",
        ),
        (
            lambda f: (f["process"] < 0) | (f["process"] >= sweep.processes),
            lambda r: f"process {r['process']} is not one of the run's {sweep.processes} (0 to {sweep.processes - 1})",
        ),
    ]
    if keyed:
        rules += [
            (
                lambda f: ~f["kernel"].isin(sweep.kernels),
                lambda r: f"unknown kernel {_short(r['kernel'])}: not in the run's sweep ({', '.join(sweep.kernels)})",
            ),
            (
                lambda f: ~f["workload_id"].isin(sweep.workload_ids),
                lambda r: f"unknown workload {_short(r['workload_id'])}: not in the run's sweep",
            ),
        ]
    return rules


#: A warm-up batch is one of a negative round (batches.csv, traversals.csv).
_WARMUP: Rule = (
    lambda f: f["warmup"] != (f["round"] < 0),
    lambda r: f"warmup is {r['warmup']} but round is {r['round']} (warm-up rounds are negative)",
)


def _read(
    run_dir: str | Path,
    name: str,
    cls: type,
    run: Run | None,
    rows_per_batch: int,
    rules: list[Rule],
    keyed: bool = True,
    optional: bool = True,
):
    """``name`` of ``run_dir`` by :func:`_read_table`: :func:`_run_rules` (``run`` read from ``run.json``, if
    there, when not given), ``rules`` and for batches the plan's; an ``optional`` file not there is an empty frame."""
    run_dir = Path(run_dir)
    path = run_dir / name
    if optional and not os.path.lexists(path):
        return pd.DataFrame(columns=[f.name for f in fields(cls)])
    if run is None and (run_dir / RUN).exists():
        run = read_run(run_dir)
    max_bytes = None if run is None else MAX_ROW_BYTES * (rows_per_batch * run.n_batches + 1024)
    plan_rules = _plan_rules(run) if cls is BatchRow and run is not None else []
    return _read_table(path, cls, [*_run_rules(run, keyed), *rules, *plan_rules], max_bytes)


def read_batches(run_dir: str | Path, run: Run | None = None):
    """``batches.csv`` of a run as a DataFrame, validated (a partial last line is ignored). With ``run``
    (read from ``run.json`` if there when not given) every row must carry its run id, a kernel and
    workload of its sweep and a key of its plan, at most once."""
    rules: list[Rule] = [
        *_positive("loops", "tests", "elapsed_ns"),
        *_not_negative("hits", "attempt", "position"),
        _WARMUP,
        (
            lambda f: ~f["dtype"].isin(["float32", "float64"]),
            lambda r: f"dtype {_short(r['dtype'])} is not float32 or float64",
        ),
        _unique(("process", "workload_id", "round", "position", "kernel"), "the batch"),
    ]
    return _read(run_dir, BATCHES, BatchRow, run, 1, rules, optional=False)


def _plan_rules(run: Run) -> list[Rule]:
    """Each batch is of its process's build and in the run's plan."""
    sweep = run.sweep
    planned = {(k.process, k.workload_id, k.round, k.position, k.kernel) for k in plan(sweep)}

    def outside(f: Any) -> Any:
        return [
            key not in planned
            for key in zip(f["process"], f["workload_id"], f["round"], f["position"], f["kernel"], strict=True)
        ]

    return [
        (
            lambda f: [b != sweep.build_of(p) for p, b in zip(f["process"], f["build"], strict=True)],
            lambda r: f"build {_short(r['build'])} is not process {r['process']}'s, {sweep.build_of(r['process'])}",
        ),
        (
            outside,
            lambda r: (
                f"batch (process {r['process']}, round {r['round']}, position "
                f"{r['position']}, kernel {r['kernel']}) is not in the run's plan"
            ),
        ),
    ]


def read_checks(run_dir: str | Path, run: Run | None = None):
    """``checks.csv`` of a run, validated (empty frame if the run has none yet)."""
    rules: list[Rule] = [
        *_positive("rays"),
        *_not_negative("attempt", "ambiguous_rays", "disagreements", "ambiguous_disagreements", "hits"),
        (
            lambda f: (f["disagreements"] > f["rays"]) | (f["ambiguous_rays"] > f["rays"]),
            lambda r: f"more disagreements or ambiguous rays than rays ({r['rays']})",
        ),
        _unique(("process", "attempt", "workload_id", "kernel"), "the check"),
    ]
    return _read(run_dir, CHECKS, CheckRow, run, 4, rules)


def read_processes(run_dir: str | Path, run: Run | None = None):
    """``processes.csv`` of a run, validated (empty frame if the run has none yet)."""
    rules: list[Rule] = [
        *_positive("pid", "peak_gflops", "peak_flops", "peak_elapsed_ns"),
        *_not_negative("attempt", "env_pad_bytes", "dummy_allocs"),
        (lambda f: ~f["phase"].isin(["start", "end"]), lambda r: f"phase {_short(r['phase'])} is not start or end"),
        _unique(("process", "attempt", "phase"), "the peak probe"),
    ]
    return _read(run_dir, PROCESSES, ProcessRow, run, 4, rules, keyed=False)


def read_traversals(run_dir: str | Path, run: Run | None = None):
    """``traversals.csv`` of a run, validated (empty if the run has none)."""
    rules: list[Rule] = [
        *_positive("rays", "null_elapsed_ns"),
        *_not_negative("attempt", "position", "nodes", "box_tests", "leaves", "triangle_tests", "null_nodes"),
        _WARMUP,
        _unique(("process", "workload_id", "round", "position", "kernel"), "the traversal of the batch"),
    ]
    return _read(run_dir, TRAVERSALS, TraversalRow, run, 1, rules)


# ------------------------------------------------------------ whole files


def write_csv(frame: Any, path: str | Path) -> None:
    """Write a DataFrame to ``path`` atomically (:func:`tribench.common.atomic_write`): no reader sees half a file."""
    with atomic_write(path) as f:
        frame.to_csv(f, index=False)


def write_run(run_dir: str | Path, record: Mapping[str, Any]) -> None:
    """Write ``run.json`` atomically (:func:`tribench.common.write_text`)."""
    write_text(Path(run_dir) / RUN, json.dumps(record, indent=2, sort_keys=True, allow_nan=False) + "\n")


def read_run(run_dir: str | Path) -> Run:
    """``run.json`` of a run, checked (:class:`~.record.Run`)."""
    run_dir = Path(run_dir)
    path = run_dir / RUN
    if not run_dir.is_dir():
        raise MissingRunFile(f"no run directory {run_dir}")
    if not os.path.lexists(path):
        raise MissingRunFile(f"{run_dir} is not a run directory (no {RUN})")
    _check_plain_file(path, 64 * 1024 * 1024)
    try:
        run = json.loads(path.read_bytes().decode("utf-8"))
    except UnicodeDecodeError:
        raise UserError(f"{path} is not UTF-8 text") from None
    except json.JSONDecodeError as exc:
        raise UserError(f"{path}:{exc.lineno}: not valid JSON ({exc.msg}); a truncated or edited file?") from None
    except RecursionError:
        raise UserError(f"{path}: not a tribench run record (nested too deeply)") from None
    if not isinstance(run, dict):
        raise UserError(f"{path} is not a tribench run record (not a JSON object)")
    try:
        return Run.from_record(run, run_dir)
    except UserError as exc:
        raise UserError(f"{path}: {exc}") from None
