"""The benchmark scripts under bench/ still run against the current API.

Speed is never asserted here (the machines are shared and noisy): every
script must parse its flags and import what it uses, and the quickest one
runs end to end through the harness on a tiny design.
"""

import os
import subprocess
import sys
from pathlib import Path

import pytest

BENCH = Path(__file__).resolve().parents[1] / "bench"
SCRIPTS = sorted(BENCH.glob("*.py"))


def bench(script: Path, *args: str, env=None) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(script), *args], capture_output=True, text=True, timeout=300, env=env)


def test_there_are_benchmarks():
    assert {"peers.py", "scaling.py", "seed_speed.py", "harness_overhead.py"} <= {s.name for s in SCRIPTS}


@pytest.mark.slow
@pytest.mark.parametrize("script", SCRIPTS, ids=lambda s: s.name)
def test_help_parses_and_imports(script):
    done = bench(script, "--help")
    assert done.returncode == 0, done.stderr
    assert done.stdout.startswith("usage:")


@pytest.mark.slow
def test_seed_speed_prints_every_kernel_and_precision_with_a_verdict(tmp_path):
    env = {**os.environ, "TRIBENCH_CACHE": str(tmp_path / "cache")}  # its workloads made afresh, not the user's
    done = bench(BENCH / "seed_speed.py", "--processes", "2", "--rounds", "1", "--size", "8", env=env)
    assert done.returncode == 0, done.stderr
    rows = [
        line.split() for line in done.stdout.splitlines() if line.split()[:1] in (["moller_seed"], ["curless_seed"])
    ]
    assert sorted((r[0], r[1]) for r in rows) == [
        (k, d) for k in ("curless_seed", "moller_seed") for d in ("float32", "float64")
    ]
    assert all(r[-1] in ("met", "missed", "undecided") for r in rows)
