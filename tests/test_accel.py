"""BVH mode (MeshSpec.accel = "bvh"): workload ids, sweeps through the BVH, refusals, peers --accel bvh."""

from __future__ import annotations

import dataclasses
import os
import subprocess
import sys
import warnings

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tribench import ext
from tribench.common import Notice, UserError
from tribench.harness import checks, runfolder, worker
from tribench.harness.jobs import peers
from tribench.harness.plan import Sweep
from tribench.workloads import bvh_cache, cache, reference
from tribench.workloads.kinds import spec_from_dict
from tribench.workloads.spec import MeshSpec, workload_id

SMALL = {"mesh": "suzanne", "triangles": 200, "width": 16, "height": 16, "dtype": "float32"}
NATIVE = "moller_trumbore_fma"


@pytest.fixture
def env(tmp_path, monkeypatch):
    monkeypatch.setenv("TRIBENCH_CACHE", str(tmp_path / "cache"))
    return {**os.environ, "TRIBENCH_CACHE": str(tmp_path / "cache")}


def cli(*args, env):
    return subprocess.run(
        [sys.executable, "-m", "tribench.cli", *args], capture_output=True, text=True, timeout=120, env=env
    )


# ------------------------------------------------------------------ ids


def test_brute_ids_are_unchanged_and_a_bvh_id_differs_from_its_twin():
    brute = MeshSpec("suzanne", triangles=100, width=16, height=16, dtype="float32")
    # pinned: the id this spec had before MeshSpec gained accel (cache files and run folders keep theirs)
    assert workload_id(brute) == "mesh-6d87b43398d7"
    assert workload_id(dataclasses.replace(brute, accel="brute")) == workload_id(brute)
    assert "accel" not in brute.to_dict()
    bvh = dataclasses.replace(brute, accel="bvh")
    assert workload_id(bvh) != workload_id(brute) and bvh.to_dict()["accel"] == "bvh"
    assert spec_from_dict(bvh.to_dict()) == bvh and bvh.brute_twin() == brute
    assert bvh.summary() == "mesh suzanne triangles=100 camera 16x16 bvh float32 rng_seed=0"
    with pytest.raises(UserError, match="unknown accel 'kd-tree': choose one of brute, bvh"):
        MeshSpec("suzanne", accel="kd-tree")


def test_max_leaf_is_a_bvh_workloads_field_left_out_when_default():
    bvh = MeshSpec("suzanne", triangles=100, width=16, height=16, dtype="float32", accel="bvh")
    small = dataclasses.replace(bvh, max_leaf=4)
    assert "max_leaf" not in bvh.to_dict() and small.to_dict()["max_leaf"] == 4
    assert workload_id(small) != workload_id(bvh) and spec_from_dict(small.to_dict()) == small
    assert small.brute_twin() == bvh.brute_twin() and small.summary().endswith("bvh max_leaf=4 float32 rng_seed=0")
    with pytest.raises(UserError, match="max_leaf applies to accel='bvh' only"):
        MeshSpec("suzanne", max_leaf=4)
    for bad in (0, 2000, 4.5, True):
        with pytest.raises(UserError, match="max_leaf"):
            MeshSpec("suzanne", accel="bvh", max_leaf=bad)


@settings(max_examples=40, deadline=None)
@given(
    mesh=st.sampled_from(["suzanne", "icosphere", "soup"]),
    triangles=st.one_of(st.none(), st.integers(1, 10**6)),
    result=st.sampled_from(["closest", "closest_uv", "any"]),
    dtype=st.sampled_from(["float32", "float64"]),
    seed=st.integers(0, 2**40),
)
def test_accel_enters_the_id_only_when_bvh(mesh, triangles, result, dtype, seed):
    spec = MeshSpec(mesh, triangles=triangles, result=result, dtype=dtype, rng_seed=seed)
    bvh = dataclasses.replace(spec, accel="bvh")
    assert {k: v for k, v in bvh.to_dict().items() if k != "accel"} == spec.to_dict()
    assert workload_id(bvh) != workload_id(spec) == workload_id(spec_from_dict(spec.to_dict()))


def test_a_bvh_workload_has_its_brute_twins_rays_and_answers(env):
    bvh = cache.make(MeshSpec(**SMALL, accel="bvh"))
    brute = cache.make(MeshSpec(**SMALL))
    assert bvh.workload_id != brute.workload_id and bvh.spec.accel == "bvh"
    assert bvh.checksum() == brute.checksum()  # every array's name, dtype, shape and bytes
    assert bvh.achieved == brute.achieved
    assert cache.load(bvh.workload_id).spec == bvh.spec  # cached under its own id


@pytest.mark.slow
def test_workloads_make_takes_accel_for_meshes_only(env):
    done = cli(
        "workloads", "make", "suzanne", "--triangles", "100", "--width", "8", "--height", "8", "--accel", "bvh", env=env
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.startswith(workload_id(MeshSpec("suzanne", triangles=100, width=8, height=8, accel="bvh")))
    assert " bvh " in done.stdout.splitlines()[0]
    done = cli("workloads", "make", "pairs", "--accel", "bvh", env=env)
    assert done.returncode == 2 and "--accel applies to meshes, not pairs" in done.stderr


# ------------------------------------------------------------------ sweeps


@pytest.mark.slow
def test_a_sweep_with_a_bvh_workload_runs_its_native_kernels_through_the_bvh(tmp_path, env):
    out = tmp_path / "run"
    done = cli(
        "sweep",
        *("--kernels", f"moller_trumbore,{NATIVE}", "--mesh", "suzanne", "--triangles", "200"),
        *("--camera", "16x16", "--dtype", "float32", "--accel", "brute,bvh", "--processes", "2"),
        *("--rounds", "2", "--warmup", "0", "--target-ms", "0.2", "--no-progress", "--out", str(out)),
        env=env,
    )
    assert done.returncode == 0, done.stderr
    brute_id, bvh_id = workload_id(MeshSpec(**SMALL)), workload_id(MeshSpec(**SMALL, accel="bvh"))
    batches = runfolder.read_batches(out)
    kernels = batches.groupby("workload_id")["kernel"].unique()
    assert sorted(kernels[brute_id]) == sorted(["moller_trumbore", NATIVE]) and list(kernels[bvh_id]) == [NATIVE]
    # checked before any batch: the BVH's closest triangles against the reference
    checks = runfolder.read_checks(out)
    on_bvh = checks.loc[checks["workload_id"] == bvh_id]
    assert len(on_bvh) == 2 and (on_bvh["disagreements"] == on_bvh["ambiguous_disagreements"]).all()
    # a BVH batch's tests are the triangle tests its traversal did, its hits the reference's
    w = cache.make(MeshSpec(**SMALL, accel="bvh"))
    per_pass = int(ext.build_bvh(NATIVE, w.triangles).intersect(w.origins, w.directions).counts[:, 3].sum())
    b = batches.loc[batches["workload_id"] == bvh_id]
    assert (b["tests"] == b["loops"] * per_pass).all() and per_pass < len(w.origins) * len(w.triangles)
    assert (b["hits"] == b["loops"] * int(w.hits.sum())).all()
    # the workers read the kernel's tree from the BVH cache, where the first built it
    identity = bvh_cache.bvh_identity(NATIVE, w.triangles, ext.DEFAULT_MAX_LEAF)
    assert bvh_cache.bvh_path(identity).is_file()
    assert (out / "estimates.csv").is_file()  # the analysis step ran: no speedup against a kernel it lacks
    speedups = pd.read_csv(out / "speedups.csv")
    assert bvh_id not in set(speedups["workload_id"])


@pytest.mark.slow
def test_a_sweep_varies_the_leaf_size_one_workload_per_value(tmp_path, env):
    out = tmp_path / "run"
    args = ["sweep", "--kernels", NATIVE, "--mesh", "suzanne", "--triangles", "200", "--camera", "16x16"]
    args += ["--dtype", "float32", "--accel", "bvh", "--processes", "2", "--rounds", "1", "--warmup", "0"]
    done = cli(*args, "--max-leaf", "4,64", "--target-ms", "0.2", "--no-progress", "--out", str(out), env=env)
    assert done.returncode == 0, done.stderr
    batches = runfolder.read_batches(out)
    for leaf in (4, 64):
        spec = MeshSpec(**SMALL, accel="bvh", max_leaf=leaf)
        w = cache.make(spec)
        per_pass = ext.build_bvh(NATIVE, w.triangles, max_leaf=leaf).intersect(w.origins, w.directions).counts[:, 3]
        b = batches.loc[batches["workload_id"] == workload_id(spec)]
        assert len(b) and (b["tests"] == b["loops"] * int(per_pass.sum())).all()
    done = cli("sweep", "--mesh", "suzanne", "--max-leaf", "8", "--out", str(tmp_path / "no"), env=env)
    assert done.returncode == 2 and "--max-leaf is the size of a BVH's leaves: give --accel bvh too" in done.stderr


@pytest.mark.slow
def test_a_bvh_workload_without_a_native_kernel_is_refused_in_one_line(tmp_path, env):
    with pytest.raises(
        UserError, match=r"no kernel of the sweep can be a BVH's leaf test .*add one of moller_trumbore_fma"
    ):
        Sweep(("moller_trumbore", "curless"), (MeshSpec(**SMALL, accel="bvh"),))
    done = cli("sweep", "--kernels", "moller_trumbore,curless", "--mesh", "suzanne", "--accel", "bvh", env=env)
    assert done.returncode == 2 and len(done.stderr.strip().splitlines()) == 1
    assert "can be a BVH's leaf test" in done.stderr
    done = cli("sweep", "--kernels", NATIVE, "--accel", "bvh", env=env)
    assert done.returncode == 2 and "--accel applies to mesh workloads: give --mesh too" in done.stderr


def test_bvh_answers_are_checked_and_a_culling_kernel_is_held_to_the_front_faces(env):
    w = cache.make(MeshSpec(**SMALL, accel="bvh"))
    bvh = ext.build_bvh(NATIVE, w.triangles)
    checksum, counts = checks.one_pass_checksum(NATIVE, w, bvh)
    assert checksum.hits == int(w.hits.sum()) and counts["disagreements"] == counts["ambiguous_disagreements"]
    job = worker.BvhJob(bvh, w.origins, w.directions, "closest", None)
    checks.check_batch(worker.time_job(job, 3), checksum, NATIVE, w)
    wrong = w.ref_index.copy()
    ray = int(np.flatnonzero(w.hits & ~w.ambiguous())[0])
    wrong[ray] = (wrong[ray] + 1) % len(w.triangles)
    with pytest.raises(checks.KernelCheckError, match=rf"'{NATIVE}' on workload {w.workload_id}.*ray {ray}\)"):
        checks.one_pass_checksum(NATIVE, dataclasses.replace(w, ref_index=wrong), bvh)
    # every face turned away from the camera: a culling kernel sees the mesh's far side
    flipped = dataclasses.replace(w, triangles=np.ascontiguousarray(w.triangles[:, [0, 2, 1]]))
    cull = "moller_trumbore_cull_fma"
    checksum, counts = checks.one_pass_checksum(cull, flipped, ext.build_bvh(cull, flipped.triangles))
    index, _ = reference.intersect_closest(flipped.origins, flipped.directions, flipped.triangles, front_only=True)
    assert checksum.hits == int((index >= 0).sum()) and counts["disagreements"] == counts["ambiguous_disagreements"]
    assert (index != w.ref_index).sum() > len(index) // 10  # the culled answers are not the two-sided ones


# ------------------------------------------------------------------ peers

TINY_BVH = peers.PeerDesign(
    width=16, height=16, triangles=200, processes=2, reps=1, choice_rays=64, choice_rounds=1, accel="bvh"
)


@pytest.mark.slow
def test_peers_with_accel_bvh_write_a_tribench_row_with_implementation_bvh(tmp_path, env):
    frame = peers.measure(tmp_path / "peers.csv", TINY_BVH, progress=False)
    assert list(pd.read_csv(tmp_path / "peers.csv", nrows=0).columns) == list(peers.COLUMNS)
    tb = frame.loc[frame["contender"] == "tribench"]
    assert len(tb) == TINY_BVH.processes * TINY_BVH.reps
    assert tb["implementation"].str.contains(r"\bbvh\b").all() and tb["workload"].str.contains(" bvh ").all()
    assert frame["kernel"].iloc[0] in ext.bvh_kernel_names() and frame["kernel"].nunique() == 1
    assert (frame["differ"] == frame["differ_ambiguous"]).all() and (frame["rays_per_s"] > 0).all()
    contenders = set(frame["contender"])
    assert "trimesh" not in contenders  # in a BVH the peers are Embree's alone
    assert set(peers.NATIVE_EMBREE) <= contenders or peers.available()["embree"] is None


@pytest.mark.slow
def test_peers_with_accel_bvh_without_embree_still_time_tribench(tmp_path, env, monkeypatch):
    monkeypatch.setattr(peers, "available", lambda: {"trimesh": "fake", "embree": None})
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        frame = peers.measure(tmp_path / "peers.csv", TINY_BVH, kernel=NATIVE, progress=False)
    assert any(issubclass(c.category, Notice) and "native Embree is not available" in str(c.message) for c in caught)
    assert set(frame["contender"]) == {"tribench", "tribench_call", "tribench_packets"}
    assert set(frame["kernel"]) == {NATIVE}
    with pytest.raises(UserError, match="'moller_trumbore' cannot be a BVH's leaf test"):
        peers.measure(tmp_path / "peers.csv", TINY_BVH, kernel="moller_trumbore", progress=False)


def test_peers_cli_refuses_a_kernel_that_cannot_be_a_leaf_test(tmp_path, env):
    done = cli("peers", "--accel", "bvh", "--kernel", "moller_trumbore", "--out", str(tmp_path), env=env)
    assert done.returncode == 2 and len(done.stderr.strip().splitlines()) == 1
    assert "cannot be a BVH's leaf test with --accel bvh" in done.stderr
    assert not (tmp_path / peers.PEERS).exists()


OCTAHEDRON_OBJ = """# a closed octahedron, faces counter-clockwise seen from outside
v 1 0 0
v -1 0 0
v 0 1 0
v 0 -1 0
v 0 0 1
v 0 0 -1
f 1 3 5
f 3 2 5
f 2 4 5
f 4 1 5
f 3 1 6
f 2 3 6
f 4 2 6
f 1 4 6
"""


@pytest.mark.slow
def test_peers_take_a_mesh_file_through_the_bvh(tmp_path, env):
    obj = tmp_path / "octahedron.obj"
    obj.write_text(OCTAHEDRON_OBJ)
    design = dataclasses.replace(TINY_BVH, mesh=str(obj), triangles=None)
    frame = peers.measure(tmp_path / "peers.csv", design, progress=False)
    tb = frame.loc[frame["contender"] == "tribench"]
    assert len(tb) == design.processes * design.reps and tb["implementation"].str.contains(r"\bbvh\b").all()
    assert tb["workload"].str.startswith("mesh octahedron.obj triangles=base camera 16x16 bvh").all()
    assert (frame["differ"] == frame["differ_ambiguous"]).all() and (frame["rays_per_s"] > 0).all()
    w = cache.make(peers.camera_spec(design))
    assert len(w.triangles) == 8 and w.hits.any()
    # tribench's set-up is its tree's build, as recorded in the BVH cache by the process that built it
    (kernel,) = set(tb["kernel"])
    assert (tb["setup_ns"] == bvh_cache.cached_bvh(kernel, w.triangles)[1]).all()
    # the command line: a relative path, the file's own triangle count; a missing file is one line
    done = subprocess.run(
        [sys.executable, "-m", "tribench.cli", "peers", "--mesh", "octahedron.obj", "--accel", "bvh"]
        + ["--camera", "16x16", "--processes", "2", "--reps", "1", "--no-progress", "--out", "run"],
        capture_output=True,
        text=True,
        timeout=120,
        env=env,
        cwd=tmp_path,
    )
    assert done.returncode == 0, done.stderr
    written = pd.read_csv(tmp_path / "run" / peers.PEERS)
    assert written["workload"].str.contains("octahedron.obj triangles=base").all()
    done = cli("peers", "--mesh", str(tmp_path / "nope.obj"), "--accel", "bvh", "--out", str(tmp_path), env=env)
    assert done.returncode == 2 and len(done.stderr.strip().splitlines()) == 1 and "nope.obj" in done.stderr
