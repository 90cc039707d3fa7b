"""Builds of the kernels by other compilers and flags (``--builds "gcc -O2;clang -O3"``): each compiled once,
its kernels checked against the reference again, run by its own processes, and compared in every table.

The end-to-end tests run the installed ``tribench`` command in a cache of their own (a build of the
extension takes about half a minute on 2 cores, so they are slow tests: CI runs them)."""

from __future__ import annotations

import json
import shutil
import sys
from pathlib import Path

import pandas as pd
import pytest
from conftest import run_tribench as tribench

from tribench import ext
from tribench.harness.plan import Sweep
from tribench.workloads.spec import PairSpec

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "kernels" / "my_moller.c"


@pytest.fixture(scope="module")
def cache(tmp_path_factory):
    """One cache for the module's tests: each build compiles once."""
    return tmp_path_factory.mktemp("cache")


@pytest.mark.parametrize(
    "text, said",
    [
        ("-O2", "starts with a flag"),
        ("gcc O2", "'O2' is not a flag"),
        ("gcc -O2;gcc  -O2", "listed twice"),
        (";".join(f"gcc -O{i % 4} -g{i}" for i in range(9)), "at most 8"),
        ("gcc '-O2", "No closing quotation"),
        ("gcc -O2 -E", "sets what the compiler writes"),
        ("gcc -O2 -o/tmp/x", "sets what the compiler writes"),
        ("gcc -DTB_KERNEL_FILE=x", "tribench's own macros"),
        ("gcc -fsanitize=address", "TRIBENCH_SANITIZE=1"),
    ],
)
def test_a_bad_build_spec_is_refused_in_one_line(text, said):
    with pytest.raises(ext.BuildError) as err:
        ext.parse_builds(text)
    assert said in str(err.value) and "\n" not in str(err.value)


def test_specs_are_normalised_and_the_installed_build_is_a_spec():
    assert ext.parse_builds(" gcc   -O2 ;installed;") == ("gcc -O2", "installed")
    assert ext.load_build("installed") is ext.load_build(ext.INSTALLED)


def test_processes_take_the_builds_in_turn_and_two_of_each_are_needed():
    s = Sweep(("moller_trumbore",), (PairSpec(n=10),), processes=5, builds=("gcc -O2", "gcc -O3"))
    assert [s.build_of(p) for p in range(5)] == ["gcc -O2", "gcc -O3"] * 2 + ["gcc -O2"]
    assert Sweep.from_dict(s.to_dict()).builds == s.builds
    assert "builds" not in Sweep(("moller_trumbore",), (PairSpec(n=10),)).to_dict()  # run.json as it was
    with pytest.raises(ext.UserError, match="at least 6 processes"):
        Sweep(("moller_trumbore",), (PairSpec(n=10),), processes=5, builds=("gcc -O1", "gcc -O2", "gcc -O3"))
    with pytest.raises(ext.UserError, match="a list of build specs"):
        Sweep(("moller_trumbore",), (PairSpec(n=10),), builds="gcc -O2")


@pytest.mark.parametrize(
    "builds, said",
    [
        ("nocc -O2", "no compiler 'nocc'"),
        ("gcc -O2 -fno-such-flag", "does not compile"),
        (f"{sys.executable} -O2", "is not a C compiler"),
    ],
)
def test_a_build_that_cannot_be_made_stops_the_sweep_with_exit_2_and_nothing_made(tmp_path, cache, builds, said):
    out = tmp_path / "run"
    args = ["sweep", "--kernels", "moller_trumbore", "--pairs", "100", "--builds", builds, "--out", out]
    done = tribench(*args, "--processes", "2", "--rounds", "1", cwd=tmp_path, cache=cache)
    assert done.returncode == 2 and said in done.stderr and "Traceback" not in done.stderr, done.stderr
    assert not out.exists()


def small_sweep(out: Path, cache: Path, *flags) -> None:
    """``tribench sweep FLAGS`` into ``out`` with a small design: 4 processes (2 per build) of 0.5 ms batches."""
    design = ("--processes", 4, "--rounds", 1, "--target-ms", 0.5, "--no-progress")
    done = tribench("sweep", *flags, *design, "--out", out, cwd=out.parent, cache=cache)
    assert done.returncode == 0, done.stderr


@pytest.mark.slow
def test_a_sweep_of_two_builds_has_estimates_speedups_and_orders_per_build(tmp_path, cache):
    """The installed build beside a fast-math one, with a kernel file (compiled again under each build): the
    fast-math build's broken promises are recorded and shown, while its processes still run. One build is
    the installed one, so the test compiles the extension once (about a minute of CI's on 2 cores)."""
    builds = ["installed", "gcc -O3 -ffast-math"]
    out = tmp_path / "run"
    kernels = "moller_seed,moller_trumbore,curless,my_moller"
    small_sweep(
        out, cache, "--kernels", kernels, "--kernel-file", EXAMPLE, "--pairs", 2000, "--builds", ";".join(builds)
    )
    batches = pd.read_csv(out / "batches.csv")
    assert {p: set(g["build"]) for p, g in batches.groupby("process")} == {
        0: {builds[0]},
        1: {builds[1]},
        2: {builds[0]},
        3: {builds[1]},
    }
    for name in ("estimates.csv", "speedups.csv", "ranking.csv", "per_process.csv"):
        table = pd.read_csv(out / name)
        assert table.columns[0] == "build" and list(dict.fromkeys(table["build"])) == builds, name
    spd = pd.read_csv(out / "speedups.csv")
    assert len(spd) == 2 * 3  # three kernels against moller_seed, under each build
    orders = pd.read_csv(out / "builds.csv")
    assert set(orders["build"]) == set(builds) and len(orders) == 2 * 6  # 6 pairs of 4 kernels, per build
    assert set(orders["order"]) <= {"holds", "differs", "undecided"}
    run = json.loads((out / "run.json").read_text())
    recorded = {b["spec"]: b for b in run["builds"]}
    assert recorded[builds[1]]["fast_math"] and "-ffast-math" in recorded[builds[1]]["flags"]
    assert recorded[builds[0]]["check"] is None  # the installed build's promises are the test suite's to check
    broken = recorded[builds[1]]["check"]
    assert set(broken) == {"moller_seed", "moller_trumbore", "curless", "my_moller"}
    assert any("nonfinite" in p for p in broken["moller_trumbore"]), broken

    # export prints what the analysis wrote, every build's benchmarks (it printed the first build's alone)
    exported = tribench("export", out, cwd=tmp_path, cache=cache)
    assert exported.returncode == 0, exported.stderr
    assert json.loads(exported.stdout) == json.loads((out / "google_benchmark.json").read_text())
    report = tribench("report", out, cwd=tmp_path, cache=cache)
    assert report.returncode == 0, report.stderr
    html = (out / "report.html").read_text()
    assert (
        'id="builds"' in html
        and "Across builds" in html
        and "moller_trumbore: float32: robustness test nonfinite" in html
    )
    # the page's orders are builds.csv's: one function made both, from the same tables
    from tribench.reports.compare import build_views, compare_many
    from tribench.reports.rundata import load_run

    many = compare_many(build_views(load_run(out)), same_run=True)
    assert list(many.orders["order"]) == list(orders["order"].iloc[::2])


@pytest.mark.slow
@pytest.mark.skipif(shutil.which("clang") is None, reason="clang is not installed (.ci/run installs it)")
def test_a_clang_build_runs_and_its_broken_watertight_promise_is_recorded(tmp_path, cache):
    """clang contracts a*b+c into an FMA by default (-ffp-contract=on) where the ISA has one: woop_fma's
    2-D edge functions, unfused in its source, are then no longer exact, and its watertight promise breaks
    (checked, recorded). Its AVX-512 and AVX2 targets both have FMA (kernels/list.h); the baseline has none,
    and there the promise holds in the clang build too."""
    out = tmp_path / "run"
    kernels = "woop_fma,moller_trumbore_fma"
    small_sweep(
        out, cache, "--kernels", kernels, "--mesh", "icosphere", "--camera", "16x16", "--builds", "installed;clang -O3"
    )
    run = json.loads((out / "run.json").read_text())
    installed, clang = run["builds"]
    assert installed["check"] is None and "clang" in clang["compiler"]
    assert clang["check"]["moller_trumbore_fma"] == []
    if ext.kernel_info("woop_fma").isa != "baseline":  # a target with FMA: the contraction happens
        assert any("shared_edges" in p for p in clang["check"]["woop_fma"]), clang["check"]
    else:
        assert clang["check"]["woop_fma"] == [], clang["check"]
