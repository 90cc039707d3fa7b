"""Sweeps end to end: real worker processes, run folders, resume after SIGKILL, the CLI."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from test_runfolder import SLOW

from tribench import ext
from tribench.harness import runfolder, runner
from tribench.harness.plan import Sweep, plan
from tribench.reports import tables as analysis
from tribench.workloads.spec import PairSpec

# A tiny design: 2 kernels, one workload, 3 processes x 2 rounds (+1 warm-up).
TINY = [
    "--kernels",
    "moller_trumbore,curless",
    "--pairs",
    "300",
    "--processes",
    "3",
    "--rounds",
    "2",
    "--warmup",
    "1",
    "--target-ms",
    "0.2",
    "--no-progress",
]


@pytest.fixture
def env(tmp_path, monkeypatch):
    monkeypatch.setenv("TRIBENCH_CACHE", str(tmp_path / "cache"))
    return {**os.environ, "TRIBENCH_CACHE": str(tmp_path / "cache")}


def cli(*args, env=None, **kw):
    return subprocess.run(
        [sys.executable, "-m", "tribench.cli", *args], capture_output=True, text=True, timeout=120, env=env, **kw
    )


def keys_of(run_dir):
    return runner.done_keys(run_dir)


@pytest.mark.slow
def test_sweep_then_stats_writes_every_batch_and_both_tables(tmp_path, env):
    out = tmp_path / "run"
    done = cli("sweep", "--out", str(out), *TINY, env=env)
    assert done.returncode == 0, done.stderr
    run = runfolder.read_run(out)
    keys = keys_of(out)
    assert sorted(keys) == sorted(plan(run.sweep)) and len(keys) == 3 * 3 * 2
    assert run.margin.source.startswith("default")
    assert set(run.isa) == {"moller_trumbore", "curless"}
    assert run.machine["build"]["flags"] and len(run.process_seeds) == 3
    batches = runfolder.read_batches(out)
    assert (batches["hits"] % batches["loops"] == 0).all()
    assert batches["warmup"].sum() == 3 * 2
    peaks = runfolder.read_processes(out)
    assert sorted(peaks["phase"]) == ["end"] * 3 + ["start"] * 3
    assert (peaks["peak_gflops"] > 0).all()
    checks = runfolder.read_checks(out)  # every kernel x workload x process, checked once
    assert len(checks) == 2 * 1 * 3 and (checks["disagreements"] == 0).all()
    assert (checks["rays"] > 0).all()

    stats = cli("stats", str(out), env=env)
    assert stats.returncode == 0, stats.stderr
    assert "moller_trumbore" in stats.stdout and "(baseline)" in stats.stdout and "95% CI" in stats.stdout
    est = pd.read_csv(out / analysis.ESTIMATES)
    spd = pd.read_csv(out / analysis.SPEEDUPS)
    for col in (
        "kernel",
        "workload_id",
        "ns_per_test",
        "ns_per_test_ci_low",
        "ns_per_test_ci_high",
        "ns_per_test_min",
        "n_processes",
        "peak_fraction",
    ):
        assert col in est.columns
    for col in (
        "kernel",
        "baseline",
        "ratio",
        "ratio_ci_low",
        "ratio_ci_high",
        "p_holm",
        "margin",
        "verdict",
        "margin_source",
    ):
        assert col in spd.columns
    assert set(est["kernel"]) == {"moller_trumbore", "curless"} and (est["n_processes"] == 3).all()
    # the fraction of the arithmetic bound: the documented ops at each process's own peak
    assert list(est["ops_per_test"]) == [ext.kernel_info(k).ops for k in est["kernel"]]
    assert (
        (est["peak_fraction_ci_low"] <= est["peak_fraction"]) & (est["peak_fraction"] <= est["peak_fraction_ci_high"])
    ).all()
    assert ((est["peak_fraction"] > 0) & (est["peak_fraction"] < 1)).all()  # scalar kernels: one lane of 8
    # the bound is the port model's at the rates run.json recorded
    assert set(run.throughput or {}) == {"isa", "peak_gflops", "float32", "float64"}
    assert (est["bound_ns_per_test"] > 0).all() and (est["peak_fraction"] > 0).all()
    assert list(spd["baseline"]) == ["moller_trumbore"] and list(spd["kernel"]) == ["curless"]
    # re-analysis reads files only: the same tables again, with another baseline on request
    again = analysis.analyse(out, baseline="curless")
    assert list(again.speedups["kernel"]) == ["moller_trumbore"]


@pytest.mark.slow
def test_sigkill_mid_sweep_then_resume_gives_exactly_the_planned_batches(tmp_path, env):
    # long enough batches (20 ms) that the kill lands inside a worker process
    args = SLOW
    killed = tmp_path / "killed"
    proc = subprocess.Popen(
        [sys.executable, "-m", "tribench.cli", "sweep", "--out", str(killed), *args],
        env=env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        start_new_session=True,
    )
    csv = killed / "batches.csv"
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        if csv.exists() and csv.read_text().count("\n") >= 12:  # header + process 0 + part of process 1
            break
        time.sleep(0.005)
    os.killpg(proc.pid, signal.SIGKILL)  # the runner and its worker, mid-write or not
    proc.wait()
    partial = keys_of(killed)
    sweep = runfolder.read_run(killed).sweep
    assert 0 < len(partial) < sweep.n_batches

    resumed = cli("sweep", "--resume", str(killed), "--no-progress", env=env)
    assert resumed.returncode == 0, resumed.stderr
    after = keys_of(killed)
    assert len(after) == len(set(after))  # nothing duplicated
    assert set(partial) <= set(after)  # nothing finished was lost

    whole = tmp_path / "whole"
    assert cli("sweep", "--out", str(whole), *args, env=env).returncode == 0
    assert sorted(after) == sorted(keys_of(whole)) == sorted(plan(sweep))
    # a process cut in half finished in a second attempt, recorded as such
    batches = runfolder.read_batches(killed)
    per_process = batches.groupby("process")["attempt"].nunique()
    assert per_process.max() <= 2
    # resuming a finished run runs nothing
    again = cli("sweep", "--resume", str(killed), "--no-progress", env=env)
    assert again.returncode == 0 and "0 batches run" in again.stderr


@pytest.mark.slow  # a sweep resumed (seconds)
def test_resume_drops_a_truncated_last_line(tmp_path, env):
    out = tmp_path / "run"
    sweep = Sweep(("moller_trumbore",), (PairSpec(n=100),), processes=2, rounds=2, target_ms=0.2)
    runner.start(sweep, out, progress=False)
    lines = (out / "batches.csv").read_text().splitlines(keepends=True)
    # lose the last two batches, leave half of the first of them as if cut mid-write
    (out / "batches.csv").write_text("".join(lines[:-2]) + lines[-2][:25])
    result = runner.resume(out, progress=False)
    assert result.batches_run == 2
    assert sorted(keys_of(out)) == sorted(plan(sweep))


def test_a_wrong_kernel_stops_the_sweep_naming_it(tmp_path, env):
    faulty = tmp_path / "faulty_worker.py"
    faulty.write_text(
        textwrap.dedent("""
        import dataclasses, sys
        from tribench import ext
        from tribench.harness import worker
        real = ext.time_batch
        def wrong(job, loops):  # curless miscounts one hit per batch
            b = real(job, loops)
            return dataclasses.replace(b, hits=b.hits + 1) if job.kernel == "curless" else b
        ext.time_batch = wrong
        sys.exit(worker.main())
    """)
    )
    sweep = Sweep(("moller_trumbore", "curless"), (PairSpec(n=100),), processes=3, rounds=2, target_ms=0.2)
    with pytest.raises(
        runner.SweepError,
        match=r"kernel 'curless' on workload pairs-.*checksum failed.*; \d+ of 18 batches saved in .*; once the "
        r"cause is fixed, finish with: tribench sweep --resume .*run$",
    ):
        runner.start(sweep, tmp_path / "run", progress=False, worker=[sys.executable, str(faulty)])
    # the sweep stopped in the first process: no later process ran
    assert set(runfolder.read_batches(tmp_path / "run")["process"]) <= {0}


@pytest.mark.parametrize(
    "args, message",
    [
        (["sweep", "--kernels", "nope"], "unknown kernel 'nope'"),
        (["sweep", "--hit-rates", "1.5"], "--hit-rates: must be a number in [0, 1], got '1.5'"),
        (["sweep", "--resume", "/no/such/run"], "no run directory"),
        (["stats", "/no/such/run"], "no run directory"),
        (["sweep", "--camera", "big"], "--camera: must be WIDTHxHEIGHT"),
    ],
)
def test_bad_flags_exit_2_with_one_line(tmp_path, env, args, message, capsys):
    from tribench import cli as command  # in this process: the flags are refused before anything runs

    if args[0] == "sweep" and "--resume" not in args:
        args = [*args, "--out", str(tmp_path / "run")]
    try:
        code = command.main(args)
    except SystemExit as stop:  # argparse's own refusals exit
        code = stop.code
    assert code == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1, err
    assert message in err
    assert not (tmp_path / "run").exists()


def test_sweep_refuses_a_non_empty_out_dir(tmp_path, env):
    (tmp_path / "run").mkdir()
    (tmp_path / "run" / "x").write_text("")
    out = cli("sweep", "--out", str(tmp_path / "run"), *TINY, env=env)
    assert out.returncode == 2 and "not empty" in out.stderr


@pytest.mark.slow
def test_calibrate_writes_its_summary_and_the_user_margin(tmp_path, env):
    # 4 processes x 3 rounds of 2 ms: with 2 x 2 of 0.2 ms (one degree of freedom) a loaded machine measured a
    # noise floor of 313%, and with 0.5 ms batches CI's (two test workers on two cores) 53%: past the largest
    # usable margin, which the command rightly refuses. A noise floor is the machine's, so a refusal for it
    # alone is measured again, twice at most; any other failure fails the test.
    for attempt in range(3):
        out = tmp_path / f"cal{attempt}"
        done = cli(
            "calibrate",
            *("--processes", "4", "--experiments", "3", "--rounds", "3", "--target-ms", "2"),
            *("--out", str(out), "--no-progress"),
            env=env,
        )
        if "an equivalence margin must be a number between 0 and 0.5" not in done.stderr:
            break
    assert done.returncode == 0, done.stderr
    assert "coverage of 1" in done.stdout and "noise floor" in done.stdout
    assert (out / "calibration.json").is_file()
    user = Path(env["TRIBENCH_CACHE"]).parent / "calibration.json"
    assert user.read_text() == (out / "calibration.json").read_text()
    # the next sweep uses it, and says so
    run = tmp_path / "run"
    assert cli("sweep", "--out", str(run), *TINY, env=env).returncode == 0
    assert str(user) in runfolder.read_run(run).margin.source


def test_a_time_spread_wide_gives_a_wide_but_bounded_peak_fraction():
    # three processes so spread that a plain t-interval of their mean time would start below 0;
    # on the log scale it stays positive, so the fraction's interval stays finite
    table = pd.DataFrame(
        {
            "kernel": ["moller_trumbore"] * 3,
            "workload_id": ["w"] * 3,
            "process": [0, 1, 2],
            "ns_per_test": [0.1, 0.2, 60.0],
        }
    )
    processes = pd.DataFrame({"process": [0, 1, 2], "peak_gflops": [100.0] * 3, "peak_isa": ["avx2+fma"] * 3})
    rates = dict.fromkeys(ext.OP_CLASSES, 50.0)
    throughput = {"isa": "avx2", "peak_gflops": 100.0, "float32": rates, "float64": rates}
    row = analysis.pipeline._peak_columns(table, processes, {"w": "float32"}, throughput).iloc[0]
    assert 0 < row["peak_fraction_ci_low"] <= row["peak_fraction"] <= row["peak_fraction_ci_high"] < np.inf
    assert row["peak_fraction_ci_high"] / row["peak_fraction_ci_low"] > 100  # and says how little is known


@pytest.mark.slow
def test_a_ctrl_c_in_the_analysis_says_every_batch_is_saved_and_how_to_make_the_tables(
    tmp_path, env, monkeypatch, capsys
):
    from tribench.cli.command import main
    from tribench.reports import tables

    def interrupted(run_dir, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(tables, "write_all", interrupted)
    out = tmp_path / "run"
    assert main(["sweep", *TINY, "--out", str(out)]) == 130
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert err == (
        f"tribench sweep: interrupted after the sweep: every batch is saved in {out}; "
        f"make its tables with: tribench stats {out}"
    )
    assert len(keys_of(out)) == 3 * 3 * 2  # processes x (rounds + warm-up) x kernels: all of them


@pytest.mark.slow
def test_a_run_copied_from_a_machine_with_more_cpus_resumes_on_one_of_this_ones(tmp_path, env, capsys):
    from tribench.cli.command import main

    out = tmp_path / "run"
    assert main(["sweep", *TINY, "--out", str(out)]) == 0
    lines = (out / "batches.csv").read_text().splitlines(keepends=True)
    (out / "batches.csv").write_text("".join(lines[: len(lines) // 2]))
    record = json.loads((out / "run.json").read_text())
    (out / "run.json").write_text(json.dumps({**record, "cpu": 4095}))  # a CPU this machine lacks
    capsys.readouterr()
    assert main(["sweep", "--resume", str(out)]) == 0
    assert "CPU 4095 of the run is not usable here; workers run on CPU " in capsys.readouterr().err
    assert len((out / "batches.csv").read_text().splitlines()) == len(lines)
