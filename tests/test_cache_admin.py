"""``tribench cache`` (workloads/cache_admin.py): every kind of cached file listed with its size, what no
installed build can use pruned, a size bound removing the oldest-used first; and the BVH cache meeting a
folder, a link or an unwritable folder in a cache file's place with one notice and the tree in memory."""

from __future__ import annotations

import io
import json
import os
import warnings

import numpy as np
import pytest
from test_cli import run

from tribench import ext
from tribench.common import UserError
from tribench.workloads import CacheWarning, bvh_cache, cache_admin
from tribench.workloads.cache import make, sealed_npz
from tribench.workloads.front import FRONT_VERSION
from tribench.workloads.spec import PairSpec, file_sha256

KERNEL = ext.bvh_kernel_names()[0]


@pytest.fixture(autouse=True)
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv("TRIBENCH_CACHE", str(tmp_path / "cache"))
    return tmp_path / "cache"


def _tris(seed: int = 0) -> np.ndarray:
    return np.ascontiguousarray(np.random.default_rng(seed).normal(size=(200, 3, 3)), np.float32)


def _bvh_file(seed: int = 0):
    bvh_cache.cached_bvh(KERNEL, _tris(seed))
    return bvh_cache.bvh_path(bvh_cache.bvh_identity(KERNEL, _tris(seed), ext.DEFAULT_MAX_LEAF))


def _another_build(path) -> None:
    """Rewrite a BVH file as another build of the extension would have made it (sealed, so only its
    identity tells)."""
    with np.load(io.BytesIO(path.read_bytes())) as z:
        meta = json.loads(str(z["meta"][()]))
        arrays = {k: z[k].copy() for k in z.files if k != "meta"}
    meta["identity"]["extension_sha256"] = "0" * 64
    path.write_bytes(sealed_npz(meta, arrays))


def _filled(cache):
    """One file of each kind, usable, plus one unusable of each kind prune removes."""
    workload = make(PairSpec(n=200)).workload_id
    good_bvh, old_bvh = _bvh_file(0), _bvh_file(1)
    _another_build(old_bvh)
    (cache / "front").mkdir()
    index, t = np.full(3, -1, np.int64), np.full(3, np.nan)
    for name, version in (("good", FRONT_VERSION), ("old", FRONT_VERSION - 1)):
        (cache / "front" / f"{name}.npz").write_bytes(sealed_npz({"front_version": version}, {"index": index, "t": t}))
    (cache / "meshes").mkdir()
    mesh = cache / "meshes" / "x.ply"
    mesh.write_bytes(b"ply mesh")
    mesh.rename(cache / "meshes" / f"{file_sha256(mesh)}.ply")
    (cache / "deadbeef.npz").write_bytes(b"not a sealed file")  # a corrupt workload
    (cache / f".x.npz.{2**22 + 1}.abcd.tmp").write_bytes(b"half")  # no such pid: a killed write
    (cache / "notes.txt").write_text("the user's own")
    return workload, good_bvh, old_bvh


def test_entries_list_every_kind_with_its_size_and_why_it_cannot_be_used(cache):
    workload, good_bvh, old_bvh = _filled(cache)
    found = {e.path.relative_to(cache).as_posix(): e for e in cache_admin.entries()}
    kinds = {name: e.kind for name, e in found.items()}
    assert kinds[f"{workload}.npz"] == "workload" and kinds["deadbeef.npz"] == "workload"
    assert kinds[f"bvh/{good_bvh.name}"] == kinds[f"bvh/{old_bvh.name}"] == "bvh"
    assert kinds["front/good.npz"] == "front" and kinds["notes.txt"] == "other"
    assert sorted(kinds.values()).count("mesh") == 1 and sorted(kinds.values()).count("temporary") == 1
    for name, e in found.items():
        assert e.size_bytes == (cache / name).stat().st_size
    unusable = {name for name, e in found.items() if e.problem}
    assert unusable == {f"bvh/{old_bvh.name}", "front/old.npz", "deadbeef.npz", f".x.npz.{2**22 + 1}.abcd.tmp"}
    assert "another build" in found[f"bvh/{old_bvh.name}"].problem
    assert "checksum" in found["deadbeef.npz"].problem


def test_prune_removes_what_no_build_can_use_and_keeps_the_rest(cache):
    workload, good_bvh, old_bvh = _filled(cache)
    before = {e.path for e in cache_admin.entries()}
    assert cache_admin.prune(dry_run=True).removed and {e.path for e in cache_admin.entries()} == before
    done = cache_admin.prune()
    gone = {e.path for e in done.removed}
    assert gone == {e.path for e in cache_admin.entries()} ^ before
    assert not old_bvh.exists() and not (cache / "front" / "old.npz").exists() and not (cache / "deadbeef.npz").exists()
    assert good_bvh.exists() and (cache / f"{workload}.npz").exists() and (cache / "notes.txt").exists()
    assert not any(e.problem for e in cache_admin.entries())
    assert cache_admin.prune().removed == []


def test_a_size_bound_removes_the_oldest_used_first(cache):
    a, b, c = (_bvh_file(seed) for seed in range(3))
    for age, path in ((300, a), (100, b), (200, c)):
        os.utime(path, (1e9 - age, 1e9 - age))
    size = a.stat().st_size
    done = cache_admin.prune(max_bytes=int(1.5 * size))  # room for one
    assert [e.path for e in done.removed] == [a, c] and b.exists()
    assert done.kept_bytes == b.stat().st_size
    assert [e.path for e in cache_admin.prune(max_bytes=0).removed] == [b]


def test_sizes_parse_and_a_bad_one_is_a_user_error():
    assert cache_admin.parse_size("0") == 0 and cache_admin.parse_size("1.5 GB") == 1_500_000_000
    assert cache_admin.parse_size("3k") == 3000 and cache_admin.parse_size("1GiB") == 2**30
    for bad in ("", "-1MB", "lots", "5 parsecs"):
        with pytest.raises(UserError, match="--max-size"):
            cache_admin.parse_size(bad)


# ------------------------------------------------------------- the BVH cache meets something in the way


def _one_notice(match: str):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        bvh, _ = bvh_cache.cached_bvh(KERNEL, _tris())
    assert [str(w.message) for w in caught if issubclass(w.category, CacheWarning)] == [str(w.message) for w in caught]
    assert len(caught) == 1 and match in str(caught[0].message), [str(w.message) for w in caught]
    assert bvh.nodes.tobytes() == ext.build_bvh(KERNEL, _tris()).nodes.tobytes()


@pytest.mark.parametrize("what", ["folder", "link"])
def test_a_folder_or_link_in_place_of_a_bvh_file_is_a_notice_and_the_tree_in_memory(cache, what):
    path = _bvh_file()
    path.unlink()
    if what == "folder":
        path.mkdir()
    else:
        (cache / "elsewhere").write_bytes(b"x")
        path.symlink_to(cache / "elsewhere")
    _one_notice(f"is a {what}, not a cache file")
    assert path.is_dir() if what == "folder" else path.is_symlink()  # left as it was, never replaced
    found = {e.path: e for e in cache_admin.entries()}
    assert f"a {what} in place" in found[path].problem
    removed = [e.path for e in cache_admin.prune().removed]
    assert removed == ([] if what == "folder" else [path]) and path.exists() == (what == "folder")
    assert (cache / "elsewhere").exists() or what == "folder"  # the link went, not what it points at


def test_an_unwritable_bvh_folder_is_a_notice_and_the_tree_in_memory(cache):
    cache.mkdir()
    (cache / "bvh").write_text("a file where the folder goes")  # root writes past chmod: this it cannot
    _one_notice("kept in memory")


@pytest.mark.slow  # five commands, a second or more each
def test_the_command_lists_and_prunes_and_refuses_a_bad_size(cache):
    env = {"TRIBENCH_CACHE": str(cache)}
    old = _bvh_file(1)
    _another_build(old)
    listed = run("cache", "list", env=env)
    assert listed.returncode == 0, listed.stderr
    assert f"bvh/{old.name}  [made by another build of the extension]" in listed.stdout
    assert "1 files" in listed.stdout and "tribench cache prune" in listed.stdout
    pruned = run("cache", "prune", env=env)
    assert pruned.returncode == 0, pruned.stderr
    assert f"removed bvh/{old.name}" in pruned.stdout and not old.exists()
    bad = run("cache", "prune", "--max-size", "lots", env=env)
    assert bad.returncode == 2 and "Traceback" not in bad.stderr
    assert bad.stderr.strip().splitlines() == [
        "tribench cache: error: --max-size 'lots': expected a size such as 500MB, 2GB or 0"
    ]
    assert run("cache", "list", env={"TRIBENCH_CACHE": str(cache / "none")}).stdout.startswith("nothing cached")


@pytest.mark.slow
def test_a_sweep_shows_its_workers_cache_notices_once_each_and_finishes(cache, tmp_path):
    env = {"TRIBENCH_CACHE": str(cache)}
    design = ["--processes", "2", "--rounds", "1", "--warmup", "0", "--target-ms", "0.05", "--no-progress"]
    sweep = ["sweep", "--kernels", KERNEL, "--mesh", "icosphere"]
    sweep += ["--triangles", "80", "--camera", "6x6", "--accel", "bvh", *design]
    first = run(*sweep, "--out", tmp_path / "a", env=env)
    assert first.returncode == 0, first.stderr
    (tree,) = (cache / "bvh").iterdir()
    tree.unlink()
    tree.mkdir()  # in the way of both workers
    second = run(*sweep, "--out", tmp_path / "b", env=env)
    assert second.returncode == 0, second.stderr
    notices = [line for line in second.stderr.splitlines() if "not a cache file" in line]
    assert notices == [
        f"tribench: cache file {tree} is a folder, not a cache file (remove it to cache it again): "
        "the BVH is kept in memory"
    ], second.stderr
    assert "Traceback" not in second.stderr


def test_a_folder_in_place_of_a_workload_file_is_a_notice_and_the_workload_in_memory(cache):
    spec = PairSpec(n=200)
    path = cache / f"{make(spec).workload_id}.npz"
    fresh = make(spec).checksum()
    path.unlink()
    path.mkdir()
    with pytest.warns(CacheWarning, match="is a folder, not a cache file.*kept in memory"):
        assert make(spec).checksum() == fresh
    assert path.is_dir()
