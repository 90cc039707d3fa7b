"""The BVH (ext/bvh.h, ext.build_bvh / ext.BVH): on random and adversarial
meshes, every native kernel on every runnable ISA finds in BVH mode the same
closest triangle as the same kernel brute force and as the float64 reference,
except on rays the reference marks ambiguous; any-hit agrees on hit or miss;
the build is deterministic and its structure sound; the counts are consistent;
malformed inputs raise UserError (or a ValueError from the C layer), never crash.

Ambiguous (by the reference, on the inputs as the kernel sees them): a plane
crossing that could decide the answer (t up to the closest hit's, 1e-3 relative
beyond) within 1e-3 of an edge (barycentric) or at a grazing angle (|cos| < 1e-3),
or a second hit within 1e-3 relative of the closest's t on a triangle that is
not an exact copy of it (exact copies tie exactly, to the lowest index), or a
triangle met (or nearly) at t ~ 0: the origin in its plane, up to 1e-3 relative.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tribench import ext
from tribench.common import UserError, UserTypeError
from tribench.ext import _core
from tribench.workloads import reference
from tribench.workloads.meshes import build_mesh
from tribench.workloads.rays import camera_rays, sphere_candidates

KERNELS = ext.bvh_kernel_names()
DTYPES = [np.float32, np.float64]
TOL = 1e-3


def _isas(kernel: str) -> list[str]:
    return [isa for isa, ok in ext.kernel_info(kernel).isas.items() if ok]


def _reference(
    o: np.ndarray, d: np.ndarray, tris: np.ndarray, front_only: bool = False
) -> tuple[np.ndarray, np.ndarray]:
    """The reference's closest triangle per ray (-1: miss) and which rays are ambiguous
    (``front_only``: the answers of a kernel that culls back faces)."""
    o, d, tris = (a.astype(np.float64) for a in (o, d, tris))
    m = len(o)
    if len(tris) * m > 400_000:
        rays, cand = sphere_candidates(o, d, tris)
    else:
        rays, cand = np.repeat(np.arange(m), len(tris)), np.tile(np.arange(len(tris)), m)
    ans = reference.intersect_pairs(o[rays], d[rays], tris[cand], front_only=front_only)
    index, best = np.full(m, -1), np.full(m, np.inf)
    hr, ht, hk = rays[ans.hit], ans.t[ans.hit], cand[ans.hit]
    order = np.lexsort((hk, ht, hr))
    first = order[np.r_[True, hr[order][1:] != hr[order][:-1]]] if len(order) else order
    index[hr[first]], best[hr[first]] = hk[first], ht[first]

    edges = tris[:, 1:] - tris[:, :1]
    edges /= np.abs(edges).max(axis=(1, 2))[:, None, None]  # scaled: huge or tiny triangles keep a normal
    normal = np.cross(edges[:, 0], edges[:, 1])[cand]
    with np.errstate(all="ignore"):
        cos = np.abs(np.einsum("ij,ij->i", d[rays], normal)) / np.linalg.norm(d[rays], axis=1)
        cos /= np.linalg.norm(normal, axis=1)
        reach = best[rays] * (1 + TOL)
        decisive = np.isfinite(ans.t) & (ans.t > 0) & (ans.t <= reach)
        shaky = decisive & ((np.abs(ans.edge_margin) < TOL) | ~(cos >= TOL))
        copy = (tris[cand] == tris[np.maximum(index, 0)][rays]).all(axis=(1, 2))
        near_tie = ans.hit & (ans.t <= reach) & ~copy
        span = np.linalg.norm(o[rays] - tris[cand, 0], axis=1)
        at_origin = (np.abs(ans.t) * np.linalg.norm(d[rays], axis=1) <= TOL * span) & (ans.edge_margin > -TOL)
    ambiguous = np.zeros(m, bool)
    ambiguous[rays[shaky | near_tie | at_origin]] = True
    return index, ambiguous


def _check(tris: np.ndarray, o: np.ndarray, d: np.ndarray, max_leaf: int = 16) -> float:
    """Asserts BVH == brute force == reference on the unambiguous rays, for every
    native kernel and runnable ISA; returns the ambiguous fraction."""
    answers = {culls: _reference(o, d, tris, culls) for culls in (False, True)}
    for kernel in KERNELS:
        ref_index, ambiguous = answers[ext.kernel_info(kernel).culls_back_faces]
        ok = ~ambiguous
        bvh = ext.build_bvh(kernel, tris, max_leaf=max_leaf)
        for isa in _isas(kernel):
            brute = ext.intersect(kernel, o, d, tris, "closest", isa=isa)  # one brute force for every layout
            for layout in ext.LAYOUTS:
                tr = bvh.intersect(o, d, "closest", isa=isa, layout=layout)
                where = (kernel, isa, layout, tris.dtype)
                np.testing.assert_array_equal(tr.hits.index[ok], brute.index[ok], err_msg=str(where))
                np.testing.assert_array_equal(tr.hits.index[ok], ref_index[ok], err_msg=str(where))
                same = tr.hits.index == brute.index  # the same triangle: the same arithmetic, bit for bit
                for name in ("t", "u", "v"):
                    np.testing.assert_array_equal(getattr(tr.hits, name)[same], getattr(brute, name)[same])
                shadow = bvh.intersect(o, d, "any", isa=isa, layout=layout)
                np.testing.assert_array_equal(shadow.hits.hit[ok], ref_index[ok] >= 0, err_msg=str(where))
                hit = shadow.hits.hit  # any hit is a hit of the kernel with t below the closest's bound
                assert (shadow.hits.t[hit] > 0).all()
                _check_counts(bvh, tr.counts, layout)
                _check_counts(bvh, shadow.counts, layout)
                assert (shadow.counts[:, 0] <= tr.counts[:, 0])[ok & (ref_index < 0)].all()
    return float(answers[False][1].mean())


def _check_counts(bvh: ext.BVH, counts: np.ndarray, layout: str) -> None:
    nodes, boxes, leaves, tris = counts.T
    assert (tris <= leaves * bvh.max_leaf).all() and (tris >= leaves).all()
    assert (leaves <= nodes).all() and (leaves <= len(bvh.leaves)).all()
    width = 32 // bvh.dtype.itemsize  # a wide node's children, tested at once: 8 float or 4 double lanes
    if layout == "binary":
        assert (nodes <= bvh.n_nodes).all()
        assert (boxes == 1 + 2 * (nodes - leaves)).all()  # the root's, then two per inner node
    elif layout == "wide":
        assert (nodes - leaves <= len(bvh.wide)).all()
        assert (boxes == width * (nodes - leaves)).all()
    else:  # a packet's wide nodes count on its first ray; each ray tests each leaf's box on its own
        packed = boxes == width * (nodes - leaves) + leaves
        assert (packed | (boxes == width * (nodes - leaves))).all()


def _soup(n: int, seed: int, dtype, scale: float = 1.0, shift: float = 0.0, rays: int = 300):
    rng = np.random.default_rng(seed)
    tris = rng.normal(size=(n, 3, 3))
    o = rng.normal(size=(rays, 3)) * 3
    target = tris[rng.integers(0, n, rays)].mean(axis=1) + rng.normal(size=(rays, 3)) * 0.3
    d = target - o  # unscaled: only the triangles and origins move
    return tuple(np.ascontiguousarray(a, dtype) for a in (tris * scale + shift, o * scale + shift, d))


@pytest.mark.parametrize("dtype", DTYPES, ids=["f32", "f64"])
def test_random_soup(dtype):
    assert _check(*_soup(400, 1, dtype)) < 0.2


@pytest.mark.parametrize("dtype", DTYPES, ids=["f32", "f64"])
def test_huge_and_tiny_extents(dtype):
    huge, tiny = (1e12, 1e-10) if dtype == np.float32 else (1e100, 1e-90)
    assert _check(*_soup(300, 2, dtype, scale=huge, shift=3 * huge)) < 0.2
    assert _check(*_soup(300, 3, dtype, scale=tiny, shift=-5 * tiny)) < 0.2


def _axis_aligned(n: int, seed: int):
    """Right triangles with legs along the axes, on integer coordinates, in planes x, y or z = const."""
    rng = np.random.default_rng(seed)
    tris = np.empty((n, 3, 3))
    for i in range(n):
        axis = rng.integers(3)
        p, q = rng.integers(-4, 4, 2).astype(float)
        leg = float(rng.integers(1, 3))
        corners = [(p, q), (p + leg, q), (p, q + leg)]
        for j, (a, b) in enumerate(corners):
            tris[i, j, axis] = rng.integers(-3, 4)
            tris[i, j, (axis + 1) % 3], tris[i, j, (axis + 2) % 3] = a, b
        tris[i, 1:, axis] = tris[i, 0, axis]
    return tris


@pytest.mark.parametrize("dtype", DTYPES, ids=["f32", "f64"])
def test_axis_aligned_triangles_and_rays(dtype):
    """Flat boxes; rays along the axes (1 / d infinite) with origins on integer
    planes, where a zero direction component meets a box's plane (0 x inf)."""
    rng = np.random.default_rng(4)
    tris = _axis_aligned(300, 4)
    m = 400
    o = rng.integers(-4, 5, (m, 3)).astype(float) + rng.choice([0.0, 0.3, 0.55], (m, 3))
    d = np.zeros((m, 3))
    d[np.arange(m), rng.integers(0, 3, m)] = rng.choice([-1.0, 1.0], m)
    d[m // 2 :] = rng.normal(size=(m - m // 2, 3))  # and oblique rays
    amb = _check(*(np.ascontiguousarray(a, dtype) for a in (tris, o, d)))
    assert amb < 0.6  # integer meshes: many rays meet an edge or a copy's neighbour


@pytest.mark.parametrize("dtype", DTYPES, ids=["f32", "f64"])
def test_flat_mesh_in_one_plane(dtype):
    """Every triangle in z = 0 (one flat box for the whole tree); rays from
    above, and rays in the plane itself (parallel: misses)."""
    rng = np.random.default_rng(5)
    g = 16
    x, y = np.meshgrid(np.arange(g + 1.0), np.arange(g + 1.0))
    pts = np.column_stack([x.ravel() + rng.uniform(-0.3, 0.3, x.size), y.ravel(), np.zeros(x.size)])
    cells = [(i * (g + 1) + j) for i in range(g) for j in range(g)]
    faces = [[c, c + 1, c + g + 2] for c in cells] + [[c, c + g + 2, c + g + 1] for c in cells]
    tris = pts[np.array(faces)]
    m = 300
    o = np.column_stack([rng.uniform(0, g, m), rng.uniform(0, g, m), rng.uniform(0.5, 5, m)])
    d = np.column_stack([rng.normal(size=(m, 2)) * 0.3, -np.ones(m)])
    o[: m // 10, 2], d[: m // 10, 2] = 0.0, 0.0  # in the plane
    o, d, tris = (np.ascontiguousarray(a, dtype) for a in (o, d, tris))
    assert _check(tris, o, d) < 0.2
    assert not ext.build_bvh(KERNELS[0], tris).intersect(o[: m // 10], d[: m // 10]).hits.hit.any()


@pytest.mark.parametrize("dtype", DTYPES, ids=["f32", "f64"])
def test_many_coincident_triangles_tie_to_the_lowest_index(dtype):
    """Stacks of exact copies (more than a leaf holds: no binned split can
    separate them) among random triangles: the closest is the lowest index of a stack."""
    rng = np.random.default_rng(6)
    base = np.array([[[0, 0, 0], [2, 0, 0], [0, 2, 0]], [[0, 0, 1], [2, 0, 1], [0, 2, 1.0]]])
    tris = np.concatenate([np.repeat(base, 60, axis=0), rng.normal(size=(120, 3, 3)) + [4, 0, 0]])
    tris = tris[rng.permutation(len(tris))]
    m = 200
    o = np.column_stack([rng.uniform(0.1, 0.8, m), rng.uniform(0.1, 0.8, m), np.full(m, 3.0)])
    d = np.tile([0.0, 0, -1], (m, 1)) + rng.normal(size=(m, 3)) * 0.05
    o, d, tris = (np.ascontiguousarray(a, dtype) for a in (o, d, tris))
    assert _check(tris, o, d, max_leaf=16) < 0.1
    top = np.flatnonzero((tris.astype(float) == base[1]).all(axis=(1, 2)))
    for kernel in KERNELS:
        hits = ext.build_bvh(kernel, tris).intersect(o, d).hits
        assert (hits.index == top.min()).mean() > 0.9


@pytest.mark.parametrize("n", [1, 5, 16, 17])
def test_one_triangle_and_fewer_than_a_leaf(n):
    for dtype in DTYPES:
        tris, o, d = _soup(n, 7 + n, dtype, rays=200)
        _check(tris, o, d)
        bvh = ext.build_bvh(KERNELS[0], tris)
        assert (bvh.n_nodes, bvh.n_slots) == ((1, 16) if n <= 16 else (bvh.n_nodes, bvh.n_slots))


@pytest.fixture(scope="module")
def suzanne():
    return build_mesh("suzanne", 100_000, rng_seed=0).triangles


@pytest.mark.slow
@pytest.mark.parametrize("dtype", DTYPES, ids=["f32", "f64"])
def test_suzanne_subdivided_to_1e5_triangles(suzanne, dtype):
    o, d = camera_rays(24, 24)
    rng = np.random.default_rng(8)
    o2 = rng.normal(size=(200, 3)) * 3 + [0, 0, -2]  # and rays from all around, through the mesh
    d2 = suzanne[rng.integers(0, len(suzanne), 200)].mean(axis=1) - o2
    o, d, tris = (np.ascontiguousarray(a, dtype) for a in (np.r_[o, o2], np.r_[d, d2], suzanne))
    amb = _check(tris, o, d)
    assert amb < 0.1
    counts = ext.build_bvh(KERNELS[0], tris).intersect(o, d).counts
    assert counts[:, 3].mean() < 0.01 * len(tris)  # a BVH, not brute force


@pytest.mark.parametrize("dtype", DTYPES, ids=["f32", "f64"])
def test_packets_of_camera_rays_answer_as_single_rays_do(dtype):
    """layout="packets" traces a camera's rays 16 at a time (one origin): the closest hits of
    the wide tree's single rays, bit for bit, with far fewer node visits; packets whose rays
    cross an axis (mixed signs), hold a zero direction component or a NaN go ray by ray."""
    tris = build_mesh("suzanne", 3000, rng_seed=0).triangles
    o, d = camera_rays(64, 24)  # packets of 16 in a row of 64: a quarter row each, one sign per axis
    d[[5, 37, 100], 0] = 0.0  # inv = inf: that packet ray by ray
    o[200], o[201, 1], d[300, 2] = np.nan, np.inf, np.nan  # a NaN origin splits a packet; the rest miss
    o, d, tris = (np.ascontiguousarray(a, dtype) for a in (o, d, tris))
    ok = np.isfinite(o).all(axis=1) & np.isfinite(d).all(axis=1)
    assert _check(tris, o[ok], d[ok]) < 0.1  # every layout against brute force and the reference
    for kernel in KERNELS:
        bvh = ext.build_bvh(kernel, tris)
        for isa in _isas(kernel):
            one, packed = (
                bvh.intersect(o, d, "closest_uv", isa=isa, layout=w, allow_nonfinite=True) for w in ("wide", "packets")
            )
            for name in ("index", "t", "u", "v"):
                np.testing.assert_array_equal(getattr(packed.hits, name), getattr(one.hits, name), err_msg=name)
            shadow = bvh.intersect(o, d, "any", isa=isa, layout="packets", allow_nonfinite=True)
            np.testing.assert_array_equal(shadow.hits.hit, one.hits.hit)
            inner = [(c.counts[:, 0] - c.counts[:, 2]).sum() for c in (packed, one)]
            assert inner[0] < 0.75 * inner[1]  # the packets were traced as one: a wide node once for 16 rays


@pytest.mark.parametrize("max_leaf", [1, 4, 40])
def test_leaf_size_is_a_parameter(max_leaf):
    tris, o, d = _soup(500, 9, np.float32)
    _check(tris, o, d, max_leaf=max_leaf)
    leaves = ext.build_bvh(KERNELS[0], tris, max_leaf=max_leaf).leaves
    assert leaves[:, 1].max() <= max_leaf


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_nodes_and_records_start_on_a_cache_line_built_or_adopted(dtype):
    tris, _, _ = _soup(700, 12, dtype)
    built = ext.build_bvh(KERNELS[0], tris)

    def off_line(a):  # a copy 16 bytes past a line's start, as numpy may give (a cache file's arrays)
        raw = np.empty(a.nbytes + 80, dtype=np.uint8)
        start = -raw.ctypes.data % 64 + 16
        out = raw[start : start + a.nbytes].view(a.dtype).reshape(a.shape)
        out[...] = a
        return out

    nodes, records = off_line(built.nodes), off_line(built.prepared.records)
    for bvh in (built, ext.adopt_bvh(built.kernel, tris, nodes, built.perm, records, 32)):
        for a in (bvh.nodes, bvh.wide, bvh.prepared.records):
            assert a.ctypes.data % ext.bvh.LINE_BYTES == 0
            assert not a.flags.writeable


def test_nonfinite_rays_miss_without_traversal():
    tris, o, d = _soup(300, 10, np.float32, rays=6)
    o[0, 0], d[1, 1], o[2, 2], d[3, 0] = np.nan, np.nan, np.inf, -np.inf
    for kernel in KERNELS:
        bvh = ext.build_bvh(kernel, tris)
        for isa in _isas(kernel):
            for mode in ("closest", "any"):
                tr = bvh.intersect(o, d, mode, isa=isa, allow_nonfinite=True)
                assert (tr.hits.index[:4] == -1).all() and np.isnan(tr.hits.t[:4]).all()
                assert (tr.counts[:4] == 0).all()
                brute = ext.intersect(kernel, o, d, tris, mode, isa=isa, allow_nonfinite=True)
                assert (brute.index[:4] == -1).all()  # brute force agrees: a miss
    with pytest.raises(UserError, match="origins contains NaN or Inf"):
        bvh.intersect(o, d)


def _structure(bvh: ext.BVH) -> None:
    """Boxes hold their triangles and children; leaves on block boundaries; perm a permutation."""
    n = len(bvh.triangles)
    assert sorted(bvh.perm[bvh.perm >= 0].tolist()) == list(range(n))
    words = bvh.nodes.view(np.uint32)[:, [6, 7] if bvh.dtype.itemsize == 4 else [12, 13]].astype(np.int64)
    lo, hi = bvh.nodes[:, 0:3], bvh.nodes[:, 3:6]
    slot_end = 0
    for i, (a, count) in enumerate(words):
        if count == 0:  # inner: the left child next, the right after it, boxes inside
            assert i + 1 < a < bvh.n_nodes
            for c in (i + 1, a):
                assert (lo[c] >= lo[i]).all() and (hi[c] <= hi[i]).all()
        else:
            assert a % 16 == 0 and a == slot_end and count <= bvh.max_leaf
            slot_end = a + -(-count // 16) * 16
            members = bvh.perm[a : a + count]
            assert (members >= 0).all() and (bvh.perm[a + count : slot_end] == -1).all()
            v = bvh.triangles[members].reshape(-1, 3)
            assert (v >= lo[i]).all() and (v <= hi[i]).all()
    assert slot_end == bvh.n_slots
    _wide_structure(bvh, lo, hi, words)


def _wide_structure(bvh: ext.BVH, lo: np.ndarray, hi: np.ndarray, words: np.ndarray) -> None:
    """The wide tree holds every leaf of the binary one once, with its box; inner children come after
    their parent and their planes bound everything below them; empty children have empty boxes."""
    width = 32 // bvh.dtype.itemsize
    planes = bvh.wide[:, : 6 * width].reshape(-1, 6, width)
    child = bvh.wide.view(np.uint32)[:, 48 : 48 + 2 * width].reshape(-1, 2, width).astype(np.int64)  # after 192 bytes
    leaf_box = {int(a): (lo[i], hi[i]) for i, (a, count) in enumerate(words) if count}
    seen = []
    for i in range(len(bvh.wide)):
        for lane in range(width):
            a, count = child[i, :, lane]
            c_lo, c_hi = planes[i, 0::2, lane], planes[i, 1::2, lane]
            if count:
                seen.append((a, count))
                np.testing.assert_array_equal((c_lo, c_hi), leaf_box[a])
            elif a:
                assert i < a < len(bvh.wide)
                assert (planes[a, 0::2].min(axis=1) >= c_lo).all() and (planes[a, 1::2].max(axis=1) <= c_hi).all()
            else:
                assert (c_lo == np.inf).all() and (c_hi == -np.inf).all()
    assert sorted(seen) == sorted(map(tuple, bvh.leaves.tolist()))


@settings(max_examples=25, deadline=None)
@given(
    n=st.integers(1, 120),
    copies=st.integers(0, 40),
    grid=st.booleans(),
    max_leaf=st.sampled_from([1, 3, 16, 33]),
    seed=st.integers(0, 2**32 - 1),
    double=st.booleans(),
)
def test_build_is_deterministic_and_sound(n, copies, grid, max_leaf, seed, double):
    rng = np.random.default_rng(seed)
    tris = rng.integers(-3, 4, (n, 3, 3)).astype(float) if grid else rng.normal(size=(n, 3, 3))
    tris = np.concatenate([tris, np.repeat(tris[:1], copies, axis=0)])
    tris = np.ascontiguousarray(tris, np.float64 if double else np.float32)
    a = ext.build_bvh(KERNELS[0], tris, max_leaf=max_leaf)
    b = ext.build_bvh(KERNELS[-1], tris.copy(), max_leaf=max_leaf)
    c = ext.build_bvh(KERNELS[-1], tris.copy(), max_leaf=max_leaf)
    assert a.nodes.tobytes() == b.nodes.tobytes() and (a.perm == b.perm).all()  # the tree does not depend on the kernel
    assert b.nodes.tobytes() == c.nodes.tobytes() and (b.perm == c.perm).all()
    np.testing.assert_array_equal(b.prepared.records, c.prepared.records)  # the same kernel records, bit for bit
    _structure(a)


def test_counts_timed_equal_counts_untimed_and_null_leaf_traverses_more():
    tris, o, d = _soup(2000, 11, np.float32, rays=500)
    bvh = ext.build_bvh("moller_trumbore_fma", tris)
    tr = bvh.intersect(o, d, "closest")
    batch = bvh.time(o, d, "closest", 2)
    sums = 2 * tr.counts.sum(axis=0)
    assert (batch.nodes, batch.box_tests, batch.leaves, batch.triangle_tests) == tuple(sums)
    assert batch.hits == 2 * tr.hits.hit.sum()
    assert batch.t_sum == pytest.approx(2 * np.nansum(tr.hits.t.astype(float)), rel=1e-6)
    uv = bvh.time(o, d, "closest_uv", 1)
    assert uv.uv_sum == pytest.approx(np.nansum(tr.hits.u.astype(float) + tr.hits.v), rel=1e-5)
    null = bvh.time(o, d, "closest", 1, null_leaf=True)
    assert null.hits == 0 and null.nodes >= sums[0] / 2
    t_hit = np.where(tr.hits.hit, tr.hits.t * np.float32(1.0001), np.inf).astype(np.float32)
    oracle = bvh.time(o, d, "closest", 1, t_max=t_hit, null_leaf=True)
    assert oracle.nodes <= null.nodes
    brute = ext.time_batch(ext.make_job("moller_trumbore_fma", o, d, tris, "closest"), 1)
    assert brute.tests == len(o) * len(tris)  # brute force: every triangle per ray
    assert batch.triangle_tests / 2 < brute.tests  # (a soup of large overlapping triangles: a poor case for a BVH)


def test_malformed_inputs_raise_user_errors():
    tris, o, d = _soup(50, 12, np.float32, rays=5)
    with pytest.raises(UserError, match="cannot be a BVH's leaf test"):
        ext.build_bvh("moller_trumbore", tris)
    with pytest.raises(UserError, match="unknown kernel"):
        ext.build_bvh("nope", tris)
    bad = tris.copy()
    bad[3, 1, 2] = np.nan
    with pytest.raises(UserError, match="triangles contains NaN"):
        ext.build_bvh(KERNELS[0], bad)
    with pytest.raises(UserError, match="shape"):
        ext.build_bvh(KERNELS[0], tris.reshape(-1, 9))
    for leaf, error in ((0, UserError), (2000, UserError), (True, UserTypeError), (4.0, UserTypeError)):
        with pytest.raises(error, match="max_leaf"):
            ext.build_bvh(KERNELS[0], tris, max_leaf=leaf)
    bvh = ext.build_bvh(KERNELS[0], tris)
    with pytest.raises(UserTypeError, match="one precision"):
        bvh.intersect(o.astype(np.float64), d.astype(np.float64))
    with pytest.raises(UserError, match="pairs"):
        bvh.intersect(o, d, "pairs")
    with pytest.raises(UserError, match="t_max must be > 0"):
        bvh.intersect(o, d, t_max=0.0)
    with pytest.raises(UserError, match="loops"):
        bvh.time(o, d, "closest", 0)
    with pytest.raises(UserTypeError, match="null_leaf"):
        bvh.time(o, d, "closest", 1, null_leaf="yes")


def test_a_malformed_tree_raises_in_c_instead_of_reading_out_of_bounds():
    tris, o, d = _soup(200, 13, np.float32, rays=20)
    bvh = ext.build_bvh(KERNELS[0], tris)
    tm = np.full(len(o), np.inf, np.float32)
    outs = [np.empty(len(o), np.int64)] + [np.empty(len(o), np.float32) for _ in range(3)]
    counts = np.empty((len(o), 4), np.int64)

    binary = ext.LAYOUTS.index("binary")

    def run(nodes, perm=bvh.perm, records=bvh.prepared.records, layout=binary):
        _core.bvh_run(
            KERNELS[0],
            4,
            2,
            ext.kernel_info(KERNELS[0]).isa,
            layout,
            o,
            d,
            len(o),
            tm,
            nodes,
            len(nodes),
            perm,
            len(perm),
            records,
            *outs,
            counts,
        )

    run(bvh.nodes)  # as built: fine
    leaf = int(np.flatnonzero(bvh.nodes.view(np.uint32)[:, 7] > 0)[0])
    for row, word, value in ((0, 6, 10**6), (0, 6, 1), (leaf, 6, 10**6), (leaf, 6, 8), (leaf, 7, 10**6)):
        nodes = bvh.nodes.copy()
        nodes.view(np.uint32)[row, word] = value
        with pytest.raises(ValueError, match="malformed BVH"):
            run(nodes)
    with pytest.raises(ValueError, match="multiple of 16"):
        run(bvh.nodes, bvh.perm[:-1], bvh.prepared.records)
    # the wide tree (8 children in float32: 48 plane floats, then 8 child words and 8 counts)
    wide = ext.LAYOUTS.index("wide")
    run(bvh.wide, layout=wide)
    words = bvh.wide.view(np.uint32)
    inner = int(np.flatnonzero((words[0, 56:] == 0) & (words[0, 48:56] > 0))[0])  # an inner child of the root
    leaf_row, leaf_lane = (int(x[0]) for x in np.nonzero(words[:, 56:] > 0))
    for row, word, value in (
        (0, 48 + inner, 0),
        (0, 48 + inner, 10**6),
        (leaf_row, 48 + leaf_lane, 8),
        (leaf_row, 56 + leaf_lane, 10**6),
    ):
        tree = bvh.wide.copy()
        tree.view(np.uint32)[row, word] = value
        with pytest.raises(ValueError, match="malformed BVH"):
            run(tree, layout=wide)
    with pytest.raises(ValueError, match="layout"):
        run(bvh.wide, layout=len(ext.LAYOUTS))
    broken = bvh.nodes.copy()
    broken.view(np.uint32)[0, 6] = 1  # the root's right child is its left
    with pytest.raises(ValueError, match="cannot be widened"):
        _core.bvh_widen(4, broken, len(broken), np.empty(((len(broken) - 1) // 2 + 1, 64), np.float32))
