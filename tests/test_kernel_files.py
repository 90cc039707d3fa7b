"""A user's own kernel (``--kernel-file FILE.c``): compiled as the built-in kernels are, checked against the
reference before anything is timed, ranked like any other kernel, carried by its run folder.

Every test runs tribench in a process of its own (the installed command, or ``python -c``): a kernel file's
kernels join the registry of the process that loads them, and must not leak into the other tests'."""

from __future__ import annotations

import hashlib
import json
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import TRIBENCH
from conftest import run_tribench as tribench

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "kernels" / "my_moller.c"


@pytest.fixture(scope="module")
def builds(tmp_path_factory):
    """One cache for the module's tests: each distinct file compiles once (a few seconds)."""
    return tmp_path_factory.mktemp("cache")


def python(code: str, cache) -> subprocess.CompletedProcess:
    env = {**os.environ, "TRIBENCH_CACHE": str(cache)}
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=600, env=env)


def variant(tmp_path: Path, name: str, old: str = "", new: str = "") -> Path:
    """The example kernel renamed to ``name``, with ``old`` replaced by ``new`` in its code."""
    text = EXAMPLE.read_text().replace("my_moller", name)
    assert old in text
    path = tmp_path / f"{name}.c"
    path.write_text(text.replace(old, new))
    return path


@pytest.mark.slow  # a compile (seconds)
def test_the_example_loads_from_python_and_answers_as_moller_trumbore(builds):
    done = python(
        f"""
import numpy as np
from tribench import ext
print(ext.load_kernels({str(EXAMPLE)!r}))
info = ext.kernel_info("my_moller")
print(info.source, info.citation.split(",")[0], info.stride, info.watertight)
rng = np.random.default_rng(0)
o, d, tris = rng.normal(size=(300, 3)), rng.normal(size=(300, 3)), rng.normal(size=(40, 3, 3))
mine, theirs = ext.intersect("my_moller", o, d, tris), ext.intersect("moller_trumbore", o, d, tris)
print(bool((mine.index == theirs.index).all()), int((mine.index >= 0).sum()) > 0)
print(ext.load_kernels({str(EXAMPLE)!r}) == ("my_moller",), "my_moller" in ext.kernel_names())
""",
        builds,
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.splitlines() == [
        "('my_moller',)",
        f"{EXAMPLE} Moller & Trumbore 9 none",
        "True True",
        "True True",
    ]


@pytest.mark.slow
def test_a_sweep_ranks_the_example_through_the_installed_command(tmp_path, builds):
    done = tribench(
        "sweep", "--kernel-file", EXAMPLE, "--kernels", "my_moller,moller_seed", "--pairs", "500",
        "--processes", "2", "--rounds", "2", "--out", "run", "--no-progress", cwd=tmp_path, cache=builds,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    run = tmp_path / "run"
    speedups = (run / "speedups.csv").read_text()
    assert ",my_moller,moller_seed," in speedups
    recorded = json.loads((run / "run.json").read_text())["sweep"]["kernel_files"]
    assert [f["path"] for f in recorded] == [str(EXAMPLE)]
    copy = run / "kernel_files" / f"{recorded[0]['sha256']}.c"
    assert copy.read_bytes() == EXAMPLE.read_bytes()
    # the run folder renders elsewhere without the original file: it carries the C it compiled
    moved = tmp_path / "moved"
    shutil.copytree(run, moved)
    done = tribench("report", moved, cwd=tmp_path, cache=tmp_path / "fresh-cache")
    assert done.returncode == 0, done.stderr
    assert "my_moller" in (moved / "report.html").read_text()


def injected(tmp_path: Path, name: str, code: str) -> Path:
    """The example kernel renamed to ``name``, with ``code`` run at the start of every test."""
    start = "    real e1[3], e2[3], p[3], s[3], q[3];"
    path = variant(tmp_path, name, start, f"{start}\n    {code}")
    path.write_text("#include <stdio.h>\n#include <stdlib.h>\n" + path.read_text())
    return path


def aborting_on(tmp_path: Path, name: str, condition: str) -> Path:
    """The example kernel renamed to ``name``, whose preparation of ``n`` triangles aborts when ``condition``."""
    plain = (
        f"#define tb_{name}_prepare_f32 tb_prepare_vertices_f32 /* the vertices as they are */\n"
        f"#define tb_{name}_prepare_f64 tb_prepare_vertices_f64\n"
    )
    aborting = (
        "#include <stdlib.h>\n#include <string.h>\n"
        "static inline void TB_FN(aborting_prepare)(const real *vertices, size_t n, real *out)\n{\n"
        f"    if ({condition})\n        abort();\n"
        "    memcpy(out, vertices, n * 9 * sizeof(real));\n}\n"
        f"#define tb_{name}_prepare_f32 aborting_prepare_f32\n"
        f"#define tb_{name}_prepare_f64 aborting_prepare_f64\n"
    )
    return variant(tmp_path, name, plain, aborting)


# what a kernel file's C may do to the process it runs in, and the one line the check then says
HOSTILE_C = {
    "exits_0": ("exit(0);", "exited before its job was done"),
    "exits_2": ("exit(2);", "exited with code 2"),
    "aborts": ("abort();", "was killed by SIGABRT"),
    "loops": (
        "for (volatile int i = 0;; ++i) {}",
        "sent nothing for 5.04 s while checking k_loops, float32, scalar: pairs",
    ),
}


@pytest.mark.slow  # a compile each (seconds)
@pytest.mark.parametrize("name", HOSTILE_C)
def test_a_kernel_that_exits_crashes_or_hangs_is_refused_in_one_line_by_the_check(tmp_path, builds, name):
    code, said = HOSTILE_C[name]
    path = injected(tmp_path, f"k_{name}", code)
    done = python(
        f"""
import os
from tribench.harness.jobs import kernel_check
os.environ["TRIBENCH_SILENCE_SECONDS"] = "5"  # the floor of each part's limit: its first part, 4,000 pairs, 5.04 s
try:
    kernel_check.load_checked([{str(path)!r}])
except kernel_check.KernelRefused as e:
    print("refused:", e)
""",
        builds,
    )
    assert done.returncode == 0 and "Traceback" not in done.stderr, done.stderr
    assert done.stdout.startswith("refused: ") and said in done.stdout and done.stdout.count("\n") == 1, done.stdout


@pytest.mark.slow
def test_a_kernel_that_prints_is_refused_in_one_line_before_anything_is_timed(tmp_path, builds):
    """Its output would be timed with it, and ran into validate's table and a sweep's own output (the robustness
    step runs the kernels in the sweep's process): millions of lines, exit 0, where the check broke nothing."""
    path = injected(tmp_path, "k_prints", 'printf("debug\\n");')
    said = f"k_prints (from {path}) is refused: it writes to standard output ("
    done = tribench(
        "sweep", "--kernel-file", path, "--kernels", "k_prints", "--pairs", "200", "--processes", "2",
        "--rounds", "1", "--warmup", "0", "--target-ms", "0.2", "--out", "run", "--no-progress",
        cwd=tmp_path, cache=builds,
    )  # fmt: skip
    assert done.returncode == 2 and done.stdout == "", done.stdout[:300]
    assert done.stderr.startswith(f"tribench sweep: error: {said}") and done.stderr.count("\n") == 1, done.stderr
    assert not (tmp_path / "run").exists()
    done = tribench("validate", "--kernel-file", path, "--quick", "--out", "v.csv", cwd=tmp_path, cache=builds)
    assert done.returncode == 2 and done.stdout == "" and said in done.stderr, done.stderr
    assert not (tmp_path / "v.csv").exists()


def test_the_check_catches_what_a_kernel_writes_to_standard_output(monkeypatch):
    """By fd 1 and through C's stdio buffer alike, and says it first; fd 1 is as it was after."""
    import ctypes

    from tribench.harness.jobs import kernel_check

    def loud(kernel, before=None):
        os.write(1, b"from write\n")
        ctypes.CDLL(None).printf(b"from printf\n")
        return ["a wrong answer"]

    monkeypatch.setattr(kernel_check, "check_kernel", loud)
    before = os.fstat(1)
    problems = kernel_check._quiet_check("k")
    assert problems[1:] == ["a wrong answer"] and problems[0].startswith(kernel_check.PRINTS)
    assert "(23 bytes in its check, the first 'from write')" in problems[0]
    assert (os.fstat(1).st_ino, os.fstat(1).st_dev) == (before.st_ino, before.st_dev)
    monkeypatch.setattr(kernel_check, "check_kernel", lambda kernel, before=None: [])
    assert kernel_check._quiet_check("k") == []


def test_with_file_kernels_adds_the_missing_ones_and_says_so_unless_workloads_name_theirs():
    from tribench.harness.jobs.sweep import with_file_kernels
    from tribench.harness.plan import Sweep
    from tribench.workloads.spec import PairSpec

    sweep, said = Sweep(("moller_trumbore",), (PairSpec(n=64),)), []
    joined = with_file_kernels(sweep, ("moller_trumbore", "curless"), said.append)
    assert joined.kernels == ("moller_trumbore", "curless") and said == [
        "the kernel files' curless join the sweep's kernels"
    ]
    assert with_file_kernels(joined, ("curless",), said.append) is joined and len(said) == 1
    placed = Sweep(("moller_trumbore",), (PairSpec(n=64),), workload_kernels=(("moller_trumbore",),))
    assert with_file_kernels(placed, ("curless",), said.append) is placed  # the main job places its own


@pytest.mark.slow
def test_a_kernel_files_kernels_join_the_sweep_whatever_kernels_names(tmp_path, builds):
    done = tribench(
        "sweep", "--kernel-file", EXAMPLE, "--kernels", "moller_trumbore", "--pairs", "200",
        "--processes", "2", "--rounds", "1", "--warmup", "0", "--target-ms", "0.2", "--out", "run",
        "--no-progress", cwd=tmp_path, cache=builds,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert "my_moller join the sweep's kernels" in done.stderr and "sweep: 2 kernels x 1 workloads" in done.stderr
    assert json.loads((tmp_path / "run" / "run.json").read_text())["sweep"]["kernels"] == [
        "moller_trumbore",
        "my_moller",
    ]


@pytest.mark.slow
def test_a_sweep_file_names_kernel_files_relative_to_itself(tmp_path, builds):
    own = variant(tmp_path, "file_moller")
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "sweep.toml").write_text(
        'kernels = ["file_moller", "moller_seed"]\nkernel_files = ["../file_moller.c"]\nprocesses = 2\nrounds = 1\n'
        '[[workloads]]\nkind = "pairs"\nn = 300\n'
    )
    done = tribench("sweep", "--file", "sub/sweep.toml", "--out", "run", "--no-progress", cwd=tmp_path, cache=builds)
    assert done.returncode == 0, done.stderr
    recorded = json.loads((tmp_path / "run" / "run.json").read_text())["sweep"]["kernel_files"]
    assert [f["path"] for f in recorded] == [str(own)]


def test_a_kernel_file_that_does_not_compile_is_one_message_with_file_and_line(tmp_path, builds):
    broken = variant(tmp_path, "broken_moller", "real abs_det = sign * det;", "real abs_det = sign * dett;")
    done = tribench("sweep", "--kernel-file", broken, "--pairs", "100", "--out", "run", cwd=tmp_path, cache=builds)
    assert done.returncode == 2
    assert done.stderr.startswith(f"tribench sweep: error: {broken} does not compile (")
    assert f"{broken}:" in done.stderr and "dett" in done.stderr and "error:" in done.stderr
    assert "Traceback" not in done.stderr and not (tmp_path / "run").exists()  # nothing timed


def test_a_wide_column_the_registry_does_not_know_is_an_error_at_its_line(tmp_path, builds):
    own = variant(tmp_path, "eight_lanes", "TB_CLEAN, TB_SCALAR_ONLY)", "TB_CLEAN, TB_EIGHT_LANES)")
    done = tribench("info", "--kernel-file", own, cwd=tmp_path, cache=builds)
    assert done.returncode == 2 and f"{own}:" in done.stderr
    assert re.search(r"error: .TB_EIGHT_LANES. undeclared", done.stderr), done.stderr


def test_the_first_compile_to_fail_stops_the_others(tmp_path):
    """A kernel file's error is known as soon as one C file fails: the compilers still running are stopped
    (a compiler left to finish would have written its file before the answer came back)."""
    from tribench.ext.toolchain import _first_failure

    late = tmp_path / "late"
    failed = _first_failure([["sh", "-c", "echo oops >&2; exit 3"], ["sh", "-c", f"sleep 5; touch {late}"]])
    assert failed is not None and failed.returncode == 3 and failed.stderr == "oops\n"
    assert not late.exists()
    assert _first_failure([["true"], ["true"]]) is None


@pytest.mark.slow
def test_a_kernel_file_of_bytes_that_are_not_utf8_is_refused_without_a_traceback(tmp_path, builds):
    junk = tmp_path / "junk.c"
    junk.write_bytes(b"\x00\x01 not C at all \xff\xfe")  # the compiler would quote them back
    done = tribench("info", "--kernel-file", junk, cwd=tmp_path, cache=builds)
    assert (
        done.returncode == 2
        and done.stderr == f"tribench info: error: {junk}: not C source: it holds NUL bytes (a binary file?)\n"
    )
    (tmp_path / "latin.c").write_bytes(b"int x = \xff\xfe;\n")  # text, not UTF-8: the compiler's own words
    done = tribench("info", "--kernel-file", tmp_path / "latin.c", cwd=tmp_path, cache=builds)
    assert done.returncode == 2 and done.stderr.startswith(
        f"tribench info: error: {tmp_path / 'latin.c'} does not compile ("
    )
    assert "Traceback" not in done.stderr


@pytest.mark.slow
def test_a_kernel_with_wrong_answers_is_refused_before_anything_is_timed(tmp_path, builds):
    sloppy = variant(
        tmp_path, "sloppy_moller", "v >= 0 && u + v <= abs_det", "v >= -0.01f * abs_det && u + v <= abs_det"
    )
    done = tribench("sweep", "--kernel-file", sloppy, "--pairs", "100", "--out", "run", cwd=tmp_path, cache=builds)
    assert done.returncode == 2, done.stderr
    assert "sloppy_moller (from" in done.stderr and "is refused" in done.stderr
    assert "closest hit on a mesh" in done.stderr  # which cases it got wrong
    assert "Traceback" not in done.stderr and not (tmp_path / "run").exists()


@pytest.mark.slow
def test_a_kernel_that_crashes_is_refused_in_one_line(tmp_path, builds):
    crashy = variant(
        tmp_path,
        "crashy_moller",
        "    real e1[3], e2[3], p[3], s[3], q[3];\n",
        "    real e1[3], e2[3], p[3], s[3], q[3];\n"
        "    if (t_max > 0)\n        return *(volatile int *)0; /* a stray pointer */\n",
    )
    done = tribench("sweep", "--kernel-file", crashy, "--pairs", "100", "--out", "run", cwd=tmp_path, cache=builds)
    assert done.returncode == 2
    assert done.stderr.splitlines() == [f"tribench sweep: error: the reference check of {crashy} was killed by SIGSEGV"]
    assert not (tmp_path / "run").exists()
    # validate refuses a crashing one first, the same way
    done = tribench("validate", "--kernel-file", crashy, "--quick", "--out", "v.csv", cwd=tmp_path, cache=builds)
    assert done.returncode == 2 and "reference check of" in done.stderr and "was killed by SIGSEGV" in done.stderr
    assert "Traceback" not in done.stderr and not (tmp_path / "v.csv").exists()


@pytest.mark.slow  # a compile (seconds)
def test_a_kernel_that_crashes_only_on_the_camera_workload_ends_a_worker_not_info_peak(tmp_path, builds):
    # its check never prepares 968 triangles; info --peak timed it in its own process, which died of SIGABRT
    path = aborting_on(tmp_path, "k_suzanne", "n == 968")  # the camera workload's Suzanne
    done = tribench("info", "--kernel-file", path, "--peak", cwd=tmp_path, cache=builds)
    assert done.returncode == 2 and "Traceback" not in done.stderr, done.stderr
    assert done.stderr.strip().splitlines()[-1] == (
        "tribench info: error: the worker timing every kernel was killed by SIGABRT: a kernel file's kernel fails "
        "on the camera workload (its check ran others)"
    )
    done = tribench("info", "--kernel-file", EXAMPLE, "--peak", cwd=tmp_path, cache=builds)  # timed in that worker
    assert done.returncode == 0, done.stderr
    rows = [line.split() for line in done.stdout.splitlines() if line.startswith("my_moller ")]
    assert len(rows) == 3 and all(r[-1].endswith("%") for r in rows[1:])  # the list, then a row per precision


@pytest.mark.slow  # a compile (seconds)
def test_a_kernel_that_crashes_only_on_the_full_robustness_suite_ends_a_worker_not_validate(tmp_path, builds):
    # its check runs the quick suite (under a million tests a precision); the full one runs 15 million, and
    # validate (and a sweep's robustness step) ran it in their own process: validate died of SIGABRT, no word
    path = injected(tmp_path, "k_tires", "static long calls; if (++calls > 2000000) abort();")
    done = tribench(
        "validate", "--kernel-file", path, "--kernels", "moller_trumbore", "--dtype", "float32", "--out", "v.csv",
        "--no-progress", cwd=tmp_path, cache=builds,
    )  # fmt: skip
    assert done.returncode == 2 and "Traceback" not in done.stderr, done.stderr
    said = done.stderr.strip().splitlines()[-1]
    assert said.startswith("tribench validate: error: the robustness suite's worker was killed by SIGABRT"), said
    assert said.endswith("a kernel file's kernel failed on the robustness suite; nothing was measured"), said
    assert not (tmp_path / "v.csv").exists()


@pytest.mark.slow  # a compile (seconds)
def test_a_kernel_that_crashes_only_on_the_sweeps_workloads_ends_no_process_but_a_worker(tmp_path, builds):
    # it passes the check (a few thousand triangles); the duration forecast timed it in the sweep's own
    # process, where an abort() on the sweep's 20000 pairs ended the notebook (exit 134) and the command
    capped = aborting_on(tmp_path, "capped_moller", "n > 10000")  # a scratch table of 10000 triangles
    done = python(
        f"""
import tribench
from tribench.common import UserError
try:
    tribench.sweep(["capped_moller"], [tribench.PairSpec(n=20000)], out={str(tmp_path / "run")!r},
                   processes=2, rounds=1, target_ms=0.2, progress=False, kernel_files=[{str(capped)!r}])
except UserError as e:
    print("refused:", e)
""",
        builds,
    )
    assert done.returncode == 0 and "Traceback" not in done.stderr, done.stderr
    assert done.stdout.startswith("refused: the worker timing a pass of each kernel was killed by SIGABRT"), done.stdout
    assert done.stdout.count("\n") == 1 and not (tmp_path / "run").exists()


@pytest.mark.slow  # a compile (seconds)
def test_a_kernel_that_never_returns_in_a_sweep_stops_it_in_one_line_and_its_batches_are_kept(
    tmp_path, builds, monkeypatch
):
    # it passes its check (a few hundred thousand tests), then loops for ever past its two millionth test in a
    # process: the sweep once waited for it for ever; the worker's silence limit now stops it
    path = injected(tmp_path, "k_stalls", "static long calls; if (++calls > 2000000) for (volatile int i = 0;; ++i) {}")
    monkeypatch.setenv("TRIBENCH_SILENCE_SECONDS", "1")  # the floor of the limit, 60 s by default
    done = tribench(
        "sweep", "--kernel-file", path, "--kernels", "k_stalls,moller_trumbore", "--pairs", "500",
        "--processes", "2", "--rounds", "60", "--target-ms", "2", "--out", "run", "--no-progress",
        cwd=tmp_path, cache=builds,
    )  # fmt: skip
    assert done.returncode == 1 and "Traceback" not in done.stderr, done.stderr
    said = done.stderr.strip().splitlines()[-1]
    assert re.search(r"worker of process \d sent nothing for [\d.]+ s while \w+ [^;]*k_stalls", said), said
    assert "(a kernel that never returns?)" in said and "finish with: tribench sweep --resume run" in said
    saved = int(re.search(r"(\d+) of \d+ batches saved in run", said).group(1))
    assert saved == len((tmp_path / "run" / "batches.csv").read_text().splitlines()) - 1


@pytest.mark.slow
def test_a_kernel_file_may_not_take_a_built_in_name(tmp_path, builds):
    clash = tmp_path / "clash.c"
    clash.write_text(EXAMPLE.read_text().replace("my_moller", "moller_trumbore"))
    done = tribench("info", "--kernel-file", clash, cwd=tmp_path, cache=builds)
    assert done.returncode == 2
    assert "moller_trumbore: the name of a built-in kernel" in done.stderr and "Traceback" not in done.stderr


@pytest.mark.slow
def test_a_local_header_is_part_of_the_kernel_file_and_of_its_copy(tmp_path, builds):
    """An edit to a header the file includes compiles it again, and what was compiled (the file with its
    headers in place) is one self-contained file that compiles without them."""
    path = variant(tmp_path, "k_hdr", "    if (det == 0)", "    if (det == K_ZERO)")
    path.write_text('#include "k_hdr.h"\n' + path.read_text())
    (tmp_path / "k_hdr.h").write_text("#define K_ZERO 0\n")
    load = f"from tribench import ext; ext.load_kernels({str(path)!r}); f = ext.kernel_file_of('k_hdr')"
    first = python(f"{load}; print(f.sha256, f.text)", builds)
    assert first.returncode == 0, first.stderr
    sha, text = first.stdout.split()
    copy = Path(text).read_text()
    assert "K_ZERO 0" in copy and '#include "k_hdr.h"' not in copy and hashlib.sha256(copy.encode()).hexdigest() == sha
    (tmp_path / "k_hdr.h").write_text("#define K_ZERO 0 /* edited */\n")
    again = python(f"{load}; print(f.sha256)", builds)
    assert again.returncode == 0 and again.stdout.split()[0] != sha, again.stderr  # compiled again
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    (elsewhere / f"{sha}.c").write_text(copy)  # as a run folder carries it: no header beside it
    alone = python(f"from tribench import ext; print(ext.load_kernels({str(elsewhere / f'{sha}.c')!r}))", builds)
    assert alone.returncode == 0 and "k_hdr" in alone.stdout, alone.stderr


@pytest.mark.slow
def test_two_kernel_files_may_not_declare_the_same_name(tmp_path, builds):
    (tmp_path / "other").mkdir()
    twin = tmp_path / "other" / "my_moller.c"
    twin.write_text(EXAMPLE.read_text().replace("u >= 0", "!(u < 0)"))  # other code, the same name
    done = tribench("info", "--kernel-file", EXAMPLE, "--kernel-file", twin, cwd=tmp_path, cache=builds)
    assert done.returncode == 2 and "Traceback" not in done.stderr, done.stderr
    assert f"my_moller (declared by {EXAMPLE}): the name of another kernel file's kernel" in done.stderr


@pytest.mark.slow
def test_a_file_without_registration_lines_says_what_it_lacks(tmp_path, builds):
    bare = tmp_path / "bare.c"
    bare.write_text('#define TB_FILE_CITATION ""\n')
    done = tribench("info", "--kernel-file", bare, cwd=tmp_path, cache=builds)
    assert done.returncode == 2
    assert "a kernel file defines TB_FILE_KERNELS(X)" in done.stderr
    assert done.stderr.count("error:") <= 3  # the first error, not its cascade


@pytest.mark.parametrize("bad", [5, "one.c", [3]])
def test_the_notebook_api_refuses_kernel_files_that_are_not_a_list_of_paths(bad, tmp_path):
    import tribench
    from tribench.common import UserTypeError
    from tribench.workloads.spec import PairSpec

    with pytest.raises(UserTypeError, match="kernel files must be a list of paths"):
        tribench.sweep(["moller_trumbore"], [PairSpec(n=10)], tmp_path / "run", kernel_files=bad)
    with pytest.raises(UserTypeError, match="kernel files must be a list of paths"):
        tribench.run(tmp_path / "run", quick=True, kernel_files=bad)
    assert not (tmp_path / "run").exists()


@pytest.mark.slow
def test_a_damaged_build_in_the_cache_is_rebuilt(tmp_path):
    cache = tmp_path / "cache"
    code = f"from tribench import ext; print(ext.load_kernels({str(EXAMPLE)!r}))"
    assert python(code, cache).returncode == 0
    (module,) = (cache / "kernel_builds").rglob("*.so")
    module.write_bytes(b"not a shared object")
    done = python(code, cache)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "('my_moller',)"


def test_a_compiled_module_cut_short_is_removed_not_loaded(tmp_path):
    """A compiled module cut short (a full disk, a crash) kills the process that loads it with SIGBUS, before any
    ImportError: it is checked against its sha256 first, removed with it, and compiled again (None here)."""
    from tribench.ext import _core

    whole = Path(_core.__file__).read_bytes()
    module = tmp_path / "kernel_builds" / "cut" / Path(_core.__file__).name.replace("_core", "_cut")
    module.parent.mkdir(parents=True)
    module.write_bytes(whole[:1000])
    module.with_name(f"{module.name}.sha256").write_text(hashlib.sha256(whole).hexdigest())
    code = "from pathlib import Path; from tribench.ext.toolchain import import_module; "
    code += f"print(import_module('_cut', Path({str(module)!r})))"
    done = python(code, tmp_path)
    assert (done.returncode, done.stdout.strip()) == (0, "None"), done.stderr
    assert list(module.parent.iterdir()) == []


@pytest.mark.slow
def test_the_walk_through_of_docs_own_kernel_runs_as_written(tmp_path, builds):
    """The bash block of docs/own-kernel.md, line for line, from a folder holding the examples: a culling
    variant ranked in a sweep and in the main job."""
    page = (ROOT / "docs" / "own-kernel.md").read_text()
    script = page.split("```bash\n", 1)[1].split("```", 1)[0]
    shutil.copytree(ROOT / "examples", tmp_path / "examples")
    env = {**os.environ, "TRIBENCH_CACHE": str(builds), "PATH": f"{TRIBENCH.parent}{os.pathsep}{os.environ['PATH']}"}
    done = subprocess.run(["bash", "-euc", script], cwd=tmp_path, env=env, capture_output=True, text=True, timeout=900)
    assert done.returncode == 0, done.stderr[-3000:]
    for run in ("runs/my-cull", "runs/my-cull-main"):
        lines = (tmp_path / run / "estimates.csv").read_text().splitlines()
        assert any(line.startswith("installed,my_cull,") for line in lines), run
    assert "my_cull" in (tmp_path / "runs" / "my-cull-main" / "ranking.csv").read_text()


@pytest.mark.slow
def test_a_native_kernel_of_ones_own_is_a_bvh_leaf_test(tmp_path, builds):
    """A native-width kernel file (TB_NATIVE_PART): built-in moller_trumbore_fma's code under another name."""
    built_in = "moller_trumbore_fma"
    code = (ROOT / "ext" / "kernels" / f"{built_in}.h").read_text()
    code = code.replace(built_in, "my_fma").replace("tb_mt_fma", "tb_my_mt_fma")
    own = tmp_path / "my_fma.c"
    own.write_text(
        '#define TB_FILE_CITATION "Moller & Trumbore 1997"\n'
        '#define TB_FILE_KERNELS(X) X(my_fma, TB_BOTH_FACES, TB_OPEN, "", TB_CLEAN, TB_NATIVE)\n'
        f"#ifdef TB_NATIVE_PART\n{code}\n#endif\n"
    )
    done = python(
        f"""
import numpy as np, trimesh
from tribench import ext
from tribench.harness.jobs.kernel_check import load_checked
print(load_checked([{str(own)!r}]), "my_fma" in ext.bvh_kernel_names())
tris = np.ascontiguousarray(trimesh.creation.icosphere(subdivisions=3).triangles).astype(np.float32)
rng = np.random.default_rng(0)
o = (3 * rng.normal(size=(200, 3))).astype(np.float32)
d = (rng.normal(size=(200, 3)) * 0.3 - o).astype(np.float32)
mine = ext.build_bvh("my_fma", tris).intersect(o, d).hits.index
print(bool((mine == ext.intersect("moller_trumbore_fma", o, d, tris).index).all()), bool((mine >= 0).any()))
""",
        builds,
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.splitlines() == ["('my_fma',) True", "True True"]
