"""The run folder's one-writer lock: an exclusive ``flock`` on ``RUN_DIR/.lock``.

A sweep or a resume holds it while it appends, so a second writer is refused with the first one's pid. Readers
(``stats``, ``report``) take no lock: they may read a folder a live sweep is writing."""

from __future__ import annotations

import datetime as _dt
import fcntl
import json
import os
import socket
import sys
import time
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from ...common import UserError
from .schema import LOCK

__all__ = ["live_writer", "writer_lock"]


def _holder(fd: int) -> dict[str, Any] | None:
    """What the lock file says about the process that holds (or held) it; None if empty or unreadable."""
    unknown = {"pid": "?", "host": "?", "since": "?"}
    try:
        data = os.pread(fd, 4096, 0)
        if not data.strip():
            return None
        holder = json.loads(data.decode())
    except (OSError, ValueError):
        return unknown
    return holder if isinstance(holder, dict) else unknown


def _describe(holder: Mapping[str, Any]) -> str:
    return f"process {holder.get('pid', '?')} on {holder.get('host', '?')} (since {holder.get('since', '?')})"


@contextmanager
def writer_lock(run_dir: str | Path) -> Iterator[None]:
    """Hold the run folder's one-writer lock for the body; raise a UserError if a live process holds it.

    The holder writes its pid, host and start time into the file and empties it on a clean release, so a non-empty
    file found unlocked (the kernel releases a ``flock`` however its holder dies) was a killed writer's: taken over,
    saying so. The file is never removed (two writers could then lock two different files)."""
    run_dir = Path(run_dir)
    path = run_dir / LOCK
    try:
        fd = os.open(path, os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW | os.O_CLOEXEC, 0o666)
    except OSError as exc:
        raise UserError(f"cannot write to the run folder {run_dir} ({path}: {exc.strerror})") from None
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = _holder(fd)
            for _ in range(50):  # a holder writes its record just after it locks: give it a moment
                if holder:
                    break
                time.sleep(0.002)
                holder = _holder(fd)
            holder = holder or {}
            raise UserError(
                f"{run_dir} is being written by {_describe(holder)}: one writer per run folder; "
                f"wait for it to finish, or stop process {holder.get('pid', '?')}"
            ) from None
        except OSError as exc:
            raise UserError(f"cannot lock {path}: {exc.strerror} (a file system without locks?)") from None
        previous = _holder(fd)
        if previous:
            print(f"tribench: taking over the lock of dead {_describe(previous)} in {run_dir}", file=sys.stderr)
        me = {
            "pid": os.getpid(),
            "host": socket.gethostname(),
            "since": _dt.datetime.now().astimezone().isoformat(timespec="seconds"),
            "argv": sys.argv,
        }
        try:
            os.ftruncate(fd, 0)
            os.pwrite(fd, json.dumps(me).encode() + b"\n", 0)
        except OSError:
            pass  # a full disk: the lock holds all the same, the message will lack the pid
        try:
            yield
        finally:  # released by this process, error or not: an empty lock file (a SIGKILL skips this)
            try:
                os.ftruncate(fd, 0)
            except OSError:
                pass
    finally:
        os.close(fd)


def live_writer(run_dir: str | Path) -> str | None:
    """Who writes ``run_dir`` now ("process N on HOST (since T)"), or None if nobody does."""
    path = Path(run_dir) / LOCK
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NOFOLLOW | os.O_CLOEXEC)
    except OSError:
        return None
    try:
        fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
    except OSError:
        return _describe(_holder(fd) or {})
    else:
        fcntl.flock(fd, fcntl.LOCK_UN)
        return None
    finally:
        os.close(fd)
