"""Incoherent secondary rays (MeshSpec rays="bounce"): one cosine-distributed
bounce from each camera hit; reproducible from the seed; plausible hit rates
(none from outside a convex mesh, some on Suzanne); every native kernel, brute
force and through its BVH, agrees with the float64 reference."""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest

from tribench import ext
from tribench.common import UserError
from tribench.harness import checks
from tribench.workloads import bvh_cache, generate, make
from tribench.workloads.meshes import bounding_sphere
from tribench.workloads.rays import BOUNCE_OFFSET
from tribench.workloads.spec import MeshSpec, workload_id

SUZANNE = {"mesh": "suzanne", "triangles": 2000, "width": 48, "height": 48}


@pytest.fixture(autouse=True)
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv("TRIBENCH_CACHE", str(tmp_path))
    return tmp_path


def test_bounces_leave_each_camera_hit_on_the_side_the_camera_saw_with_cosine_density():
    big = {**SUZANNE, "width": 96, "height": 96}
    camera, bounce = make(MeshSpec(**big)), make(MeshSpec(**big, rays="bounce"))
    rows = np.flatnonzero(camera.ref_index >= 0)
    assert len(bounce.origins) == len(rows) == bounce.achieved["primary_hits"]
    assert bounce.achieved["primary_rays"] == 96 * 96 == bounce.spec.targets()["primary_rays"]
    tri = camera.triangles[camera.ref_index[rows]].astype(float)
    normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    normal /= np.linalg.norm(normal, axis=1)[:, None]
    d_cam = camera.directions[rows].astype(float)
    normal[np.einsum("ij,ij->i", normal, d_cam) > 0] *= -1
    hit = camera.origins[rows] + camera.ref_t[rows, None] * d_cam
    centre, radius = bounding_sphere(camera.triangles.reshape(-1, 3).astype(float))
    offset = BOUNCE_OFFSET * (radius + np.linalg.norm(centre))
    assert bounce.achieved["bounce_offset"] == pytest.approx(offset)
    np.testing.assert_allclose(bounce.origins, hit + offset * normal, atol=1e-12)
    d = bounce.directions.astype(float)
    np.testing.assert_allclose(np.linalg.norm(d, axis=1), 1, atol=1e-12)
    cos = np.einsum("ij,ij->i", d, normal)
    assert (cos > 0).all()
    # cosine density: cos^2 is uniform on [0, 1) (mean 1/2, variance 1/12); E[cos] = 2/3
    n = len(cos)
    assert abs(np.mean(cos**2) - 0.5) < 4 * np.sqrt(1 / 12 / n)
    assert abs(np.mean(cos) - 2 / 3) < 4 * np.sqrt(1 / 18 / n)


def test_reproducible_from_the_seed():
    spec = MeshSpec(**SUZANNE, rays="bounce", dtype="float32")
    a, b = generate(spec), generate(spec)
    assert a.checksum() == b.checksum()
    other = generate(MeshSpec(**SUZANNE, rays="bounce", dtype="float32", rng_seed=1))
    assert not np.array_equal(a.directions, other.directions)
    assert workload_id(spec) != workload_id(MeshSpec(**SUZANNE, dtype="float32"))  # not the camera's id


def test_hit_rates_are_plausible():
    convex = make(MeshSpec("icosphere", rays="bounce", width=64, height=64))
    assert len(convex.origins) > 1000 and convex.achieved["ray_hits"] == 0  # leaving a convex mesh: always a miss
    suzanne = make(MeshSpec(**SUZANNE, rays="bounce"))
    assert 0.03 < suzanne.achieved["ray_hit_rate"] < 0.5  # ears, brows and eyes catch some


@pytest.mark.parametrize("dtype", ["float32", "float64"])
def test_every_native_kernel_brute_and_in_its_bvh_agrees_with_the_reference(dtype):
    w = make(MeshSpec(**SUZANNE, rays="bounce", dtype=dtype))
    assert w.achieved["ambiguous_rays"] < 0.02 * len(w.origins)
    for kernel in ext.bvh_kernel_names():
        brute, _ = checks.one_pass_checksum(kernel, w)  # raises on a disagreement outside the ambiguous rays
        bvh, _ = bvh_cache.cached_bvh(kernel, w.triangles)
        in_bvh, counts = checks.one_pass_checksum(kernel, w, bvh)
        assert counts["disagreements"] == counts["ambiguous_disagreements"]
        if not ext.kernel_info(kernel).culls_back_faces:
            assert brute.hits == in_bvh.hits == int(w.hits.sum())
    twin = make(MeshSpec(**SUZANNE, rays="bounce", dtype=dtype, accel="bvh"))
    assert twin.checksum() == w.checksum()


def test_spec_and_command_line():
    with pytest.raises(UserError, match="n_rays applies to rays='hit_rate' only"):
        MeshSpec("suzanne", rays="bounce", n_rays=10)
    assert (
        MeshSpec("suzanne", rays="bounce").summary()
        == "mesh suzanne triangles=base bounces of camera 512x512 float64 rng_seed=0"
    )
    env = {**os.environ}
    done = subprocess.run(
        [sys.executable, "-m", "tribench.cli", "workloads", "make", "suzanne", "--rays", "bounce"]
        + ["--triangles", "300", "--width", "16", "--height", "16"],
        capture_output=True,
        text=True,
        timeout=120,
        env=env,
    )
    assert done.returncode == 0, done.stderr
    spec = MeshSpec("suzanne", triangles=300, width=16, height=16, rays="bounce")
    assert done.stdout.startswith(workload_id(spec)) and "bounces of camera 16x16" in done.stdout
