"""The tribench command line, run as a user runs it."""

import os
import subprocess
import sys

import pandas as pd
import pytest

from tribench import ext


def run(*args, cwd=None, env=None, timeout=120):
    """``tribench ARGS`` as a user runs it: a fresh process, the real entry point."""
    return subprocess.run(
        [sys.executable, "-m", "tribench.cli", *map(str, args)],
        capture_output=True,
        text=True,
        timeout=timeout,
        cwd=cwd,
        env=None if env is None else {**os.environ, **env},
    )


def test_info_prints_kernels_flags_and_cpu():
    out = run("info")
    assert out.returncode == 0, out.stderr
    for name in ext.kernel_names():
        assert name in out.stdout
    assert "-ffp-contract=off" in out.stdout
    assert "compiler" in out.stdout and "simd" in out.stdout and "cpu" in out.stdout


def test_info_isa_is_refused_without_peak_and_beyond_the_cpu():
    out = run("info", "--isa", "avx2")
    assert (
        out.returncode == 2
        and out.stderr.strip() == "tribench info: error: --isa chooses what --peak measures; add --peak"
    )
    if "avx512" not in ext.probe_isas():
        out = run("info", "--peak", "--isa", "avx512")
        assert out.returncode == 2 and "this CPU runs only" in out.stderr and "Traceback" not in out.stderr


def test_unknown_command_is_a_usage_error():
    out = run("frobnicate")
    assert out.returncode == 2
    assert "invalid choice" in out.stderr


def test_the_parser_is_built_without_scipy_stats():
    """Every command builds the whole parser first, its help and usage errors included: scipy.stats (most
    of a second of imports) waits for the first statistic."""
    code = "import sys; from tribench.cli import command; command.build_parser(); print('scipy.stats' in sys.modules)"
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0 and done.stdout.strip() == "False", done.stderr


def test_a_ctrl_c_after_the_command_finished_changes_nothing():
    """An interrupt while Python tears down (a user's late Ctrl-C, here sent from an exit hook)
    leaves a finished command's status 0 and prints nothing: it used to die of the signal."""
    code = (
        "import atexit, os, signal, sys\n"
        "from tribench.cli import console\n"
        "atexit.register(lambda: os.kill(os.getpid(), signal.SIGINT))\n"
        "sys.argv = ['tribench', 'info']\n"
        "console()\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0 and "KeyboardInterrupt" not in out.stderr, (out.returncode, out.stderr)


def test_a_ctrl_c_inside_trimesh_load_interrupts_and_is_not_a_bad_mesh_file():
    """trimesh catches BaseException around its ``os.path.isfile``: a Ctrl-C landing there (as one did in CI) was
    reported as "cannot read mesh file ...: string is not a file". Now it waits for trimesh and interrupts."""
    code = (
        "import os, signal, sys, time\n"
        "from tribench.cli import command\n"
        "from tribench.workloads.meshes import SUZANNE_PATH, read_mesh_file\n"
        "for sig in (signal.SIGINT, signal.SIGALRM):\n"
        "    signal.signal(sig, command._ctrl_c)\n"
        "isfile, hits = os.path.isfile, []\n"
        "def isfile_hit_by_ctrl_c(path):\n"
        "    if not hits and sys._getframe(1).f_globals['__name__'] == 'trimesh.exchange.load':\n"
        "        hits.append(os.kill(os.getpid(), signal.SIGINT))\n"
        "    return isfile(path)\n"
        "os.path.isfile = isfile_hit_by_ctrl_c\n"
        "try:\n"
        "    read_mesh_file(SUZANNE_PATH)\n"
        "    time.sleep(5)\n"
        "except KeyboardInterrupt:\n"
        "    print('interrupted', len(hits))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0 and out.stdout == "interrupted 1\n", (out.stdout, out.stderr)


@pytest.mark.slow
def test_run_quick_is_the_main_job_end_to_end(tmp_path):
    # the README's main job, in its quick form: sweep, statistics, report
    env = {**os.environ, "TRIBENCH_CACHE": str(tmp_path / "cache")}
    out = tmp_path / "run"
    done = subprocess.run(
        [sys.executable, "-m", "tribench.cli", "run", "--quick", "--out", str(out), "--no-progress"],
        capture_output=True,
        text=True,
        timeout=300,
        env=env,
    )
    assert done.returncode == 0, done.stderr
    assert "expected for the sweep: about " in done.stderr  # stated before the sweep starts
    for name in ("batches.csv", "checks.csv", "estimates.csv", "speedups.csv", "run.json", "report.html"):
        assert (out / name).is_file(), name
    assert f"report: {out / 'report.html'}" in done.stdout
    for kernel in ("curless_seed", "moller_seed", "moller_trumbore"):
        assert kernel in done.stdout
    from tribench.harness.jobs import peers

    if any(peers.available().values()):  # the report's peers, measured by the run
        frame = pd.read_csv(out / "peers.csv")
        assert {"tribench", "tribench_call"} <= set(frame["contender"])
        assert "brute force, runs at" in (out / "report.html").read_text(encoding="utf-8")
        assert "contenders measured -> " in done.stderr
    else:
        assert not (out / "peers.csv").exists() and "tribench[peers]" in done.stderr
