"""The one worker protocol (tribench.harness.protocol): lines by type, notices once, errors in one line."""

from __future__ import annotations

import os
import sys
import warnings

import pytest

from tribench.common import Notice
from tribench.harness import protocol

#: A worker in the protocol: its job is the Python code it runs, with ``emit`` at hand.
WORKER = [
    sys.executable,
    "-c",
    "import sys; from tribench.harness import protocol as p; "
    "sys.exit(p.serve(lambda job: exec(job, {'emit': p.emit, 'sys': sys})))",
]


def run(job: str) -> list[tuple[str, dict]]:
    got: list[tuple[str, dict]] = []
    handlers = {kind: (lambda m, k=kind: got.append((k, m))) for kind in ("row", "other")}
    protocol.run_worker(WORKER, job, os.environ, handlers, "test worker")
    return got


def test_each_line_goes_to_the_handler_of_its_type_in_order():
    got = run("emit('row', {'a': 1}); emit('other', {'b': 2}); emit('row', {'a': 3})")
    assert got == [("row", {"a": 1}), ("other", {"b": 2}), ("row", {"a": 3})]


def test_a_notice_is_shown_once_however_many_workers_send_it():
    job = "import warnings; from tribench.common import Notice; warnings.warn('cache rebuilt: x', Notice)"
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        run(job)
        run(job)
    assert [str(c.message) for c in caught if issubclass(c.category, Notice)] == ["cache rebuilt: x"]


def test_a_users_error_is_one_line_said_by_the_worker():
    with pytest.raises(protocol.WorkerError, match="^no such kernel 'x'$") as caught:
        run("emit('row', {'a': 1}); raise ValueError(\"no such kernel 'x'\")")
    assert caught.value.said


def test_an_os_error_names_its_file():
    with pytest.raises(protocol.WorkerError, match="a worker could not go on: Is a directory on /tmp"):
        run("open('/tmp').read()")


def test_a_crash_names_the_worker_its_exit_code_and_the_end_of_its_stderr():
    with pytest.raises(protocol.WorkerError, match=r"^test worker exited with code 1: .*ZeroDivisionError") as caught:
        run("1 / 0")
    assert not caught.value.said


def test_a_line_of_unknown_type_stops_the_worker():
    with pytest.raises(protocol.WorkerError, match="test worker sent a line of unknown type 'surprise'"):
        run("emit('surprise', {}); import time; time.sleep(30)")


def test_what_the_workers_code_writes_to_stdout_cannot_break_a_line():
    # a debug printf in a user's kernel writes to fd 1, which the worker points at stderr
    job = "import os; emit('row', {'a': 1}); print('debug'); os.write(1, b'raw\\n'); emit('row', {'a': 2})"
    assert run(job) == [("row", {"a": 1}), ("row", {"a": 2})]


@pytest.mark.parametrize(
    ("job", "said"),
    [
        ("import os; os._exit(0)", "exited before its job was done (exit code 0"),
        ("import os; os._exit(2)", "exited with code 2"),
        ("import os, signal; os.kill(os.getpid(), signal.SIGABRT)", "was killed by SIGABRT"),
    ],
)
def test_a_worker_that_exits_or_dies_before_its_end_line_fails_in_one_line(job, said):
    with pytest.raises(protocol.WorkerError, match="test worker") as info:
        run(job)
    assert said in str(info.value) and "\n" not in str(info.value)


def test_a_worker_past_its_time_limit_is_stopped_and_said_so():
    with pytest.raises(protocol.WorkerError, match=r"sent nothing for 0.3 s"):
        protocol.run_worker(WORKER, "import time; time.sleep(60)", os.environ, {}, "test worker", timeout=0.3)


def test_a_worker_sets_how_long_it_may_be_silent_and_each_line_restarts_the_clock():
    lines = []
    speaks = (
        "import time; emit('silence', {'seconds': 0.6, 'during': 'talking'});"
        "[(time.sleep(0.2), emit('row', {'i': i})) for i in range(4)]"  # 0.8 s in all, never 0.6 s silent
    )
    protocol.run_worker(WORKER, speaks, os.environ, {"row": lines.append}, "test worker", timeout=30)
    assert len(lines) == 4
    stalls = "import time; emit('silence', {'seconds': 0.3, 'during': 'timing k on w'}); time.sleep(60)"
    with pytest.raises(protocol.WorkerError, match=r"sent nothing for 0.3 s while timing k on w \(a kernel"):
        protocol.run_worker(WORKER, stalls, os.environ, {}, "test worker", timeout=30)
    unbounded = (
        "import time; emit('silence', {'seconds': None, 'during': 'building'}); time.sleep(0.8); emit('row', {})"
    )
    protocol.run_worker(WORKER, unbounded, os.environ, {"row": lines.append}, "test worker", timeout=0.3)
