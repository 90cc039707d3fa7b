"""The one worker protocol: a fresh process per job, the job on stdin, typed JSON lines on a private channel.

Every measurement (the sweeps', the peers', a kernel file's check) runs in such a worker. :func:`run_worker`
is the parent's side, :func:`serve` the worker's: the channel is stdout moved to a descriptor of its own,
fd 1 going to stderr, so a ``printf`` in a user's kernel cannot break a line. The protocol's own types:
``notice`` (printed once however many workers send it), ``error`` (exit code 3: :class:`WorkerError`),
``silence`` (``seconds``: how long the worker may now go without a line, None for ever; ``during``: what it does;
past it, it is stopped, as a kernel that never returns) and ``end``, without which a worker failed (a kernel that
called ``exit()``). Its stderr shows only on failure."""

from __future__ import annotations

import io
import json
import os
import signal
import subprocess
import sys
import tempfile
import threading
import time
import warnings
from collections.abc import Callable, Mapping, Sequence
from typing import Any, TextIO

from ..common import Notice, UserError

__all__ = ["WorkerError", "emit", "run_apart", "run_worker", "serve", "serve_apart"]


class WorkerError(RuntimeError):
    """A worker's own error line (``said`` True), or its exit without one (with the last lines of its stderr)."""

    def __init__(self, message: str, said: bool = False) -> None:
        super().__init__(message)
        self.said = said


_NOTICES_SHOWN: set[str] = set()


def run_worker(
    command: Sequence[str],
    job: str,
    env: Mapping[str, str],
    handlers: Mapping[str, Callable[[dict[str, Any]], None]],
    name: str,
    timeout: float | None = None,
) -> None:
    """Run one worker to its end: ``job`` to its stdin, each line to ``handlers[type]``.

    Raises :class:`WorkerError` on an error line, a line not the protocol's, an exit before ``end`` or with a
    non-zero code, or a silence longer than allowed (killed): ``timeout`` seconds until the worker's ``silence``
    lines say otherwise. A handler's exception kills the worker and propagates."""
    error, ended = None, False
    with tempfile.TemporaryFile("w+") as err:
        proc = subprocess.Popen(
            list(command), stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=err, env=dict(env), text=True
        )
        assert proc.stdin is not None and proc.stdout is not None  # both are pipes
        watch = _Watch(proc, timeout)
        try:
            proc.stdin.write(job)
            proc.stdin.close()
            for line in proc.stdout:
                watch.heard()
                try:
                    message = json.loads(line)
                    kind = message.pop("type")
                except (ValueError, AttributeError, KeyError):
                    raise WorkerError(f"{name} sent a line that is not the protocol's: {line.strip()[:80]!r}") from None
                if kind == "end":
                    ended = True
                elif kind == "silence":
                    watch.limit, watch.during = message["seconds"], message["during"]
                elif kind == "notice":
                    if message["message"] not in _NOTICES_SHOWN:  # once: ten workers, one file
                        _NOTICES_SHOWN.add(message["message"])
                        warnings.warn(message["message"], Notice, stacklevel=2)
                elif kind == "error":
                    error = message["message"]
                elif kind in handlers:
                    handlers[kind](message)
                else:
                    raise WorkerError(f"{name} sent a line of unknown type {kind!r}")
            code = proc.wait()
        except BaseException:
            proc.kill()
            proc.wait()
            raise
        finally:
            watch.stop()
        if watch.fired is not None:
            during = f" while {watch.during}" if watch.during else ""
            raise WorkerError(
                f"{name} sent nothing for {watch.fired:.3g} s{during} (a kernel that never returns?): it was stopped"
            )
        if error is not None:
            raise WorkerError(error, said=True)
        if code != 0:
            raise WorkerError(f"{name} {_exit_words(code, err)}")
        if not ended:
            raise WorkerError(f"{name} exited before its job was done (exit code 0: its code called exit()?)")


class _Watch:
    """Kills ``proc`` once it has sent no line for ``limit`` seconds (None: never); ``fired`` is then that limit."""

    def __init__(self, proc: subprocess.Popen, limit: float | None) -> None:
        self.proc, self.limit, self.during = proc, limit, ""
        self.last = time.monotonic()
        self.fired: float | None = None
        self._stopped = threading.Event()
        threading.Thread(target=self._watch, daemon=True).start()

    def heard(self) -> None:
        self.last = time.monotonic()

    def stop(self) -> None:
        self._stopped.set()

    def _watch(self) -> None:
        while not self._stopped.wait(self._left()):
            limit = self.limit
            if limit is not None and time.monotonic() - self.last >= limit:
                self.fired = limit
                self.proc.kill()
                return

    def _left(self) -> float:
        """How long to sleep: until the limit would pass, at most a second (a ``silence`` line may change it)."""
        limit = self.limit
        return 1.0 if limit is None else min(1.0, max(0.001, self.last + limit - time.monotonic()))


def run_apart(
    module: str,
    job: Any,
    kernel_files: Sequence[str],
    handlers: Mapping[str, Callable[[dict[str, Any]], None]],
    name: str,
    fails: str | None,
    build: str | None = None,
) -> None:
    """``job`` in ``python -m module``'s worker (:func:`serve_apart`), ``kernel_files`` loaded there first (under
    ``build``, if given): a user's kernels on inputs their check never ran. A failure is one UserError, ``fails``
    (if any) said after a crash or a hang."""
    text = json.dumps({"build": build, "kernel_files": list(kernel_files), "job": job})
    try:
        run_worker([sys.executable, "-m", module], text, os.environ, handlers, name)
    except WorkerError as exc:
        raise UserError(f"{exc}: {fails}" if fails and not exc.said else str(exc)) from None


def serve_apart(work: Callable[[Any], None]) -> int:
    """The worker's main for :func:`run_apart`: the build chosen, the kernel files loaded, then ``work(job)``;
    the exit code."""
    import faulthandler

    from .. import ext

    def load_then_work(text: str) -> None:
        d = json.loads(text)
        build = d["build"]
        try:
            if build is not None:
                ext.use_build(build)
            for path in d["kernel_files"]:  # by path, as the sweep's workers load them
                ext.load_kernels(path)
        except UserError as e:
            raise UserError(f"build {build}: {e}" if build is not None else str(e)) from None
        work(d["job"])

    faulthandler.disable()  # a crash is reported by the parent, in one line
    return serve(load_then_work)


def _exit_words(code: int, err: TextIO) -> str:
    """How a worker ended, as said, and the last lines it wrote to ``err`` (a temporary file):
    ``exited with code 4``, ``was killed by SIGSEGV: a | b``."""
    names = {-s.value: s.name for s in signal.Signals}
    how = f"was killed by {names[code]}" if code in names else f"exited with code {code}"
    err.seek(0)
    tail = err.read().strip().splitlines()[-5:]
    return f"{how}: {' | '.join(tail)}" if tail else how


#: The worker's end of the channel (see :func:`serve`); stdout outside a worker.
_CHANNEL: TextIO | None = None


def emit(kind: str, record: Any) -> None:
    """Send one line of type ``kind``: a flat row (a dataclass, by its fields) or a dict."""
    # vars, not asdict: the rows are flat, and asdict's deep copy costs 45 us a batch
    fields = record if isinstance(record, dict) else vars(record)
    out = _CHANNEL or sys.stdout
    out.write(json.dumps({"type": kind, **fields}) + "\n")
    out.flush()


def serve(work: Callable[[str], None], errors: tuple[type[BaseException], ...] = ()) -> int:
    """A worker's main: run ``work(job)`` on the job read from stdin; the exit code.

    ``errors``, ValueError (UserError among them) and OSError (a cache file) become the ``error`` line, exit code 3."""
    global _CHANNEL
    _CHANNEL = _take_channel()
    warnings.showwarning = _pass_notices(warnings.showwarning)
    expected: tuple[type[BaseException], ...] = (ValueError, OSError, *errors)
    try:
        work(sys.stdin.read())
    except KeyboardInterrupt:
        return 130  # Ctrl-C reaches the whole process group; the parent reports it
    except BrokenPipeError:
        return 141  # the parent is gone: nothing to report to
    except expected as exc:
        message = str(exc)
        if isinstance(exc, OSError) and not isinstance(exc, FileNotFoundError):  # a missing file's message names it
            where = f" on {exc.filename}" if exc.filename else ""  # what failed, on which file, in one line
            message = f"a worker could not go on: {exc.strerror or type(exc).__name__}{where}"
        emit("error", {"message": message})
        return 3
    emit("end", {})
    return 0


def _take_channel() -> TextIO | None:
    """The process's stdout as the protocol's alone, fd 1 going to stderr; None where stdout is no
    file descriptor (a test's capture): :func:`emit` then writes to ``sys.stdout`` as it is."""
    try:
        fd = sys.stdout.fileno()
    except (AttributeError, ValueError, io.UnsupportedOperation):
        return None
    sys.stdout.flush()
    channel = os.fdopen(os.dup(fd), "w")
    os.dup2(sys.stderr.fileno(), fd)
    return channel


def _pass_notices(shown):
    """tribench's notices (a cache file rebuilt) go to the parent, which prints each once."""

    def show(message, category, filename, lineno, file=None, line=None) -> None:
        if issubclass(category, Notice):
            emit("notice", {"message": str(message)})
        else:
            shown(message, category, filename, lineno, file, line)

    return show
