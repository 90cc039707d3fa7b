"""The run folder under attack: two writers, kills, a full disk, and files edited, cut or replaced.

Every case ends either in the right tables or in one line on stderr naming the
file (and line), exit code 2; never a traceback, never a silently wrong table.
"""

from __future__ import annotations

import errno
import json
import os
import resource
import shutil
import signal
import stat
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest
from conftest import analysed
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from tribench.common import UserError
from tribench.harness import runfolder, runner
from tribench.harness.plan import Sweep, plan
from tribench.reports import tables as analysis
from tribench.workloads.spec import PairSpec

SLOW = [
    "--kernels",
    "moller_trumbore,curless",
    "--pairs",
    "300",
    "--processes",
    "4",
    "--rounds",
    "3",
    "--warmup",
    "1",
    "--target-ms",
    "20",
    "--no-progress",
]


@pytest.fixture(scope="module")
def cache(tmp_path_factory):
    path = tmp_path_factory.mktemp("cache")
    old = os.environ.get("TRIBENCH_CACHE")
    os.environ["TRIBENCH_CACHE"] = str(path)
    yield path
    if old is None:
        del os.environ["TRIBENCH_CACHE"]
    else:
        os.environ["TRIBENCH_CACHE"] = old


@pytest.fixture(scope="module")
def finished(cache, tmp_path_factory):
    """A small finished run with its tables (made once; tests work on copies)."""
    out = tmp_path_factory.mktemp("finished") / "run"
    sweep = Sweep(("moller_trumbore", "curless"), (PairSpec(n=200),), processes=3, rounds=2, warmup=1, target_ms=0.2)
    runner.start(sweep, out, progress=False)
    analysed(out)  # the analysis step: every table the report reads
    return out


@pytest.fixture
def run(finished, tmp_path):
    copy = tmp_path / "run"
    shutil.copytree(finished, copy)
    return copy


def cli(*args, limit_bytes=None, **kw):
    def limit():  # a "full disk": no file may grow past limit_bytes (EFBIG, SIGXFSZ ignored)
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit_bytes, limit_bytes))

    return subprocess.run(
        [sys.executable, "-m", "tribench.cli", *args],
        capture_output=True,
        text=True,
        timeout=180,
        preexec_fn=limit if limit_bytes else None,
        **kw,
    )


def popen(*args):
    return subprocess.Popen(
        [sys.executable, "-m", "tribench.cli", *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
    )


def one_line_error(done, *words, preamble=0):
    """Exit 2 and one error line (after ``preamble`` lines of progress a sweep prints first)."""
    assert done.returncode == 2, done.stderr
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 + preamble and "Traceback" not in done.stderr, done.stderr
    for w in words:
        assert w in lines[-1], done.stderr


def planned(run_dir):
    return sorted(plan(runfolder.read_run(run_dir).sweep))


def batch_lines(run_dir):
    return (run_dir / "batches.csv").read_text().splitlines(keepends=True)


def kill_mid_sweep(out: Path) -> int:
    """Start a sweep, SIGKILL it (and its worker) in the middle; its pid."""
    proc = popen("sweep", "--out", str(out), *SLOW)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        if (out / "batches.csv").exists() and (out / "batches.csv").read_text().count("\n") >= 12:
            break
        time.sleep(0.005)
    os.killpg(proc.pid, signal.SIGKILL)
    proc.communicate()
    return proc.pid


# ------------------------------------------------------------ one writer


@pytest.mark.slow
def test_two_resumes_after_a_kill_one_runs_the_other_is_refused(cache, tmp_path):
    out = tmp_path / "run"
    dead = kill_mid_sweep(out)
    before = runner.done_keys(out)
    assert 0 < len(before) < len(planned(out))
    first = popen("sweep", "--resume", str(out), "--no-progress")
    deadline = time.monotonic() + 60  # the second starts once the first holds the lock, so it meets it
    # ...and has written its name into it (the lock is taken a moment before the name is written)
    while f"process {first.pid} " not in (runfolder.live_writer(out) or "") and first.poll() is None:
        assert time.monotonic() < deadline, "the first resume never took the lock"
        time.sleep(0.005)
    # The first is paused while the second runs, so the second meets the lock however loaded the machine
    # (unpaused, the first could finish its few seconds of batches before the second even starts).
    first.send_signal(signal.SIGSTOP)
    try:
        second = popen("sweep", "--resume", str(out), "--no-progress")
        second.wait(timeout=180)
    finally:
        first.send_signal(signal.SIGCONT)
    results = {p.pid: (p.wait(timeout=180), *p.communicate()) for p in (first, second)}
    codes = sorted(code for code, _, _ in results.values())
    assert codes == [0, 2], results
    winner = next(pid for pid, (code, _, _) in results.items() if code == 0)
    loser = next(r for r in results.values() if r[0] == 2)
    assert len(loser[2].strip().splitlines()) == 1, loser[2]
    assert f"{out} is being written by process {winner}" in loser[2]
    assert f"taking over the lock of dead process {dead}" in results[winner][2]
    after = runner.done_keys(out)
    assert sorted(after) == planned(out)  # none lost, none twice
    assert set(before) <= set(after)
    assert runfolder.live_writer(out) is None  # released


@pytest.mark.slow
def test_a_second_writer_is_refused_while_the_first_lives_and_readers_are_not(run):
    with runfolder.writer_lock(run):
        assert (
            runfolder.live_writer(run)
            == f"process {os.getpid()} on {os.uname().nodename} "
            + f"(since {json.loads((run / '.lock').read_text())['since']})"
        )
        done = cli("sweep", "--resume", str(run), "--no-progress")
        one_line_error(done, str(run), f"process {os.getpid()}", "one writer per run folder")
        stats = cli("stats", str(run))  # a reader: allowed, and told the run is being written
        assert stats.returncode == 0, stats.stderr
        assert "still being written by process" in stats.stderr
    assert (run / ".lock").read_text() == ""  # released cleanly: nothing to take over
    again = cli("sweep", "--resume", str(run), "--no-progress")
    assert again.returncode == 0 and "taking over" not in again.stderr, again.stderr


@pytest.mark.slow  # two sweeps at once (seconds)
def test_start_into_a_folder_another_start_is_writing_is_refused(run):
    other = run.parent / "fresh"
    other.mkdir()
    with runfolder.writer_lock(other):
        done = cli(
            "sweep",
            "--out",
            str(other),
            "--kernels",
            "moller_trumbore",
            "--pairs",
            "200",
            "--processes",
            "1",
            "--rounds",
            "1",
            "--no-progress",
        )
        one_line_error(done, "is being written by process", preamble=2)  # the plan and expected-duration lines
    assert not (other / "run.json").exists()


# ------------------------------------------------------------ full disk


@pytest.mark.slow
def test_full_disk_mid_sweep_exits_2_with_the_resume_command_and_whole_lines(finished, cache, tmp_path):
    out = tmp_path / "run"
    args = [
        "--kernels",
        "moller_trumbore,curless",
        "--pairs",
        "200",
        "--processes",
        "5",
        "--rounds",
        "4",
        "--warmup",
        "1",
        "--target-ms",
        "0.2",
        "--no-progress",
    ]
    full = cli("sweep", "--out", str(out), *args, limit_bytes=5000)  # run.json fits, the batches do not
    # after the plan and expected-duration lines
    one_line_error(full, f"tribench sweep --resume {out}", "batches.csv", preamble=2)
    lines = batch_lines(out)
    assert lines and all(line.endswith("\n") for line in lines)
    kept = runner.done_keys(out)  # validated: every row whole and valid
    assert 0 < len(kept) < len(planned(out))
    resumed = cli("sweep", "--resume", str(out), "--no-progress")
    assert resumed.returncode == 0, resumed.stderr
    assert "dropped a partial" not in resumed.stderr  # there was none to drop
    after = runner.done_keys(out)
    assert sorted(after) == planned(out) and set(kept) <= set(after)


@pytest.mark.slow  # the analysis run twice on a full disk (seconds)
def test_stats_on_a_full_disk_keeps_the_previous_tables(run):
    before = {name: (run / name).read_bytes() for name in (analysis.ESTIMATES, analysis.SPEEDUPS)}
    full = cli("stats", str(run), limit_bytes=100)
    one_line_error(full, "cannot write", analysis.ESTIMATES)
    assert {name: (run / name).read_bytes() for name in before} == before
    assert not [p for p in run.iterdir() if p.name.endswith(".tmp")]


@pytest.mark.slow
def test_report_on_a_full_disk_is_one_line_and_leaves_no_half_page(run):
    full = cli("report", str(run), "--quiet", limit_bytes=100)
    one_line_error(full, "cannot write")
    assert not (run / "report.html").exists()
    assert not [p for p in run.iterdir() if p.name.endswith(".tmp")]


# ------------------------------------------------------------ validation


def _edit(run_dir: Path, line: int, column: str, value: str) -> None:
    lines = batch_lines(run_dir)
    header = lines[0].rstrip("\n").split(",")
    fields = lines[line - 1].rstrip("\n").split(",")
    fields[header.index(column)] = value
    lines[line - 1] = ",".join(fields) + "\n"
    (run_dir / "batches.csv").write_text("".join(lines))


@pytest.mark.parametrize(
    "column, value, words",
    [
        ("run_id", "20200101T000000-abcdef", ["run id '20200101T000000-abcdef' is not this run's"]),
        ("kernel", "woop", ["unknown kernel 'woop'"]),
        ("elapsed_ns", "-5", ["elapsed_ns is -5; must be positive"]),
        ("elapsed_ns", "0", ["elapsed_ns is 0; must be positive"]),
        ("elapsed_ns", "nan", ["elapsed_ns is 'nan', not an integer"]),
        ("tests", "0", ["tests is 0; must be positive"]),
        ("loops", "-1", ["loops is -1; must be positive"]),
        ("round", "77", ["not in the run's plan"]),
        ("process", "9", ["process 9 is not one of the run's 3"]),
        ("t_sum", "abc", ["t_sum is 'abc', not a finite number"]),
        ("t_sum", "inf", ["t_sum is 'inf', not a finite number"]),
        ("warmup", "yes", ["warmup is 'yes', not True or False"]),
    ],
)
def test_stats_and_report_refuse_a_bad_row_naming_file_and_line(run, column, value, words):
    _edit(run, 5, column, value)
    refused(run, f"{run / 'batches.csv'}:5: ", *words)
    if column == "kernel":  # the installed command too: one line, exit 2
        for command in ("stats", "report"):
            one_line_error(cli(command, str(run)), f"{run / 'batches.csv'}:5: ", *words)


def refused(run_dir: Path, *words: str, resume: bool = True) -> None:
    """stats (analyse), the report (load_run) and a resume all refuse with one line holding ``words``."""
    from tribench.reports.rundata import load_run

    calls = [analysis.analyse, load_run] + ([lambda r: runner.resume(r, progress=False)] if resume else [])
    for call in calls:
        with pytest.raises(UserError) as err:
            call(run_dir)
        assert "\n" not in str(err.value) and all(w in str(err.value) for w in words), str(err.value)


def test_duplicated_batches_are_refused_naming_both(run):
    lines = batch_lines(run)
    (run / "batches.csv").write_text("".join(lines + [lines[3]]))
    refused(run, f"batches.csv:{len(lines) + 1}: ", "is written twice (two writers?)")


def _insert(text: str, line: int, new: str) -> str:
    lines = text.splitlines(keepends=True)
    return "".join(lines[: line - 1] + [new + "\n"] + lines[line - 1 :])


@pytest.mark.parametrize(
    "name, mangle, words",
    [
        ("header", lambda t: t.replace("elapsed_ns", "elapsed", 1), [":1: the header is not batches.csv's columns"]),
        ("garbage line", lambda t: _insert(t, 3, "#!garbage\x00"), [":3: "]),
        ("blank line", lambda t: _insert(t, 3, ""), [":3: a blank line"]),
        ("quoted newline", lambda t: _insert(t, 3, '"a\nb"'), [":4: 1 fields, expected 21"]),
        ("short row", lambda t: t.replace("\n", "\n1,2,3\n", 1), [":2: 3 fields, expected 21"]),
        ("not utf-8", lambda t: t.replace("\n", "\n\udcff\n", 1), [":2: not UTF-8 text"]),
    ],
)
def test_garbage_in_the_middle_is_refused_with_its_line(run, name, mangle, words):
    text = (run / "batches.csv").read_text()
    (run / "batches.csv").write_bytes(mangle(text).encode("utf-8", "surrogateescape"))
    refused(run, "batches.csv", *words)


def test_a_partial_last_line_is_still_tolerated(run):
    text = (run / "batches.csv").read_text()
    (run / "batches.csv").write_text(text + text.splitlines()[3][:30])
    assert cli("stats", str(run)).returncode == 0


def test_crlf_and_a_bom_change_no_value_and_are_read(run):
    before = runfolder.read_batches(run)
    data = (run / "batches.csv").read_bytes()
    (run / "batches.csv").write_bytes(b"\xef\xbb\xbf" + data.replace(b"\n", b"\r\n"))
    assert runfolder.read_batches(run).equals(before)


@pytest.mark.parametrize(
    "name, setup, words",
    [
        (
            "run.json cut",
            lambda r: (r / "run.json").write_text((r / "run.json").read_text()[:200]),
            ["run.json:", "not valid JSON"],
        ),
        ("run.json a list", lambda r: (r / "run.json").write_text("[1, 2]"), ["not a tribench run record"]),
        ("run.json deep", lambda r: (r / "run.json").write_text("[" * 100000 + "]" * 100000), ["run.json"]),
        ("run.json binary", lambda r: (r / "run.json").write_bytes(b"\xff\xfe{}"), ["run.json is not UTF-8"]),
        ("run.json no sweep", lambda r: (r / "run.json").write_text('{"run_id": "x"}'), ["'sweep' is missing"]),
        (
            "margin nan",
            lambda r: (r / "run.json").write_text(
                (r / "run.json").read_text().replace('"value": 0.01', '"value": NaN')
            ),
            ["key 'margin.value'"],
        ),
        (
            "batches a symlink",
            lambda r: (
                (r / "b2").write_bytes((r / "batches.csv").read_bytes()),
                (r / "batches.csv").unlink(),
                (r / "batches.csv").symlink_to(r / "b2"),
            ),
            ["batches.csv is a symbolic link"],
        ),
        (
            "batches a fifo",
            lambda r: ((r / "batches.csv").unlink(), os.mkfifo(r / "batches.csv")),
            ["batches.csv is not a regular file"],
        ),
        (
            "batches huge",
            lambda r: (r / "batches.csv").write_bytes(
                (r / "batches.csv").read_bytes() + b"x" * (runfolder.MAX_ROW_BYTES * 2000)
            ),
            ["batches.csv", " bytes"],
        ),
        (
            "batches a folder",
            lambda r: ((r / "batches.csv").unlink(), (r / "batches.csv").mkdir()),
            ["batches.csv is not a regular file"],
        ),
        ("no batches", lambda r: (r / "batches.csv").unlink(), ["no batches.csv"]),  # resume runs them all
        (
            "processes other run",
            lambda r: (r / "processes.csv").write_text(
                (r / "processes.csv").read_text().replace(runfolder.read_run(r).run_id, "other", 1)
            ),
            ["processes.csv:2: run id 'other'"],
        ),
    ],
)
def test_hostile_run_folders_give_one_line_naming_the_file(run, name, setup, words):
    setup(run)
    refused(run, *words, resume=name != "no batches")  # a run killed before its first batch resumes
    if name in ("run.json cut", "batches a symlink"):
        for command in ("stats", "report"):
            one_line_error(cli(command, str(run)), *words)


def test_a_symlinked_batches_file_is_never_appended_to(run, tmp_path):
    target = tmp_path / "elsewhere.csv"
    target.write_bytes((run / "batches.csv").read_bytes())
    (run / "batches.csv").unlink()
    (run / "batches.csv").symlink_to(target)
    before = target.read_bytes()
    with pytest.raises(UserError, match="symbolic link"):
        runfolder.RowWriter(run / "batches.csv", runfolder.BATCH_COLUMNS)
    assert target.read_bytes() == before


def test_a_writer_whose_header_cannot_be_written_leaves_no_file_open(tmp_path, monkeypatch):
    """A full disk at the header: the OSError names the file, the partial header is cut, no descriptor is left."""

    class FullDisk:  # the os module as the writer sees it, every write refused
        def __getattr__(self, name):
            return getattr(os, name)

        def write(self, fd, data):
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(sys.modules[runfolder.RowWriter.__module__], "os", FullDisk())
    before = len(os.listdir("/dev/fd"))
    with pytest.raises(OSError, match="batches.csv"):
        runfolder.RowWriter(tmp_path / "batches.csv", runfolder.BATCH_COLUMNS)
    assert len(os.listdir("/dev/fd")) == before
    assert (tmp_path / "batches.csv").read_bytes() == b""


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_any_corruption_of_batches_is_a_user_error_or_a_valid_table(finished, tmp_path, data):
    """Random bytes over a random stretch of batches.csv: a one-line UserError, or rows that are all valid."""
    run = Path(tempfile.mkdtemp(dir=tmp_path)) / "run"
    shutil.copytree(finished, run)
    raw = (run / "batches.csv").read_bytes()
    at = data.draw(st.integers(0, len(raw) - 1))
    junk = data.draw(st.binary(min_size=1, max_size=40))
    (run / "batches.csv").write_bytes(raw[:at] + junk + raw[at + data.draw(st.integers(0, 40)) :])
    try:
        frame = runfolder.read_batches(run)
    except UserError as exc:
        message = str(exc)
        assert "\n" not in message and "batches.csv" in message
        return
    good = runfolder.read_batches(finished)
    keys = set(zip(frame["process"], frame["round"], frame["position"], frame["kernel"], strict=True))
    assert keys <= set(zip(good["process"], good["round"], good["position"], good["kernel"], strict=True))
    assert (frame["elapsed_ns"] > 0).all() and (frame["tests"] > 0).all()
    shutil.rmtree(run)


# ------------------------------------------------------------ what a whole-file write may replace


@pytest.mark.parametrize(
    "make",
    [
        lambda p: p.mkdir(),
        lambda p: p.symlink_to(p.parent / "elsewhere"),
        lambda p: os.mkfifo(p),
        pytest.param(
            lambda p: os.mknod(p, stat.S_IFCHR | 0o666, os.makedev(1, 3)),  # a /dev/null of our own
            marks=pytest.mark.skipif(os.geteuid() != 0, reason="only root makes a device"),
        ),
    ],
)
def test_a_whole_file_write_replaces_only_a_regular_file(tmp_path, make):
    from tribench.common import write_text

    target = tmp_path / "report.html"
    make(target)
    before = os.lstat(target)
    with pytest.raises(UserError, match="not a regular file"):
        write_text(target, "x")
    after = os.lstat(target)
    assert (after.st_mode, after.st_ino) == (before.st_mode, before.st_ino)
    assert not (tmp_path / "elsewhere").exists()
    assert [p.name for p in tmp_path.iterdir()] == ["report.html"]  # no temporary file left


@pytest.mark.parametrize(
    ("record", "finish"),
    [
        ({"main_job": {"quick": True}}, "(tribench run --resume {d} finishes an interrupted run)"),
        ({"replicates": {"run_dir": "/runs/old"}}, "(tribench replicate /runs/old --resume {d} finishes an"),
        ({}, "(tribench sweep --resume {d} finishes an interrupted run)"),
        ({"seed_replay": {"scenes": []}}, None),  # no command resumes these
        ({"calibration": {"margin": 0.01}}, None),
        (None, None),  # no run.json: no run to finish
    ],
)
def test_an_occupied_out_folder_names_the_command_that_finishes_its_own_job(finished, tmp_path, record, finish):
    """It said 'tribench sweep --resume D' for every folder: a main job's or a replication's folder needs its own
    command (sweep --resume finishes a main job's sweep alone), and a seed replay or a folder of other files none."""
    from tribench.harness.runfolder.io import check_new_run_dir

    (tmp_path / "d").mkdir()
    if record is None:
        (tmp_path / "d" / "notes.txt").write_text("{}")
    else:  # a real run's record, as each job writes it
        whole = {**json.loads((finished / "run.json").read_text()), **record}
        (tmp_path / "d" / "run.json").write_text(json.dumps(whole))
    with pytest.raises(UserError, match="exists and is not empty") as refused:
        check_new_run_dir(tmp_path / "d")
    said = str(refused.value)
    if finish is None:
        assert said.endswith("a new run needs a new or empty folder"), said
    else:
        assert finish.format(d=tmp_path / "d") in said, said
