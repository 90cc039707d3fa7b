"""Harness pieces in-process: plan, run files, checks, internal kernels, FMA probe."""

from __future__ import annotations

import dataclasses
import io
import json
import math
import shutil
import subprocess
import sys

import numpy as np
import pytest
from conftest import safe_pairs

from tribench import ext
from tribench.harness import checks, machine, runfolder, worker
from tribench.harness.jobs import calibrate as calibration
from tribench.harness.plan import Sweep, plan
from tribench.harness.sweep_file import expand_workloads, load_sweep_file
from tribench.workloads import cache, front, reference
from tribench.workloads.spec import MeshSpec, PairSpec, workload_id

#: the seed's tests as its program pays for them (tests/test_seed_object.py)
SEED_OBJECT = ("moller_seed_object", "curless_seed_object")
INTERNAL = ("moller_trumbore_aa", "moller_seed_aa", "moller_trumbore_same", "moller_trumbore_twice")
#: the kernel each internal kernel copies
ORIGINAL = {
    "moller_trumbore_aa": "moller_trumbore",
    "moller_seed_aa": "moller_seed",
    "moller_trumbore_same": "moller_trumbore",
    "moller_trumbore_twice": "moller_trumbore",
}


@pytest.fixture(autouse=True)
def _cache(tmp_path, monkeypatch):
    monkeypatch.setenv("TRIBENCH_CACHE", str(tmp_path / "cache"))


def small_sweep(**kw) -> Sweep:
    base = dict(
        kernels=("moller_trumbore", "curless", "moller_seed"),
        workloads=(PairSpec(n=50, hit_rate=0.3), PairSpec(n=50, hit_rate=0.7)),
        processes=3,
        rounds=4,
        warmup=2,
        rng_seed=5,
    )
    return Sweep(**{**base, **kw})


# ------------------------------------------------------------------ plan


def test_plan_is_deterministic_and_complete():
    s = small_sweep()
    keys = plan(s)
    assert keys == plan(small_sweep())
    assert len(keys) == len(set(keys)) == s.n_batches
    # every (process, workload, round) has each kernel exactly once, positions 0..K-1
    groups: dict = {}
    for k in keys:
        groups.setdefault((k.process, k.workload_id, k.round), []).append(k)
    assert len(groups) == 3 * 2 * (2 + 4)
    for g in groups.values():
        assert sorted(k.kernel for k in g) == sorted(s.kernels)
        assert [k.position for k in g] == [0, 1, 2]
    assert {k.round for k in keys} == set(range(-2, 4))
    assert sum(k.round < 0 for k in keys) == 3 * 2 * 2 * 3  # warm-up rounds
    # orders are randomised, and depend on the seed
    orders = {tuple(k.kernel for k in g) for g in groups.values()}
    assert len(orders) > 1
    assert plan(small_sweep(rng_seed=6)) != keys


def test_sweep_round_trips_through_json_and_rejects_bad_input():
    s = small_sweep()
    assert Sweep.from_dict(s.to_dict()) == s
    with pytest.raises(ValueError, match="unknown kernel 'nope'"):
        small_sweep(kernels=("nope",))
    with pytest.raises(ValueError, match="processes"):
        small_sweep(processes=0)
    with pytest.raises(ValueError, match=r"a workload is listed twice .*: pairs n=5 "):
        small_sweep(workloads=(PairSpec(n=5), PairSpec(n=5)))  # it names the workload
    # numpy's integers are integers (a notebook's arange), its non-integral floats are not
    assert PairSpec(n=np.int64(5)) == PairSpec(n=5)
    with pytest.raises(ValueError, match="must be an integer"):
        PairSpec(n=np.float64(5.5))
    # a plan a newer tribench wrote with a part this one does not know is not run without it
    with pytest.raises(ValueError, match=r"unknown sweep field\(s\): shuffle \(a run of a newer tribench\?\)"):
        Sweep.from_dict({**s.to_dict(), "shuffle": "by-kernel"})


def test_sweep_file_expands_lists_into_a_grid(tmp_path):
    path = tmp_path / "sweep.toml"
    path.write_text(
        'kernels = ["moller_trumbore"]\nprocesses = 2\nrounds = 3\n'
        '[[workloads]]\nkind = "pairs"\nn = 20\nhit_rate = [0.1, 0.9]\ndtype = ["float32", "float64"]\n'
        '[[workloads]]\nkind = "mesh"\nmesh = "icosphere"\ntriangles = [20, 80]\nwidth = 4\nheight = 4\n'
    )
    s = load_sweep_file(path, {"rounds": 2, "rng_seed": None})
    assert (s.processes, s.rounds, s.rng_seed) == (2, 2, 0)
    assert len(s.workloads) == 6
    assert s.workloads[4] == MeshSpec("icosphere", triangles=20, width=4, height=4)
    assert len(expand_workloads({"kind": "pairs", "n": 3})) == 1
    path.write_text('kernels = ["moller_trumbore"]\nbogus = 1\n')
    with pytest.raises(ValueError, match="unknown key"):
        load_sweep_file(path)


# ------------------------------------------------------------ run files


def _row(i: int, **kw) -> runfolder.BatchRow:
    base = dict(
        run_id="r",
        process=i % 2,
        round=i - 1,
        position=0,
        kernel="k,1",
        build='gcc -O2 -DX="a,b"',
        workload_id="w",
        dtype="float64",
        mode="pairs",
        warmup=i == 0,
        loops=3,
        tests=30,
        elapsed_ns=1000 + i,
        start_ns=10**12 + i,
        invol_ctx_switches=0,
        hits=9,
        t_sum=0.1 + i / 3,
        cpu=1,
        isa="scalar/sse2",
        attempt=0,
        steal_ticks=-1,
    )
    return runfolder.BatchRow(**{**base, **kw})


def test_batch_rows_round_trip_and_a_partial_last_line_is_dropped(tmp_path):
    rows = [_row(i) for i in range(4)]
    with runfolder.RowWriter(tmp_path / "batches.csv", runfolder.BATCH_COLUMNS) as w:
        for r in rows:
            w.append(r)
    frame = runfolder.read_batches(tmp_path)
    assert tuple(frame.columns) == runfolder.BATCH_COLUMNS
    back = [runfolder.BatchRow(**r) for r in frame.to_dict("records")]
    assert back == rows  # incl. a comma in a name, bools and full float precision
    assert frame["warmup"].dtype == bool
    # a write cut by a kill: the partial row is ignored on read, cut off by repair
    with open(tmp_path / "batches.csv", "a") as f:
        f.write("r,1,5,0,moller")
    assert len(runfolder.read_batches(tmp_path)) == 4
    assert runfolder.repair_csv(tmp_path / "batches.csv")
    assert not runfolder.repair_csv(tmp_path / "batches.csv")
    assert (tmp_path / "batches.csv").read_text().endswith("\n")
    assert len(runfolder.read_batches(tmp_path)) == 4


def test_missing_run_files_are_file_not_found(tmp_path):
    with pytest.raises(FileNotFoundError):
        runfolder.read_run(tmp_path / "nope")
    with pytest.raises(FileNotFoundError):
        runfolder.read_batches(tmp_path)


# ------------------------------------------------------------------ checks


def test_one_pass_checksum_matches_the_reference_and_batches_check():
    w = cache.make(PairSpec(n=200, hit_rate=0.4))
    c, counts = checks.one_pass_checksum("moller_trumbore", w)
    assert counts == {"rays": 200, "ambiguous_rays": 0, "disagreements": 0, "ambiguous_disagreements": 0}
    hits, t_sum = w.expected_checksum()
    assert c.hits == hits and math.isclose(c.t_sum, t_sum, rel_tol=1e-12)
    job = ext.make_job("moller_trumbore", w.origins, w.directions, w.triangles, w.mode)
    batch = ext.time_batch(job, 3)
    checks.check_batch(batch, c, "moller_trumbore", w)
    bad = dataclasses.replace(batch, hits=batch.hits - 1)
    with pytest.raises(checks.KernelCheckError, match="'moller_trumbore'.*checksum failed"):
        checks.check_batch(bad, c, "moller_trumbore", w)


def test_a_tampered_reference_is_caught_naming_the_kernel():
    w = cache.make(PairSpec(n=200, hit_rate=0.4))
    flipped = w.ref_hit.copy()
    flipped[7] = ~flipped[7]
    tampered = dataclasses.replace(w, ref_hit=flipped)
    with pytest.raises(checks.KernelCheckError, match=r"kernel 'curless' on workload pairs-.*1 of 200 rays.*ray 7"):
        checks.one_pass_checksum("curless", tampered)


def test_the_seed_kernels_differences_are_counted_not_fatal():
    # a triangle too small for moller_seed's |det| < 1e-4: it misses every hit,
    # by design; the check records that instead of stopping the sweep
    w = cache.make(PairSpec(n=200, hit_rate=0.5, scale=1e-3))
    checksum, counts = checks.one_pass_checksum("moller_seed", w)
    assert checksum.hits == 0
    assert counts["disagreements"] == int(w.ref_hit.sum()) == 100
    with pytest.raises(checks.KernelCheckError):
        checks.one_pass_checksum("moller_trumbore", dataclasses.replace(w, ref_hit=~w.ref_hit))


@pytest.mark.parametrize("kernel", ext.kernel_names())
@pytest.mark.parametrize("mode", ["pairs", "any", "closest_uv"])
def test_every_kernel_passes_its_checks_in_every_mode(kernel, mode):
    # culling kernels are held to the culled reference, wide ones run no pairs
    if mode == "pairs":
        spec = PairSpec(n=300, hit_rate=0.5, miss_mix={"outside_edge_1": 0.5, "beyond_t_max": 0.5})
    else:
        spec = MeshSpec("icosphere", triangles=80, width=10, height=10, dtype="float32", result=mode)
    if mode not in ext.kernel_info(kernel).modes:
        return
    w = cache.make(spec)
    checksum, counts = checks.one_pass_checksum(kernel, w)
    if not ext.kernel_info(kernel).seed_replay:
        assert counts["disagreements"] == counts["ambiguous_disagreements"]
    job = ext.make_job(kernel, w.origins, w.directions, w.triangles, w.mode, t_max=w.t_max)
    checks.check_batch(ext.time_batch(job, 2), checksum, kernel, w)


@pytest.mark.parametrize("mesh", ["suzanne", "icosphere"])
@pytest.mark.parametrize("flip", [False, True])
def test_a_culling_kernel_on_a_brute_force_mesh_is_held_to_the_brute_force_front_faces(mesh, flip):
    # the check takes the front-face answers from the two-sided reference (brute force only for
    # rays whose closest hit is a back face): they must be brute force's, ties and all
    w = cache.make(MeshSpec(mesh, triangles=300, width=12, height=12, dtype="float32"))
    if flip:  # every face turned away from the camera: the culled answers are the far side's
        w = dataclasses.replace(w, triangles=np.ascontiguousarray(w.triangles[:, [0, 2, 1]]))
    brute = reference.intersect_closest(w.origins, w.directions, w.triangles, t_max=w.t_max, front_only=True)
    derived = front.compute_front_reference(w)
    np.testing.assert_array_equal(derived[0], brute[0])
    np.testing.assert_array_equal(derived[1], brute[1])
    assert flip == bool((brute[0] != w.ref_index).any())
    cull = "moller_trumbore_cull_fma"
    checksum, counts = checks.one_pass_checksum(cull, w)
    assert checksum.hits == int((brute[0] >= 0).sum()) and counts["disagreements"] == counts["ambiguous_disagreements"]


def test_calibrated_loops_hit_the_target_roughly():
    w = cache.make(PairSpec(n=500, hit_rate=0.5))
    job = ext.make_job("moller_trumbore", w.origins, w.directions, w.triangles, w.mode)
    loops = worker.calibrate_loops(job, 1e6)
    elapsed = min(ext.time_batch(job, loops).elapsed_ns for _ in range(5))
    assert 0.3e6 < elapsed < 3e6


# ------------------------------------------------------ internal kernels


def test_internal_kernels_are_hidden_but_callable():
    public = ext.kernel_names()
    everything = ext.kernel_names(internal=True)
    assert not set(INTERNAL) & set(public)
    # the honesty checks (copies of moller_trumbore), then bench/yardstick.py's yardstick
    assert set(everything) == set(public) | set(INTERNAL) | {"moller_trumbore_yardstick"} | set(SEED_OBJECT)
    assert ext.bytes_per_triangle("moller_trumbore_twice", "float64") == 72


@pytest.mark.parametrize("kernel", INTERNAL)
@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_internal_kernels_agree_with_the_reference_on_pairs(kernel, dtype):
    o, d, tris = (np.ascontiguousarray(a, dtype=dtype) for a in safe_pairs(500, seed=3))
    ref = reference.intersect_pairs(o.astype(float), d.astype(float), tris.astype(float))
    hit, t = ext.intersect_pairs(kernel, o, d, tris)
    assert np.array_equal(hit, ref.hit)
    rtol = 1e-4 if dtype == np.float32 else 1e-12
    assert np.allclose(t[hit], ref.t[ref.hit], rtol=rtol)
    # and the same answers as the kernel they copy, bit for bit
    hit2, t2 = ext.intersect_pairs(ORIGINAL[kernel], o, d, tris)
    assert np.array_equal(hit, hit2) and np.array_equal(t[hit], t2[hit2])


@pytest.mark.parametrize("kernel", INTERNAL)
def test_internal_kernels_agree_with_the_reference_on_closest_hits(kernel):
    w = cache.make(MeshSpec("icosphere", triangles=80, width=12, height=12, dtype="float32"))
    assert checks.one_pass_checksum(kernel, w) == checks.one_pass_checksum(ORIGINAL[kernel], w)


@pytest.mark.skipif(shutil.which("objdump") is None, reason="needs binutils' objdump")
@pytest.mark.parametrize("twin", ["moller_trumbore_aa", "moller_seed_aa"])
def test_an_aa_twin_has_code_of_its_own(twin):
    # GCC's identical-code folding once made the twins' entry points jumps into the
    # originals' code: an A/A comparison of one function with itself (core.h, TB_NO_ICF)
    so = ext._core.__file__
    name = f"tb_{twin}_time_closest_f32"
    text = subprocess.run(
        ["objdump", "-d", "--no-show-raw-insn", f"--disassemble={name}", so], capture_output=True, text=True
    ).stdout
    body = [line for line in text.splitlines() if line.startswith(" ") and ":" in line]
    if not body:
        pytest.skip(f"{name} is not in the module's symbol table (a stripped build)")
    assert len(body) > 20 and "jmp" not in body[0], "\n".join(body[:5])


@pytest.mark.skipif(shutil.which("objdump") is None, reason="needs binutils' objdump")
def test_the_same_code_kernel_runs_the_originals_loop():
    # its true ratio is exactly 1 only if its timed loop is moller_trumbore's own
    name = "tb_moller_trumbore_same_time_closest_f32"
    text = subprocess.run(
        ["objdump", "-d", "--no-show-raw-insn", f"--disassemble={name}", ext._core.__file__],
        capture_output=True,
        text=True,
    ).stdout
    body = [line for line in text.splitlines() if line.startswith(" ") and ":" in line]
    if not body:
        pytest.skip(f"{name} is not in the module's symbol table (a stripped build)")
    assert len(body) < 8 and "<tb_moller_trumbore_time_closest_f32>" in text, "\n".join(body)


# -------------------------------------------------------------- FMA probe


@pytest.mark.parametrize("force_scalar", [False, True])
def test_fma_peak_is_positive_and_finite(force_scalar):
    p = ext.fma_peak(20_000, force_scalar=force_scalar)
    assert p.flops > 0 and p.elapsed_ns > 0
    assert math.isfinite(p.gflops) and p.gflops > 0
    assert p.isa in ("avx2+fma", "neon+fma", "scalar")
    if force_scalar:
        assert p.isa == "scalar"
    with pytest.raises(ValueError):
        ext.fma_peak(0)


def test_camera_fractions_put_every_kernel_against_its_bound():
    from tribench.harness.peak import bound_from_mix, camera_fractions

    gflops, isa, rate_isa, rates, table = camera_fractions(dtypes=("float64",), rounds=1, size=8)
    assert sorted(table["kernel"]) == sorted(ext.kernel_names())
    assert rate_isa == ext.probe_isas()[0]
    assert gflops > 0 and isa
    for r in table.itertuples(index=False):
        assert r.ops_per_test == ext.kernel_info(r.kernel).ops > 0
        # a record per triangle, in whole blocks of the form's lanes
        lanes = ext.kernel_info(r.kernel).lanes
        assert r.records_bytes >= -(-968 // lanes) * lanes * ext.kernel_info(r.kernel).bytes_per_triangle["float64"]
        assert r.bound_ns_per_test == pytest.approx(bound_from_mix(ext.kernel_info(r.kernel).mix, rates["float64"]))
        assert r.fraction == pytest.approx(r.bound_ns_per_test / r.ns_per_test) and r.fraction > 0


@pytest.mark.skipif("avx2" not in ext.probe_isas(), reason="needs AVX2")
def test_camera_fractions_hold_every_native_kernel_to_the_isa_asked():
    from tribench.harness.peak import camera_fractions

    _, _, rate_isa, _, table = camera_fractions(dtypes=("float32",), rounds=1, size=8, isa="avx2")
    assert rate_isa == "avx2"
    wide = table[[ext.kernel_info(k).lanes > 1 for k in table["kernel"]]]
    native = [k for k in ext.kernel_names() if ext.kernel_info(k).lanes > 1]
    assert sorted(wide["kernel"]) == sorted(native) and all(f.endswith(", avx2") for f in wide["form"])
    assert set(table.loc[[ext.kernel_info(k).lanes == 1 for k in table["kernel"]], "form"]) == {"scalar"}


# ------------------------------------------------------------ calibration


def test_latest_margin_uses_a_calibration_of_this_cpu_only(tmp_path):
    path = calibration.user_calibration_path()
    assert path == tmp_path / "calibration.json"
    assert calibration.latest_margin("cpu x").source.startswith("default")
    path.write_text('{"margin": 0.02, "cpu_model": "cpu x", "created": "today"}')
    m = calibration.latest_margin("cpu x")
    assert m.value == 0.02 and str(path) in m.source
    assert calibration.latest_margin("cpu y").value == 0.01


def test_two_cpus_behind_one_brand_name_are_two_machines(tmp_path, monkeypatch):
    """A hypervisor shows a Zen 3 and a Zen 5 both as "AMD EPYC": their family and model numbers
    name them apart, so the Zen 5's calibration is not applied on the Zen 3."""
    brand = {"model name": "AMD EPYC", "stepping": "1"}
    monkeypatch.setattr(machine, "_cpuinfo", lambda: {**brand, "cpu family": "26", "model": "2"})
    zen5 = machine.cpu_model()
    monkeypatch.setattr(machine, "_cpuinfo", lambda: {**brand, "cpu family": "25", "model": "1"})
    zen3 = machine.cpu_model()
    assert (zen5, zen3) == ("AMD EPYC (family 26, model 2)", "AMD EPYC (family 25, model 1)")
    calibration.user_calibration_path().write_text(json.dumps({"margin": 0.03, "cpu_model": zen5}))
    assert calibration.latest_margin(zen5).value == 0.03
    assert f"another CPU, {zen5}" in calibration.latest_margin(zen3).source
    monkeypatch.setattr(machine, "_cpuinfo", lambda: {"Model": "Raspberry Pi 4 Model B Rev 1.4"})
    assert machine.cpu_model() == "Raspberry Pi 4 Model B Rev 1.4"  # no numbers given: the name alone


NEOVERSE_V1 = """processor\t: 0
BogoMIPS\t: 2100.00
Features\t: fp asimd evtstrm aes pmull sha1 sha2 crc32 atomics fphp asimdhp cpuid sve
CPU implementer\t: 0x41
CPU architecture: 8
CPU part\t: 0xd40

processor\t: 1
CPU part\t: 0xd0c
"""


def test_an_aarch64_cpu_is_named_from_its_implementer_and_part(monkeypatch, tmp_path):
    fake = tmp_path / "cpuinfo"
    fake.write_text(NEOVERSE_V1)
    real_path = machine.Path
    monkeypatch.setattr(machine, "Path", lambda p: real_path(fake) if p == "/proc/cpuinfo" else real_path(p))
    assert machine.cpu_model() == "ARM Neoverse-V1 (implementer 0x41, part 0xd40)"  # the first CPU's part
    assert machine.simd_features() == ["asimd", "sve"]
    assert ", NEON; " in machine.describe()
    fake.write_text(NEOVERSE_V1.replace("0x41", "0x99"))
    assert machine.cpu_model() == "CPU part 0xd40 (implementer 0x99, part 0xd40)"  # unknown: the numbers


def test_macos_facts_come_from_sysctl(monkeypatch):
    out = "machdep.cpu.brand_string: Apple M2\nhw.optional.AdvSIMD: 1\nhw.optional.arm.FEAT_SVE: 0\n"
    monkeypatch.setattr(machine.sys, "platform", "darwin")
    monkeypatch.setattr(machine.subprocess, "run", lambda *a, **k: subprocess.CompletedProcess(a, 0, out, ""))
    assert machine.cpu_model() == "Apple M2" and machine.simd_features() == ["asimd"]


def test_a_run_that_could_not_pin_says_so_in_one_line():
    from types import SimpleNamespace as Run  # the two fields pinning reads

    from tribench.reports import about

    assert about.pinning(Run(cpu=3, machine={})) == "pinned to CPU 3"
    assert "cannot pin" in about.pinning(Run(cpu=None, machine={"can_pin": False}))
    assert "asked for no pinning" in about.pinning(Run(cpu=-1, machine={"can_pin": True}))


def test_a_bench_figure_names_its_cpu_widest_isa_and_compiler(monkeypatch):
    zen5 = {"model name": "AMD EPYC", "cpu family": "26", "model": "2", "flags": "sse2 avx2 fma avx512f"}
    monkeypatch.setattr(machine, "_cpuinfo", lambda: zen5)
    line = machine.describe()
    assert line.startswith("machine: AMD EPYC (family 26, model 2), AVX-512; tribench ")
    assert line.endswith(ext.build_info()["compiler"])
    monkeypatch.setattr(machine, "_cpuinfo", lambda: {**zen5, "flags": "sse2 avx2 fma"})
    assert ", AVX2; " in machine.describe()


def test_a_plan_names_its_workloads_by_id():
    assert workload_id(PairSpec(n=5)) in {k.workload_id for k in plan(small_sweep(workloads=(PairSpec(n=5),)))}


def test_a_worker_that_meets_an_os_error_reports_one_line_not_a_traceback(monkeypatch, capsys):
    """A cache file the worker cannot read (a folder in its place, no permission) ends the worker with
    one message the runner shows, naming the file."""
    job = worker.WorkerJob("r", 0, 0, 1, None, 1.0, (), {})

    def refuse(*_):
        raise PermissionError(13, "Permission denied", "/cache/bvh/x.npz")

    monkeypatch.setattr(worker, "run_job", refuse)
    monkeypatch.setattr(sys, "stdin", io.StringIO(job.to_json()))
    assert worker.main() == 3
    (line,) = capsys.readouterr().out.splitlines()
    assert json.loads(line) == {
        "type": "error",
        "message": "a worker could not go on: Permission denied on /cache/bvh/x.npz",
    }
