"""Issue #53's classes and the newer surfaces, attacked as a hostile user would: the helpers, the judge and
the table are ``test_hostile.py``'s (``python tests/test_hostile.py`` prints every class's row).

Each class runs one or two representative commands per kind of attack (the long, focused tests are in
test_kernel_files.py, test_cli_flags.py, test_protocol.py, test_cache_corruption.py, test_replicate.py);
where a command is done, the case checks its effect, so a flag or file that was taken and ignored is a
silent drop, not a pass.
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import time
from collections.abc import Callable
from pathlib import Path

import pytest
from test_hostile import EXAMPLE, SMALL, Outcome, Scratch, failures, judge, planned, run_class, small_sweep

TINY = ["--processes", "2", "--rounds", "1", "--warmup", "0", "--target-ms", "0.2", "--no-progress"]


def own_kernel(s: Scratch, name: str, code: str = "", prelude: str = "") -> Path:
    """The example kernel file renamed to ``name``, running the C ``code`` first in every test."""
    start = "    real e1[3], e2[3], p[3], s[3], q[3];"
    text = EXAMPLE.read_text().replace("my_moller", name).replace(start, f"{start}\n    {code}")
    path = s.root / f"{name}.c"
    path.write_text("#include <stdio.h>\n#include <stdlib.h>\n#include <string.h>\n" + prelude + text)
    return path


# One kernel file does what $K_HOW says (one compile for every case): the C a user's debugging leaves in.
HOSTILE_C = r"""
#ifndef K_HOW_ONCE /* the file is read once per precision */
#define K_HOW_ONCE
static int tb_k_how(void)
{
    static int how = -1;
    if (how < 0) {
        const char *e = getenv("K_HOW");
        char cmd[4096] = {0};
        FILE *f = fopen("/proc/self/cmdline", "rb");
        size_t n = f ? fread(cmd, 1, sizeof cmd - 1, f) : 0;
        for (size_t i = 0; i < n; ++i) /* NULs between arguments: one string to search */
            cmd[i] = cmd[i] ? cmd[i] : ' ';
        if (f)
            fclose(f);
        how = !e ? 0 : !strcmp(e, "printf") ? 1 : !strcmp(e, "exit0") ? 2 : !strcmp(e, "exit2") ? 3
            : !strcmp(e, "abort") ? 4 : !strcmp(e, "loop") ? 5
            : !strcmp(e, "abort_in_worker") && strstr(cmd, "harness.worker") ? 4 : 0;
    }
    return how;
}
#endif
"""
HOW = 'switch (tb_k_how()) { case 1: printf("debug\\n"); break; case 2: exit(0); case 3: exit(2); '
HOW += "case 4: abort(); case 5: for (volatile int i = 0;; ++i) {} }"


def kernel_as(s: Scratch, how: str, *args: str, api: str = "") -> subprocess.CompletedProcess:
    """The hostile kernel file, doing ``how``: a sweep of it (or the notebook ``api`` code)."""
    as_how = Scratch(s.root, {**s.env, "K_HOW": how})
    if api:
        return as_how.python(api, timeout=120)
    return as_how.tribench("sweep", "--kernel-file", "k_how.c", "--pairs", "200", "--out", f"r-{how}", *args)


def kernel_code_cases(s: Scratch) -> list[Outcome]:
    """1: the user's kernel code prints, exits, aborts, loops; a header it includes is edited; a name twice."""
    own_kernel(s, "k_how", HOW, prelude=HOSTILE_C)
    out = []
    for how, words in (("exit0", "exited before its job was done"), ("exit2", "exited with code 2"),
                       ("abort", "SIGABRT"), ("printf", "writes to standard output")):  # fmt: skip
        o = judge(
            f"K_HOW={how}: a kernel that calls it in the check", kernel_as(s, how, *TINY), refused=True, words=(words,)
        )
        o.dropped = (s.root / f"r-{how}" / "batches.csv").exists()  # timed after all
        out.append(o)
    p = kernel_as(s, "abort_in_worker", *SMALL[:6], "--no-progress")
    o = judge("K_HOW=abort_in_worker: a kernel that aborts in a worker", p, refused=True, words=("SIGABRT",), code=1)
    o.unclear |= "--resume" not in p.stderr  # how to finish what was run
    out.append(o)
    api = (
        "import os, sys, tribench\nfrom tribench.common import UserError\n"
        "os.environ['TRIBENCH_SILENCE_SECONDS'] = '3'  # 60 s by default\ntry:\n"
        "    tribench.sweep(['k_how'], [tribench.PairSpec(n=50)], 'lr', kernel_files=['k_how.c'])\n"
        "except UserError as e:\n    sys.exit(print(e, file=sys.stderr) or 2)\n"
    )
    out.append(
        judge(
            "K_HOW=loop: a kernel that never returns",
            kernel_as(s, "loop", api=api),
            refused=True,
            words=("sent nothing for 3.0",),
        )
    )
    out[
        -1
    ].command = (
        "K_HOW=loop tribench.sweep(['k_how'], ..., kernel_files=['k_how.c']) with a floor of 3 s on its silence limits"
    )
    out += header_cases(s)
    twin = s.root / "other" / "k_how.c"  # other code, the same name (the first file is compiled already)
    twin.parent.mkdir()
    twin.write_text((s.root / "k_how.c").read_text().replace("u >= 0", "!(u < 0)"))
    p = s.tribench("info", "--kernel-file", "k_how.c", "--kernel-file", "other/k_how.c")
    out.append(judge("two kernel files, one name", p, refused=True, words=("another kernel file",)))
    return out


def header_cases(s: Scratch) -> list[Outcome]:
    """A header the kernel file includes: an edit that makes it wrong is seen; the run reports without it."""
    path = own_kernel(s, "k_hdr", prelude='#include "k_hdr.h"\n')
    path.write_text(path.read_text().replace("if (!(u >= 0 &&", "if (!(u >= K_SLACK &&"))
    (s.root / "k_hdr.h").write_text("#define K_SLACK 0\n")
    first = s.tribench("sweep", "--kernel-file", "k_hdr.c", "--pairs", "200", "--out", "h1", *TINY)
    (s.root / "k_hdr.h").write_text("#define K_SLACK (-0.2f * abs_det) /* wrong answers */\n")
    edited = s.tribench("sweep", "--kernel-file", "k_hdr.c", "--pairs", "200", "--out", "h2", *TINY)
    shutil.move(s.root / "h1", s.root / "moved-h1")
    (s.root / "k_hdr.h").unlink()
    return [
        judge("a kernel file with a header", first, refused=False),
        judge("its header edited to give wrong answers", edited, refused=True, words=("k_hdr", "refused"), quoted=True),
        judge("its run reported moved, the header gone", s.tribench("report", "moved-h1"), refused=False),
    ]


def dropped_flag_cases(s: Scratch) -> list[Outcome]:
    """2: flags the chosen mode would ignore are refused; flags taken have their effect."""
    (s.root / "s.toml").write_text('kernels = ["moller_seed"]\n[[workloads]]\nkind = "pairs"\nn = 50\n')
    refusals = {
        "--file with workload flags": (
            ["--file", "s.toml", "--hit-rates", "0.1,0.9", "--dtype", "float32"],
            "--hit-rates",
        ),
        "--file with --mesh --camera": (["--file", "s.toml", "--mesh", "suzanne", "--camera", "8x8"], "--mesh"),
        "--triangles without --mesh": (["--kernels", "moller_seed", "--triangles", "100"], "--triangles"),
        "--camera without --mesh": (["--kernels", "moller_seed", "--camera", "8x8"], "--camera"),
        "a flag given twice": (
            ["--kernels", "moller_seed", "--hit-rates", "0.2", "--hit-rates", "0.8"],
            "more than once",
        ),
        "a kernel that runs no workload": (["--kernels", "moller_trumbore_fma,moller_seed"], "no pairs mode"),
    }
    out = []
    for case, (args, word) in refusals.items():
        out.append(judge(case, s.tribench("sweep", *args, "--out", "never"), refused=True, words=(word,)))
    api = (
        "import sys, tribench\nfrom tribench.common import UserError\ntry:\n"
        "    tribench.sweep(['moller_seed', 'curless'], [tribench.PairSpec(n=50)], 'nb', baseline='nosuch')\n"
        "except UserError as e:\n    sys.exit(print(e, file=sys.stderr) or 2)\n"
    )
    o = judge('the notebook\'s baseline="nosuch"', s.python(api), refused=True, words=("nosuch",))
    o.command, o.dropped = (
        "tribench.sweep(['moller_seed', 'curless'], ..., baseline='nosuch')",
        (s.root / "nb").exists(),
    )
    out.append(o)
    for o in out[:-1]:
        o.dropped = (s.root / "never").exists()  # a refusal leaves no run folder behind
    args = ["--kernels", "moller_seed,curless", "--hit-rates", "0.2,0.8", "--dtype", "float32", "--pairs", "300"]
    p = s.tribench("sweep", *args, "--out", "taken", *TINY)
    o = judge("workload flags are taken", p, refused=False)
    plan = planned(s.root / "taken")
    got = {(w.get("hit_rate"), w.get("dtype"), w.get("n")) for w in plan.get("workloads", [])}
    o.dropped = got != {(0.2, "float32", 300), (0.8, "float32", 300)} or plan.get("kernels") != [
        "moller_seed",
        "curless",
    ]
    out.append(o)
    args = ["--kernels", "moller_trumbore_fma", "--mesh", "suzanne", "--triangles", "100", "--camera", "8x6"]
    p = s.tribench("sweep", *args, "--out", "mesh", *TINY)
    o = judge("mesh flags are taken", p, refused=False)
    w = (planned(s.root / "mesh").get("workloads") or [{}])[0]
    o.dropped = (w.get("triangles"), w.get("width"), w.get("height")) != (100, 8, 6)
    return [*out, o]


PLAN_KEYS = ("kernels", "workloads", "workload_kernels", "sequential", "builds", "processes", "rounds", "rng_seed")


def sweep_file_cases(s: Scratch) -> list[Outcome]:
    """3: a run folder's sweep.toml plans the same run again: kernel files, builds, workload_kernels, sequential."""
    own = own_kernel(s, "k_file")
    (s.root / "plan.toml").write_text(
        'kernels = ["moller_seed", "k_file", "curless"]\nkernel_files = ["k_file.c"]\nprocesses = 4\nrounds = 1\n'
        'warmup = 0\ntarget_ms = 0.2\nbuilds = ["installed", "gcc -O0"]\n'
        'workload_kernels = [["moller_seed", "k_file"], ["moller_seed", "curless"]]\n'
        "sequential = {stage = 2, target = 0.5, budget_s = 30.0}\n"
        '[[workloads]]\nkind = "pairs"\nn = 200\nhit_rate = [0.2, 0.8]\n'
    )
    first = s.tribench("sweep", "--file", "plan.toml", "--out", "a", "--no-progress")
    rendered = s.tribench("report", "a")  # writes a/sweep.toml
    shutil.copytree(s.root / "a", s.root / "moved" / "a")
    own.unlink()  # as on another machine: only the folder's copy of the kernel file
    again = s.tribench("sweep", "--file", "moved/a/sweep.toml", "--out", "b", "--no-progress")
    out = [judge("a sweep file with every part", first, refused=False), judge("its report", rendered, refused=False)]
    o = judge("its run's sweep.toml, elsewhere", again, refused=False)
    a, b = planned(s.root / "a"), planned(s.root / "b")
    o.dropped = not a or any(a.get(k) != b.get(k) for k in PLAN_KEYS)
    shas = [[f["sha256"] for f in p.get("kernel_files", [])] for p in (a, b)]
    o.dropped |= shas[0] != shas[1] or not shas[0]
    return [*out, o]


def traceback_cases(s: Scratch) -> list[Outcome]:
    """4: what once raised a traceback."""
    cases = {
        "validate, a kernel twice": (
            ["validate", "--kernels", "moller_trumbore,moller_trumbore", "--quick"],
            "more than once",
        ),
        "validate, a precision twice": (["validate", "--dtype", "float32,float32", "--quick"], "more than once"),
        "workloads show a folder": (["workloads", "show", "/etc"], "not a workload id"),
        "workloads show a glob": (["workloads", "show", "a**b"], "not a workload id"),
        "calibrate a folder": (["calibrate", "--workload", "/etc"], "not a workload id"),
        "a 400-digit cache size": (["cache", "prune", "--max-size", "9" * 400], "too large"),
    }
    out = []
    for case, (args, word) in cases.items():
        o = judge(case, s.tribench(*args, "--out", "v.csv") if args[0] == "validate" else s.tribench(*args),
                  refused=True, words=(word,))  # fmt: skip
        o.rows_lost = int((s.root / "v.csv").exists())  # a half-written CSV
        out.append(o)
    return out


def hang_cases(s: Scratch) -> list[Outcome]:
    """5: a pipe, links and a folder in the cache never hang a walk; SIGTERM during a compile leaves nothing."""
    cache = Path(s.env["TRIBENCH_CACHE"])
    small_sweep(s, "w", "moller_seed")
    os.mkfifo(cache / "x.npz")
    (cache / "out.npz").symlink_to(s.root)
    (cache / "gone.npz").symlink_to(s.root / "nowhere.npz")
    (cache / "dir.npz").mkdir()
    out = [
        judge(f"{what}, a pipe and links in the cache", s.tribench(*args, timeout=60), refused=False)
        for what, args in (("cache list", ["cache", "list"]), ("workloads list", ["workloads", "list"]),
                           ("cache prune", ["cache", "prune", "--max-size", "1GB"]))
    ]  # fmt: skip
    return [*out, sigterm_case(s)]


def sigterm_case(s: Scratch) -> Outcome:
    """SIGTERM to the command alone during a ``--builds`` compile: it ends, and takes its compilers along."""
    from test_cli_flags import _compilers_under

    cache = Path(s.env["TRIBENCH_CACHE"])
    argv = ["tribench", "sweep", *SMALL, "--builds", "gcc -O1", "--out", "t"]
    p = subprocess.Popen(argv, cwd=s.root, env=s.env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                         start_new_session=True)  # fmt: skip
    end = time.monotonic() + 120
    while not _compilers_under(cache) and time.monotonic() < end and p.poll() is None:
        time.sleep(0.1)
    p.send_signal(signal.SIGTERM)
    try:
        stdout, stderr = p.communicate(timeout=30)
        code = p.returncode
    except subprocess.TimeoutExpired:
        os.killpg(p.pid, signal.SIGKILL)
        stdout, stderr = p.communicate()
        code = -1
    o = judge("SIGTERM during a --builds compile", subprocess.CompletedProcess(argv, 0, stdout, stderr), refused=False)
    time.sleep(0.5)
    left = _compilers_under(cache) + [str(t) for t in (cache / "kernel_builds").glob("*/tmp*")]
    o.hang = code == -1 or bool(left)
    o.crash, o.unclear = code not in (130, -1), "interrupted" not in stderr
    if left:
        os.killpg(p.pid, signal.SIGKILL) if code == -1 else None
    return o


def data_lost_cases(s: Scratch) -> list[Outcome]:
    """6: an output over a measured file (named, through a link, through ``..``) is refused and the file kept."""
    small_sweep(s, "r", "moller_seed,curless")
    before = {f: f.read_bytes() for f in (s.root / "r").iterdir() if f.suffix in (".csv", ".json")}
    (s.root / "link.json").symlink_to(s.root / "r" / "batches.csv")
    (s.root / "sub").mkdir()
    cases = {
        "export over batches.csv": ["export", "r", "--out", "r/batches.csv"],
        "export through a link to it": ["export", "r", "--out", "link.json"],
        "export through ..": ["export", "r", "--out", "sub/../r/batches.csv"],
        "compare over run.json": ["compare", "r", "r", "--out", "r/run.json"],
        "validate over batches.csv": ["validate", "--kernels", "moller_seed", "--quick", "--out", "r/batches.csv"],
    }
    out = []
    for case, args in cases.items():
        o = judge(case, s.tribench(*args), refused=True, words=("measured file",) if "link" not in case else ())
        o.rows_lost = sum(f.read_bytes() != b for f, b in before.items())
        out.append(o)
    return out


def message_cases(s: Scratch) -> list[Outcome]:
    """7: refusals that once misled: each now names what is wrong."""
    (s.root / "garbage.stl").write_bytes(os.urandom(4000))
    (s.root / "binary.c").write_bytes(b"\x7fELF\x00\x01" + os.urandom(4000))
    (s.root / "tiny.txt").write_text("source 0 3 1 1 1 1\ntri 0 0 -2  1e-30 0 -2  0 1e-30 -2\n")
    (s.root / "twice.toml").write_text(
        'kernels = ["moller_seed"]\n[[workloads]]\nkind = "pairs"\nn = 64\n[[workloads]]\nkind = "pairs"\nn = 64\n'
    )
    (s.root / "afile").write_text("not a folder\n")
    pairs = ["workloads", "make", "pairs", "--n", "64"]
    cases = {
        "--scale 1e300": ([*pairs, "--scale", "1e300"], ("1e+300",)),
        "--scale 1e-320": ([*pairs, "--scale", "1e-320"], ("1e-320",)),
        "a miss stage twice": ([*pairs, "--miss-mix", "parallel=0.5,parallel=0.5"], ("parallel", "twice")),
        "a workload twice": (["sweep", "--file", "twice.toml", "--out", "x"], ("twice.toml", "listed twice", "64")),
        "a billion experiments": (["calibrate", "--experiments", "1000000000"], ("experiments",)),
        "a 1e-30 scene triangle": (["seed", "--quick", "--scene", "tiny.txt", "--out", "sd"], ("too small",)),
        "a garbage .stl": (["workloads", "make", "garbage.stl"], ("garbage.stl", "not a mesh file")),
        "a binary kernel file": (["info", "--kernel-file", "binary.c"], ("binary.c", "not C source")),
        "peers on one process": (["peers", "--processes", "1"], ("--processes",)),
    }
    out = [judge(case, s.tribench(*args), refused=True, words=words) for case, (args, words) in cases.items()]
    o = judge("stats --margin's range", s.tribench("stats", "--help"), refused=False)
    o.unclear |= "[0, 1]" in o.said or "0.5" not in s.tribench("stats", "--help").stdout
    o.command = "tribench stats --help (its --margin line)"
    out.append(o)
    code = "import numpy as np, tribench\nprint(tribench.PairSpec(n=np.int64(100)).n)\n"
    out.append(judge("PairSpec(n=np.int64(100))", s.python(code), refused=False))
    out[-1].command = "tribench.PairSpec(n=np.int64(100))"
    cache_file = Scratch(s.root, {**s.env, "TRIBENCH_CACHE": str(s.root / "afile")})
    out.append(judge("a cache path that is a file", cache_file.tribench(*pairs), refused=False))
    out[-1].command = "TRIBENCH_CACHE=afile " + out[-1].command
    return out + [more_cpus_case(s)]


def more_cpus_case(s: Scratch) -> Outcome:
    """A run copied from a machine with more CPUs: its resume says which CPU it runs on instead."""
    small_sweep(s, "big", "moller_seed")
    record = json.loads((s.root / "big" / "run.json").read_text())
    (s.root / "big" / "run.json").write_text(json.dumps({**record, "cpu": 4096}))
    p = s.tribench("sweep", "--resume", "big", "--no-progress")
    o = judge("a run from a machine with more CPUs", p, refused=False)
    o.unclear |= "CPU 4096" not in p.stderr
    return o


# ------------------------------------------------------------------- the newer surfaces

NEW = ("badouel", "wald", "segura_feito", "kensler_shirley", "shevtsov")
NEW_NATIVE = ("badouel_fma", "wald_fma", "segura_feito_fma", "kensler_shirley_fma", "shevtsov_fma")


def new_kernel_cases(s: Scratch) -> list[Outcome]:
    """The five new kernels and their _fma forms: validate and sweep with odd inputs; kernel files taking
    their names."""
    out = []
    p = s.tribench("validate", "--kernels", ",".join(NEW), "--quick", "--dtype", "float32", "--out", "v.csv")
    o = judge("validate the five", p, refused=False)
    o.dropped = not o.unclear and set(_column(s.root / "v.csv", "kernel")) != set(NEW)
    out.append(o)
    p = s.tribench("validate", "--kernels", ",".join(NEW_NATIVE), "--quick", "--dtype", "float64", "--out", "f.csv")
    o = judge("validate their _fma forms", p, refused=False)
    o.dropped = not o.unclear and set(_column(s.root / "f.csv", "kernel")) != set(NEW_NATIVE)
    out.append(o)
    odd = {
        "a name in capitals": (["Wald"], ("Wald",)),
        "a name twice, spaced": (["wald, wald"], ("wald",)),
        "an _fma form of no kernel": (["wald_fma_fma"], ("wald_fma_fma",)),
        "a trailing comma": (["badouel,"], ("empty item",)),
        "two --kernels": (["wald", "--kernels", "badouel"], ("given more than once",)),
        "a name in two words": (["wald", "badouel,wald"], ("wald more than once",)),
    }
    for case, (names, words) in odd.items():
        out.append(
            judge(
                f"validate, {case}",
                s.tribench("validate", "--kernels", *names, "--quick", "--out", "twice.csv"),
                refused=True,
                words=words,
            )
        )
    p = s.tribench("sweep", "--kernels", "wald_fma,badouel", "--out", "x", *SMALL)
    out.append(judge("sweep, an _fma form on pairs", p, refused=True, words=("wald_fma", "no pairs mode")))
    args = ["--kernels", "shevtsov,segura_feito", "--hit-rates", "0,1", "--dtype", "float64"]
    p = s.tribench("sweep", *args, "--out", "pairs", *TINY, "--pairs", "200")
    o = judge("sweep, hit rates 0 and 1", p, refused=False)
    plan = planned(s.root / "pairs")
    o.dropped = plan.get("kernels") != ["shevtsov", "segura_feito"] or len(plan.get("workloads", [])) != 2
    out.append(o)
    args = ["--kernels", "kensler_shirley_fma,badouel_fma", "--mesh", "suzanne", "--accel", "bvh", "--camera", "8x8"]
    p = s.tribench("sweep", *args, "--out", "bvh", *TINY)
    o = judge("sweep, two _fma forms in a BVH", p, refused=not p.returncode == 0, words=("bvh",))
    o.dropped = p.returncode == 0 and planned(s.root / "bvh").get("kernels") != ["kensler_shirley_fma", "badouel_fma"]
    out.append(o)
    for name in ("wald", "shevtsov_fma"):
        path = s.root / f"{name}.c"
        path.write_text(EXAMPLE.read_text().replace("my_moller", name))
        p = s.tribench("sweep", "--kernel-file", path.name, "--out", "k", *SMALL)
        out.append(judge(f"a kernel file named {name}", p, refused=True, words=(name, "built-in"), quoted=True))
    return out


def _column(path: Path, name: str) -> list[str]:
    import pandas as pd

    return list(pd.read_csv(path)[name].unique()) if path.is_file() else []


def replicate_cases(s: Scratch) -> list[Outcome]:
    """``tribench replicate``: a run whose mesh file moved, folders that are no run or no replication, --resume
    with --out, then a folder edited: run.json tampered or from a newer tribench, batches.csv gone, its kernel
    file's copy changed, --out inside it."""
    import trimesh

    trimesh.creation.icosphere(subdivisions=2).export(s.root / "one.obj")
    args = ["--kernels", "moller_seed,curless", "--mesh", "one.obj", "--camera", "8x8", "--out", "m", *SMALL]
    made = s.tribench("sweep", *args)
    (s.root / "one.obj").rename(s.root / "moved.obj")  # as on another machine: only the run folder's copy
    shutil.copytree(s.root / "m", s.root / "elsewhere" / "m")  # ... copied there, where the cache is empty
    there = Scratch(s.root, {**s.env, "TRIBENCH_CACHE": str(s.root / "empty-cache")})
    out = [
        judge("sweep on a mesh file", made, refused=False),
        judge("replicate a copy after the mesh moved",
              there.tribench("replicate", "elsewhere/m", "--out", "r", "--no-progress"), refused=False),
        judge("the replication's report", s.tribench("report", "r"), refused=False),
        judge("export after the mesh moved", s.tribench("export", "m", "--out", "m.json"), refused=False),
        judge("LaTeX of the replication", s.tribench("export", "r", "--format", "latex"), refused=False),
        judge("replicate into the run", s.tribench("replicate", "m", "--out", "m"), refused=True, words=("not empty",)),
        judge("replicate a folder that is no run", s.tribench("replicate", "."), refused=True, words=("run.json",)),
        judge("resume what is no replication", s.tribench("replicate", "m", "--resume", "m"), refused=True,
              words=("no replication",)),
        judge("resume with --out", s.tribench("replicate", "m", "--resume", "r", "--out", "x"), refused=True,
              words=("--out",)),
    ]  # fmt: skip
    return out + edited_run_cases(s)


def edited_run_cases(s: Scratch) -> list[Outcome]:
    """Replicate a copy of a run with a kernel file, edited one way each."""
    own_kernel(s, "k_rep")
    small_sweep(s, "k", "moller_seed", "--kernel-file", "k_rep.c")
    (copy := s.root / "k_rep.c").unlink()
    record = json.loads((s.root / "k" / "run.json").read_text())
    sha = record["sweep"]["kernel_files"][0]["sha256"]
    edits: dict[str, tuple[Callable[[Path], object], bool, tuple[str, ...]]] = {
        "run.json cut short": (lambda d: (d / "run.json").write_text("{\"sweep\": "), True, ("run.json",)),
        "run.json from a newer tribench": (
            lambda d: (d / "run.json").write_text(json.dumps({**record, "tribench_version": "99.0"})), False, ()),
        "a kernel renamed in run.json": (lambda d: (d / "run.json").write_text(
            json.dumps(record).replace('"moller_seed"', '"nosuch"')), True, ("nosuch",)),
        "a sweep field of a newer tribench": (lambda d: (d / "run.json").write_text(
            json.dumps({**record, "sweep": {**record["sweep"], "shuffle": "by-kernel"}})), True, ("shuffle",)),
        "batches.csv gone": (lambda d: (d / "batches.csv").unlink(), True, ("batches.csv",)),
        "its kernel file's copy edited": (lambda d: (d / "kernel_files" / f"{sha}.c").write_text(
            (d / "kernel_files" / f"{sha}.c").read_text().replace("u >= 0", "!(u < 0)")), False, ()),
    }  # fmt: skip
    out = []
    for i, (case, (edit, refuse, words)) in enumerate(edits.items()):
        shutil.copytree(s.root / "k", s.root / f"e{i}")
        edit(s.root / f"e{i}")
        p = s.tribench("replicate", f"e{i}", "--out", f"re{i}", "--no-progress")
        out.append(judge(f"replicate, {case}", p, refused=refuse, words=words, quoted=True))
    # the edited copy is passed over for the cache's copy of the recorded code; with no cache, refused
    files = planned(s.root / f"re{i}").get("kernel_files", [])
    out[-1].dropped = out[-1].unclear or [f["sha256"] for f in files] != [sha]
    fresh = Scratch(s.root, {**s.env, "TRIBENCH_CACHE": str(s.root / "fresh-cache")})
    p = fresh.tribench("replicate", f"e{i}", "--out", "fresh", "--no-progress")
    out.append(
        judge(
            "replicate, the copy edited and no cache",
            p,
            refused=True,
            words=("kernel_files", "has changed since the run"),
        )
    )
    p = s.tribench("replicate", "k", "--out", "k/again", "--no-progress")
    out.append(judge("replicate with --out inside the run", p, refused=True, words=("inside",)))
    assert not copy.exists()
    return out


def export_cases(s: Scratch) -> list[Outcome]:
    """``tribench export``: each format; an unfinished, an unanalysed run; an unknown format; --out a folder."""
    small_sweep(s, "m", "moller_seed,curless")
    out = []
    for form in ("gbench", "bmf", "latex", "methods"):
        p = s.tribench("export", "m", "--format", form, "--out", f"m.{form}")
        o = judge(f"export --format {form}", p, refused=False)
        o.dropped = not o.unclear and (s.root / f"m.{form}").stat().st_size < 100
        out.append(o)
    shutil.copytree(s.root / "m", s.root / "cut")
    rows = (s.root / "cut" / "batches.csv").read_text().splitlines(keepends=True)
    (s.root / "cut" / "batches.csv").write_text("".join(rows[: len(rows) // 2]))  # as a run stopped halfway
    shutil.copytree(s.root / "m", s.root / "raw")
    for derived in ("estimates.csv", "speedups.csv"):
        (s.root / "raw" / derived).unlink()
    (s.root / "afolder").mkdir()
    cases = {
        "an unfinished run": (["cut", "--format", "latex"], ("tribench",)),
        "an unanalysed run": (["raw", "--format", "methods"], ("tribench stats",)),
        "an unknown format": (["m", "--format", "csv"], ("--format",)),
        "--out a folder": (["m", "--out", "afolder"], ("folder",)),
        "--format latex over run.json": (["m", "--format", "latex", "--out", "m/run.json"], ("measured file",)),
    }
    for case, (args, words) in cases.items():
        out.append(judge(case, s.tribench("export", *args), refused=True, words=words))
    return out


def layout_cases(s: Scratch) -> list[Outcome]:
    """The moved layout: commands from another folder, a run folder renamed, a read-only run folder."""
    small_sweep(s, "m", "moller_seed,curless")
    (s.root / "else").mkdir()
    elsewhere = Scratch(s.root / "else", s.env)
    out = [
        judge("report from another folder", elsewhere.tribench("report", "../m"), refused=False),
        judge("export from another folder", elsewhere.tribench("export", str(s.root / "m"), "--format", "methods"),
              refused=False),
    ]  # fmt: skip
    (s.root / "m").rename(s.root / "renamed")
    out += [
        judge("report of a renamed run", s.tribench("report", "renamed"), refused=False),
        judge("stats of a renamed run", s.tribench("stats", "renamed"), refused=False),
        judge("resume of a renamed finished run", s.tribench("sweep", "--resume", "renamed", "--no-progress"),
              refused=False),
    ]  # fmt: skip
    return out + read_only_cases(s, s.root / "renamed")


def read_only_cases(s: Scratch, run: Path) -> list[Outcome]:
    """A run folder nobody may write: immutable (``chattr +i``, which holds for root too) where the file
    system has it; else no case."""
    if subprocess.run(["chattr", "-R", "+i", str(run)], capture_output=True).returncode != 0:
        return []
    try:
        return [
            judge("report of a read-only run", s.tribench("report", run.name), refused=True, words=("cannot write",)),
            judge("export of a read-only run", s.tribench("export", run.name, "--format", "latex"), refused=False),
        ]
    finally:
        subprocess.run(["chattr", "-R", "-i", str(run)], check=True)


def aarch64_cases(s: Scratch) -> list[Outcome]:
    """On aarch64 under qemu, with the package ``bash .ci/aarch64 WORK`` built into WORK (its folder named by
    $TRIBENCH_AARCH64_WORK; else no case): an x86 ISA asked of NEON's kernels, by variable and by flag."""
    work = Path(os.environ.get("TRIBENCH_AARCH64_WORK", "/nonexistent"))
    py = work / "root" / "usr" / "bin" / "python3.11"
    if not py.is_file():
        return []
    env = {**s.env, "QEMU_LD_PREFIX": str(work / "root"), "PYTHONPATH": str(work / "site")}
    arm, out = [str(py), "-m", "tribench.cli"], []
    for case, extra, args, words in (
        ("TRIBENCH_ISA=avx2", {"TRIBENCH_ISA": "avx2"}, ["validate", "--kernels", "moller_trumbore_fma", "--quick"],
         ("TRIBENCH_ISA='avx2'", "neon")),
        ("info --peak --isa avx2", {}, ["info", "--peak", "--isa", "avx2"], ("--isa avx2", "neon")),
        ("info --isa of no ISA", {}, ["info", "--peak", "--isa", "sse9"], ("--isa",)),
    ):  # fmt: skip
        p = Scratch(s.root, {**env, **extra}).run([*arm, *args], 300)
        o = judge(f"aarch64: {case}", p, refused=True, words=words)
        o.command = " ".join([*(f"{k}={v}" for k, v in extra.items()), "(aarch64, qemu) tribench", *args])
        out.append(o)
    return out


CLASSES: dict[str, Callable[[Scratch], list[Outcome]]] = {
    "#53.1 the user's kernel code": kernel_code_cases,
    "#53.2 flags silently dropped": dropped_flag_cases,
    "#53.3 sweep.toml reproduces the run": sweep_file_cases,
    "#53.4 tracebacks": traceback_cases,
    "#53.5 hangs and strays": hang_cases,
    "#53.6 data lost": data_lost_cases,
    "#53.7 messages": message_cases,
    "new: the five new kernels": new_kernel_cases,
    "new: replicate": replicate_cases,
    "new: export": export_cases,
    "new: the moved layout": layout_cases,
    "new: aarch64 under qemu": aarch64_cases,
}


@pytest.mark.slow
@pytest.mark.parametrize("name", list(CLASSES))
def test_every_hostile_case_is_done_or_refused_in_one_clear_line(name, tmp_path):
    outcomes = run_class(CLASSES[name], tmp_path)
    if not outcomes and CLASSES[name] is aarch64_cases:
        pytest.skip("no aarch64 build: TRIBENCH_AARCH64_WORK=WORK after bash .ci/aarch64 WORK")
    assert outcomes and not failures(outcomes), failures(outcomes)
