"""A hostile user's cases, class by class: each must end done (exit 0) or refused (exit 2) in one clear
line, with no traceback, no crash and, for interrupted sweeps, no batch lost or duplicated after a resume.

Every case runs the installed ``tribench`` command (or, for the notebook API, a fresh Python) in a scratch
folder and cache; :func:`judge` classes what a user sees:
  crash      exit status other than 0 (done) and 2 (refused), or a signal;
  traceback  a Python traceback on either stream;
  unclear    refused, but not in one line naming what the case expects;
  rows lost  for interrupted sweeps: planned batches missing or duplicated after ``--resume``.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from conftest import TRIBENCH

SMALL = ["--processes", "2", "--rounds", "2", "--target-ms", "1", "--pairs", "200", "--no-progress"]


@dataclass
class Outcome:
    case: str
    command: str
    crash: bool = False
    traceback: bool = False
    unclear: bool = False
    rows_lost: int = 0
    said: str = ""  # the last line the user saw

    @property
    def failed(self) -> bool:
        return self.crash or self.traceback or self.unclear or self.rows_lost > 0


@dataclass
class Scratch:
    root: Path
    env: dict[str, str] = field(default_factory=dict)

    def tribench(self, *args: str, timeout: float = 300) -> subprocess.CompletedProcess:
        return subprocess.run(
            ["tribench", *args], cwd=self.root, env=self.env, capture_output=True, text=True, timeout=timeout
        )

    def python(self, code: str) -> subprocess.CompletedProcess:
        return subprocess.run(
            [sys.executable, "-c", code], cwd=self.root, env=self.env, capture_output=True, text=True, timeout=300
        )


def judge(
    case: str, p: subprocess.CompletedProcess, *, refused: bool, words: tuple[str, ...] = (), quoted: bool = False
) -> Outcome:
    """Class one finished command: done (exit 0) or refused (exit 2 in one line holding ``words``; with
    ``quoted``, that line may be followed by what it quotes: a compiler's diagnostics, the failed checks)."""
    text = p.stdout + p.stderr
    o = Outcome(case, " ".join(p.args) if isinstance(p.args, list) else str(p.args))
    o.crash = p.returncode not in (0, 2)
    o.traceback = "Traceback (most recent call last)" in text
    o.said = (text.strip().splitlines() or [""])[-1][:200]
    if refused:
        lines = [line for line in p.stderr.splitlines() if line.strip()] or [""]
        said = lines[0] if quoted else p.stderr
        one = quoted or len(lines) == 1
        o.unclear = p.returncode != 2 or not one or not all(w.lower() in said.lower() for w in words)
    else:
        o.unclear = p.returncode != 0
    return o


def small_sweep(s: Scratch, out: str, kernels: str, *extra: str) -> subprocess.CompletedProcess:
    return s.tribench("sweep", "--kernels", kernels, "--hit-rates", "0.5", "--out", out, *SMALL, *extra)


# ---------------------------------------------------------------- the classes


def compare_cases(s: Scratch) -> list[Outcome]:
    small_sweep(s, "a", "moller_seed,curless")
    small_sweep(s, "b", "moller_seed,moller_trumbore")
    return [
        judge("runs that share only the baseline", s.tribench("compare", "a", "b", "--out", "c.html"), refused=False),
        judge("a run given twice", s.tribench("compare", "a", "a"), refused=True, words=("twice",)),
        judge("a folder that is no run", s.tribench("compare", "a", "."), refused=True),
    ]


def moved_mesh_cases(s: Scratch) -> list[Outcome]:
    import trimesh

    trimesh.creation.icosphere(subdivisions=2).export(s.root / "one.obj")
    p = s.tribench(
        "sweep", "--kernels", "moller_seed,curless", "--mesh", "one.obj", "--camera", "8x8", "--out", "m", *SMALL
    )
    (s.root / "one.obj").rename(s.root / "moved.obj")
    return [
        judge("sweep on a mesh file", p, refused=False),
        judge("report after the mesh moved", s.tribench("report", "m"), refused=False),
        judge("export after the mesh moved", s.tribench("export", "m", "--out", "m.json"), refused=False),
    ]


def cache_cases(s: Scratch) -> list[Outcome]:
    out = []
    small_sweep(s, "w1", "moller_seed")
    files = sorted((Path(s.env["TRIBENCH_CACHE"])).rglob("*.npz"))
    files[0].write_bytes(b"not a workload")  # corrupt: detected and rebuilt
    out.append(judge("a corrupt workload file", small_sweep(s, "w2", "moller_seed"), refused=False))
    files[0].unlink()
    files[0].mkdir()  # a folder in its place
    out.append(judge("a folder in place of a workload file", small_sweep(s, "w3", "moller_seed"), refused=False))
    bvh = ["--kernels", "moller_trumbore_fma", "--mesh", "suzanne", "--accel", "bvh", "--camera", "8x8"]
    bvh += ["--processes", "2", "--rounds", "2", "--target-ms", "1", "--no-progress"]
    out.append(judge("a BVH sweep", s.tribench("sweep", *bvh, "--out", "b1"), refused=False))
    trees = sorted((Path(s.env["TRIBENCH_CACHE"]) / "bvh").rglob("*.npz"))
    if trees:
        trees[0].unlink()
        trees[0].mkdir()  # a folder in a tree file's place
        out.append(judge("a folder in place of a BVH file", s.tribench("sweep", *bvh, "--out", "b2"), refused=False))
        trees[0].rmdir()
        trees[0].symlink_to(s.root / "elsewhere.npz")  # a link in its place
        out.append(judge("a link in place of a BVH file", s.tribench("sweep", *bvh, "--out", "b3"), refused=False))
    out.append(judge("tribench cache list", s.tribench("cache", "list"), refused=False))
    out.append(judge("tribench cache prune", s.tribench("cache", "prune", "--max-size", "1MB"), refused=False))
    out.append(
        judge(
            "a size that is no size", s.tribench("cache", "prune", "--max-size", "lots"), refused=True, words=("lots",)
        )
    )
    return out


def overflow_cases(s: Scratch) -> list[Outcome]:
    v = np.array([[0, 0, 0], [1e300, 0, 0], [0, 1e300, 0]])
    (s.root / "huge.obj").write_text("".join(f"v {a} {b} {c}\n" for a, b, c in v) + "f 1 2 3\n")
    return [
        judge(
            f"coordinates near 1e300, {what}",
            s.tribench(*args),
            refused=True,
            words=("overflow",),
        )
        for what, args in (
            ("brute-force sweep", ["sweep", "--kernels", "moller_seed", "--mesh", "huge.obj", "--out", "h", *SMALL]),
            ("workloads make --accel bvh", ["workloads", "make", "huge.obj", "--accel", "bvh"]),
            ("peers", ["peers", "--mesh", "huge.obj", "--quick", "--out", "p.csv"]),
        )
    ]


API_CASES = {
    "sweep(None)": "tribench.sweep(None, [tribench.PairSpec(n=10, hit_rate=0.5)])",
    "sweep of a string": "tribench.sweep('moller_trumbore', [tribench.PairSpec(n=10, hit_rate=0.5)])",
    "one spec for a list": "tribench.sweep(['moller_seed'], tribench.PairSpec(n=10, hit_rate=0.5))",
    "out=5": "tribench.sweep(['moller_seed'], [tribench.PairSpec(n=10, hit_rate=0.5)], out=5)",
    "load(3)": "tribench.load(3)",
    "load(None)": "tribench.load(None)",
    "compare of names": "tribench.compare(['a', 'b'])",
    "run(quick='yes')": "tribench.run(quick='yes')",
    "progress='no'": "tribench.sweep(['moller_seed'], [tribench.PairSpec(n=10, hit_rate=0.5)], progress='no')",
}


def api_cases(s: Scratch) -> list[Outcome]:
    out = []
    for case, call in API_CASES.items():
        code = (
            "import sys, tribench\nfrom tribench.common import UserError\n"
            f"try:\n    {call}\nexcept UserError as e:\n"
            "    print(e, file=sys.stderr)\n    sys.exit(2 if len(str(e).splitlines()) == 1 else 3)\n"
        )
        out.append(judge(case, s.python(code), refused=True))
    return out


def interrupted_cases(s: Scratch) -> list[Outcome]:
    """SIGINT a sweep mid-run, resume it: every planned batch exactly once."""
    out = []
    for delay in (3.0, 6.0):
        run = f"i{delay:g}"
        args = ["tribench", "sweep", "--kernels", "moller_seed,curless,moller_trumbore", "--hit-rates", "0.2,0.8"]
        args += ["--out", run, *SMALL[:-3], "--pairs", "20000", "--rounds", "4"]
        p = subprocess.Popen(args, cwd=s.root, env=s.env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        time.sleep(delay)
        p.send_signal(signal.SIGINT)
        stdout, stderr = p.communicate(timeout=120)
        first = subprocess.CompletedProcess(args, 0 if p.returncode in (0, 130, 2) else p.returncode, stdout, stderr)
        o = judge(f"Ctrl-C after {delay:g} s", first, refused=False)
        o.unclear = p.returncode != 0 and "tribench sweep --resume" not in stderr and "tribench stats" not in stderr
        resumed = s.tribench("sweep", "--resume", run, "--no-progress")
        r = judge(f"resume after Ctrl-C at {delay:g} s", resumed, refused=False)
        batches = pd.read_csv(s.root / run / "batches.csv")
        import json

        planned = json.loads((s.root / run / "run.json").read_text())["sweep"]
        expected = planned["processes"] * (planned["rounds"] + planned.get("warmup", 1)) * len(planned["kernels"])
        expected *= len(planned["workloads"])
        keys = batches[["process", "round", "kernel", "workload_id"]].astype(str).agg("|".join, axis=1)
        r.rows_lost = abs(expected - keys.nunique()) + int(keys.duplicated().sum())
        out += [o, r]
    out.append(late_ctrl_c_case(s))
    return out


def late_ctrl_c_case(s: Scratch) -> Outcome:
    """Ctrl-C 50 ms after a sweep's last line, while Python tears down: a finished command stays finished."""
    args = ["tribench", "sweep", "--kernels", "moller_seed,curless", "--hit-rates", "0.5", "--out", "late", *SMALL]
    p = subprocess.Popen(args, cwd=s.root, env=s.env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    said = []
    for line in p.stderr:  # type: ignore[union-attr]
        said.append(line)
        if line.startswith("next:"):
            time.sleep(0.05)
            p.send_signal(signal.SIGINT)
            break
    stdout, stderr = p.communicate(timeout=120)
    done = subprocess.CompletedProcess(args, p.returncode, stdout, "".join(said) + stderr)
    o = judge("Ctrl-C as the sweep ends", done, refused=False)
    o.crash, o.unclear = p.returncode not in (0, 130), False
    return o


def huge_scene_cases(s: Scratch) -> list[Outcome]:
    from tribench.workloads.seed import scene as seed_scene

    line = "tri -1 -1 -2  0 1 -2.5  0 -1 -3\n"
    (s.root / "huge.txt").write_text("source 0 3 1 1 1 1\n" + line * (seed_scene.MAX_TRIANGLES + 1))
    return [
        judge(
            "a scene past the triangle bound",
            s.tribench("seed", "--quick", "--scene", "huge.txt", "--out", "sd"),
            refused=True,
            words=("triangles",),
        )
    ]


def interval_cases(s: Scratch) -> list[Outcome]:
    p = small_sweep(s, "t2", "moller_seed,curless")
    o = judge("two processes: a time's interval", p, refused=False)
    est = pd.read_csv(s.root / "t2" / "estimates.csv")
    o.unclear = o.unclear or bool((est["ns_per_test_ci_low"] <= 0).any())
    return [o]


def ray_file_cases(s: Scratch) -> list[Outcome]:
    if "--rays" not in s.tribench("sweep", "--help").stdout:
        return []
    rng = np.random.default_rng(0)
    good = {"origins": rng.normal(size=(64, 3)) + [0, 0, -4], "directions": np.tile([0.0, 0, 1], (64, 1))}
    bad = {
        "NaN in origins": {**good, "origins": np.where(np.arange(64)[:, None] == 5, np.nan, good["origins"])},
        "a zero direction": {**good, "directions": np.vstack([good["directions"][:-1], [0, 0, 0]])},
        "origins of shape (N, 2)": {**good, "origins": good["origins"][:, :2]},
        "integer arrays": {k: v.astype(np.int64) for k, v in good.items()},
        "no directions": {"origins": good["origins"]},
    }
    out = []
    np.savez(s.root / "good.npz", **good)
    out.append(
        judge(
            "a good ray file",
            s.tribench(
                "sweep", "--kernels", "moller_seed", "--mesh", "suzanne", "--rays", "good.npz", "--out", "r", *SMALL
            ),
            refused=False,
        )
    )
    for case, arrays in bad.items():
        np.savez(s.root / "bad.npz", **arrays)
        p = s.tribench(
            "sweep",
            "--kernels",
            "moller_seed",
            "--mesh",
            "suzanne",
            "--rays",
            "bad.npz",
            "--out",
            f"r-{len(out)}",
            *SMALL,
        )
        out.append(judge(case, p, refused=True, words=("bad.npz",)))
    (s.root / "junk.npz").write_bytes(b"PK\x03\x04 not really")
    p = s.tribench(
        "sweep", "--kernels", "moller_seed", "--mesh", "suzanne", "--rays", "junk.npz", "--out", "rj", *SMALL
    )
    out.append(judge("a file that is no npz", p, refused=True, words=("junk.npz",)))
    return out


def embree_cases(s: Scratch) -> list[Outcome]:
    """The native Embree peer: a run, its compiled module damaged in the cache, coordinates past its range."""
    quick = ["peers", "--quick", "--accel", "bvh", "--triangles", "2000"]
    out = [judge("peers --accel bvh with native Embree", s.tribench(*quick, "--out", "p1"), refused=False)]
    for module in (Path(s.env["TRIBENCH_CACHE"]) / "kernel_builds").rglob("_embree_*.so"):
        module.write_bytes(b"not a module")  # detected on import, compiled again
    out.append(judge("a damaged native Embree module", s.tribench(*quick, "--out", "p2"), refused=False))
    v = np.array([[0, 0, 0], [1e20, 0, 0], [0, 1e20, 0], [0, 0, 1e20]])  # finite in float32, its squares are not
    faces = "f 1 2 3\nf 1 3 4\nf 1 4 2\nf 2 4 3\n"
    (s.root / "far.obj").write_text("".join(f"v {a} {b} {c}\n" for a, b, c in v) + faces)
    p = s.tribench("peers", "--quick", "--mesh", "far.obj", "--triangles", "4", "--out", "p3")
    out.append(judge("peers on a mesh past float32's range", p, refused=True, words=("float32", "overflow")))
    return out


EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "kernels" / "my_moller.c"


def kernel_file_cases(s: Scratch) -> list[Outcome]:
    """A user's own kernel file: missing, a folder, empty, junk, not compiling, a built-in's name, wrong answers."""
    text = EXAMPLE.read_text()
    files = {
        "empty.c": "",
        "junk.c": "\x00\x01 not C at all \xff",
        "typo.c": text.replace("my_moller", "typo_moller").replace("sign * det;", "sign * dett;"),
        "clash.c": text.replace("my_moller", "moller_trumbore"),
        "sloppy.c": text.replace("my_moller", "sloppy_moller").replace("v >= 0 &&", "v >= -0.01f * abs_det &&"),
    }
    for name, body in files.items():
        (s.root / name).write_text(body)
    (s.root / "folder.c").mkdir()
    cases = {"no such file": "missing.c", "a folder": "folder.c", **{f"{n}": n for n in files}}
    out = []
    for case, name in cases.items():
        p = s.tribench("sweep", "--kernel-file", name, "--out", f"k-{len(out)}", *SMALL)
        said = (name,) if name != "sloppy.c" else ("sloppy_moller", "refused")
        out.append(judge(case, p, refused=True, words=said, quoted=True))
    good = s.tribench(
        "sweep", "--kernel-file", str(EXAMPLE), "--kernels", "my_moller,moller_seed", "--out", "k", *SMALL
    )
    out.append(judge("the example kernel file", good, refused=False))
    return out


def build_cases(s: Scratch) -> list[Outcome]:
    """--builds: no such compiler, an unknown flag, flags that write elsewhere, a shell in the spec, one build."""
    marker = s.root / "pwned"
    cases = {
        "no such compiler": ("installed;nosuchcc -O2", ("nosuchcc",)),
        "an unknown flag": ("installed;gcc -fno-such-flag", ("-fno-such-flag",)),
        "a flag that writes elsewhere": ("installed;gcc -O2 -o/tmp/x", ("writes",)),
        "a shell in the spec": (f"installed;gcc -O2 $(touch {marker})", ("$(touch",)),
        "one build only": ("installed", ("two",)),
        "a trailing separator": ("installed;", ("spec",)),
    }
    may_run = ("a shell in the spec", "one build only", "a trailing separator")
    out = []
    for case, (spec, words) in cases.items():
        four = [*SMALL[:1], "4", *SMALL[2:]]  # two builds need four processes
        p = s.tribench("sweep", "--kernels", "moller_seed", "--builds", spec, "--out", f"b-{len(out)}", *four)
        must_refuse = case not in may_run
        o = judge(case, p, refused=must_refuse or p.returncode != 0, words=words, quoted=True)
        o.crash |= marker.exists()  # a spec is never run by a shell
        out.append(o)
    return out


def replicate_cases(s: Scratch) -> list[Outcome]:
    """``tribench replicate`` and the paper exports: a run whose mesh file moved, folders that are no run or
    no replication, outputs over a measured file."""
    import trimesh

    trimesh.creation.icosphere(subdivisions=2).export(s.root / "one.obj")
    made = s.tribench(
        "sweep", "--kernels", "moller_seed,curless", "--mesh", "one.obj", "--camera", "8x8", "--out", "m", *SMALL
    )
    (s.root / "one.obj").rename(s.root / "moved.obj")  # as on another machine: only the run folder's copy
    return [
        judge("sweep on a mesh file", made, refused=False),
        judge(
            "replicate after the mesh moved", s.tribench("replicate", "m", "--out", "r", "--no-progress"), refused=False
        ),
        judge("the replication's report", s.tribench("report", "r"), refused=False),
        judge("replicate into the run", s.tribench("replicate", "m", "--out", "m"), refused=True, words=("not empty",)),
        judge("replicate a folder that is no run", s.tribench("replicate", "."), refused=True, words=("run.json",)),
        judge(
            "resume what is no replication",
            s.tribench("replicate", "m", "--resume", "m"),
            refused=True,
            words=("no replication",),
        ),
        judge(
            "resume with --out",
            s.tribench("replicate", "m", "--resume", "r", "--out", "x"),
            refused=True,
            words=("--out",),
        ),
        judge(
            "latex over run.json",
            s.tribench("export", "m", "--format", "latex", "--out", "m/run.json"),
            refused=True,
            words=("measured file",),
        ),
        judge("methods of the replication", s.tribench("export", "r", "--format", "methods"), refused=False),
    ]


CLASSES: dict[str, Callable[[Scratch], list[Outcome]]] = {
    "1 compare": compare_cases,
    "2 moved mesh file": moved_mesh_cases,
    "3 cache": cache_cases,
    "4 coordinates past float range": overflow_cases,
    "5 notebook API": api_cases,
    "6 interrupted sweeps": interrupted_cases,
    "7 huge scenes": huge_scene_cases,
    "8 time intervals": interval_cases,
    "new: ray files": ray_file_cases,
    "new: native Embree peer": embree_cases,
    "new: kernel files": kernel_file_cases,
    "new: builds": build_cases,
    "new: replicate and exports": replicate_cases,
}


@pytest.mark.slow
@pytest.mark.parametrize("name", list(CLASSES))
def test_every_hostile_case_is_done_or_refused_in_one_clear_line(name, tmp_path):
    env = {**os.environ, "TRIBENCH_CACHE": str(tmp_path / "cache"), "PATH": f"{TRIBENCH.parent}:{os.environ['PATH']}"}
    outcomes = CLASSES[name](Scratch(tmp_path, env))
    failed = [f"{o.case}: {o.command}\n  said: {o.said}" for o in outcomes if o.failed]
    assert outcomes and not failed, "\n".join(failed)
