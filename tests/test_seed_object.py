"""The seed's tests as its program pays for them (ext/kernels/seed_objects.h): the same answers as the
seed kernels whose arithmetic they repeat, the same test counts, and the calls that are their cost."""

from __future__ import annotations

import platform
import re
import shutil
import subprocess

import numpy as np
import pytest

from tribench import ext
from tribench.ext import _core

TWIN = {"moller_seed_object": "moller_seed", "curless_seed_object": "curless_seed"}


def _workload(dtype: str, seed: int = 1, rays: int = 1500, triangles: int = 200):
    rng = np.random.default_rng(seed)
    tris = rng.normal(size=(triangles, 3, 3)).astype(dtype)
    o = (rng.normal(size=(rays, 3)) * 0.3 + [0, 0, -5]).astype(dtype)
    d = (rng.normal(size=(rays, 3)) * 0.2 + [0, 0, 1]).astype(dtype)
    return o, d, tris


@pytest.mark.parametrize("dtype", ["float32", "float64"])
@pytest.mark.parametrize("kernel", sorted(TWIN))
@pytest.mark.parametrize("mode", ["closest", "any", "pairs"])
def test_the_object_path_answers_as_its_arithmetic_twin(kernel, mode, dtype):
    o, d, tris = _workload(dtype)
    if mode == "pairs":
        tris = tris[np.arange(len(o)) % len(tris)]
    mine, twin = ext.intersect(kernel, o, d, tris, mode), ext.intersect(TWIN[kernel], o, d, tris, mode)
    assert (mine.index >= 0).sum() > len(o) // 20  # the workload has hits to compare
    np.testing.assert_array_equal(mine.index, twin.index)
    # Curless's point q is a double Point in the seed: its edge tests round differently in the last bit
    tolerance = 0 if kernel == "moller_seed_object" or dtype == "float64" else 1e-6
    for field in ("t", "u", "v"):
        np.testing.assert_allclose(getattr(mine, field), getattr(twin, field), rtol=tolerance, atol=tolerance)


@pytest.mark.parametrize("kernel", sorted(TWIN))
def test_t_max_and_nonfinite_rays_are_handled_as_the_twin_does(kernel):
    o, d, tris = _workload("float32", seed=2, rays=300)
    t_max = np.full(len(o), 4.8, np.float32)  # cuts some hits off
    mine = ext.intersect(kernel, o, d, tris, "closest", t_max=t_max)
    twin = ext.intersect(TWIN[kernel], o, d, tris, "closest", t_max=t_max)
    np.testing.assert_array_equal(mine.index, twin.index)
    d[:10] = np.nan
    mine = ext.intersect(kernel, o, d, tris, "any", allow_nonfinite=True)
    twin = ext.intersect(TWIN[kernel], o, d, tris, "any", allow_nonfinite=True)
    np.testing.assert_array_equal(mine.index, twin.index)
    assert (mine.index[:10] == -1).all()


@pytest.mark.parametrize("kernel", sorted(TWIN))
@pytest.mark.parametrize("mode", ["closest", "any"])
def test_a_timed_batch_counts_the_twins_tests_and_hits(kernel, mode):
    o, d, tris = _workload("float32", seed=3, rays=400, triangles=100)
    mine = ext.time_batch(ext.make_job(kernel, o, d, tris, mode), 2)
    twin = ext.time_batch(ext.make_job(TWIN[kernel], o, d, tris, mode), 2)
    assert (mine.tests, mine.hits) == (twin.tests, twin.hits) and mine.tests > 0
    assert mine.t_sum == pytest.approx(twin.t_sum, rel=1e-6)


@pytest.mark.slow
@pytest.mark.skipif(platform.machine() not in ("x86_64", "AMD64"), reason="x86-64 code")
@pytest.mark.skipif(shutil.which("objdump") is None, reason="needs objdump (binutils)")
def test_every_vector_operation_stays_a_call_as_in_the_seeds_build():
    """What makes the object path cost what the seed's program costs: the compiler must not inline
    the Vecteur operations, the destructors or the virtual call back into the test."""
    text = subprocess.run(
        ["objdump", "-d", "--no-show-raw-insn", _core.__file__], capture_output=True, text=True, check=True
    ).stdout

    def calls(function: str) -> list[str]:
        body = re.search(rf"^[0-9a-f]+ <{function}>:\n(.*?)\n\n", text, re.S | re.M)
        assert body, f"{function} is not in the module"
        return re.findall(r"\bcall\s+\S+ <([^>+]+)", body.group(1))

    for p in ("f32", "f64"):
        moller = [c.removesuffix(f"_{p}") for c in calls(f"tb_so_moller_intersecte_{p}")]
        # as g++ -O2 lays out the seed's Triangle::intersecte: two edges, p, det, s, u, then the four
        # destructors of a u miss (most tests' path), then q, v, t and the hit's Intersection
        assert (
            moller[:10]
            == ["tb_so_vec_from"] * 2
            + ["tb_so_cross", "tb_so_dot", "tb_so_vec_from", "tb_so_dot"]
            + ["tb_so_vec_destroy"] * 4
        )
        assert sorted(moller[10:]) == sorted(
            ["tb_so_cross", "tb_so_dot", "tb_so_dot", "tb_so_vec_destroy", "tb_so_hit_make"]
        )
        curless = calls(f"tb_so_curless_coupe_{p}")
        assert curless.count(f"tb_so_cross_{p}") == 3 and curless.count(f"tb_so_vec_from_{p}") == 6
        scene = re.search(rf"^[0-9a-f]+ <tb_so_scene_intersecte_{p}>:\n(.*?)\n\n", text, re.S | re.M).group(1)
        assert re.search(r"\bcall\s+\*", scene), "the virtual call is gone"
        # the seed's origin: x and y each stored by itself, then read back as one 16-byte pair (the
        # load the CPU cannot forward from the two stores, as g++'s code of Curless's test does)
        for fn in (f"tb_so_curless_intersecte_{p}", f"tb_so_curless_coupe_{p}"):
            body = re.search(rf"^[0-9a-f]+ <{fn}>:\n(.*?)\n\n", text, re.S | re.M).group(1)
            slot = r"(?:0x([0-9a-f]+))?\(%rsp\)"
            stored = {int(x or "0", 16) for x in re.findall(rf"\bv?movsd\s+%xmm\d+,{slot}", body)}
            pairs = {int(x or "0", 16) for x in re.findall(rf"\b(?:v?mov[au]pd|v?addpd)\s+{slot},%xmm", body)}
            assert any(x in stored and x + 8 in stored for x in pairs), f"{fn}: origin's x and y not split"
