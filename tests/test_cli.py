"""The tribench command line, run as a user runs it."""

import subprocess
import sys

from tribench import ext


def run(*args):
    return subprocess.run(
        [sys.executable, "-m", "tribench.harness.cli", *args], capture_output=True, text=True, timeout=120
    )


def test_info_prints_kernels_flags_and_cpu():
    out = run("info")
    assert out.returncode == 0, out.stderr
    for name in ext.kernel_names():
        assert name in out.stdout
    assert "-ffp-contract=off" in out.stdout
    assert "compiler" in out.stdout and "simd" in out.stdout and "cpu" in out.stdout


def test_unknown_command_is_a_usage_error():
    out = run("frobnicate")
    assert out.returncode == 2
    assert "invalid choice" in out.stderr
