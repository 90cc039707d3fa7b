"""A run folder over a mesh file renders and exports anywhere: the file is named by its content and copied.

The attack: ``tribench sweep --mesh FILE``, then move or edit the file; ``tribench report RUN`` and
``tribench export RUN`` failed with "unknown mesh" or blamed run.json.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys

import pytest

from tribench.common import UserError
from tribench.workloads import cache, mesh_files
from tribench.workloads.spec import MeshSpec, workload_id

OCTAHEDRON = """\
v 1 0 -3\nv -1 0 -3\nv 0 1 -3\nv 0 -1 -3\nv 0 0 -2\nv 0 0 -4
f 1 3 5\nf 3 2 5\nf 2 4 5\nf 4 1 5\nf 3 1 6\nf 2 3 6\nf 4 2 6\nf 1 4 6
"""


def tribench(*args, cache_dir):
    env = {**os.environ, "TRIBENCH_CACHE": str(cache_dir)}
    return subprocess.run(
        [sys.executable, "-m", "tribench.cli", *args], capture_output=True, text=True, timeout=300, env=env
    )


@pytest.fixture
def swept(tmp_path):
    """A tiny sweep over a mesh file, then the file moved away and every cache emptied: another machine."""
    mesh = tmp_path / "one.obj"
    mesh.write_text(OCTAHEDRON)
    run = tmp_path / "run"
    args = ["sweep", "--kernels", "moller_trumbore,curless", "--mesh", str(mesh), "--camera", "8x8"]
    args += ["--dtype", "float32", "--processes", "2", "--rounds", "2", "--target-ms", "0.2", "--no-progress"]
    done = tribench(*args, "--out", str(run), cache_dir=tmp_path / "cache")
    assert done.returncode == 0, done.stderr
    assert list((run / mesh_files.RUN_FOLDER).glob("*.obj"))  # the run folder carries its mesh
    mesh.rename(tmp_path / "elsewhere.obj")
    shutil.rmtree(tmp_path / "cache")
    return run, tmp_path


@pytest.mark.slow
def test_report_and_export_never_need_the_original_mesh_file(swept):
    run, tmp_path = swept
    for command in (["stats", str(run)], ["report", str(run)], ["export", str(run)]):
        done = tribench(*command, cache_dir=tmp_path / "other-cache")
        assert done.returncode == 0, (command, done.stderr)
        assert "unknown mesh" not in done.stderr and "edited file" not in done.stderr
    assert "one.obj" in (run / "report.html").read_text(encoding="utf-8")


@pytest.mark.slow
def test_an_edited_mesh_file_is_named_by_the_content_its_run_used(swept):
    run, tmp_path = swept
    (tmp_path / "one.obj").write_text(OCTAHEDRON.replace("v 1 0 -3", "v 2 0 -3"))  # back, but changed
    done = tribench("report", str(run), cache_dir=tmp_path / "other-cache")
    assert done.returncode == 0, done.stderr


def test_a_workload_rebuilds_from_the_cached_copy_and_a_lost_file_is_one_clear_error(tmp_path, monkeypatch):
    monkeypatch.setenv("TRIBENCH_CACHE", str(tmp_path / "cache"))
    mesh = tmp_path / "one.obj"
    mesh.write_text(OCTAHEDRON)
    spec = MeshSpec(str(mesh), width=8, height=8)
    built = cache.make(spec)  # keeps a copy beside the cache
    recorded = MeshSpec(**{k: v for k, v in spec.to_dict().items() if k != "kind"})
    assert recorded == spec and workload_id(recorded) == workload_id(spec)
    mesh.unlink()
    (tmp_path / "cache" / f"{workload_id(spec)}.npz").unlink()
    assert cache.make(recorded).checksum() == built.checksum()  # rebuilt from the copy
    shutil.rmtree(tmp_path / "cache")
    with pytest.raises(UserError, match=r"one\.obj is gone since this workload was defined"):
        cache.make(recorded)


def test_the_run_folder_names_the_copies_folder_the_module_writes():
    from tribench.harness import runfolder

    assert runfolder.MESHES_DIR == mesh_files.RUN_FOLDER


def test_a_recorded_hash_is_checked_for_its_form_and_refused_on_a_built_in_mesh():
    with pytest.raises(UserError, match="64 hexadecimal digits"):
        MeshSpec("/nowhere/one.obj", mesh_sha256="abc")
    with pytest.raises(UserError, match="mesh file only"):
        MeshSpec("suzanne", mesh_sha256="0" * 64)


def test_a_folder_where_a_copy_goes_is_a_notice_not_a_stop(tmp_path):
    from tribench.common import Notice

    mesh = tmp_path / "one.obj"
    mesh.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    sha = mesh_files.file_sha256(mesh)
    (tmp_path / "run" / mesh_files.RUN_FOLDER / f"{sha}.obj").mkdir(parents=True)
    with pytest.warns(Notice, match="is not a regular file: no copy of one.obj is kept there"):
        mesh_files.copy_into_run(tmp_path / "run", mesh, sha)


@pytest.mark.parametrize("index", [5, -1])
def test_a_ply_face_naming_a_vertex_it_lacks_is_one_line(tmp_path, index):
    # trimesh reads a PLY's faces as written: 5 was numpy's IndexError, -1 silently the last vertex
    path = tmp_path / "bad.ply"
    path.write_text(
        "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
        "element face 2\nproperty list uchar int vertex_indices\nend_header\n"
        f"0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 1 2\n3 0 1 {index}\n"
    )
    with pytest.raises(UserError, match=rf"^mesh file .* has a face naming vertex {index}, .* vertices are 0 to 3\)$"):
        MeshSpec(str(path))
