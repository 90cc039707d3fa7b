"""Tests of tribench.workloads: specs, pairs, meshes, ray sets, cache and CLI.

Every check of a generated workload recomputes the answer independently from
the stored arrays (the float64 reference, brute force, or a float32
Moller-Trumbore written here), never by reading back the generator's own
figures.
"""

from __future__ import annotations

import dataclasses
import json
import os
import re
import shutil
import subprocess
import sys
import warnings

import numpy as np
import pytest

from tribench import ext
from tribench.cli.workloads import main as workloads_main
from tribench.common import UserError
from tribench.workloads import (
    MISS_STAGES,
    CacheWarning,
    MeshSpec,
    PairSpec,
    cache_dir,
    classify_misses,
    generate,
    intersect_closest,
    intersect_pairs,
    list_cached,
    load,
    make,
    spec_from_dict,
    workload_id,
)
from tribench.workloads.meshes import base_mesh, build_mesh, place
from tribench.workloads.pairs import BARY_MARGIN, HIT, OTHER, SCALE_RANGE, T_MARGIN
from tribench.workloads.rays import camera_candidates, camera_rays, closest_hits, sphere_candidates
from tribench.workloads.workload import arrays_sha256


@pytest.fixture(autouse=True)
def private_cache(tmp_path, monkeypatch):
    """Every test gets its own cache directory: the user's cache is never touched."""
    monkeypatch.setenv("TRIBENCH_CACHE", str(tmp_path / "cache"))
    return tmp_path / "cache"


def inputs_sha256(w) -> str:
    return arrays_sha256({"origins": w.origins, "directions": w.directions, "triangles": w.triangles})


def moller_trumbore(o, d, tri, dtype):
    """A plain Moller-Trumbore in ``dtype`` arithmetic (no epsilon), as a kernel would run it."""
    o, d, tri = (np.asarray(a, dtype=dtype) for a in (o, d, tri))
    e1, e2 = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    p = np.cross(d, e2)
    det = (e1 * p).sum(axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = dtype(1) / det
        s = o - tri[:, 0]
        u = (s * p).sum(axis=1) * inv
        q = np.cross(s, e1)
        v = (d * q).sum(axis=1) * inv
        t = (e2 * q).sum(axis=1) * inv
        return (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 0)


# ---------------------------------------------------------------- specs


@pytest.mark.parametrize(
    "kwargs, message",
    [
        (dict(hit_rate=-0.1), "hit_rate must be in"),
        (dict(hit_rate=1.5), "hit_rate must be in"),
        (dict(hit_rate=float("nan")), "finite"),
        (dict(n=0), "between 1 and"),
        (dict(n=-5), "between 1 and"),
        (dict(n=2.5), "integer"),
        (dict(n=True), "integer"),
        (dict(order="random"), "unknown order"),
        (dict(shape="cube"), "unknown shape"),
        (dict(dtype="float16"), "unknown dtype"),
        (dict(miss_mix={"parallel": 0.5}), "sum to 1"),
        (dict(miss_mix={"parallel": 1.5, "behind_origin": -0.5}), ">= 0"),
        (dict(miss_mix={"outside_edge_4": 1.0}), "unknown miss stage"),
        (dict(miss_mix="most"), "unknown miss_mix"),
        (dict(miss_mix=[("parallel", 0.5), ("parallel", 0.5)]), "names the stage.s. parallel twice"),
        (dict(scale=0.0), "scale must be > 0"),
        (dict(offset=float("inf")), "finite"),
        (dict(rng_seed=-1), "between 0 and"),
    ],
)
def test_pair_spec_rejects_impossible_requests(kwargs, message):
    with pytest.raises(ValueError, match=message):
        PairSpec(**kwargs)


@pytest.mark.parametrize(
    "kwargs, message",
    [
        (dict(mesh="teapot"), "unknown mesh 'teapot'"),
        (dict(triangles=0), "between 1 and"),
        (dict(triangles=-3), "between 1 and"),
        (dict(rays="laser"), "unknown rays"),
        (dict(hit_rate=0.5), "applies to rays='hit_rate' only"),
        (dict(n_rays=100), "applies to rays='hit_rate' only"),
        (dict(rays="hit_rate", width=64), "applies to rays='camera' or 'bounce' only"),
        (dict(rays="hit_rate", hit_rate=1.01), "hit_rate must be in"),
        (dict(rays="hit_rate", n_rays=0), "between 1 and"),
        (dict(width=0), "between 1 and"),
        (dict(dtype="int32"), "unknown dtype"),
    ],
)
def test_mesh_spec_rejects_impossible_requests(kwargs, message):
    with pytest.raises(ValueError, match=message):
        MeshSpec(**kwargs)


def test_spec_dicts_round_trip_and_are_toml_friendly():
    specs = [
        PairSpec(n=7, hit_rate=0.25, miss_mix={"parallel": 0.5, "outside_edge_2": 0.5}, order="sorted"),
        MeshSpec("icosphere", 100, rays="hit_rate", hit_rate=0.2, n_rays=50, dtype="float32", rng_seed=3),
        MeshSpec("suzanne", width=32, height=16),
    ]
    for spec in specs:
        d = spec.to_dict()
        flat = json.loads(json.dumps(d))
        assert spec_from_dict(flat) == spec
        # TOML has no null and only str/int/float/bool/tables: no None anywhere.
        assert all(v is not None for v in d.values())
        assert all(isinstance(v, (str, int, float, dict)) for v in d.values())
    with pytest.raises(ValueError, match="unknown pairs spec field"):
        spec_from_dict({"kind": "pairs", "n": 3, "colour": "red"})
    with pytest.raises(ValueError, match="unknown workload kind"):
        spec_from_dict({"kind": "teapot"})


def test_workload_id_is_canonical_and_sensitive():
    base = PairSpec(n=100, hit_rate=0.5)
    assert workload_id(base) == workload_id(PairSpec(n=100.0, hit_rate=1 / 2))
    assert workload_id(base) == workload_id(PairSpec(n=100, miss_mix="edges"))
    others = [
        PairSpec(n=101),
        PairSpec(n=100, rng_seed=1),
        PairSpec(n=100, dtype="float32"),
        PairSpec(n=100, order="sorted"),
    ]
    ids = {workload_id(s) for s in others}
    assert workload_id(base) not in ids and len(ids) == len(others)
    assert workload_id(MeshSpec("suzanne")) != workload_id(MeshSpec("suzanne", 968))


def test_numpy_scalars_are_numbers_in_a_spec_and_bools_are_not():
    # a notebook's np.linspace(0, 1, 5, dtype=np.float32) or np.int64 hit rate was "not a finite number"
    assert PairSpec(n=10, hit_rate=np.float32(0.5), scale=np.float32(2.0)) == PairSpec(n=10, hit_rate=0.5, scale=2.0)
    assert PairSpec(n=10, hit_rate=np.int64(1), miss_mix={"parallel": np.float32(1)}) == PairSpec(
        n=10, hit_rate=1.0, miss_mix="parallel"
    )
    assert MeshSpec("icosphere", rays="hit_rate", hit_rate=np.float16(0.25)).hit_rate == 0.25
    for bad in (True, np.bool_(True), "0.5", np.float32("nan"), 10**400):
        with pytest.raises(UserError, match=r"^hit_rate must be a finite number, got .{1,80}$"):
            PairSpec(n=10, hit_rate=bad)


# ---------------------------------------------------------------- pairs


@pytest.mark.parametrize("h", [i / 10 for i in range(11)])
def test_pairs_hit_exactly_round_h_n_by_the_reference(h):
    n = 2000
    w = generate(PairSpec(n=n, hit_rate=h, miss_mix="uniform", rng_seed=11))
    ans = intersect_pairs(w.origins, w.directions, w.triangles)  # independent of the stored answers
    assert int(ans.hit.sum()) == round(h * n)
    assert np.array_equal(ans.hit, w.ref_hit)
    np.testing.assert_array_equal(w.ref_t[w.ref_hit], ans.t[ans.hit])
    assert np.isnan(w.ref_t[~w.ref_hit]).all()
    assert w.expected_checksum() == (round(h * n), pytest.approx(float(ans.t[ans.hit].sum()), rel=1e-12))


@pytest.mark.parametrize(
    "mix",
    [
        "edges",
        "uniform",
        "behind_origin",
        {"parallel": 0.1, "behind_origin": 0.3, "outside_edge_1": 0.6},
        {"outside_edge_2": 0.25, "outside_edge_3": 0.75},
        {"beyond_t_max": 0.5, "parallel": 0.2, "outside_edge_1": 0.3},
    ],
)
def test_achieved_miss_mix_within_one_percent(mix):
    spec = PairSpec(n=2000, hit_rate=0.4, miss_mix=mix, rng_seed=5)
    w = generate(spec)
    codes = classify_misses(w.origins, w.directions, w.triangles, t_max=w.t_max)
    misses = codes[codes != HIT]
    assert not (misses == OTHER).any()
    for k, stage in enumerate(MISS_STAGES):
        achieved = float((misses == k).mean())
        assert abs(achieved - spec.miss_fractions()[stage]) <= 0.01, stage
        assert w.achieved["miss_mix"][stage] == pytest.approx(achieved)


def test_order_sorted_groups_outcomes_and_shuffled_mixes_them():
    common = dict(n=600, hit_rate=0.5, miss_mix="uniform", rng_seed=2)
    codes = classify_misses(*_inputs(generate(PairSpec(order="sorted", **common))))
    assert (np.diff(codes.astype(int)) >= 0).all() and codes[0] == HIT
    assert codes[-1] == MISS_STAGES.index("outside_edge_3")  # uniform: the five stages before beyond_t_max
    shuffled = classify_misses(*_inputs(generate(PairSpec(order="shuffled", **common))))
    assert np.array_equal(np.sort(shuffled), codes)  # same outcomes...
    assert (np.diff(shuffled.astype(int)) < 0).sum() > 100  # ...interleaved


def _inputs(w):
    return w.origins, w.directions, w.triangles


@pytest.mark.parametrize("shape", ["sphere", "equilateral", "sliver"])
@pytest.mark.parametrize("dtype", ["float32", "float64"])
def test_margins_survive_rounding_and_kernels_agree(shape, dtype):
    spec = PairSpec(
        n=2000, hit_rate=0.5, miss_mix="uniform", shape=shape, dtype=dtype, offset=3.0, scale=2.0, rng_seed=9
    )
    w = generate(spec)
    assert w.origins.dtype == w.triangles.dtype == np.dtype(dtype)
    assert w.origins.flags.c_contiguous and w.triangles.flags.c_contiguous
    np.testing.assert_allclose(np.linalg.norm(w.directions.astype(np.float64), axis=1), 1.0, atol=1e-6)

    ans = intersect_pairs(*_inputs(w))
    codes = classify_misses(*_inputs(w))
    b = np.column_stack([ans.w, ans.u, ans.v])
    inside = (codes == HIT) | (codes == MISS_STAGES.index("behind_origin"))
    assert b[inside].min() >= BARY_MARGIN
    for e, j in ((1, 2), (2, 0), (3, 1)):  # outside edge e: the weight of the opposite vertex < 0
        sel = codes == MISS_STAGES.index(f"outside_edge_{e}")
        assert sel.any()
        assert b[sel, j].max() <= -BARY_MARGIN
        assert np.delete(b[sel], j, axis=1).min() >= BARY_MARGIN
    crossing = codes != MISS_STAGES.index("parallel")
    assert np.abs(ans.t[crossing]).min() >= T_MARGIN * spec.scale
    # The point of the margins: a kernel in the workload's own precision agrees on every pair.
    kernel = moller_trumbore(*_inputs(w), dtype=np.dtype(dtype).type)
    assert np.array_equal(kernel, w.ref_hit)


BEYOND = MISS_STAGES.index("beyond_t_max")


@pytest.mark.parametrize(
    "mix, counts",
    [
        ("beyond_t_max", {"beyond_t_max": 700}),
        # apportion([0, .25, 0, .35, 0, .4], 700) = [0, 175, 0, 245, 0, 280]
        (
            {"behind_origin": 0.25, "outside_edge_2": 0.35, "beyond_t_max": 0.4},
            {"behind_origin": 175, "outside_edge_2": 245, "beyond_t_max": 280},
        ),
    ],
)
@pytest.mark.parametrize("dtype", ["float32", "float64"])
def test_beyond_t_max_counts_are_exact(mix, counts, dtype):
    w = generate(PairSpec(n=1000, hit_rate=0.3, miss_mix=mix, dtype=dtype, rng_seed=3))
    assert w.t_max is not None and w.t_max.dtype == np.dtype(dtype) and w.t_max.shape == (1000,)
    codes = classify_misses(*_inputs(w), t_max=w.t_max)
    want = {s: counts.get(s, 0) for s in MISS_STAGES}
    assert {s: int((codes == k).sum()) for k, s in enumerate(MISS_STAGES)} == want
    assert int((codes == HIT).sum()) == 300 and not (codes == OTHER).any()
    assert w.achieved["miss_counts"] == want and w.achieved["hits"] == 300
    # Without t_max the beyond_t_max pairs are hits: the limit is what makes them miss.
    assert int((classify_misses(*_inputs(w)) == HIT).sum()) == 300 + counts["beyond_t_max"]


@pytest.mark.parametrize("dtype", ["float32", "float64"])
def test_beyond_t_max_pairs_hit_without_the_limit_and_miss_with_it_by_a_margin(dtype):
    spec = PairSpec(
        n=2000,
        hit_rate=0.3,
        miss_mix={"beyond_t_max": 0.5, "outside_edge_3": 0.5},
        shape="sliver",
        dtype=dtype,
        scale=2.0,
        offset=3.0,
        rng_seed=8,
    )
    w = generate(spec)
    tm = w.t_max.astype(np.float64)
    free = intersect_pairs(*_inputs(w))
    limited = intersect_pairs(*_inputs(w), t_max=tm)
    beyond = classify_misses(*_inputs(w), t_max=w.t_max) == BEYOND
    assert beyond.sum() == 700
    assert free.hit[beyond].all() and not limited.hit[beyond].any()
    assert np.column_stack([free.w, free.u, free.v])[beyond].min() >= BARY_MARGIN
    assert (free.t[beyond] - tm[beyond]).min() >= T_MARGIN * spec.scale
    assert tm[beyond].min() >= T_MARGIN * spec.scale
    assert np.isinf(tm[~beyond]).all() and (tm[~beyond] > 0).all()  # no limit on the other pairs
    # The stored answers are the limited ones.
    assert np.array_equal(w.ref_hit, limited.hit)
    assert np.isnan(w.ref_t[beyond]).all()
    np.testing.assert_array_equal(w.ref_edge_margin, limited.edge_margin)


def test_beyond_t_max_is_deterministic_and_t_max_only_with_the_stage():
    spec = PairSpec(n=1000, hit_rate=0.3, miss_mix="beyond_t_max", dtype="float32", rng_seed=6)
    a, b = generate(spec), generate(spec)
    assert a.checksum() == b.checksum() and a.t_max.tobytes() == b.t_max.tobytes()
    assert "t_max" in a.arrays()
    assert (
        generate(PairSpec(n=1000, hit_rate=0.3, miss_mix="beyond_t_max", dtype="float32", rng_seed=7)).checksum()
        != a.checksum()
    )
    for mix in ("edges", "uniform", "parallel", {"beyond_t_max": 0.0, "outside_edge_1": 1.0}):
        w = generate(PairSpec(n=200, miss_mix=mix))
        assert w.t_max is None and "t_max" not in w.arrays()


@pytest.mark.parametrize("dtype", ["float32", "float64"])
def test_every_pairs_kernel_agrees_with_the_reference_on_beyond_t_max(dtype):
    from tribench import ext

    spec = PairSpec(
        n=3000,
        hit_rate=0.3,
        miss_mix={"beyond_t_max": 0.6, "outside_edge_1": 0.2, "behind_origin": 0.2},
        shape="sliver",
        dtype=dtype,
        rng_seed=12,
    )
    w = generate(spec)
    # both faces count here: the culling kernels answer another question
    kernels = [
        k for k in ext.kernel_names() if "pairs" in ext.kernel_info(k).modes and not ext.kernel_info(k).culls_back_faces
    ]
    assert {"curless_seed", "moller_seed", "curless", "moller_trumbore"} <= set(kernels)
    for k in kernels:
        hit, _ = ext.intersect_pairs(k, w.origins, w.directions, w.triangles, t_max=w.t_max)
        assert np.array_equal(hit, w.ref_hit), k
        # and the same kernel without the limit sees the beyond_t_max pairs as hits
        free, _ = ext.intersect_pairs(k, w.origins, w.directions, w.triangles)
        assert int(free.sum()) == 900 + 1260, k


def test_cache_round_trip_keeps_t_max(private_cache):
    spec = PairSpec(n=500, hit_rate=0.3, miss_mix={"beyond_t_max": 0.5, "outside_edge_2": 0.5}, dtype="float32")
    w = make(spec)
    for again in (make(spec), load(w.workload_id)):
        assert again.t_max is not None and again.t_max.dtype == np.float32
        assert again.t_max.tobytes() == w.t_max.tobytes()
        assert again.checksum() == w.checksum()
        assert again.achieved["miss_counts"]["beyond_t_max"] == 175
    # A workload without the stage is stored without t_max and loads back without it.
    plain = make(PairSpec(n=100))
    assert load(plain.workload_id).t_max is None


def test_shapes_have_the_stated_aspect_ratios():
    from tribench.workloads.geometry import aspect_ratios

    def aspect(shape):
        return aspect_ratios(generate(PairSpec(n=500, shape=shape)).triangles.astype(np.float64))

    assert aspect("equilateral").max() < 1.4
    sliver = aspect("sliver")
    assert 9.9 < sliver.min() and sliver.max() < 1010 and np.median(sliver) > 50
    assert aspect("sphere").max() <= 1e3


def test_extreme_offset_in_float32_is_a_clear_error():
    with pytest.raises(ValueError, match="too large for this precision"):
        generate(PairSpec(n=200, dtype="float32", offset=1e6, scale=1e-3, shape="sliver"))


@pytest.mark.parametrize(
    ("dtype", "scale"), [("float32", 1e13), ("float32", 1e-15), ("float64", 1e80), ("float64", 1e-90)]
)
def test_a_pair_scale_past_the_precisions_products_is_refused_before_generating(dtype, scale):
    # float32 at 1e13 was made, and 90% of moller_trumbore's hits were misses; float64 at 1e80 never ended
    with pytest.raises(
        UserError, match=rf"^scale = {re.escape(f'{scale:.3g}')} is outside what {dtype} holds .*: a pair's scale may"
    ):
        generate(PairSpec(n=50, dtype=dtype, scale=scale))


@pytest.mark.parametrize("dtype", ["float32", "float64"])
def test_at_both_ends_of_the_scale_range_every_clean_kernel_agrees_with_the_reference(dtype):
    kernels = [
        k for k in ext.kernel_names() if "pairs" in ext.kernel_info(k).modes and not ext.kernel_info(k).seed_replay
    ]
    for scale in SCALE_RANGE[dtype]:
        w = generate(PairSpec(n=300, dtype=dtype, scale=scale, shape="sliver", miss_mix="uniform", winding="facing"))
        for k in (k for k in kernels if dtype in ext.kernel_info(k).precisions):
            hit = ext.intersect(k, w.origins, w.directions, w.triangles, "pairs", t_max=w.t_max).hit
            assert np.array_equal(hit, w.ref_hit), (k, scale)


def test_same_spec_same_bytes():
    spec = PairSpec(n=1500, hit_rate=0.3, miss_mix="uniform", shape="sliver", dtype="float32", rng_seed=4)
    a, b = generate(spec), generate(spec)
    assert a.checksum() == b.checksum()
    assert generate(PairSpec(n=1500, hit_rate=0.3, rng_seed=5)).checksum() != a.checksum()
    mesh = MeshSpec("suzanne", 300, rays="hit_rate", n_rays=100, rng_seed=1)
    assert generate(mesh).checksum() == generate(mesh).checksum()


def test_pair_inputs_match_the_recorded_bytes():
    # Pair inputs use only + - * / sqrt on PCG64 draws: these bytes must come out on any
    # IEEE-754 machine. If a deliberate generator change alters them, bump PAIRS_VERSION.
    w = generate(PairSpec(n=64, hit_rate=0.5, miss_mix="uniform", shape="sliver", dtype="float64", rng_seed=7))
    assert inputs_sha256(w) == "fb00ea41166edf61770b01f7c73855919de28d6b72fd3928edf3f0fe90615a76"


@pytest.mark.slow
def test_determinism_across_two_fresh_processes(tmp_path):
    code = (
        "from tribench.workloads import make, PairSpec, MeshSpec\n"
        "for s in [PairSpec(n=500, hit_rate=0.3, miss_mix='uniform', dtype='float32', shape='sliver'),\n"
        "          MeshSpec('suzanne', 300, rays='hit_rate', n_rays=128),\n"
        "          MeshSpec('heightfield', 2000, width=16, height=16, dtype='float32')]:\n"
        "    w = make(s)\n"
        "    print(w.workload_id, w.checksum())\n"
    )
    outputs = []
    for run in ("first", "second"):
        env = dict(os.environ, TRIBENCH_CACHE=str(tmp_path / run), PYTHONPATH=os.pathsep.join(p for p in sys.path if p))
        done = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=120)
        assert done.returncode == 0, done.stderr
        outputs.append(done.stdout)
        assert len(list((tmp_path / run).glob("*.npz"))) == 3  # each process built its own
    assert outputs[0] == outputs[1]
    assert len(outputs[0].splitlines()) == 3


# ---------------------------------------------------------------- meshes


@pytest.mark.parametrize("count", [100, 968, 5000, 20000])
def test_suzanne_exact_triangle_counts(count):
    mesh = build_mesh("suzanne", count, rng_seed=0)
    assert mesh.faces.shape == (count, 3)
    assert mesh.faces.min() >= 0 and mesh.faces.max() < len(mesh.vertices)
    assert len(np.unique(mesh.faces)) == len(mesh.vertices)  # no unreferenced vertex
    if count == 968:
        assert mesh.method == "base"


def test_suzanne_base_is_the_file_turned_and_moved():
    v, f = base_mesh("suzanne")
    assert v.shape == (507, 3) and f.shape == (968, 3)
    mesh = build_mesh("suzanne", None, rng_seed=0)
    np.testing.assert_array_equal(mesh.faces, f)
    x, y, z = v.T
    np.testing.assert_array_equal(mesh.vertices, np.column_stack([x, z, -y]) + [0.0, 0.5, -2.0])


@pytest.mark.parametrize("name, counts", [("icosphere", [501, 2000]), ("uvsphere", [777]), ("heightfield", [99, 3001])])
def test_other_meshes_exact_triangle_counts(name, counts):
    for count in counts:
        assert build_mesh(name, count, rng_seed=0).faces.shape == (count, 3)


def test_tiny_counts_are_exact_too():
    for count in (1, 2, 3):
        assert len(build_mesh("suzanne", count, rng_seed=0).faces) == count


def test_soup_is_seeded_and_exact():
    a, b = build_mesh("soup", 321, rng_seed=1), build_mesh("soup", 321, rng_seed=2)
    assert a.faces.shape == (321, 3)
    assert not np.array_equal(a.vertices, b.vertices)
    assert np.array_equal(a.vertices, build_mesh("soup", 321, rng_seed=1).vertices)


def test_other_meshes_are_placed_in_view():
    for name in ("icosphere", "uvsphere", "heightfield", "soup"):
        v = place(name, base_mesh(name)[0])
        centre = (v.min(axis=0) + v.max(axis=0)) / 2
        np.testing.assert_allclose(centre, [0, 0, -2], atol=1e-12)
        assert np.linalg.norm(v - centre, axis=1).max() == pytest.approx(1.5)


def _write_tetrahedron(path):
    path.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 2 3 4\nf 1 4 3\n")
    return path


def test_mesh_file_input(tmp_path):
    path = _write_tetrahedron(tmp_path / "tet.obj")
    spec = MeshSpec(str(path), rays="hit_rate", hit_rate=0.5, n_rays=64)
    w = make(spec)
    assert w.triangles.shape == (4, 3, 3)
    assert int(w.hits.sum()) == 32
    # The same content elsewhere is the same workload; other content is another.
    copy = shutil.copy(path, tmp_path / "other_name.obj")
    assert workload_id(MeshSpec(copy, rays="hit_rate", hit_rate=0.5, n_rays=64)) == w.workload_id
    with open(copy, "a") as f:
        f.write("# changed\n")
    assert workload_id(MeshSpec(copy, rays="hit_rate", hit_rate=0.5, n_rays=64)) != w.workload_id
    assert make(MeshSpec(str(path), 30, width=8, height=8)).triangles.shape == (30, 3, 3)


@pytest.mark.parametrize(
    "content, name, message",
    [
        (b"\x00\xff\xfe garbage \x13" * 40, "bad.obj", "cannot read mesh file"),
        (b"v 0 0 0\nv 1 0 0\n", "points.obj", "holds no triangles"),
        (b"ply\nformat nonsense\n", "bad.ply", "cannot read mesh file"),
        (b"v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n", "flat.obj", "no triangle of non-zero area"),
        (b"v 1e300 0 0\nv 0 1e300 0\nv 0 0 1e300\nf 1 2 3\n", "huge.obj", "coordinates up to 1e\\+300.*overflow"),
    ],
)
def test_corrupt_mesh_file_is_a_clear_error(tmp_path, content, name, message):
    path = tmp_path / name
    path.write_bytes(content)
    with pytest.raises(ValueError, match=message):
        MeshSpec(str(path))


def test_missing_mesh_file_is_a_clear_error(tmp_path):
    with pytest.raises(UserError, match="no such file"):
        MeshSpec(str(tmp_path / "nothing.obj"))


def test_a_folder_given_as_a_mesh_is_named_a_folder(tmp_path):
    with pytest.raises(UserError, match="is a folder"):
        MeshSpec(str(tmp_path))


# ---------------------------------------------------------------- ray sets


def test_culled_camera_reference_equals_brute_force():
    tri = build_mesh("suzanne", 300, rng_seed=0).triangles
    # Add triangles that straddle the eye's plane, lie behind the eye, or fill the view.
    extra = np.array(
        [
            [[-0.2, -0.2, 1.0], [0.3, -0.1, 2.5], [0.0, 0.3, 1.5]],
            [[-1.0, -1.0, 3.0], [1.0, -1.0, 3.0], [0.0, 1.0, 3.0]],
            [[-9.0, -9.0, -5.0], [9.0, -9.0, -5.0], [0.0, 9.0, -5.0]],
        ]
    )
    tri = np.concatenate([tri, extra])
    o, d = camera_rays(24, 24)
    culled = closest_hits(o, d, tri, *camera_candidates(tri, 24, 24))
    index, t = intersect_closest(o, d, tri)
    assert np.array_equal(culled.index, index)
    np.testing.assert_array_equal(culled.t, t)
    assert 0 < (index >= 0).mean() < 1 and (index == len(tri) - 1).any() and (index == len(tri) - 3).any()
    assert culled.tests < len(o) * len(tri)


def test_sphere_culled_reference_equals_brute_force():
    rng = np.random.default_rng(3)
    tri = build_mesh("soup", 400, rng_seed=0).triangles
    o = rng.normal(size=(300, 3)) * 3
    d = rng.normal(size=(300, 3)) * 1.5 + ([0, 0, -2] - o)
    culled = closest_hits(o, d, tri, *sphere_candidates(o, d, tri))
    index, t = intersect_closest(o, d, tri)
    assert np.array_equal(culled.index, index)
    np.testing.assert_array_equal(culled.t, t)
    assert 0.2 < (index >= 0).mean() < 0.9


@pytest.mark.parametrize("h", [0.0, 0.3, 1.0])
def test_per_ray_hit_rate_is_exact_by_brute_force(h):
    w = generate(MeshSpec("suzanne", 400, rays="hit_rate", hit_rate=h, n_rays=150, dtype="float32", rng_seed=2))
    index, t = intersect_closest(*_inputs(w))
    assert int((index >= 0).sum()) == round(h * 150)
    assert np.array_equal(index, w.ref_index)
    assert np.all(np.abs(w.ref_edge_margin) >= BARY_MARGIN)  # no ray near an edge
    assert w.achieved["ray_hit_rate"] == round(h * 150) / 150


def test_suzanne_camera_sees_the_monkey():
    w = make(MeshSpec("suzanne", width=64, height=64))
    hits = w.hits.reshape(64, 64)
    assert 0.15 < hits.mean() < 0.22  # the face fills about a fifth of the view
    assert hits[:, :20].any() and hits[:, -20:].any()  # the ears reach both sides
    assert not hits[-16:].any()  # nothing below the chin
    assert w.achieved["test_hit_rate"] < w.achieved["ray_hit_rate"] / 100
    assert w.achieved["ray_hits"] == int(hits.sum())


# ---------------------------------------------------------------- cache


def _corrupt(path, how, other=None):
    if how == "truncated":
        path.write_bytes(path.read_bytes()[: path.stat().st_size // 2])
    elif how == "garbage":
        path.write_bytes(os.urandom(4096))
    elif how == "checksum":
        with np.load(path) as z:
            arrays = {k: z[k] for k in z.files}
        arrays["origins"] = arrays["origins"] + 1.0
        np.savez(path, **arrays)
    elif how == "other_spec":
        shutil.copy(other, path)
    elif how == "version":
        with np.load(path) as z:
            arrays = {k: z[k] for k in z.files}
        meta = json.loads(str(arrays["meta"][()]))
        meta["version"] = 999
        arrays["meta"] = np.array(json.dumps(meta))
        np.savez(path, **arrays)


@pytest.mark.parametrize("how", ["truncated", "garbage", "checksum", "other_spec", "version"])
def test_corrupted_cache_file_is_detected_and_rebuilt(how, private_cache):
    spec = PairSpec(n=300, hit_rate=0.5)
    fresh = make(spec)
    path = private_cache / f"{fresh.workload_id}.npz"
    other = make(PairSpec(n=300, hit_rate=0.4))
    _corrupt(path, how, private_cache / f"{other.workload_id}.npz")
    with pytest.warns(CacheWarning, match="invalid"):
        rebuilt = make(spec)
    assert rebuilt.checksum() == fresh.checksum()
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the rebuilt file is valid again: no warning
        assert make(spec).checksum() == fresh.checksum()


def test_load_by_id_and_rebuild_from_stored_spec(private_cache):
    w = make(PairSpec(n=100, hit_rate=0.2))
    assert load(w.workload_id).checksum() == w.checksum()
    _corrupt(private_cache / f"{w.workload_id}.npz", "checksum")
    with pytest.warns(CacheWarning):
        assert load(w.workload_id).checksum() == w.checksum()
    with pytest.raises(FileNotFoundError, match="no cached workload"):
        load("pairs-000000000000")
    _corrupt(private_cache / f"{w.workload_id}.npz", "garbage")
    with pytest.raises(ValueError, match="no spec that still gives this id"):
        load(w.workload_id)


def test_cache_files_are_written_whole_and_listed(private_cache):
    a = make(PairSpec(n=50))
    b = make(MeshSpec("icosphere", 40, rays="hit_rate", n_rays=20))
    assert sorted(p.name for p in private_cache.iterdir()) == sorted([f"{a.workload_id}.npz", f"{b.workload_id}.npz"])
    listed = {c.workload_id: c for c in list_cached()}
    assert set(listed) == {a.workload_id, b.workload_id}
    assert listed[b.workload_id].spec == b.spec.to_dict() and listed[b.workload_id].problem is None
    assert listed[a.workload_id].achieved["hits"] == 25
    assert cache_dir() == private_cache


def test_workload_arrays_are_read_only():
    w = generate(PairSpec(n=10))
    with pytest.raises(ValueError):
        w.origins[0, 0] = 1.0


# ---------------------------------------------------------------- CLI


def run_cli(*argv):
    return workloads_main(list(argv))


@pytest.mark.slow  # workloads made and drawn through the command (seconds)
def test_cli_make_list_show_and_picture(tmp_path, capsys):
    assert run_cli("make", "pairs", "--n", "500", "--hit-rate", "0.3", "--miss-mix", "uniform") == 0
    out = capsys.readouterr().out
    wid = out.split()[0]
    assert wid.startswith("pairs-") and "miss_mix.parallel" in out
    assert run_cli("make", "suzanne", "--width", "48", "--height", "48") == 0
    mesh_id = capsys.readouterr().out.split()[0]
    assert run_cli("list") == 0
    listed = capsys.readouterr().out
    assert wid in listed and mesh_id in listed
    for shown, png in ((wid[:10], tmp_path / "pairs.png"), (mesh_id, tmp_path / "mesh.png")):
        assert run_cli("show", shown, "--png", str(png)) == 0
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 20_000
    assert "ray_hit_rate" in capsys.readouterr().out
    assert run_cli("make", "icosphere", "--hit-rate", "0.5", "--n-rays", "64", "--json") == 0
    report = json.loads(capsys.readouterr().out)
    assert report["spec"]["rays"] == "hit_rate" and report["achieved"]["ray_hits"] == 32
    png = tmp_path / "rays.png"
    assert run_cli("show", report["workload_id"], "--png", str(png)) == 0 and png.stat().st_size > 20_000


@pytest.mark.parametrize(
    "argv, message",
    [
        (["make", "pairs", "--hit-rate", "1.5"], "hit_rate must be in [0, 1]"),
        (["make", "pairs", "--n", "0"], "between 1 and"),
        (["make", "suzanne", "--triangles", "0"], "between 1 and"),
        (["make", "suzanne", "--n", "10"], "--n applies to pairs"),
        (["make", "pairs", "--triangles", "10"], "--triangles applies to meshes"),
        (["make", "no/such/mesh.obj"], "no such file"),
        (["make", "pairs", "--miss-mix", "parallel=x"], "bad miss-mix item"),
        (["show", "pairs-ffffffffffff"], "no cached workload"),
    ],
)
def test_cli_user_errors_are_one_line(argv, message, capsys):
    assert run_cli(*argv) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1 and "Traceback" not in err


def test_cli_corrupt_mesh_file(tmp_path, capsys):
    bad = tmp_path / "bad.ply"
    bad.write_bytes(b"ply\nformat nonsense\n")
    assert run_cli("make", str(bad)) == 2
    assert "cannot read mesh file" in capsys.readouterr().err


def test_a_mesh_past_float_range_is_refused_in_one_line_without_warnings(tmp_path, capsys):
    huge = tmp_path / "huge.obj"
    huge.write_text("v 1e300 0 0\nv 0 1e300 0\nv 0 0 1e300\nv 1e300 1e300 0\nf 1 2 3\nf 1 4 2\n")
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # numpy's overflow warnings would fail here
        assert run_cli("make", str(huge), "--accel", "bvh") == 2
    err = capsys.readouterr().err
    assert "overflow" in err and err.count("\n") == 1 and "Traceback" not in err


def test_a_mesh_finite_in_float64_but_past_float32_is_refused_for_float32_only(tmp_path, capsys):
    huge = tmp_path / "f32.obj"
    huge.write_text("v 5e38 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\n")
    assert run_cli("make", str(huge), "--dtype", "float32") == 2
    err = capsys.readouterr().err
    assert "in float32 their squares overflow" in err and "float64" in err and err.count("\n") == 1
    with pytest.raises(UserError, match="in float32 their squares overflow"):
        MeshSpec(str(huge), dtype="float32")
    assert MeshSpec(str(huge), dtype="float64").dtype == "float64"  # 5e38 squared is finite in float64


# ------------------------------------------------------------ winding


@pytest.mark.parametrize("shape", ["sphere", "sliver"])
@pytest.mark.parametrize("dtype", ["float32", "float64"])
def test_facing_pairs_face_their_rays_and_keep_every_kind_and_answer(shape, dtype):
    from tribench.workloads.geometry import dot, triangle_normals

    common = dict(n=3000, hit_rate=0.4, miss_mix="uniform", shape=shape, dtype=dtype, rng_seed=4)
    drawn, facing = generate(PairSpec(**common)), generate(PairSpec(**common, winding="facing"))
    cos = dot(facing.directions.astype(float), triangle_normals(facing.triangles.astype(float)))
    parallel = classify_misses(facing.origins, facing.directions, facing.triangles) == MISS_STAGES.index("parallel")
    assert (cos[~parallel] < 0).all() and parallel.sum() == facing.achieved["miss_counts"]["parallel"] > 0
    drawn_front = dot(drawn.directions.astype(float), triangle_normals(drawn.triangles.astype(float))) < 0
    assert 0.4 < drawn_front[~parallel].mean() < 0.6  # as drawn, half the rays meet a back face
    assert facing.achieved["miss_counts"] == drawn.achieved["miss_counts"]
    assert int(facing.ref_hit.sum()) == int(drawn.ref_hit.sum()) == 1200
    assert (
        facing.achieved["hits_front_facing"] == 1.0 == dict((f, t) for f, t, _ in facing.compare())["hits_front_facing"]
    )
    assert "hits_front_facing" not in drawn.targets()  # a random winding has no target for it


def test_every_culling_kernel_agrees_with_the_reference_on_facing_pairs_only():
    from tribench import ext

    # every stage, so rays behind the origin, parallel ones and ones stopped by t_max face their triangle too
    every_stage = dict.fromkeys(MISS_STAGES, 1 / len(MISS_STAGES))
    culling = [k for k in ext.kernel_names() if ext.kernel_info(k).culls_back_faces]
    with_pairs = [k for k in culling if "pairs" in ext.kernel_info(k).modes]
    assert with_pairs, culling  # else this test tests nothing
    for dtype in ("float32", "float64"):
        spec = PairSpec(n=2400, hit_rate=0.5, miss_mix=every_stage, dtype=dtype, rng_seed=8)
        for winding, agrees in (("facing", True), ("random", False)):
            w = generate(dataclasses.replace(spec, winding=winding))
            for k in with_pairs:
                hit, t = ext.intersect_pairs(k, w.origins, w.directions, w.triangles, t_max=w.t_max)
                assert np.array_equal(hit, w.ref_hit) == agrees, (k, winding, dtype)
                if agrees:
                    np.testing.assert_allclose(t[hit], w.ref_t[hit], rtol=1e-5 if dtype == "float32" else 1e-12)


def test_random_winding_keeps_the_ids_it_always_had_and_facing_is_another_workload():
    assert "winding" not in PairSpec(n=10).to_dict()  # so every earlier workload id stands
    assert workload_id(PairSpec(n=10)) != workload_id(PairSpec(n=10, winding="facing"))
    assert " facing " in PairSpec(n=10, winding="facing").summary()
    with pytest.raises(UserError, match="winding"):
        PairSpec(n=10, winding="front")
