"""Progress off a terminal (plain lines a CI log shows), --no-progress, and the expected duration line."""

from __future__ import annotations

import io
import os
import re
import subprocess
import sys

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from test_sweep import TINY as SWEEP_TINY

from tribench.common import UserError
from tribench.harness import duration, runner
from tribench.harness.plan import Sweep
from tribench.workloads.spec import PairSpec

TINY = [a for a in SWEEP_TINY if a != "--no-progress"]  # the sweep tests' tiny design, progress shown
PLAIN = re.compile(
    r"^tribench sweep: (\d+)/(\d+) batches \((\d+)%\), \d+ s elapsed(, about \d+(\.\d+)? (s|min|h) left)?$"
)


def cli(tmp_path, *args, seconds: str | None = "0"):
    env = {**os.environ, "TRIBENCH_CACHE": str(tmp_path / "cache")}
    env.pop(runner.PROGRESS_VARIABLE, None)
    if seconds is not None:
        env[runner.PROGRESS_VARIABLE] = seconds
    # stderr is a pipe here, as in a CI log
    return subprocess.run(
        [sys.executable, "-m", "tribench.cli", *args], capture_output=True, text=True, timeout=120, env=env
    )


@pytest.mark.slow
def test_a_sweep_off_a_terminal_prints_plain_progress_lines(tmp_path):
    done = cli(tmp_path, "sweep", "--out", str(tmp_path / "run"), *TINY)
    assert done.returncode == 0, done.stderr
    assert "\r" not in done.stderr  # no bar drawn into the log
    lines = [line for line in done.stderr.splitlines() if line.startswith("tribench sweep:")]
    assert lines, done.stderr
    for line in lines:
        assert PLAIN.match(line), line
    counts = [int(PLAIN.match(line)[1]) for line in lines]
    total = int(PLAIN.match(lines[0])[2])
    assert total == 3 * 3 * 2 and counts == sorted(counts) and len(lines) <= 10  # a line per tenth at most
    assert counts[-1] == total
    # the duration is stated before the first batch
    expected = [i for i, line in enumerate(done.stderr.splitlines()) if line.startswith("expected: about ")]
    assert expected and expected[0] < done.stderr.splitlines().index(lines[0])


@pytest.mark.slow
def test_no_progress_silences_the_plain_lines_too(tmp_path):
    done = cli(tmp_path, "sweep", "--out", str(tmp_path / "run"), *TINY, "--no-progress")
    assert done.returncode == 0, done.stderr
    assert "tribench sweep:" not in done.stderr and "\r" not in done.stderr
    assert "expected: about " in done.stderr  # the forecast is no progress report


@pytest.mark.slow
def test_validate_off_a_terminal_prints_plain_lines_per_kernel(tmp_path):
    out = tmp_path / "v.csv"
    args = ["validate", "--quick", "--kernels", "moller_trumbore,curless", "--dtype", "float64", "--out", str(out)]
    done = cli(tmp_path, *args)
    assert done.returncode == 0, done.stderr
    assert re.search(r"^tribench validate: 1/2 kernels \(50%\), \d+ s elapsed, about", done.stderr, re.M)
    quiet = cli(tmp_path, *args, "--no-progress")
    assert quiet.returncode == 0 and "tribench validate:" not in quiet.stderr


@pytest.mark.slow
@pytest.mark.parametrize("bad", ["soon", "-1", "nan", "inf"])
def test_a_bad_interval_is_one_line_naming_the_variable_before_the_run_folder(tmp_path, bad):
    done = cli(tmp_path, "sweep", "--out", str(tmp_path / "run"), *TINY, seconds=bad)
    assert done.returncode == 2
    assert done.stderr.count("\n") == 1 and runner.PROGRESS_VARIABLE in done.stderr, done.stderr
    assert not (tmp_path / "run" / "run.json").exists()


class Pipe(io.StringIO):
    def isatty(self) -> bool:
        return False


@settings(max_examples=60, deadline=None)
@given(total=st.integers(1, 3000), step=st.integers(1, 50))
def test_plain_lines_come_at_most_every_tenth_and_reach_the_end(total, step):
    os.environ[runner.PROGRESS_VARIABLE] = "0"
    try:
        pipe = Pipe()
        bar = runner.Progress(total, 0, stream=pipe, unit="batches")
        done = 0
        while done < total:
            n = min(step, total - done)
            bar.advance(n)
            done += n
        bar.close()
    finally:
        del os.environ[runner.PROGRESS_VARIABLE]
    lines = pipe.getvalue().splitlines()
    assert 1 <= len(lines) <= 10
    assert all(PLAIN.match(line) for line in lines)
    assert re.fullmatch(rf"tribench sweep: {total}/{total} batches \(100%\), \d+ s elapsed", lines[-1])
    assert all(line.endswith(" left") for line in lines[:-1])


def test_the_end_gets_its_line_though_less_than_a_tenth_came_since_the_last(monkeypatch):
    monkeypatch.setenv(runner.PROGRESS_VARIABLE, "0")
    pipe = Pipe()
    bar = runner.Progress(95, 0, stream=pipe)
    for _ in range(95):
        bar.advance()
    lines = pipe.getvalue().splitlines()
    assert [PLAIN.match(line)[1] for line in lines] == ["10", "20", "30", "40", "50", "60", "70", "80", "90", "95"]


def test_no_line_before_the_interval(monkeypatch):
    monkeypatch.setenv(runner.PROGRESS_VARIABLE, "3600")
    pipe = Pipe()
    bar = runner.Progress(10, 0, stream=pipe)
    for _ in range(10):
        bar.advance()
    bar.close()
    assert pipe.getvalue() == ""


def test_progress_seconds_reads_the_variable(monkeypatch):
    monkeypatch.delenv(runner.PROGRESS_VARIABLE, raising=False)
    assert runner.progress_seconds() == runner.PROGRESS_SECONDS
    monkeypatch.setenv(runner.PROGRESS_VARIABLE, " 2.5 ")
    assert runner.progress_seconds() == 2.5
    monkeypatch.setenv(runner.PROGRESS_VARIABLE, "often")
    with pytest.raises(UserError, match=runner.PROGRESS_VARIABLE):
        runner.progress_seconds()


@settings(max_examples=40, deadline=None)
@given(seconds=st.floats(0, 1e6))
def test_format_duration_is_short_and_never_zero(seconds):
    text = duration.format_duration(seconds)
    number, unit = text.split()
    assert unit in ("s", "min", "h") and float(number) > 0 and "e" not in number


def test_the_estimate_counts_every_batch_and_grows_with_the_design(tmp_path, monkeypatch):
    monkeypatch.setenv("TRIBENCH_CACHE", str(tmp_path / "cache"))
    small = Sweep(("moller_trumbore", "curless"), (PairSpec(n=300),), processes=2, rounds=2, warmup=1, target_ms=0.2)
    big = Sweep(small.kernels, small.workloads, processes=4, rounds=8, warmup=1, target_ms=0.2)
    tests, passes, twins = duration.measure_passes(small)
    assert twins == {}  # no BVH workload
    assert tests == {small.workload_ids[0]: 300} and set(passes) == {(k, small.workload_ids[0]) for k in small.kernels}
    assert all(s > 0 for s in passes.values())
    a, b = duration.model(small, tests, passes), duration.model(big, tests, passes)
    assert (a.batches, b.batches) == (small.n_batches, big.n_batches)
    assert 0 < a.seconds < b.seconds
    assert a.line().startswith("expected: about ") and a.line("for the sweep").startswith("expected for the sweep: ")


def test_the_forecasts_worker_may_be_silent_while_a_workload_is_made_and_briefly_while_a_kernel_runs(
    tmp_path, monkeypatch
):
    monkeypatch.setenv("TRIBENCH_CACHE", str(tmp_path / "cache"))
    sweep = Sweep(("moller_trumbore", "curless"), (PairSpec(n=300),), processes=2, rounds=2, warmup=1, target_ms=0.2)
    lines: list[dict] = []
    duration._passes(sweep, lambda kind, line: lines.append({"type": kind, **line}))
    assert {line["type"] for line in lines} == {"silence"}
    making, *passes = lines
    assert making["seconds"] is None and sweep.workload_ids[0] in making["during"]
    assert [p["during"].split()[4] for p in passes] == list(sweep.kernels)  # "timing a pass of K on W"
    assert all(60 <= p["seconds"] < 600 for p in passes)


def test_a_bvh_workloads_forecast_times_its_tree_and_the_null_twin_of_each_batch(tmp_path, monkeypatch):
    # a BVH pass was once forecast as brute force (rays x triangles tests): 11 minutes for a sweep of 2 s
    from tribench.workloads.spec import MeshSpec

    monkeypatch.setenv("TRIBENCH_CACHE", str(tmp_path / "cache"))
    spec = MeshSpec("suzanne", 2000, width=16, height=16, dtype="float32", accel="bvh")
    sweep = Sweep(("moller_trumbore_fma",), (spec,), processes=2, rounds=2, warmup=1, target_ms=0.2)
    tests, passes, twins = duration.measure_passes(sweep)
    assert set(twins) == set(passes) == {("moller_trumbore_fma", sweep.workload_ids[0])}
    assert all(s > 0 for s in (*passes.values(), *twins.values()))
    assert duration.model(sweep, tests, passes, twins).seconds > duration.model(sweep, tests, passes).seconds
