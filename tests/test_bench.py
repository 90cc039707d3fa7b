"""The benchmark scripts under bench/ still run against the current API.

Speed is never asserted here (the machines are shared and noisy): every
script must parse its flags and import what it uses, and the quickest one
runs end to end through the harness on a tiny design.
"""

import importlib.util
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

BENCH = Path(__file__).resolve().parents[1] / "bench"
SCRIPTS = sorted(BENCH.glob("*.py"))


def bench(script: Path, *args: str, env=None) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(script), *args], capture_output=True, text=True, timeout=300, env=env)


def test_there_are_benchmarks():
    assert {"embree_native.py", "scaling.py", "seed_speed.py", "harness_overhead.py"} <= {s.name for s in SCRIPTS}


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


def load_script(name: str):
    spec = importlib.util.spec_from_file_location(name, BENCH / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


# A callgrind profile as valgrind 3.19 writes one: names numbered at first use ("(1) name", then
# "(1)"), files and functions numbered apart, inlined code under fi=/fe=, and a call's inclusive
# cost on the line after calls= (the callee's own lines are counted where they stand).
PROFILE = """\
# callgrind format
version: 1
positions: line
events: Ir D1mr

fl=(1) /src/ext/bvh.c
fn=(1) py_time
cfi=(2) /src/ext/bvh_trace.h
cfn=(2) walk
calls=1 10
20 1000 9
5 4 0

fl=(2)
fn=(2)
30 100 2
fi=(3) /src/ext/kernels/woop.h
+3 50 5
fe=(2)
*
31 7 1
fi=(4) /usr/lib/gcc/include/fmaintrin.h
12 3 1
"""


def test_the_callgrind_profile_is_read_file_by_file(tmp_path):
    counts = load_script("bvh_counts")
    (profile := tmp_path / "p.callgrind").write_text(PROFILE)
    events, rows = counts.cost_lines(profile)
    by_file = counts.costs_by_file(events, rows)
    assert events == ["Ir", "D1mr"]
    got = {f: list(c) for f, c in by_file.items() if c.any()}
    assert got == {
        "/src/ext/bvh.c": [4, 0],  # not the 1000 the call to walk cost: walk's lines are counted below
        "/src/ext/bvh_trace.h": [107, 3],
        "/src/ext/kernels/woop.h": [50, 5],
        "/usr/lib/gcc/include/fmaintrin.h": [3, 1],
    }
    assert [counts.part(f) for f in got] == ["walk", "walk", "leaf test", "leaf test"]
    assert counts.part("/usr/lib/gcc/include/avxintrin.h") == "either"  # the walk's vectors and the leaves' alike


# The same with --dump-instr=yes: each cost line starts with its instruction's address (absolute,
# relative or "*"), then its line; objects named like files (ob=, and a call's cob=).
PROFILE_BY_INSTRUCTION = """\
# callgrind format
version: 1
positions: instr line
events: Ir D1mr

ob=(1) /usr/lib/libembree3.so.3
fl=(1) ???
fn=(1) 0x0000000000001000
0x1000 0 5 1
+4 0 5
cob=(2) /work/peer.so
cfl=(2) ???
cfn=(2) 0x0000000000002000
calls=1 0x2000 0
* 0 100
+3 0 2

ob=(2)
fl=(2)
fn=(2)
0x2000 0 9
"""


def test_the_callgrind_profile_by_instruction_is_read_by_address(tmp_path):
    counts = load_script("bvh_counts")
    (profile := tmp_path / "p.callgrind").write_text(PROFILE_BY_INSTRUCTION)
    events, rows = counts.cost_lines(profile)
    assert counts.executions(events, rows, "libembree") == (
        "/usr/lib/libembree3.so.3",
        {0x1000: 5, 0x1004: 5, 0x1007: 2},
    )
    assert counts.executions(events, rows, "libnothing") == ("", {})
    by_file = counts.costs_by_file(events, rows)  # the two position columns are not costs
    assert events == ["Ir", "D1mr"] and list(by_file["???"]) == [21, 1]


@pytest.mark.slow
@pytest.mark.skipif(shutil.which("valgrind") is None, reason="valgrind is not installed")
def test_bvh_counts_counts_each_contender_under_valgrind(tmp_path):
    from tribench.ext import embree

    if embree.missing():
        pytest.skip(embree.missing())
    env = {**os.environ, "TRIBENCH_CACHE": str(tmp_path / "cache")}
    args = ("--triangles", "2000", "--camera", "32x32", "--rays", "100", "--kernels", "moller_trumbore_fma")
    done = bench(BENCH / "bvh_counts.py", *args, env=env)
    assert done.returncode == 0, done.stderr
    rows = [line.split() for line in done.stdout.splitlines()]
    for contender in ("moller_trumbore_fma", "embree"):
        counted = [r for r in rows if r and r[0] == contender]
        assert len(counted) == 2 * (2 if contender == "embree" else 1)  # camera and bounce
        assert all(float(r[-7]) > 0 for r in counted)  # instructions a ray
    split = [line.split(":", 1)[1] for line in done.stdout.splitlines() if "walk | leaf test | either" in line]
    assert len(split) == 2
    if load_script("bvh_counts").has_line_tables():  # built with TRIBENCH_LINE_TABLES=1
        # instructions of the walk, then of the leaf test: both counted
        assert all(float(s.split()[1]) > 0 and float(s.split()[3]) > 0 for s in split), split
    else:  # a default build: callgrind cannot tell the two apart, and the bench says so
        assert all("not split" in s for s in split), split
    # Embree's single rays, both modes, both ray sets: its node tests and triangle blocks, counted
    masks = [line.split() for line in done.stdout.splitlines() if "node tests (8-wide masks)" in line]
    assert len(masks) == 4 and all(float(m[0]) > 0 and float(m[5]) > 0 for m in masks)


def test_the_yardstick_times_every_algorithms_native_form():
    from tribench import ext

    forms = load_script("yardstick").all_forms()
    native = set(ext.bvh_kernel_names())
    assert native <= {k for k, isa in forms if isa is None}
    assert {ext.kernel_info(k).algorithm for k in native} == {
        ext.kernel_info(k).algorithm for k in ext.kernel_names() if ext.kernel_info(k).lanes > 1
    }


@pytest.mark.slow
def test_kernels_side_by_side_sets_every_brute_force_form_beside_another_build(tmp_path):
    from tribench import ext

    env = {**os.environ, "TRIBENCH_CACHE": str(tmp_path / "cache")}
    core = ext._core.__file__  # the same build as "before": the mode runs, whatever the ratios
    args = ("--before", core, "--pairs", "64", "--rounds", "2", "--batch-ms", "0.1")
    done = bench(BENCH / "kernels_side_by_side.py", *args, env=env)
    assert done.returncode == 0, done.stderr
    ratios = [line.split()[4:] for line in done.stdout.splitlines() if line.startswith("this build / before: ")]
    forms = {(k, "pairs") for k in ext.kernel_names() if "pairs" in ext.kernel_info(k).modes}
    forms |= {(k, "suzanne") for k in ext.kernel_names()}  # closest mode: every kernel
    expected = {(k, dtype, where) for k, where in forms for dtype in ("float32", "float64")}
    assert {(r[0], r[1], r[2]) for r in ratios[:-1]} == expected and len(ratios) == len(expected) + 1
    assert all(float(r[-3]) > 0 for r in ratios[:-1]) and ratios[-1][:2] == ["geometric", "mean"]


@pytest.mark.slow
def test_kernels_side_by_side_heads_each_column_with_its_kernel(tmp_path):
    from tribench import ext

    done = bench(BENCH / "kernels_side_by_side.py", "--pairs", "64", "--rounds", "1", "--hit-rates", "1")
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    head = next(line for line in lines if line.startswith("dtype"))
    rows = [line for line in lines if line.startswith("float")]
    kernels = [k for k in ext.kernel_names() if "pairs" in ext.kernel_info(k).modes]
    assert head.split()[2 : 2 + len(kernels)] == kernels  # no two names run together
    for row in rows:
        # each kernel's ratio ("0.97x") ends where its name ends in the header
        ends = [m.end() for m in re.finditer(r"\S+x(?= |$)", row)]
        assert ends == [m.end() for m in re.finditer(r"\S+", head)][2 : 2 + len(kernels)], (head, row)


@pytest.mark.slow
def test_protocol_design_says_the_batch_length_it_ran(tmp_path):
    env = {**os.environ, "TRIBENCH_CACHE": str(tmp_path / "cache")}
    done = bench(BENCH / "protocol_design.py", "--target-ms", "0.5", "--processes", "2", "--rounds", "2", env=env)
    assert done.returncode == 0, done.stderr
    # one pass over the camera workload outlasts 0.5 ms: the pilot ran longer batches and says so
    line = next(line for line in done.stdout.splitlines() if line.startswith("batches of"))
    ran = float(re.search(r"asked, ([0-9.]+) ms run", line).group(1))
    assert ran > 0.5 and "one pass over the rays" in line, line


def test_bvh_bench_builds_the_default_tree_and_counts_per_ray_over_every_pass(monkeypatch, capsys):
    import numpy as np

    from tribench import ext

    script = load_script("bvh")
    leaves = []
    build = script._core.bvh_build
    monkeypatch.setattr(
        script._core,
        "bvh_build",
        lambda size, tris, n, leaf, *out: leaves.append(leaf) or build(size, tris, n, leaf, *out),
    )
    rng = np.random.default_rng(0)
    tris = (rng.uniform(-1, 1, (500, 1, 3)) + rng.normal(0, 0.05, (500, 3, 3))).astype(np.float32)
    script.bench_build(tris, reps=1)
    assert set(leaves) == {ext.DEFAULT_MAX_LEAF}  # the C build alone and build_bvh: one tree

    o = np.tile(np.float32([0, 0, -4]), (256, 1))
    d = np.ascontiguousarray(rng.uniform(-0.2, 0.2, (256, 3)) + [0, 0, 1], np.float32)
    capsys.readouterr()
    script.bench_trace(tris, o, d, ["moller_trumbore_fma"], reps=1, batch_ms=2.0)
    out = capsys.readouterr().out
    passes = int(re.search(r"(\d+) passes a batch", out).group(1))
    assert passes >= 1
    counts = ext.build_bvh("moller_trumbore_fma", tris).intersect(o, d).counts.mean(axis=0)
    assert f"nodes {counts[0]:.1f}, box tests" in out and f"triangle tests {counts[3]:.1f};" in out, out
