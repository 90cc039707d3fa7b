"""A user's own rays (``--rays FILE.npz``): checked in Python, hashed into the id, answered by the reference,
carried by the run folder; every bad file is one clear error."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from tribench.common import UserError
from tribench.harness.sweep_file import load_sweep_file
from tribench.workloads import cache, mesh_files, ray_files
from tribench.workloads.kinds import spec_from_dict
from tribench.workloads.reference import intersect_closest
from tribench.workloads.spec import MeshSpec, workload_id

TRIBENCH = Path(sys.executable).parent / "tribench"  # the installed command


def own_rays(n: int = 200, seed: int = 1) -> dict[str, np.ndarray]:
    """Rays from a sphere of radius 4 about the icosphere (centre (0, 0, -2)) toward points near it."""
    rng = np.random.default_rng(seed)
    start = rng.normal(size=(n, 3))
    start = 4 * start / np.linalg.norm(start, axis=1)[:, None] + [0, 0, -2]
    aim = rng.normal(size=(n, 3)) * 0.8 + [0, 0, -2]
    return {"origins": start.astype(np.float32), "directions": (aim - start).astype(np.float32)}


def save(path: Path, **arrays) -> Path:
    np.savez(path, **arrays)
    return path


@pytest.fixture
def cache_dir(tmp_path, monkeypatch):
    monkeypatch.setenv("TRIBENCH_CACHE", str(tmp_path / "cache"))
    return tmp_path / "cache"


def test_own_rays_get_the_reference_of_brute_force_with_their_t_max(tmp_path, cache_dir):
    rays = own_rays()
    t_max = np.full(200, np.inf, np.float32)
    t_max[::3] = 0.5  # some hits lie beyond (the directions are 3 to 5 long)
    path = save(tmp_path / "mine.npz", **rays, t_max=t_max)
    w = cache.make(MeshSpec("icosphere", rays=str(path)))
    assert w.spec.n_rays == 200 and w.achieved["rays"] == 200
    assert w.t_max is not None and w.t_max.tolist() == t_max.astype(np.float64).tolist()
    assert w.origins.dtype == np.float64 and np.array_equal(w.origins, rays["origins"].astype(np.float64))
    index, t = intersect_closest(w.origins, w.directions, w.triangles, t_max=w.t_max)
    assert np.array_equal(w.ref_index, index) and np.allclose(w.ref_t, t, equal_nan=True)
    unlimited, _ = intersect_closest(w.origins, w.directions, w.triangles)
    assert 0 < (w.ref_index >= 0).sum() < (unlimited >= 0).sum()  # t_max turned some hits into misses
    assert (w.ref_index < 0).any()


def test_the_id_is_the_content_not_the_path_and_round_trips(tmp_path, cache_dir):
    path = save(tmp_path / "a.npz", **own_rays())
    spec = MeshSpec("icosphere", rays=str(path))
    moved = shutil.copy(path, tmp_path / "b.npz")
    assert workload_id(MeshSpec("icosphere", rays=moved)) == workload_id(spec)
    other = save(tmp_path / "c.npz", **own_rays(seed=2))
    assert workload_id(MeshSpec("icosphere", rays=str(other))) != workload_id(spec)
    assert workload_id(MeshSpec("icosphere", rays=str(path), dtype="float32")) != workload_id(spec)
    back = spec_from_dict(spec.to_dict())
    assert back == spec and workload_id(back) == workload_id(spec)
    assert spec.to_dict()["rays_sha256"] == spec.rays_sha256 and spec.to_dict()["n_rays"] == 200


def test_existing_workload_ids_do_not_change():
    # the ids these specs had before ray files existed (main at d997c68)
    assert workload_id(MeshSpec("icosphere", width=8, height=8)) == "mesh-548af5e76bb4"
    assert workload_id(MeshSpec("suzanne", rays="hit_rate", n_rays=100)) == "mesh-a834a87d65b6"
    assert workload_id(MeshSpec("suzanne", rays="bounce", accel="bvh")) == "mesh-6f8bdf85e3cd"
    assert "rays_sha256" not in MeshSpec("suzanne").to_dict()


def test_a_lost_ray_file_rebuilds_from_the_cached_copy_then_is_one_clear_error(tmp_path, cache_dir):
    path = save(tmp_path / "mine.npz", **own_rays())
    spec = MeshSpec("icosphere", rays=str(path))
    built = cache.make(spec)
    assert (cache_dir / mesh_files.RAYS_FOLDER / f"{spec.rays_sha256}.npz").is_file()
    path.unlink()
    (cache_dir / f"{workload_id(spec)}.npz").unlink()
    assert cache.make(spec_from_dict(spec.to_dict())).checksum() == built.checksum()
    shutil.rmtree(cache_dir)
    with pytest.raises(UserError, match=r"ray file .*mine\.npz is gone since this workload was defined"):
        cache.make(spec_from_dict(spec.to_dict()))


def test_the_run_folder_names_the_folder_the_module_writes():
    from tribench.harness import runfolder

    assert runfolder.RAYS_DIR == mesh_files.RAYS_FOLDER


def test_a_sweep_file_takes_a_ray_file(tmp_path):
    path = save(tmp_path / "mine.npz", **own_rays())
    sweep = tmp_path / "sweep.toml"
    sweep.write_text(
        f'kernels = ["moller_trumbore"]\n[[workloads]]\nkind = "mesh"\nmesh = "icosphere"\nrays = "{path}"\n'
    )
    (spec,) = load_sweep_file(sweep).workloads
    assert isinstance(spec, MeshSpec) and spec.rays_from_file and spec.n_rays == 200


# ------------------------------------------------------------------ bad files


def _rays(n=4):
    return {"origins": np.zeros((n, 3)), "directions": np.tile([0.0, 0.0, -1.0], (n, 1))}


def _with(**changes):
    def make(path):
        arrays = {**_rays(), **changes}
        np.savez(path, **{k: v for k, v in arrays.items() if v is not None})

    return make


def _row(name, row, value):
    a = _rays()[name].copy()
    a[row] = value
    return a


def _write(data: bytes):
    return lambda path: path.write_bytes(data)


BAD = {
    "text": (_write(b"origins,directions\n1,2\n"), r"not an \.npz file"),
    "npy": (lambda p: np.save(p.with_suffix(".npy"), np.zeros(3)) or p.with_suffix(".npy").rename(p), r"\.npy"),
    "cut": (lambda p: (_with()(p), p.write_bytes(p.read_bytes()[:-200])), r"not an \.npz file|corrupt"),
    "no directions": (_with(directions=None), r"no 'directions' array"),
    "unknown array": (_with(tmax=np.ones(4)), r"unknown array\(s\) 'tmax'"),
    "four columns": (_with(origins=np.zeros((4, 4))), r"'origins' must have shape \(N, 3\), got \(4, 4\)"),
    "flat t_max": (_with(t_max=np.ones((4, 1))), r"'t_max' must have shape \(N,\)"),
    "rows differ": (_with(directions=np.ones((5, 3))), r"different numbers of rows: origins 4, directions 5"),
    "ints": (_with(origins=np.zeros((4, 3), np.int64)), r"'origins' must be float32 or float64, got int64"),
    "objects": (_with(origins=np.array([[None] * 3] * 4)), r"'origins' must be float32 or float64, got object"),
    "empty": (_with(origins=np.zeros((0, 3)), directions=np.zeros((0, 3))), r"0 rays: a ray file holds 1 to"),
    "nan": (_with(origins=_row("origins", 2, [0, np.nan, 0])), r"origins row 2 is not finite \(\[0\.0, nan, 0\.0\]\)"),
    "inf": (_with(directions=_row("directions", 1, [np.inf, 0, 0])), r"directions row 1 is not finite"),
    "zero": (_with(directions=_row("directions", 3, [0, 0, 0])), r"directions row 3 is zero"),
    "t_max nan": (_with(t_max=np.array([1, 1, np.nan, 1])), r"t_max row 2 is not > 0"),
    "t_max zero": (_with(t_max=np.array([1, 0, 1, 1.0])), r"t_max row 1 is not > 0"),
}


@pytest.mark.parametrize("case", BAD)
def test_a_bad_ray_file_is_one_error_naming_the_file_and_what_is_wrong(tmp_path, case):
    write, message = BAD[case]
    path = tmp_path / "bad.npz"
    write(path)
    with pytest.raises(UserError, match=message) as caught:
        MeshSpec("icosphere", rays=str(path))
    assert str(caught.value).startswith(f"ray file {path}") and "\n" not in str(caught.value)


def test_a_float64_direction_that_is_zero_in_float32_is_refused_at_that_precision(tmp_path):
    path = save(tmp_path / "tiny.npz", origins=np.zeros((2, 3)), directions=np.array([[0, 0, -1], [0, 1e-50, 0]]))
    assert MeshSpec("icosphere", rays=str(path)).n_rays == 2
    with pytest.raises(UserError, match=r"\(rounded to float32\): directions row 1 is zero"):
        MeshSpec("icosphere", rays=str(path), dtype="float32")


def test_sizes_over_the_bounds_are_refused_before_the_data_is_read(tmp_path, monkeypatch):
    path = save(tmp_path / "big.npz", **_rays(10))
    monkeypatch.setattr(ray_files, "MAX_FILE_RAYS", 9)
    with pytest.raises(UserError, match=r"10 rays: a ray file holds 1 to 9 rays"):
        ray_files.read_ray_file(path)
    monkeypatch.setattr(ray_files, "MAX_FILE_BYTES", 100)
    with pytest.raises(UserError, match=r"MB: at most 0 MB"):
        ray_files.read_ray_file(path)


def test_options_that_a_ray_file_replaces_are_refused(tmp_path):
    path = str(save(tmp_path / "mine.npz", **_rays()))
    for option in ({"width": 8}, {"hit_rate": 0.5}, {"n_rays": 4}):
        with pytest.raises(UserError, match="does not apply to a ray file"):
            MeshSpec("icosphere", rays=path, **option)
    with pytest.raises(UserError, match="not one of camera, hit_rate, bounce and a folder"):
        MeshSpec("icosphere", rays=str(tmp_path))
    with pytest.raises(UserError, match="rays_sha256 applies to a ray file only"):
        MeshSpec("icosphere", rays_sha256="0" * 64)


# ------------------------------------------------------------------ the installed command


def tribench(*args, cwd, cache_dir):
    env = {**os.environ, "TRIBENCH_CACHE": str(cache_dir)}
    return subprocess.run([TRIBENCH, *map(str, args)], capture_output=True, text=True, timeout=300, cwd=cwd, env=env)


@pytest.mark.slow
def test_workloads_make_takes_a_ray_file_through_the_installed_command(tmp_path):
    save(tmp_path / "mine.npz", **own_rays())
    done = tribench("workloads", "make", "icosphere", "--rays", "mine.npz", cwd=tmp_path, cache_dir=tmp_path / "c")
    assert done.returncode == 0, done.stderr
    assert "200 rays from mine.npz" in done.stdout


def test_a_bad_ray_file_on_the_command_line_exits_2_with_one_line(tmp_path, monkeypatch, capsys, cache_dir):
    from tribench import cli

    monkeypatch.chdir(tmp_path)
    _with(origins=_row("origins", 1, [np.nan, 0, 0]))(tmp_path / "bad.npz")
    assert cli.main(["workloads", "make", "icosphere", "--rays", "bad.npz"]) == 2
    assert capsys.readouterr().err.splitlines() == [
        f"tribench workloads: error: ray file {tmp_path / 'bad.npz'}: origins row 1 is not finite ([nan, 0.0, 0.0])"
    ]
    camera = ["--mesh", "icosphere", "--camera", "8x8"]
    for extra, message in (([], "give --mesh too"), (camera, "--camera and --rays")):
        assert cli.main(["sweep", "--rays", "bad.npz", *extra, "--out", "run"]) == 2
        err = capsys.readouterr().err
        assert message in err and len(err.splitlines()) == 1 and "Traceback" not in err
    assert cli.main(["sweep", "--mesh", "icosphere", "--rays", "bad.npz", "--out", "run"]) == 2
    assert "origins row 1 is not finite" in capsys.readouterr().err and not (tmp_path / "run").exists()


@pytest.mark.slow
def test_a_sweep_over_own_rays_runs_and_reports_without_the_file(tmp_path):
    save(tmp_path / "mine.npz", **own_rays(), t_max=np.full(200, 5.0, np.float32))
    args = ["sweep", "--mesh", "icosphere", "--rays", "mine.npz", "--kernels", "moller_trumbore,curless"]
    args += ["--dtype", "float32,float64", "--processes", "2", "--rounds", "2", "--target-ms", "0.2", "--no-progress"]
    done = tribench(*args, "--out", "run", cwd=tmp_path, cache_dir=tmp_path / "cache")
    assert done.returncode == 0, done.stderr
    run = tmp_path / "run"
    (copy,) = (run / mesh_files.RAYS_FOLDER).glob("*.npz")
    assert copy.read_bytes() == (tmp_path / "mine.npz").read_bytes()
    (tmp_path / "mine.npz").unlink()
    shutil.rmtree(tmp_path / "cache")
    done = tribench("report", "run", cwd=tmp_path, cache_dir=tmp_path / "other-cache")
    assert done.returncode == 0, done.stderr
    assert "200 rays from mine.npz" in (run / "report.html").read_text(encoding="utf-8")
