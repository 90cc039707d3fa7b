"""Every command example the README and docs/ give, and ``tribench workloads``'s docstring, run as a user runs it.

The examples are read from the documents themselves, so a new example fails
here until it has a concrete form below, and a broken one fails like it would
for a user (``workloads make`` once failed for every KIND while its own tests,
which built their own parser, passed). Sizes are appended or chosen tiny so
the whole file takes seconds per command.
"""

from __future__ import annotations

import json
import re
import shlex
import shutil
from pathlib import Path

import numpy as np
import pytest
from test_cli import run

from tribench.cli import workloads as workloads_cli
from tribench.cli.command import build_parser
from tribench.workloads.seed.scene import builtin_scene_path

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
COMMANDS_DOC = ROOT / "docs" / "commands.md"

# A sweep as small as a sweep gets: 2 processes x 1 round of 0.05 ms batches.
TINY_DESIGN = ["--processes", "2", "--rounds", "1", "--warmup", "0", "--target-ms", "0.05", "--no-progress"]


def table_examples(path: Path) -> list[str]:
    """The backticked commands in the first column of a document's command tables."""
    examples = []
    for line in path.read_text(encoding="utf-8").splitlines():
        cells = line.split(" | ")
        if line.startswith("| `tribench ") and len(cells) >= 2:
            examples += re.findall(r"`([^`]+)`", cells[0])
    return examples


def heading_examples(path: Path) -> list[str]:
    """The backticked commands of a document's headings that are nothing but commands (docs/commands.md's
    sections: ``### `tribench workloads make KIND …` / `list` / `show ID [--png FILE]` ``)."""
    examples = []
    for line in path.read_text(encoding="utf-8").splitlines():
        if re.fullmatch(r"#+ `tribench [^`]+`( / `[^`]+`)*", line):
            examples += re.findall(r"`([^`]+)`", line)
    return examples


def readme_examples() -> list[str]:
    """Every command example the documentation gives: the README's command table, and the command
    tables and command headings of every page in docs/."""
    examples = table_examples(README)
    for page in sorted((ROOT / "docs").glob("*.md")):
        examples += table_examples(page) + heading_examples(page)
    return examples


def docstring_examples() -> list[str]:
    """The command lines of the Examples block of tribench.cli.workloads, without their comments."""
    block = workloads_cli.__doc__.split("Examples")[1]
    return [line.split("#")[0].strip() for line in block.splitlines() if line.strip().startswith("tribench ")]


# Each README example -> the concrete command lines that exercise it ({tmp}, {run}, {mesh}, {scene} filled in).
# `run` and `info --peak` take minutes and seconds: test_cli runs `run --quick` end to end, test_main_job
# resumes an interrupted main job, and
# test_cli_flags interrupts `info --peak` once it has started; here they are only parsed.
# run, or resumed with a run of their own elsewhere (test_replicate.py resumes a replication)
SLOW = {"run --quick", "run", "run --resume {run}", "info --peak", "replicate {run} --resume {run_b}"}
CONCRETE = {
    "tribench info [--peak]": ["info", "info --peak"],
    "tribench run [--quick] [--resume RUN_DIR]": ["run", "run --quick", "run --resume {run}"],
    "tribench seed [--scene FILE] [--quick] [--all-kernels]": [
        "seed --scene {scene} --quick --all-kernels --size 12 --sample 24 --no-progress --out {tmp}/seed"
    ],
    "tribench workloads make KIND …": [
        "workloads make pairs --n 300",
        "workloads make icosphere --triangles 80 --width 8 --height 8",
        "workloads make icosphere --triangles 80 --width 8 --height 8 --accel bvh",
    ],
    "list": ["workloads list"],
    "show ID [--png FILE]": ["workloads show {mesh} --png {tmp}/mesh.png", "workloads show {mesh}"],
    "tribench cache list": ["cache list"],
    "tribench cache prune [--max-size SIZE] [--dry-run]": ["cache prune --dry-run", "cache prune --max-size 1GB"],
    "tribench sweep --kernels … --hit-rates … --mesh suzanne --triangles 100,968 --out RUN_DIR": [
        "sweep --kernels moller_trumbore,curless --hit-rates 0.2,0.8 --pairs 100 --mesh suzanne "
        "--triangles 100,968 --camera 6x6 --out {tmp}/sweep " + shlex.join(TINY_DESIGN)
    ],
    "tribench peers [--quick] [--mesh FILE] [--accel bvh] [--out RUN_DIR]": [
        "peers --quick --camera 8x8 --processes 2 --reps 1 --no-progress --out {run}",
        "peers --quick --accel bvh --triangles 200 --camera 8x8 --processes 2 --reps 1 --no-progress "
        "--out {tmp}/peers.csv",
        "peers --quick --mesh icosphere --accel bvh --camera 8x8 --processes 2 --reps 1 --no-progress "
        "--out {tmp}/peers-icosphere.csv",
    ],
    "tribench stats RUN_DIR [--baseline NAME]": ["stats {run}", "stats {run} --baseline curless"],
    "tribench validate [--kernels K …] [--dtype D …] [--quick] [--out FILE.csv]": [
        "validate --kernels moller_trumbore curless --dtype float32 --quick --out {tmp}/v.csv"
    ],
    # test_sweep's calibrate design: with TINY_DESIGN's one degree of freedom a loaded machine's A/A noise floor
    # passed the largest usable margin and the command rightly refused to save it
    "tribench calibrate": [
        "calibrate --processes 4 --experiments 1 --rounds 3 --warmup 0 --target-ms 0.5 --no-progress --out {tmp}/cal"
    ],
    "tribench report RUN_DIR": ["report {run}"],
    "tribench compare RUN RUN [RUN …] [--out FILE] [--fail-if-slower]": [
        "compare {run} {run_b} --out {tmp}/compare.html",
        "compare {run} {run_b} --fail-if-slower",  # a copy: no kernel is slower, the gate passes
        "compare {run} {run_b} {run_c} --out {tmp}/compare3.html",
    ],
    "tribench replicate RUN_DIR [--out NEW_DIR] [--resume NEW_DIR]": [
        "replicate {run} --out {tmp}/rep --no-progress",
        "replicate {run} --resume {run_b}",
    ],
    "tribench export RUN_DIR [--format FORMAT] [--out FILE]": [
        "export {run}",
        "export {run} --out {tmp}/gbench.json",
        "export {run} --format latex --out {tmp}/ranking.tex",
        "export {run} --format methods",
        "export {run} --format bmf",
    ],
}


@pytest.fixture(scope="module")
def env(tmp_path_factory):
    """A workload cache (and so a user calibration) of this module's own, and a HOME with a mesh file."""
    root = tmp_path_factory.mktemp("cli-examples")
    (root / "home" / "meshes").mkdir(parents=True)
    import trimesh

    trimesh.creation.icosphere(subdivisions=5).export(root / "home" / "meshes" / "bunny.ply")  # 20480 faces
    return {"TRIBENCH_CACHE": str(root / "cache" / "workloads"), "HOME": str(root / "home")}


@pytest.fixture(scope="module")
def run_dir(env, tmp_path_factory):
    out = tmp_path_factory.mktemp("cli-run") / "run"
    done = run(
        "sweep",
        "--kernels",
        "moller_trumbore,curless",
        "--hit-rates",
        "0.5",
        "--pairs",
        "100",
        *TINY_DESIGN,
        "--out",
        out,
        env=env,
    )
    assert done.returncode == 0, done.stderr
    return out


@pytest.fixture(scope="module")
def mesh_prefix(env):
    """A unique prefix of a cached mesh workload's id, as the docstring's `show mesh-3f2a` uses one."""
    done = run("workloads", "make", "suzanne", "--triangles", "100", "--width", "6", "--height", "6", "--json", env=env)
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout)["workload_id"][:12]


def test_the_readme_and_the_docstring_have_examples():
    assert len(readme_examples()) >= 12 and len(docstring_examples()) >= 6
    assert set(readme_examples()) == set(CONCRETE), "give each README and docs/ example a concrete form here"


def test_the_readme_table_and_the_commands_page_name_the_same_commands():
    readme, page = table_examples(README), heading_examples(COMMANDS_DOC)
    assert len(readme) == len(set(readme)) and len(page) == len(set(page)), "a command listed twice"
    assert readme == page, "README's command table and docs/commands.md's sections: the same commands, in order"


@pytest.mark.parametrize("example", sorted(CONCRETE))
def test_concrete_forms_use_every_flag_of_the_example(example):
    lines = [shlex.split(c) for c in CONCRETE[example]]
    words = example.replace("tribench ", "").split()
    command = words[0] if words[0] not in ("list", "show") else "workloads"
    assert all(line[0] == command for line in lines)
    for flag in (w.strip("[]") for w in words if w.strip("[]").startswith("--")):
        assert any(flag in line for line in lines), f"{flag} of {example!r} is never run"
    for line in lines:  # the real parser takes it
        build_parser().parse_args(
            [w.format(tmp="/nonexistent", run="/", run_b="/", run_c="/", mesh="m", scene=README) for w in line]
        )


# Each example is a run of the installed command (2-8 s each, about a minute for all): CI runs them with
# the slow tests, so the README's test command stays under its 3 minutes (docs/decisions.md).
@pytest.mark.slow
@pytest.mark.parametrize("command", [c for cs in CONCRETE.values() for c in cs if c not in SLOW])
def test_readme_example_runs(command, env, run_dir, mesh_prefix, tmp_path):
    others = {"run_b": tmp_path / "run_b", "run_c": tmp_path / "run_c"}
    for name, copy in others.items():  # other runs for compare, as the run is now (a run given twice is refused)
        if "{" + name + "}" in command:
            shutil.copytree(run_dir, copy)
    argv = shlex.split(
        command.format(tmp=tmp_path, run=run_dir, **others, mesh=mesh_prefix, scene=builtin_scene_path("scene02"))
    )
    done = run(*argv, env=env, timeout=120)
    if argv[0] == "calibrate" and done.returncode == 2 and "an equivalence margin must be" in done.stderr:
        # on a loaded machine this tiny design's A/A noise floor can pass the largest usable margin: the
        # record is kept, and the command rightly refuses to make it the margin of later sweeps
        assert (tmp_path / "cal" / "calibration.json").is_file() and "Traceback" not in done.stderr
        return
    assert done.returncode == 0, done.stderr
    assert "Traceback" not in done.stderr
    if "--png" in argv:
        assert (tmp_path / "mesh.png").stat().st_size > 0
    if "--out" in argv and argv[0] != "peers":
        assert Path(argv[argv.index("--out") + 1]).exists()


def _sized(argv: list[str]) -> list[str]:
    """The docstring's command with tiny sizes (a flag it gives is set in place: a flag given twice is refused)."""
    if argv[:2] != ["workloads", "make"] or argv[2] == "pairs":
        return argv
    if "--hit-rate" in argv or "--n-rays" in argv:
        return _with(argv, "--n-rays", "64")
    if "--rays" in argv and argv[argv.index("--rays") + 1].endswith(".npz"):
        return argv  # a ray file brings its own rays: no camera to size
    return _with(_with(argv, "--width", "8"), "--height", "8")


def _with(argv: list[str], flag: str, value: str) -> list[str]:
    """``argv`` with ``flag`` set to ``value``: in place if it is there, else appended."""
    if flag not in argv:
        return [*argv, flag, value]
    at = argv.index(flag) + 1
    return [*argv[:at], value, *argv[at + 1 :]]


@pytest.mark.slow
@pytest.mark.parametrize("example", docstring_examples())
def test_workloads_docstring_example_runs(example, env, mesh_prefix, tmp_path):
    argv = shlex.split(example)[1:]
    argv = [env["HOME"] + w[1:] if w.startswith("~/") else w for w in argv]  # as the shell expands ~
    if argv[:2] == ["workloads", "show"]:
        argv[2] = mesh_prefix
    if "--rays" in argv and argv[argv.index("--rays") + 1].endswith(".npz"):  # the user's file, made here
        rng = np.random.default_rng(0)
        origins = rng.uniform(-0.5, 0.5, (64, 3)) + [0, 0, 4]
        np.savez(tmp_path / argv[argv.index("--rays") + 1], origins=origins, directions=np.tile([0.0, 0, -1], (64, 1)))
    done = run(*_sized(argv), env=env, cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert "Traceback" not in done.stderr
    if argv[:2] == ["workloads", "make"]:
        assert re.match(r"(pairs|mesh)-[0-9a-f]{12}  ", done.stdout)
    if "--png" in argv:
        assert (tmp_path / argv[argv.index("--png") + 1]).stat().st_size > 0
