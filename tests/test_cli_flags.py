"""Command-line values a hostile user gives, Ctrl-C, and what main() turns into exit codes.

Every bad value is refused up front -- exit 2, one ``error:`` line naming the
flag, no traceback, nothing written -- instead of being replaced by a default
(``--pairs 0`` once ran 10,000 pairs) or failing late. Ctrl-C stops every
command with one line and exit 130. A bug in tribench keeps its traceback.
"""

from __future__ import annotations

import argparse
import math
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from test_cli import run

from tribench.cli import command as cli
from tribench.cli import flags
from tribench.cli import info as info_command
from tribench.common import UserError

SMALL = ["--kernels", "moller_trumbore", "--pairs", "50", "--processes", "1", "--rounds", "1", "--warmup", "0"]
NOT_A_CPU = str(max(os.sched_getaffinity(0)) + 1)


def _refused(argv: list[str], capsys) -> str:
    """Run ``tribench ARGV`` in this process; assert it is refused as a user error; its last stderr line."""
    try:
        code = cli.main(argv)
    except SystemExit as exc:  # argparse's usage error
        code = exc.code
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1, err  # one line: no usage block, no traceback
    return err.strip().splitlines()[-1]


# (argv, what the one line must name); tmp files: 'afile' is a file, 'adir' a non-empty folder
HOSTILE = [
    (["sweep", "--pairs", "0"], "--pairs"),
    (["sweep", "--pairs", "-5"], "--pairs"),
    (["sweep", "--pairs", str(10**30)], "--pairs"),
    (["sweep", "--pairs", "1e4"], "--pairs"),
    (["sweep", "--pairs", "ten"], "--pairs"),
    (["sweep", "--hit-rates", ""], "--hit-rates"),
    (["sweep", "--hit-rates", ","], "--hit-rates"),
    (["sweep", "--hit-rates", "0.5,,0.7"], "--hit-rates"),
    (["sweep", "--hit-rates", "nan"], "--hit-rates"),
    (["sweep", "--hit-rates", "inf"], "--hit-rates"),
    (["sweep", "--hit-rates", "1.5"], "--hit-rates"),
    (["sweep", "--hit-rates", "-0.1"], "--hit-rates"),
    (["sweep", "--hit-rates", "½"], "--hit-rates"),
    (["sweep", "--kernels", ""], "--kernels"),
    (["sweep", "--kernels", "no_such_kernel", "--pairs", "10"], "no_such_kernel"),
    (["sweep", "--mesh", ""], "--mesh"),
    (["sweep", "--mesh", "suzanne", "--triangles", "0"], "--triangles"),
    (["sweep", "--mesh", "suzanne", "--triangles", ""], "--triangles"),
    (["sweep", "--mesh", "suzanne", "--camera", "64"], "--camera"),
    (["sweep", "--mesh", "suzanne", "--camera", "0x64"], "--camera"),
    (["sweep", "--mesh", "suzanne", "--camera", "64x64x2"], "--camera"),
    (["sweep", "--mesh", "suzanne", "--camera", f"{10**30}x2"], "--camera"),
    (["sweep", "--dtype", "float16"], "--dtype"),
    (["sweep", "--dtype", ""], "--dtype"),
    (["sweep", "--processes", "0"], "--processes"),
    (["sweep", "--rounds", "-1"], "--rounds"),
    (["sweep", "--rounds", "1e9"], "--rounds"),
    (["sweep", "--warmup", "-1"], "--warmup"),
    (["sweep", "--target-ms", "0"], "--target-ms"),
    (["sweep", "--target-ms", "nan"], "--target-ms"),
    (["sweep", "--target-ms", "inf"], "--target-ms"),
    (["sweep", "--rng-seed", "-1"], "--rng-seed"),
    (["sweep", "--rng-seed", str(2**64)], "--rng-seed"),
    (["sweep", "--cpu", NOT_A_CPU], "--cpu"),
    (["sweep", "--cpu", "999"], "--cpu"),
    (["sweep", "--cpu", "-1"], "--cpu"),
    (["sweep", "--out", ""], "--out"),
    (["sweep", "--out", "afile"], "--out"),
    (["sweep", "--out", "afile/sub"], "--out"),
    (["sweep", "--out", "adir"], "--out"),
    (["sweep", "--out", "a\0b"], "--out"),
    (["sweep", "--resume", ""], "--resume"),
    (["sweep", "--resume", "nowhere"], "--resume"),
    (["sweep", "--resume", "afile"], "--resume"),
    (["sweep", "--resume", "adir", "--pairs", "10"], "--resume"),
    (["sweep", "--file", "nowhere.toml"], "--file"),
    (["sweep", "--file", "adir"], "--file"),
    (["run", "--out", ""], "--out"),
    (["run", "--out", "afile/sub"], "--out"),
    (["seed", "--out", "adir"], "--out"),
    (["seed", "--scene", "adir"], "--scene"),
    (["seed", "--scene", "nowhere.txt"], "--scene"),
    (["seed", "--size", "0"], "--size"),
    (["seed", "--sample", "-3"], "--sample"),
    (["calibrate", "--out", "afile"], "--out"),
    (["calibrate", "--experiments", "0"], "--experiments"),
    (["calibrate", "--processes", "0"], "--processes"),
    (["calibrate", "--experiments", "1000000000"], "use fewer experiments"),
    (["stats", "nowhere"], "RUN_DIR"),
    (["stats", "afile"], "RUN_DIR"),
    (["stats", ""], "RUN_DIR"),
    (["stats", "adir", "--margin", "nan"], "--margin"),
    (["stats", "adir", "--margin", "-0.5"], "--margin"),
    (["stats", "adir", "--margin", "1e9"], "--margin"),
    (["peers", "--cpu", NOT_A_CPU], "--cpu"),
    (["peers", "--camera", "0x0"], "--camera"),
    (["peers", "--processes", "0"], "--processes"),
    (["peers", "--reps", "0"], "--reps"),
    (["peers", "--triangles", "-1"], "--triangles"),
    (["peers", "--out", ""], "--out"),
    (["peers", "--out", "afile/sub"], "--out"),
    (["peers", "--out", "afile/x.csv"], "--out"),
    (["validate", "--out", ""], "--out"),
    (["validate", "--out", "afile/x.csv"], "--out"),
    (["validate", "--kernels", ""], "--kernels"),
    (["validate", "--dtype", "float16"], "--dtype"),
    (["validate", "--rng-seed", "-1"], "--rng-seed"),
    (["report", "nowhere"], "RUN_DIR"),
    (["report", "afile"], "RUN_DIR"),
    (["compare", "adir", "nowhere"], "RUN"),
    (["compare", "adir", "adir", "--out", "adir"], "--out"),
    (["compare", "adir", "adir", "--out", "afile/c.html"], "--out"),
    (["export", "nowhere"], "RUN_DIR"),
    (["export", "adir", "--out", "adir"], "--out"),
    (["export", "adir", "--out", "afile/x.json"], "--out"),
    (["workloads", "make", "pairs", "--n", "0"], "n (number of pairs)"),
    (["workloads", "make", "pairs", "--n", str(10**30)], "n (number of pairs)"),
    (["workloads", "make", "pairs", "--hit-rate", "nan"], "hit_rate"),
    (["workloads", "make", "pairs", "--rng-seed", "-1"], "--rng-seed"),
    (["workloads", "make", "pairs", "--width", "8"], "--width"),
    (["workloads", "make", "suzanne", "--n", "8"], "--n"),
    (["workloads", "make", "suzanne", "--width", "0"], "width"),
    (["workloads", "make", "adir"], "adir"),
    (["workloads", "show", "no-such-id"], "no-such-id"),
    (["workloads", "show", "x", "--png", "afile/x.png"], "--png"),
    (["workloads", "show", "x", "--png", "adir"], "--png"),
]


@pytest.fixture
def hostile_cwd(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("TRIBENCH_CACHE", str(tmp_path / "cache"))
    (tmp_path / "afile").write_text("not a folder\n")
    (tmp_path / "adir").mkdir()
    (tmp_path / "adir" / "something").write_text("x\n")
    return tmp_path


@pytest.mark.parametrize("argv, names", HOSTILE, ids=[" ".join(a)[:60] for a, _ in HOSTILE])
def test_a_hostile_value_is_refused_up_front_naming_it(argv, names, hostile_cwd, capsys):
    before = sorted(p.relative_to(hostile_cwd) for p in hostile_cwd.rglob("*") if "cache" not in p.parts)
    line = _refused(argv, capsys)
    assert line.startswith(f"tribench {argv[0]}") and ": error: " in line and names in line, line
    after = sorted(p.relative_to(hostile_cwd) for p in hostile_cwd.rglob("*") if "cache" not in p.parts)
    assert after == before  # nothing written: no run folder that can never resume, no half file


@pytest.mark.slow
def test_the_issues_values_are_refused_by_the_installed_command(tmp_path):
    # as the issue found them: replaced silently, or a late failure, or a traceback
    (tmp_path / "afile").write_text("x\n")
    for argv in (
        ["sweep", "--pairs", "0"],
        ["sweep", "--hit-rates", ""],
        ["sweep", "--out", ""],
        ["sweep", "--cpu", "999", *SMALL],
        ["sweep", "--out", "afile/sub"],
        ["validate", "--out", "afile/x.csv"],
    ):
        done = run(*argv, cwd=tmp_path)
        assert done.returncode == 2 and "Traceback" not in done.stderr, (argv, done.stderr)
        assert f"tribench {argv[0]}: error: argument {argv[1]}" in done.stderr.splitlines()[-1]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["afile"]


@pytest.mark.parametrize(
    ("extra", "said"),
    [
        (
            ["--file", "s.toml", "--hit-rates", "0.1,0.9", "--dtype", "float32"],
            "--hit-rates, --dtype describe workloads",
        ),
        (["--file", "s.toml", "--pairs", "100"], "--pairs describe workloads"),
        (["--file", "s.toml", "--mesh", "suzanne", "--camera", "8x8"], "--mesh, --camera describe workloads"),
        (["--kernels", "moller_trumbore", "--triangles", "100"], "--triangles applies to mesh workloads"),
        (["--kernels", "moller_trumbore", "--camera", "8x8"], "--camera applies to mesh workloads"),
        (
            ["--kernels", "moller_trumbore_fma,moller_trumbore", "--pairs", "50"],
            "moller_trumbore_fma has no pairs mode",
        ),
    ],
)
def test_a_flag_the_sweep_would_ignore_is_refused_in_one_line(extra, said, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("TRIBENCH_CACHE", str(tmp_path / "cache"))
    (tmp_path / "s.toml").write_text('kernels = ["moller_trumbore"]\n[[workloads]]\nkind = "pairs"\nn = 50\n')
    assert said in _refused(["sweep", *extra, "--out", str(tmp_path / "run")], capsys)
    assert not (tmp_path / "run").exists()


@pytest.mark.parametrize(
    ("argv", "said"),
    [
        (
            ["validate", "--kernels", "moller_trumbore,moller_trumbore", "--quick"],
            "names moller_trumbore more than once",
        ),
        (["validate", "--dtype", "float32,float32", "--quick"], "names float32 more than once"),
        (["sweep", "--hit-rates", "0.5,0.5"], "names 0.5 more than once"),
        (["workloads", "show", "/etc"], "'/etc' is not a workload id"),
        (["workloads", "show", "a**b"], "'a**b' is not a workload id"),
        (["calibrate", "--workload", "/etc"], "'/etc' is not a workload id"),
        (["cache", "prune", "--max-size", "9" * 400], "too large"),
        (["export", "run", "--out", "run/batches.csv"], "is a measured file of the run folder"),
        (["peers", "--processes", "1"], "--processes: must be an integer from 2"),
        (["workloads", "make", "garbage.stl"], "'garbage.stl': not a mesh file trimesh reads"),
        (["info", "--kernel-file", "binary.c"], "binary.c: not C source: it holds NUL bytes"),
        (["workloads", "make", "pairs", "--n", "64", "--scale", "1e300"], "scale = 1e+300 is outside what float64"),
        (["workloads", "make", "pairs", "--n", "64", "--scale", "1e-320"], "scale = 1e-320 is outside what float64"),
        (["compare", "run", "run", "--out", "run/run.json"], "is a measured file of the run folder"),
        (["sweep", "--out", "run/sub"], "is inside the run folder"),
        (["validate", "--kernels", "wald", "--kernels", "badouel", "--quick"], "--kernels: given more than once"),
        (["sweep", "--hit-rates", "0.2", "--hit-rates", "0.8"], "--hit-rates: given more than once"),
        (["validate", "--kernels", "wald", "badouel,wald", "--quick"], "kernels name wald more than once"),
        (["validate", "--dtype", "float32", "float64,float32", "--quick"], "dtypes name float32 more than once"),
        (["replicate", "run", "--out", "run/again/deeper"], "is inside the run folder"),
    ],
)
def test_what_once_raised_a_traceback_is_one_line(argv, said, tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("TRIBENCH_CACHE", str(tmp_path / "cache"))
    monkeypatch.chdir(tmp_path)
    (tmp_path / "run").mkdir()
    for name in ("run.json", "batches.csv"):
        (tmp_path / "run" / name).write_text("measured\n")
    garbage = bytes(np.random.default_rng(0).integers(0, 256, 4000, dtype=np.uint8))
    (tmp_path / "garbage.stl").write_bytes(garbage)
    (tmp_path / "binary.c").write_bytes(garbage)
    assert said in _refused(argv, capsys)
    assert (tmp_path / "run" / "batches.csv").read_text() == "measured\n"


def test_resume_refuses_every_other_sweep_flag(tmp_path, capsys):
    (tmp_path / "run").mkdir()
    for extra in (["--camera", "8x8"], ["--cpu", str(min(os.sched_getaffinity(0)))], ["--rng-seed", "3"]):
        assert "--resume takes no other sweep options" in _refused(
            ["sweep", "--resume", str(tmp_path / "run"), *extra], capsys
        )


@pytest.mark.slow
@pytest.mark.parametrize("flag, value", [("--rounds", "1000000000"), ("--processes", "1000000000000")])
def test_a_huge_plan_is_refused_before_anything_is_allocated(flag, value, tmp_path):
    i = SMALL.index(flag)  # in place of SMALL's own value: a flag given twice is refused for that alone
    done = run("sweep", *SMALL[:i], flag, value, *SMALL[i + 2 :], "--out", tmp_path / "run", timeout=20)
    assert done.returncode == 2 and "Traceback" not in done.stderr
    assert "must be between 1 and" in done.stderr and len(done.stderr.strip().splitlines()) == 1
    assert not (tmp_path / "run").exists()


# ------------------------------------------------------------- the checks themselves


@settings(max_examples=300, deadline=None)
@given(st.text())
def test_a_count_is_an_int_in_range_or_refused(text):
    try:
        value = flags.positive_int(text)
    except argparse.ArgumentTypeError as exc:
        assert repr(text) in str(exc)
    else:
        assert type(value) is int and 1 <= value <= flags.MAX_COUNT and value == int(text)


@settings(max_examples=300, deadline=None)
@given(st.one_of(st.text(), st.lists(st.floats(), min_size=1).map(lambda xs: ",".join(map(repr, xs)))))
def test_a_float_list_is_finite_numbers_in_range_or_refused(text):
    try:
        values = flags.float_list(0, 1)(text)
    except argparse.ArgumentTypeError:
        return
    assert values and all(math.isfinite(v) and 0 <= v <= 1 for v in values)
    assert len(values) == len(text.split(","))


@settings(max_examples=200, deadline=None)
@given(st.text())
def test_a_camera_is_two_sides_or_refused(text):
    try:
        width, height = flags.camera(text)
    except argparse.ArgumentTypeError:
        return
    assert 1 <= width <= flags.MAX_SIDE and 1 <= height <= flags.MAX_SIDE


def test_a_file_to_read_is_a_regular_file_or_refused_saying_what_it_is(tmp_path):
    (tmp_path / "scene.txt").write_text("fond 0 0 0\n")
    assert flags.existing_file(str(tmp_path / "scene.txt")) == str(tmp_path / "scene.txt")
    for path, said in ((tmp_path, "the folder"), ("/dev/null", "a regular file"), (tmp_path / "nope", "no such file")):
        with pytest.raises(argparse.ArgumentTypeError, match=said):
            flags.existing_file(str(path))


@pytest.mark.skipif(os.geteuid() == 0, reason="root may write anywhere")
def test_an_unwritable_folder_is_refused(tmp_path):
    locked = tmp_path / "locked"
    locked.mkdir(mode=0o500)
    for check in (flags.output_file, flags.output_folder):
        with pytest.raises(argparse.ArgumentTypeError, match="permission"):
            check(str(locked / "x"))


# ------------------------------------------------------------------- main()


def test_a_user_error_and_an_environment_error_are_one_line_exit_2(monkeypatch, capsys):
    def missing(args):
        open("/nonexistent/run.json")

    def mistaken(args):
        raise UserError("the thing is wrong; do this instead")

    for handler, message in (
        (missing, "/nonexistent/run.json: No such file or directory"),
        (mistaken, "the thing is wrong; do this instead"),
    ):
        monkeypatch.setattr(info_command, "run", handler)
        assert cli.main(["info"]) == 2
        assert capsys.readouterr().err == f"tribench info: error: {message}\n"


@pytest.mark.parametrize("bug", [ValueError("a bug"), KeyError("a bug"), TypeError("a bug"), AssertionError()])
def test_a_bug_keeps_its_traceback(bug, monkeypatch):
    def broken(args):
        raise bug

    monkeypatch.setattr(info_command, "run", broken)
    with pytest.raises(type(bug)):
        cli.main(["info"])


def test_a_bug_shows_its_traceback_from_the_command(tmp_path):
    # the installed console script, with a handler broken at start-up (sitecustomize)
    (tmp_path / "sitecustomize.py").write_text(
        "import tribench.cli.info as c\ndef _broken(args):\n    raise KeyError('a bug')\nc.run = _broken\n"
    )
    script = Path(sys.executable).parent / "tribench"
    done = subprocess.run(
        [script, "info"], capture_output=True, text=True, timeout=60, env={**os.environ, "PYTHONPATH": str(tmp_path)}
    )
    assert done.returncode == 1 and "Traceback" in done.stderr and "KeyError: 'a bug'" in done.stderr


def test_a_closed_pipe_is_not_an_error(tmp_path):
    done = subprocess.run(
        f"{sys.executable} -m tribench.cli info | head -1", shell=True, capture_output=True, text=True, timeout=60
    )
    assert done.stdout.startswith("tribench ") and done.stderr == ""


# ------------------------------------------------------------------ Ctrl-C


def _interrupt(args: list, marker: str, cwd: Path, deadline: float = 60, ready=lambda: True) -> tuple[int, str, float]:
    """Start ``tribench ARGS`` in its own process group, wait for ``marker`` on stderr (and ``ready()``),
    then send SIGINT to the group as a terminal's Ctrl-C does; the exit code, stderr and seconds to exit."""
    proc = subprocess.Popen(
        [sys.executable, "-m", "tribench.cli", *map(str, args)],
        cwd=cwd,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
    )
    seen = []
    try:
        end = time.monotonic() + deadline
        while time.monotonic() < end:
            line = proc.stderr.readline()
            seen.append(line)
            if marker in line or not line:
                break
        assert any(marker in s for s in seen), "".join(seen)
        while not ready() and time.monotonic() < end:
            time.sleep(0.05)
        time.sleep(0.3)  # inside the work, past the line
        t0 = time.monotonic()
        os.killpg(proc.pid, signal.SIGINT)
        rest = proc.stderr.read()
        code = proc.wait(timeout=10)
        return code, "".join(seen) + rest, time.monotonic() - t0
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()


def _lines(path: Path) -> int:
    return len(path.read_text().splitlines()) if path.exists() else 0


@pytest.mark.slow
def test_ctrl_c_stops_a_sweep_keeping_its_batches(tmp_path):
    out = tmp_path / "run"
    code, err, seconds = _interrupt(
        ["sweep", "--kernels", "moller_trumbore", "--pairs", "200", "--processes", "50", "--no-progress", "--out", out],
        "sweep: ",
        tmp_path,
        ready=lambda: _lines(out / "batches.csv") > 1,
    )
    assert code == 130 and "Traceback" not in err and seconds < 3, err
    assert f"finish with: tribench sweep --resume {out}" in err.splitlines()[-1]
    assert _lines(out / "batches.csv") > 1  # the header and what was measured


@pytest.mark.parametrize(
    "args, marker",
    [
        (["info", "--peak"], "measuring the FMA peak"),
        (["seed", "--quick", "--no-progress", "--out", "seed"], "workload: "),
    ],
)
@pytest.mark.slow
def test_ctrl_c_stops_a_command_with_one_line(args, marker, tmp_path):
    code, err, seconds = _interrupt(args, marker, tmp_path)
    assert code == 130 and "Traceback" not in err and seconds < 3, err
    assert err.splitlines()[-1] == f"tribench {args[0]}: interrupted"


@pytest.mark.parametrize("text", ["1\x1f", "1_000", "\u0661\u0662", "1e3", "2.0", "0x10", "12 3"])
def test_a_count_is_a_plain_ascii_decimal(text):
    with pytest.raises(argparse.ArgumentTypeError):
        flags.positive_int(text)


@pytest.mark.parametrize("text, value", [("0.5", 0.5), (".5", 0.5), ("1e-2", 0.01), (" 1 ", 1.0)])
def test_a_number_is_a_plain_ascii_decimal(text, value):
    assert flags.float_in(0, 1)(text) == value
    for bad in ("1_0", "inf", "nan", "0x1", "\u0661"):
        with pytest.raises(argparse.ArgumentTypeError):
            flags.float_in(0, 1)(bad)


def _compilers_under(folder: Path) -> list[str]:
    """The compiler processes (cc1, as, gcc) whose command line names ``folder``."""
    found = []
    for proc in Path("/proc").iterdir():
        try:
            argv = (proc / "cmdline").read_bytes().split(b"\0")
        except OSError:
            continue
        if any(str(folder).encode() in a for a in argv) and Path(argv[0].decode(errors="replace")).name in (
            "cc1",
            "as",
            "gcc",
        ):
            found.append(proc.name)
    return found


@pytest.mark.slow
def test_sigterm_during_a_builds_compile_stops_the_compilers_and_leaves_no_objects(tmp_path):
    cache = tmp_path / "cache"
    proc = subprocess.Popen(
        [sys.executable, "-m", "tribench.cli", "sweep", *SMALL, "--builds", "gcc -O1", "--out", tmp_path / "run"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        env={**os.environ, "TRIBENCH_CACHE": str(cache)},
        start_new_session=True,
    )
    try:
        end = time.monotonic() + 120
        while not _compilers_under(cache) and time.monotonic() < end and proc.poll() is None:
            time.sleep(0.1)
        assert _compilers_under(cache), "the build's compile never started"
        os.kill(proc.pid, signal.SIGTERM)  # the parent alone, as `kill` or a CI runner's stop
        err = proc.stderr.read()
        assert proc.wait(timeout=20) == 130 and "Traceback" not in err, err
        assert err.splitlines()[-1] == "tribench sweep: interrupted"
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    time.sleep(0.5)
    assert _compilers_under(cache) == []
    assert not list((cache / "kernel_builds").glob("*/tmp*")), "a stopped compile's objects were left"
