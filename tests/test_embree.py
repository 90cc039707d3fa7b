"""Native Embree (tribench.ext.embree): its answers against the float64 reference, its refusals, its absence."""

from __future__ import annotations

import numpy as np
import pytest

from tribench.common import UserError
from tribench.ext import embree
from tribench.workloads import cache, robustness
from tribench.workloads.spec import MeshSpec

needs_embree = pytest.mark.skipif(embree.missing() is not None, reason=str(embree.missing()))
CASES = [(robust, width, isa) for robust in (False, True) for width in embree.WIDTHS for isa in embree.ISAS]


@pytest.fixture(scope="module")
def workload(tmp_path_factory):
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("TRIBENCH_CACHE", str(tmp_path_factory.mktemp("cache")))
        return cache.make(MeshSpec("suzanne", triangles=500, rays="camera", width=40, height=37, dtype="float32"))


@needs_embree
@pytest.mark.parametrize("robust,width,isa", CASES)
def test_closest_hits_agree_with_the_reference_but_on_ambiguous_rays(workload, robust, width, isa):
    w = workload
    scene = embree.EmbreeScene(w.triangles, robust, isa=isa)
    index, t = scene.intersect(w.origins, w.directions, width=width)
    wrong = index != w.ref_index
    assert not (wrong & ~w.ambiguous()).any()
    hit = index >= 0
    assert hit.sum() > 100 and np.isinf(t[~hit]).all()
    assert np.allclose(t[hit & ~wrong], w.ref_t[hit & ~wrong], rtol=1e-4)
    # the timed loop counts the same hits and t, loops times; 1,480 rays: the last packet is partial
    traced = scene.trace(w.origins, w.directions, width=width, loops=3)
    assert traced.hits == 3 * hit.sum() and traced.rays == len(w.origins) and traced.elapsed_ns > 0
    assert traced.t_sum == pytest.approx(3 * t[hit].astype(np.float64).sum(), rel=1e-6)


@needs_embree
@pytest.mark.parametrize("width", embree.WIDTHS)
def test_robust_mode_is_watertight_on_rays_aimed_at_shared_edges_and_vertices(width):
    sets = robustness.build("float32", quick=True, tests=("shared_edges", "shared_vertices"))
    for test in ("shared_edges", "shared_vertices"):
        for mesh in sets.meshes[test]:
            scene = embree.EmbreeScene(mesh.triangles, robust=True)
            index, _ = scene.intersect(mesh.origins, mesh.directions, width=width)
            through = (index[:, None] == mesh.incident).any(axis=1)
            assert through.all(), f"{test}: {(~through).sum()} of {len(index)} rays fell through"


@needs_embree
def test_t_max_stops_the_rays(workload):
    w = workload
    scene = embree.EmbreeScene(w.triangles)
    index, _ = scene.intersect(w.origins, w.directions, t_max=np.full(len(w.origins), 1e-3, np.float32))
    assert (index == -1).all()


@needs_embree
def test_bad_input_is_refused_before_c(workload):
    w = workload
    with pytest.raises(UserError, match="float32"):
        embree.EmbreeScene(w.triangles.astype(np.float64))
    bad = w.triangles.copy()
    bad[0, 0, 0] = np.nan
    with pytest.raises(UserError, match="NaN or Inf"):
        embree.EmbreeScene(bad)
    with pytest.raises(UserError, match="isa must be one of"):
        embree.EmbreeScene(w.triangles, isa="avx2,threads=8")
    scene = embree.EmbreeScene(w.triangles)
    with pytest.raises(UserError, match="differ in length"):
        scene.trace(w.origins, w.directions[:-1])
    with pytest.raises(UserError, match="width"):
        scene.trace(w.origins, w.directions, width=8)
    with pytest.raises(UserError, match="loops"):
        scene.trace(w.origins, w.directions, loops=0)
    with pytest.raises(UserError, match="shape"):
        scene.intersect(w.origins[:, :2].copy(), w.directions)


@needs_embree
def test_coordinates_past_embrees_range_are_refused_not_dropped_or_aborted():
    # past FLT_LARGE Embree drops a triangle silently, and a ray aborts the process on an assertion
    tri = np.array([[[1e19, 0, 0], [0, 1, 0], [-1, -1, 0]]], np.float32)
    with pytest.raises(UserError, match="triangles: Embree takes coordinates within"):
        embree.EmbreeScene(tri)
    scene = embree.EmbreeScene(np.array([[[1, 0, 0], [0, 1, 0], [-1, -1, 0]]], np.float32))
    far = np.array([[1e30, 0, -1]], np.float32)
    with pytest.raises(UserError, match="origins: Embree takes coordinates within"):
        scene.trace(far, np.array([[0, 0, 1]], np.float32), width=16)
    with pytest.raises(UserError, match="directions: Embree takes coordinates within"):
        scene.intersect(np.zeros((1, 3), np.float32), np.array([[0, 0, 1e19]], np.float32))
    # a zero direction and degenerate triangles are defined: misses, as the reference says
    index, _ = scene.intersect(np.array([[0, 0, -1]], np.float32), np.zeros((1, 3), np.float32))
    assert index.tolist() == [-1]


def test_without_embree_it_says_how_to_install_in_one_line(monkeypatch):
    missing = embree.EmbreeMissing(f"native Embree is not available (no header); {embree.INSTALL}")
    monkeypatch.setattr(embree, "_loaded", lambda: missing)
    assert embree.version() is None and "\n" not in embree.missing()
    with pytest.raises(embree.EmbreeMissing, match="libembree-dev"):
        embree.EmbreeScene(np.zeros((1, 3, 3), np.float32))
