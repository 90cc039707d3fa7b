"""The front-face reference (what a culling kernel must answer): equal to brute force, computed once, cached
sealed beside the workload, and never used when the file is corrupt, stale or another workload's."""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from tribench.harness import checks
from tribench.workloads import CacheWarning, cache, front, list_cached, reference
from tribench.workloads.seed.workload import SeedSpec
from tribench.workloads.spec import MeshSpec

# a shadow stream: a few of its rays meet a back face first (the brute-force part runs)
SHADOW = SeedSpec("scene02", "shadow", sample=300, width=24, height=24, dtype="float64")
CAMERA = MeshSpec("icosphere", triangles=80, width=12, height=12, result="any")


@pytest.fixture
def env(tmp_path, monkeypatch):
    monkeypatch.setenv("TRIBENCH_CACHE", str(tmp_path / "cache"))
    return tmp_path / "cache"


def _brute(w):
    return reference.intersect_closest(w.origins, w.directions, w.triangles, t_max=w.t_max, front_only=True)


@pytest.mark.parametrize("spec", [SHADOW, CAMERA], ids=["seed-shadow", "icosphere-any"])
def test_equals_brute_force_over_the_front_faces(env, spec):
    w = cache.make(spec)
    index, t = front.compute_front_reference(w)
    want_index, want_t = _brute(w)
    np.testing.assert_array_equal(index, want_index)
    np.testing.assert_array_equal(t, want_t)
    if spec is SHADOW:  # not vacuous: rays whose two-sided closest hit is a back face were searched again
        assert ((w.ref_index >= 0) & (index != w.ref_index)).sum() > 0


@settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(seed=st.integers(0, 2**31), flip=st.booleans())
def test_equals_brute_force_on_any_mesh_from_either_side(env, seed, flip):
    w = cache.make(MeshSpec("icosphere", triangles=80, rays="hit_rate", hit_rate=0.7, n_rays=64, rng_seed=seed))
    if flip:  # every face turned: the closest hit of every ray is a back face
        w = dataclasses.replace(w, triangles=np.ascontiguousarray(w.triangles[:, [0, 2, 1]]))
    index, t = front.compute_front_reference(w)
    want_index, want_t = _brute(w)
    np.testing.assert_array_equal(index, want_index)
    np.testing.assert_array_equal(t, want_t)


def test_computed_once_then_read_from_its_own_sealed_file(env, monkeypatch):
    w = cache.make(SHADOW)
    first = front.front_reference(w)
    path = front.front_path(w.workload_id)
    assert path.is_file() and path.parent == env / "front"

    def no_second_computation(_):
        raise AssertionError("computed again")

    monkeypatch.setattr(front, "compute_front_reference", no_second_computation)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        again = front.front_reference(cache.make(SHADOW))
    for a, b in zip(first, again, strict=True):
        np.testing.assert_array_equal(a, b)
    # the folder of its own keeps it out of the workload listing and the id prefixes
    assert [c.workload_id for c in list_cached()] == [w.workload_id]
    assert cache.resolve_id(w.workload_id[:6]) == w.workload_id


def _corruptions(good: bytes, other: bytes):
    yield "flipped bit", good[:100] + bytes([good[100] ^ 4]) + good[101:]
    yield "cut", good[: len(good) // 2]
    yield "empty", b""
    yield "appended", good + b"x"
    yield "another workload's file", other


def test_a_corrupt_stale_or_foreign_file_is_recomputed_with_a_notice(env, monkeypatch):
    w, v = cache.make(SHADOW), cache.make(CAMERA)
    want = front.front_reference(w)
    path = front.front_path(w.workload_id)
    good = path.read_bytes()
    front.front_reference(v)
    other = front.front_path(v.workload_id).read_bytes()
    for what, bad in _corruptions(good, other):
        path.write_bytes(bad)
        with pytest.warns(CacheWarning, match=f"cache file {path} is invalid"):
            got = front.front_reference(w)
        np.testing.assert_array_equal(got[0], want[0])
        assert path.read_bytes() == good, what  # rewritten whole
    # the same id holding other arrays (a workload changed in memory) is not answered from the file
    flipped = dataclasses.replace(w, triangles=np.ascontiguousarray(w.triangles[:, [0, 2, 1]]))
    with pytest.warns(CacheWarning, match="another workload"):
        np.testing.assert_array_equal(front.front_reference(flipped)[0], _brute(flipped)[0])
    # a file made by another version of the computation
    path.write_bytes(good)
    monkeypatch.setattr(front, "FRONT_VERSION", front.FRONT_VERSION + 1)
    with pytest.warns(CacheWarning, match="another version"):
        front.front_reference(w)


def test_the_worker_holds_a_culling_kernel_to_the_cached_reference(env):
    w = cache.make(SHADOW)
    checksum, counts = checks.one_pass_checksum("moller_trumbore_cull_fma", w)
    assert front.front_path(w.workload_id).is_file()
    assert counts["disagreements"] == counts["ambiguous_disagreements"]
    assert checksum.hits == int((_brute(w)[0] >= 0).sum()) < int(w.hits.sum())  # fewer hits than two-sided
