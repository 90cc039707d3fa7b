"""Files and values tribench reads: sweep files, plan bounds, calibration.json.

Every mistake is one UserError that names the file and the key (or the
field), raised before anything is measured or allocated.
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
import tracemalloc

import pytest

from tribench.common import UserError
from tribench.harness.jobs import calibrate as calibration
from tribench.harness.jobs.calibrate import MAX_MARGIN, Margin, latest_margin, user_calibration_path
from tribench.harness.plan import MAX_BATCHES, MAX_PROCESSES, Sweep, default_sweep
from tribench.harness.sweep_file import load_sweep_file
from tribench.workloads.spec import PairSpec

PAIR = (PairSpec(n=10),)
HEAD = 'kernels = ["moller_trumbore"]\nprocesses = 2\n'
TABLE = '[[workloads]]\nkind = "pairs"\nn = 100\n'


# ------------------------------------------------------------------ plan size


@pytest.mark.parametrize(
    "design, message",
    [
        ({"rounds": 1_000_000_000}, "rounds must be between 1 and 100,000"),
        (
            {"processes": 1_000_000_000_000},
            "processes must be between 1 and 10,000, got 1,000,000,000,000 "
            r"\(each process costs",
        ),
        ({"processes": 2**63 - 1}, "processes must be between"),
        (
            {"processes": 10_000, "rounds": 100},
            "the sweep has 1,010,000 batches .* at most 1,000,000 "
            r"\(about 2.2 hours of timed batches at the default 8 ms",
        ),
        ({"warmup": -1}, "warmup must be between 0"),
        ({"processes": 2.0}, "processes must be an integer"),
        ({"processes": True}, "processes must be an integer"),
        ({"target_ms": True}, "target_ms must be a number"),
        ({"target_ms": math.nan}, "target_ms must be a number"),
        ({"rng_seed": 2**64}, "rng_seed must be between 0 and"),
    ],
)
def test_plan_bounds_from_the_api(design, message):
    tracemalloc.start()
    try:
        with pytest.raises(UserError, match=message):
            Sweep(("moller_trumbore",), PAIR, **design)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 5_000_000  # refused before a plan is built


def test_a_plan_at_the_bound_is_accepted_and_the_default_sweep_is_far_below_it():
    assert Sweep(("moller_trumbore",), PAIR, processes=10_000, rounds=99, warmup=1).n_batches == MAX_BATCHES
    assert default_sweep().n_batches < MAX_BATCHES / 25  # about 2% of the bound


@pytest.mark.parametrize("bad", ["5", '"moller_trumbore"', '["moller_trumbore", 3]', "{a = 1}"])
def test_kernels_of_the_wrong_type_name_the_file_and_key(tmp_path, bad):
    f = tmp_path / "sweep.toml"
    f.write_text(f"kernels = {bad}\n{TABLE}")
    with pytest.raises(UserError, match=f"{f}: kernels: expected a list of kernel names"):
        load_sweep_file(f)


@pytest.mark.parametrize(
    "line, message",
    [
        ("processes = 9223372036854775807", "processes must be between 1 and 10,000"),
        ("rounds = 1000000000", "rounds must be between 1 and 100,000"),
        ("processes = 1.5", "processes must be an integer"),
        ('processes = "3"', "processes must be an integer"),
        ("target_ms = true", "target_ms must be a number"),
        ("rng_seed = -1", "rng_seed must be between 0"),
        ("rng_seed = 1979-05-27", "rng_seed must be an integer"),
        ("colour = 3", r"unknown key\(s\) colour"),
    ],
)
def test_top_level_values_name_the_file_and_key(tmp_path, line, message):
    f = tmp_path / "sweep.toml"
    f.write_text(f'kernels = ["moller_trumbore"]\n{line}\n{TABLE}')
    with pytest.raises(UserError, match=f"^{f}: {message}"):
        load_sweep_file(f)


@pytest.mark.parametrize(
    "lines, message",
    [
        ('hit_rate = "x"', r"workloads\[1\]: hit_rate must be a finite number, got 'x'"),
        ("hit_rate = [0.1, 2.0]", r"workloads\[1\]: hit_rate must be in \[0, 1\], got 2.0"),
        ("hit_rate = 99999999999999999999999999999999999999", r"workloads\[1\]: hit_rate must be in \[0, 1\]"),
        ("hit_rate = 1" + "0" * 400, r"workloads\[1\]: hit_rate must be a finite number"),
        ("n = inf", r"workloads\[1\]: n \(number of pairs\) must be an integer"),
        ("n = nan", r"workloads\[1\]: n \(number of pairs\) must be an integer"),
        ("n = 1e400", r"workloads\[1\]: n \(number of pairs\) must be an integer"),
        ("kind = 5", r"workloads\[1\]: workload kind must be 'pairs', 'mesh' or 'seed', got 5"),
        ("kind = {a = 1}", r"workloads\[1\]: workload kind must be 'pairs', 'mesh' or 'seed', got \{'a': 1\}"),
        ("miss_mix = 5", r"workloads\[1\]: miss_mix must be a preset name or a fraction per stage"),
        ("miss_mix = {parallel = 'x'}", r"workloads\[1\]: miss_mix\[parallel\] must be a finite number"),
        ("dtype = 3", r"workloads\[1\]: unknown dtype 3"),
        ("order = {a = 1}", r"workloads\[1\]: unknown order"),
        ("n = []", r"workloads\[1\]: an empty list"),
        ("mesh = 'suzanne'", r"workloads\[1\]: unknown pairs spec field\(s\): mesh"),
    ],
)
def test_workload_tables_name_the_file_and_table(tmp_path, lines, message):
    f = tmp_path / "sweep.toml"
    second = (
        "[[workloads]]\n"
        + "".join(line for line in ('kind = "pairs"\n', "n = 100\n") if not lines.startswith(line.split()[0] + " "))
        + lines
        + "\n"
    )
    f.write_text(HEAD + TABLE + second)
    with pytest.raises(UserError, match=f"^{f}: {message}"):
        load_sweep_file(f)


def test_unreadable_sweep_files_name_the_file(tmp_path):
    cases = {
        "missing.toml": None,
        "folder.toml": "dir",
        "binary.toml": b"\xff\xfe\x00",
        "deep.toml": "kernels = " + "[" * 100_000 + "]" * 100_000,
        "deep_table.toml": HEAD + TABLE + "miss_mix = " + "{a = " * 5000 + "1" + "}" * 5000,
        "bad.toml": "kernels = [",
        "workloads.toml": 'kernels = ["moller_trumbore"]\nworkloads = 3\n',
    }
    for name, content in cases.items():
        f = tmp_path / name
        if content == "dir":
            f.mkdir()
        elif isinstance(content, bytes):
            f.write_bytes(content)
        elif content is not None:
            f.write_text(content)
        with pytest.raises(UserError, match=f"^{f}: "):
            load_sweep_file(f)


def test_a_huge_grid_is_refused_before_it_is_built(tmp_path):
    f = tmp_path / "grid.toml"
    n = ", ".join(str(i) for i in range(1, 1001))
    h = ", ".join(str(i / 1000) for i in range(1000))
    f.write_text(f'{HEAD}[[workloads]]\nkind = "pairs"\nn = [{n}]\nhit_rate = [{h}]\n')
    with pytest.raises(UserError, match=f"{f}: the sweep has 1,000,000 workloads; at most 1,000"):
        load_sweep_file(f)


def test_flags_over_a_sweep_file_are_named(tmp_path):
    f = tmp_path / "sweep.toml"
    f.write_text(HEAD + TABLE)
    with pytest.raises(UserError, match=f"{f} with the command-line flags: rounds must be between"):
        load_sweep_file(f, {"rounds": 10**9})
    assert load_sweep_file(f, {"rounds": 3, "rng_seed": None}).rounds == 3


@pytest.mark.slow
def test_plan_bounds_from_the_command_line(tmp_path):
    f = tmp_path / "sweep.toml"
    f.write_text(f"{HEAD.replace('processes = 2', 'processes = 9223372036854775807')}{TABLE}")
    env = {**os.environ, "TRIBENCH_CACHE": str(tmp_path / "cache")}
    for args in (
        ["--file", str(f)],
        ["--rounds", "1000000000", "--pairs", "100"],
        ["--processes", str(MAX_PROCESSES + 1), "--pairs", "100"],
    ):
        r = subprocess.run(
            [
                sys.executable,
                "-m",
                "tribench.cli",
                "sweep",
                "--kernels",
                "moller_trumbore",
                *args,
                "--out",
                str(tmp_path / "run"),
            ],
            capture_output=True,
            text=True,
            env=env,
            timeout=120,
        )
        assert r.returncode == 2 and "must be between" in r.stderr, r.stderr
        assert len(r.stderr.strip().splitlines()) == 1 and "Traceback" not in r.stderr
        assert not (tmp_path / "run").exists()


# ---------------------------------------------------------------- calibration


@pytest.fixture
def user_cal(tmp_path, monkeypatch):
    monkeypatch.setenv("TRIBENCH_CACHE", str(tmp_path / "cache"))
    path = user_calibration_path()
    path.parent.mkdir(parents=True, exist_ok=True)
    return path


def _write_cal(path, **fields):
    record = {"cpu_model": "test cpu", "created": "2024-01-01", "run_dir": "r", **fields}
    path.write_text(json.dumps(record, allow_nan=True))


@pytest.mark.parametrize("margin", [math.nan, math.inf, -0.5, 1e9, MAX_MARGIN * 1.01, "0.02", True, None, [0.01]])
def test_a_bad_calibration_margin_names_the_file_and_the_fix(user_cal, margin):
    _write_cal(user_cal, margin=margin)
    with pytest.raises(
        UserError,
        match=f"{user_cal}: key 'margin': an equivalence margin must be .*"
        "run `tribench calibrate` again, or delete the file",
    ):
        latest_margin("test cpu")


@pytest.mark.parametrize("text", ["", "{", "[]", '{"cpu_model": "test cpu"}', "[" * 100_000])
def test_a_calibration_file_that_is_not_one_names_the_file(user_cal, text):
    user_cal.write_text(text)
    with pytest.raises(UserError, match=f"{user_cal}: not a calibration file"):
        latest_margin("test cpu")


@pytest.mark.parametrize("margin", [0, 1e-9, 0.01, 0.02, MAX_MARGIN])
def test_a_good_margin_is_used(user_cal, margin):
    _write_cal(user_cal, margin=margin)
    m = latest_margin("test cpu")
    assert m.value == margin and str(user_cal) in m.source
    assert latest_margin("other cpu").source.startswith("default")


def test_no_calibration_file_is_the_default(user_cal):
    assert latest_margin("test cpu").source.startswith("default")


def test_every_margin_a_verdict_uses_is_checked():
    with pytest.raises(UserError, match="margin of --margin: an equivalence margin must be"):
        Margin(math.nan, "--margin")
    assert Margin(0.01, "x").value == 0.01


def test_a_sweep_with_a_bad_calibration_stops_before_measuring(tmp_path):
    env = {**os.environ, "TRIBENCH_CACHE": str(tmp_path / "cache")}
    (tmp_path / "calibration.json").write_text('{"margin": NaN, "cpu_model": null}')
    r = subprocess.run(
        [
            sys.executable,
            "-m",
            "tribench.cli",
            "sweep",
            "--kernels",
            "moller_trumbore",
            "--pairs",
            "100",
            "--processes",
            "2",
            "--rounds",
            "1",
            "--out",
            str(tmp_path / "run"),
        ],
        capture_output=True,
        text=True,
        env=env,
        timeout=120,
    )
    assert r.returncode == 2 and f"{tmp_path / 'calibration.json'}: key 'margin'" in r.stderr, r.stderr
    assert "Traceback" not in r.stderr and not (tmp_path / "run").exists()
    assert calibration.CALIBRATION == "calibration.json"


def test_calibrate_on_a_bvh_workload_says_its_kernel_cannot_be_a_leaf_test(tmp_path):
    """The sweep below said 'add one of moller_trumbore_fma, ...': a kernel a calibration cannot add."""
    from tribench.harness.jobs.calibrate import calibrate
    from tribench.workloads.spec import MeshSpec

    bvh = MeshSpec(mesh="suzanne", triangles=100, width=8, height=8, accel="bvh")
    with pytest.raises(UserError, match=r"^moller_trumbore cannot be a BVH's leaf test, .*brute-force mesh"):
        calibrate(tmp_path / "cal", workloads=(bvh,), processes=2, experiments=1, save=False)
    assert not (tmp_path / "cal").exists()
