"""A hostile user's cases, class by class: each must end done (exit 0) or refused (exit 2) in one clear
line, with no traceback, no crash, no hang, no flag dropped and, for interrupted sweeps, no batch lost or
duplicated after a resume. The classes of issue #53 and the newer surfaces are in ``test_hostile_new.py``.

Every case runs the installed ``tribench`` command (or, for the notebook API, a fresh Python) in a scratch
folder and cache; :func:`judge` classes what a user sees:
  crash         exit status other than 0 (done), 2 (refused) and, where the case expects a measurement to
                fail (a kernel that aborts in a worker), 1; or a signal;
  traceback     a Python traceback on either stream;
  hang          the command (or a process it left) still running at the case's time limit;
  unclear       refused, but not in one line naming what the case expects;
  silent drop   done, but a flag or input it took had no effect (the case checks the effect);
  rows lost     measured rows missing, duplicated or overwritten.

The table of every class (the issue's closing note), from the repository with the package installed:
    .venv/bin/python tests/test_hostile.py [WORD ...]      (only the classes whose name holds a WORD)
with TRIBENCH_AARCH64_WORK=WORK after ``bash .ci/aarch64 WORK``, the aarch64 class runs too.
"""

from __future__ import annotations

import json
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
HUNG = -1000  # no exit status: the case's time limit stopped it


@dataclass
class Outcome:
    case: str
    command: str
    crash: bool = False
    traceback: bool = False
    hang: bool = False
    unclear: bool = False
    dropped: bool = False
    rows_lost: int = 0
    said: str = ""  # the last line the user saw

    @property
    def failed(self) -> bool:
        return self.crash or self.traceback or self.hang or self.unclear or self.dropped or self.rows_lost > 0


@dataclass
class Scratch:
    root: Path
    env: dict[str, str] = field(default_factory=dict)

    def tribench(self, *args: str, timeout: float = 300) -> subprocess.CompletedProcess:
        return self.run(["tribench", *args], timeout)

    def python(self, code: str, timeout: float = 300) -> subprocess.CompletedProcess:
        return self.run([sys.executable, "-c", code], timeout)

    def run(self, argv: list[str], timeout: float) -> subprocess.CompletedProcess:
        """``argv`` in a session of its own: past ``timeout``, or with a process left behind once it ended,
        the whole session is killed and the case is a hang."""
        p = subprocess.Popen(
            argv, cwd=self.root, env=self.env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
            start_new_session=True,
        )  # fmt: skip
        try:
            stdout, stderr = p.communicate(timeout=timeout)
        except subprocess.TimeoutExpired:  # a worker holding the pipes counts too
            _kill_session(p.pid)
            stdout, stderr = p.communicate()
            return subprocess.CompletedProcess(argv, HUNG, stdout, stderr)
        return subprocess.CompletedProcess(argv, HUNG if _kill_session(p.pid) else p.returncode, stdout, stderr)


def _kill_session(pid: int, grace: float = 2.0) -> bool:
    """Whether a process of ``pid``'s session was still there after ``grace`` seconds (then killed)."""
    end = time.monotonic() + grace
    while True:
        try:
            os.killpg(pid, 0)
        except ProcessLookupError:
            return False
        if time.monotonic() > end:
            os.killpg(pid, signal.SIGKILL)
            return True
        time.sleep(0.05)


def judge(
    case: str,
    p: subprocess.CompletedProcess,
    *,
    refused: bool,
    words: tuple[str, ...] = (),
    quoted: bool = False,
    code: int = 2,
) -> Outcome:
    """Class one finished command: done (exit 0) or refused (exit ``code``, 2 for a user's error, 1 for a
    measurement that failed, in one line holding ``words``; with ``quoted``, that line may be followed by what
    it quotes: a compiler's diagnostics, the failed checks)."""
    text = p.stdout + p.stderr
    o = Outcome(case, " ".join(map(str, p.args)) if isinstance(p.args, list) else str(p.args))
    o.hang = p.returncode == HUNG
    o.crash = not o.hang and p.returncode not in (0, 2, code)
    o.traceback = "Traceback (most recent call last)" in text
    o.said = (text.strip().splitlines() or [""])[-1][:200]
    if o.hang:
        return o
    if refused:
        lines = [line for line in p.stderr.splitlines() if line.strip()] or [""]
        said = lines[0] if quoted else p.stderr
        one = quoted or len(lines) == 1
        if code != 2:  # a measurement that failed: after the lines of a run that started, its one last line
            said, one = lines[-1], True
        o.unclear = p.returncode != code or not one or not all(w.lower() in said.lower() for w in words)
    else:
        o.unclear = p.returncode != 0
    return o


def planned(run: Path) -> dict:
    """The plan a run folder recorded (``run.json``'s sweep), or {} if it has none."""
    try:
        return json.loads((run / "run.json").read_text())["sweep"]
    except (OSError, ValueError, KeyError):
        return {}


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
        args += ["--out", run, "--processes", "2", "--rounds", "4", "--target-ms", "1", "--pairs", "20000"]
        p = subprocess.Popen(args, cwd=s.root, env=s.env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        time.sleep(delay)
        p.send_signal(signal.SIGINT)
        stdout, stderr = p.communicate(timeout=120)
        first = subprocess.CompletedProcess(args, 0 if p.returncode in (0, 130, 2) else p.returncode, stdout, stderr)
        o = judge(f"Ctrl-C after {delay:g} s", first, refused=False)
        o.unclear = p.returncode != 0 and "tribench sweep --resume" not in stderr and "tribench stats" not in stderr
        resumed = s.tribench("sweep", "--resume", run, "--no-progress")
        r = judge(f"resume after Ctrl-C at {delay:g} s", resumed, refused=False)
        out += [o, r]
        if not (s.root / run / "batches.csv").is_file():  # refused (then said so above), or nothing run yet
            continue
        batches = pd.read_csv(s.root / run / "batches.csv")
        planned = json.loads((s.root / run / "run.json").read_text())["sweep"]
        expected = planned["processes"] * (planned["rounds"] + planned.get("warmup", 1)) * len(planned["kernels"])
        expected *= len(planned["workloads"])
        keys = batches[["process", "round", "kernel", "workload_id"]].astype(str).agg("|".join, axis=1)
        r.rows_lost = abs(expected - keys.nunique()) + int(keys.duplicated().sum())
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


CLASSES: dict[str, Callable[[Scratch], list[Outcome]]] = {
    "earlier: compare": compare_cases,
    "earlier: cache": cache_cases,
    "earlier: coordinates past float range": overflow_cases,
    "earlier: notebook API": api_cases,
    "earlier: interrupted sweeps": interrupted_cases,
    "earlier: huge scenes": huge_scene_cases,
    "earlier: time intervals": interval_cases,
    "earlier: ray files": ray_file_cases,
    "earlier: native Embree peer": embree_cases,
    "earlier: kernel files": kernel_file_cases,
    "earlier: builds": build_cases,
}


def run_class(cases: Callable[[Scratch], list[Outcome]], root: Path) -> list[Outcome]:
    """One class's cases in ``root`` with a cache of their own; commands shown relative to ``root``."""
    env = {**os.environ, "TRIBENCH_CACHE": str(root / "cache"), "PATH": f"{TRIBENCH.parent}:{os.environ['PATH']}"}
    outcomes = cases(Scratch(root, env))
    for o in outcomes:
        o.command = o.command.replace(f"{root}/", "").replace(sys.executable, "python")
    return outcomes


def failures(outcomes: list[Outcome]) -> str:
    return "\n".join(f"{o.case}: {o.command}\n  said: {o.said}" for o in outcomes if o.failed)


COLUMNS = ("crashes", "tracebacks", "hangs", "unclear errors", "silent drops", "rows lost")


def table(results: dict[str, list[Outcome]]) -> str:
    """The Markdown table of every class, then each class's commands with what was wrong with any."""
    head = ["class", "cases tried", *COLUMNS]
    rows = [head, ["---"] * len(head)]
    for name, outcomes in results.items():
        counts = [sum(getattr(o, a) for o in outcomes) for a in ("crash", "traceback", "hang", "unclear", "dropped")]
        rows.append([name, len(outcomes), *counts, sum(o.rows_lost for o in outcomes)])
    rows.append(["all", *(sum(r[i] for r in rows[2:]) for i in range(1, len(head)))])
    lines = ["| " + " | ".join(map(str, r)) + " |" for r in rows]
    for name, outcomes in results.items():
        lines += ["", f"**{name}**", ""]
        for o in outcomes:
            wrong = [a for a in ("crash", "traceback", "hang", "unclear", "dropped", "rows_lost") if getattr(o, a)]
            command = o.command.replace("\n", "; ").replace("`", "'")
            lines.append(f"- {o.case}: `{command}`" + (f" **{', '.join(wrong)}**: {o.said}" if wrong else ""))
    return "\n".join(lines)


def every_class() -> dict[str, Callable[[Scratch], list[Outcome]]]:
    import test_hostile_new

    return {**test_hostile_new.CLASSES, **CLASSES}


def main(words: list[str]) -> int:
    import tempfile

    results = {}
    for name, cases in every_class().items():
        if words and not any(w.lower() in name.lower() for w in words):
            continue
        t0 = time.monotonic()
        with tempfile.TemporaryDirectory(prefix="hostile-") as root:
            try:
                results[name] = run_class(cases, Path(root))
            except Exception as exc:  # the class's own code failed: its row says so, the other rows still come
                results[name] = [Outcome("the class's own code", name, crash=True, said=f"{type(exc).__name__}: {exc}")]
        print(f"{name}: {len(results[name])} cases in {time.monotonic() - t0:.0f} s", file=sys.stderr)
    print(table(results))
    return 1 if any(o.failed for outcomes in results.values() for o in outcomes) else 0


@pytest.mark.slow
@pytest.mark.parametrize("name", list(CLASSES))
def test_every_hostile_case_is_done_or_refused_in_one_clear_line(name, tmp_path):
    outcomes = run_class(CLASSES[name], tmp_path)
    assert outcomes and not failures(outcomes), failures(outcomes)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
