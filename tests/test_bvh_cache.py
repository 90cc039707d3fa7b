"""The BVH cache (workloads/bvh_cache.py) and ext.adopt_bvh: a cached tree
answers byte for byte as a fresh build; a corrupt, cut, stale or tampered file
is reported once (a CacheWarning) and rebuilt; a tampered tree is refused by
the C check before any traversal, and one it accepts answers as the original.
"""

from __future__ import annotations

import io
import json
import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from tribench import ext
from tribench.common import UserError
from tribench.workloads import CacheWarning, bvh_cache
from tribench.workloads.cache import sealed_npz

KERNELS = ext.bvh_kernel_names()


@pytest.fixture(autouse=True)
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv("TRIBENCH_CACHE", str(tmp_path))
    return tmp_path


def _scene(n: int = 300, dtype=np.float32, seed: int = 0):
    rng = np.random.default_rng(seed)
    tris = rng.normal(size=(n, 3, 3))
    o = rng.normal(size=(200, 3)) * 3
    d = tris[rng.integers(0, n, 200)].mean(axis=1) - o
    return tuple(np.ascontiguousarray(a, dtype) for a in (tris, o, d))


def _same_answers(a: ext.BVH, b: ext.BVH, o: np.ndarray, d: np.ndarray) -> None:
    for mode in ("closest_uv", "any"):
        ta, tb = a.intersect(o, d, mode), b.intersect(o, d, mode)
        for x, y in zip(ta.hits, tb.hits, strict=True):
            assert x.tobytes() == y.tobytes()
        assert (ta.counts == tb.counts).all()


def _path(kernel: str, tris: np.ndarray):
    return bvh_cache.bvh_path(bvh_cache.bvh_identity(kernel, tris, ext.DEFAULT_MAX_LEAF))


def _quiet(kernel, tris):
    """cached_bvh, failing on any warning."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        return bvh_cache.cached_bvh(kernel, tris)


def _rebuilt(kernel, tris, match: str) -> ext.BVH:
    """cached_bvh, which must warn exactly once (matching ``match``) and rebuild a sound file."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        bvh, _ = bvh_cache.cached_bvh(kernel, tris)
    notices = [w for w in caught if issubclass(w.category, CacheWarning)]
    assert len(notices) == 1 and len(caught) == 1, [str(w.message) for w in caught]
    assert match in str(notices[0].message) and str(_path(kernel, tris)) in str(notices[0].message)
    _quiet(kernel, tris)  # the rebuilt file is sound
    return bvh


@pytest.mark.parametrize("dtype", [np.float32, np.float64], ids=["f32", "f64"])
@pytest.mark.parametrize("kernel", [KERNELS[0], KERNELS[-1]])
def test_round_trip_answers_byte_for_byte_as_a_fresh_build(kernel, dtype):
    tris, o, d = _scene(dtype=dtype)
    fresh = ext.build_bvh(kernel, tris)
    built, build_ns = _quiet(kernel, tris)
    assert _path(kernel, tris).is_file() and build_ns > 0
    stamp = _path(kernel, tris).stat().st_mtime_ns
    loaded, recorded_ns = _quiet(kernel, tris.copy())  # another array with the same triangles
    assert _path(kernel, tris).stat().st_mtime_ns == stamp  # read, not written again
    assert recorded_ns == build_ns
    for bvh in (built, loaded):
        assert bvh.nodes.tobytes() == fresh.nodes.tobytes() and bvh.perm.tobytes() == fresh.perm.tobytes()
        assert bvh.prepared.records.tobytes() == fresh.prepared.records.tobytes()
        _same_answers(bvh, fresh, o, d)


def test_a_file_per_kernel_leaf_size_and_triangles():
    tris, _, _ = _scene()
    other = tris.copy()
    other[0, 0, 0] += 1
    paths = {
        bvh_cache.bvh_path(bvh_cache.bvh_identity(k, t, leaf))
        for k in KERNELS[:2]
        for t in (tris, other)
        for leaf in (8, 16)
    }
    assert len(paths) == 8


def _cuts_and_flips(data: bytes):
    n = len(data)
    yield "empty", b""
    for at in (1, n // 3, n - 80, n - 1):
        yield f"cut at {at}", data[:at]
    yield "appended", data + b"\0"
    for at in (0, 100, n // 2, n - 40, n - 1):
        flipped = bytearray(data)
        flipped[at] ^= 0x10
        yield f"bit flipped at {at}", bytes(flipped)


def test_a_corrupt_or_cut_file_is_reported_once_and_rebuilt():
    kernel = KERNELS[0]
    tris, o, d = _scene()
    fresh = ext.build_bvh(kernel, tris)
    _quiet(kernel, tris)
    path = _path(kernel, tris)
    pristine = path.read_bytes()
    for what, data in _cuts_and_flips(pristine):
        path.write_bytes(data)
        bvh = _rebuilt(kernel, tris, "checksum")
        _same_answers(bvh, fresh, o, d)
        assert path.read_bytes() != data, what


def _resealed(path, edit) -> None:
    """Rewrites the cache file with ``edit(meta, arrays)`` applied, sealed again (a deliberate tamper)."""
    with np.load(io.BytesIO(path.read_bytes())) as z:
        meta = json.loads(str(z["meta"][()]))
        arrays = {k: z[k].copy() for k in z.files if k != "meta"}
    edit(meta, arrays)
    path.write_bytes(sealed_npz(meta, arrays))


@pytest.mark.parametrize(
    "what, edit, match",
    [
        ("stale build version", lambda m, a: m["identity"].update(build_version=-1), "stale"),
        ("another kernel", lambda m, a: m["identity"].update(kernel=KERNELS[1]), "stale"),
        ("a missing array", lambda m, a: a.pop("perm"), "arrays"),
        ("build time not a number", lambda m, a: m.update(build_ns="soon"), "build_ns"),
        ("a right child out of range", lambda m, a: a["nodes"].view(np.uint32).__setitem__((0, 6), 10**6), "children"),
        ("a slot naming no triangle", lambda m, a: a["perm"].__setitem__(0, 10**6), "no triangle"),
        ("a shrunk box", lambda m, a: a["nodes"].__setitem__((0, 3), a["nodes"][0, 0]), "box"),
        ("a record changed", lambda m, a: a["records"].__setitem__((0, 0, 0), 7.0), "records"),
    ],
    ids=lambda x: x if isinstance(x, str) else "",
)
def test_a_tampered_resealed_file_is_refused_and_rebuilt(what, edit, match):
    kernel = KERNELS[0]
    tris, o, d = _scene()
    fresh = ext.build_bvh(kernel, tris)
    _quiet(kernel, tris)
    _resealed(_path(kernel, tris), edit)
    _same_answers(_rebuilt(kernel, tris, match), fresh, o, d)


def test_an_unwritable_cache_is_a_notice_and_the_tree_in_memory(cache):
    (cache / "bvh").write_text("a file where the folder goes")
    tris, o, d = _scene()
    with pytest.warns(CacheWarning, match="bvh.*kept in memory"):
        bvh, _ = bvh_cache.cached_bvh(KERNELS[0], tris)
    _same_answers(bvh, ext.build_bvh(KERNELS[0], tris), o, d)


# ------------------------------------------------------------- adopt_bvh


def _adopt(b: ext.BVH, tris=None, nodes=None, perm=None, records=None, max_leaf=None) -> ext.BVH:
    return ext.adopt_bvh(
        b.kernel,
        b.triangles if tris is None else tris,
        b.nodes if nodes is None else nodes,
        b.perm if perm is None else perm,
        b.prepared.records if records is None else records,
        b.max_leaf if max_leaf is None else max_leaf,
    )


@pytest.mark.parametrize("dtype", [np.float32, np.float64], ids=["f32", "f64"])
def test_adopt_refuses_each_broken_invariant(dtype):
    tris, _, _ = _scene(400, dtype)
    b = ext.build_bvh(KERNELS[0], tris)
    leaf = int(np.flatnonzero(b.nodes.view(np.uint32)[:, 7 if dtype == np.float32 else 13] > 0)[0])
    col = 6 if dtype == np.float32 else 12

    def node_word(row, word, value):
        nodes = b.nodes.copy()
        nodes.view(np.uint32)[row, col + word] = value
        return {"nodes": nodes}

    def perm_with(**slots):
        perm = b.perm.copy()
        for at, value in slots.items():
            perm[int(at[1:])] = value
        return {"perm": perm}

    padding = int(np.flatnonzero(b.perm < 0)[0])
    first = int(np.flatnonzero(b.perm >= 0)[1])
    nan_box, shrunk, outside = b.nodes.copy(), b.nodes.copy(), b.nodes.copy()
    nan_box[0, 2] = np.nan
    shrunk[leaf, 3:6] = shrunk[leaf, 0:3]  # the leaf's box: a point
    outside[1, 0:3] -= 1  # a child's box past its parent's
    cases = [
        (node_word(0, 0, 10**6), "children are out of range"),
        (node_word(0, 0, 1), "children are out of range"),
        (node_word(0, 0, 3), "depth-first order"),
        (node_word(leaf, 0, 10**6), "consecutive whole blocks"),
        (node_word(leaf, 0, 8), "consecutive whole blocks"),
        (node_word(leaf, 1, 10**6), "more triangles than max_leaf"),
        ({"nodes": nan_box}, "not finite"),
        ({"nodes": shrunk}, "outside its leaf's box"),
        ({"nodes": outside}, "inside its parent's"),
        ({"nodes": np.concatenate([b.nodes, b.nodes[-1:]])}, "left over"),
        (perm_with(**{f"s{first}": int(b.perm[first - 1])}), "two slots"),
        (perm_with(**{f"s{first}": -1}), "no triangle"),
        (perm_with(**{f"s{first}": len(tris)}), "no triangle"),
        (perm_with(**{f"s{padding}": 0}), "padding slot"),
        ({"perm": b.perm[:-16], "records": b.prepared.records[:-1]}, "consecutive whole blocks"),
        (
            {"perm": np.r_[b.perm, np.full(16, -1)], "records": np.r_[b.prepared.records, b.prepared.records[-1:]]},
            "exactly n_slots",
        ),
        ({"max_leaf": 2}, "more triangles than max_leaf"),
        ({"tris": tris[:-1]}, "no triangle"),
        ({"records": b.prepared.records[:-1]}, "records"),
        ({"nodes": b.nodes.astype(np.float32 if dtype == np.float64 else np.float64)}, "nodes must be"),
    ]
    for change, match in cases:
        with pytest.raises(UserError, match=f"malformed BVH.*{match}"):
            _adopt(b, **change)
    _adopt(b)  # untouched: fine


@pytest.mark.parametrize("dtype", [np.float32, np.float64], ids=["f32", "f64"])
def test_adopt_takes_every_kernels_own_tree_flat_triangles_included(dtype):
    """Flat triangles' records are no-hit records, not the kernel's arithmetic:
    adopt must accept them (and only for triangles that are flat)."""
    tris, o, d = _scene(200, np.float64, seed=5)
    tris[::7, 2] = tris[::7, 0]  # a repeated vertex
    tris[3::11] = 0.0  # a point
    tris = np.ascontiguousarray(tris, dtype)
    assert ext.flat(tris).sum() >= 40
    for kernel in KERNELS:
        b = ext.build_bvh(kernel, tris)
        _same_answers(_adopt(b), b, o.astype(dtype), d.astype(dtype))
        records = b.prepared.records.copy()
        slot = int(np.flatnonzero((b.perm >= 0) & ~ext.flat(tris)[np.maximum(b.perm, 0)])[0])
        records[slot // 16, :, slot % 16] = np.nan
        with pytest.raises(UserError, match="not flat a miss"):
            _adopt(b, records=records)  # a solid triangle made invisible


def test_adopt_refuses_a_tree_deeper_than_the_traversal_stack():
    """A chain: inner node i has inner node i + 1 as its left child and a
    one-triangle leaf as its right, 99 levels deep (the traversal's stack: 80)."""
    n = 101
    tris = np.ascontiguousarray(np.arange(n)[:, None, None] + np.eye(3)[None], np.float32)
    nodes = np.zeros((2 * n - 1, 8), np.float32)
    nodes[:, 0:3], nodes[:, 3:6] = tris.min(axis=(0, 1)), tris.max(axis=(0, 1))
    words = nodes.view(np.uint32)
    for i in range(n - 1):  # depth first: the right child follows the left subtree
        words[i, 6:8] = (2 * n - 2 - i, 0)
    perm = np.full(16 * n, -1, np.int64)
    for k, leaf in enumerate(range(n - 1, 2 * n - 1)):  # the deepest leaf first, then the right children upwards
        words[leaf, 6:8] = (16 * k, 1)
        perm[16 * k] = k
    info = ext.kernel_info(KERNELS[0])
    records = np.zeros((n, info.stride, info.lanes), np.float32)
    with pytest.raises(UserError, match="deeper than the traversal's stack"):
        ext.adopt_bvh(KERNELS[0], tris, nodes, perm, records, 1)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(
    array=st.sampled_from(["nodes", "perm"]),
    at=st.integers(0, 2**31),
    bits=st.integers(1, 2**32 - 1),
    double=st.booleans(),
)
def test_a_tampered_tree_is_refused_or_answers_as_the_original(array, at, bits, double):
    """Any one word changed: adopt refuses the tree, or (a box grown, say)
    the tree it accepts finds the same closest hits as the original."""
    tris, o, d = _scene(150, np.float64 if double else np.float32, seed=3)
    b = _original(double)
    words = (b.nodes if array == "nodes" else b.perm).copy()
    flat = words.view(np.uint32).reshape(-1)
    flat[at % len(flat)] ^= np.uint32(bits)
    try:
        tampered = _adopt(b, **{array: words})
    except UserError as e:
        assert str(e).startswith("malformed BVH")
        return
    ours, theirs = tampered.intersect(o, d), b.intersect(o, d)
    assert (ours.hits.index == theirs.hits.index).all()


_ORIGINALS: dict[bool, ext.BVH] = {}


def _original(double: bool) -> ext.BVH:
    if double not in _ORIGINALS:
        tris, _, _ = _scene(150, np.float64 if double else np.float32, seed=3)
        _ORIGINALS[double] = ext.build_bvh(KERNELS[0], tris)
    return _ORIGINALS[double]
