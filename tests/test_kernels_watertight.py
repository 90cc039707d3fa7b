"""woop and plucker: agreement with the reference, and the watertight promise.

Every check runs both kernels in float32 and float64, in the scalar form and
their native forms woop_fma and plucker_fma on each of their instruction sets. The
watertight checks shoot rays at the shared edges and vertices of exactly
representable, exactly coplanar meshes: a ray through the interior of such a
mesh that hits no triangle is a crack. ``pytest -s`` prints the measured
crack and double-hit rates; moller_trumbore is measured beside them as the
control that shows the workload can find cracks.
"""

from __future__ import annotations

import functools
from fractions import Fraction

import numpy as np
import pytest
import trimesh
from conftest import as_dtype, reference_answers, safe_pairs

from tribench import ext
from tribench.workloads import reference

KERNELS = ["woop", "plucker"]
DTYPES = [np.float32, np.float64]
DTYPE_IDS = ["f32", "f64"]
# the native forms held to their algorithm's promises here, and their runnable ISAs
NATIVE = {"woop_fma": "woop", "plucker_fma": "plucker"}
# (kernel, form) of every check below that runs a form
CASES = [(k, "scalar") for k in KERNELS] + [
    (k, isa) for k in NATIVE for isa, ok in ext.kernel_info(k).isas.items() if ok
]
PLUCKER_CASES = [(k, f) for k, f in CASES if k == "plucker" or NATIVE.get(k) == "plucker"]
WOOP_CASES = [(k, f) for k, f in CASES if k == "woop" or NATIVE.get(k) == "woop"]
T_RTOL = {np.float32: 1e-4, np.float64: 1e-10}
UV_ATOL = {np.float32: 1e-4, np.float64: 1e-9}


def _intersect(kernel, form, o, d, tris, mode="closest_uv", **options):
    """One call of `kernel` in `form`: "scalar", or a native kernel on that ISA."""
    isa = None if form == "scalar" else form
    return ext.intersect(kernel, o, d, tris, mode, isa=isa, **options)


def test_registered_with_raw_vertices_and_a_native_form():
    for kernel in KERNELS:
        assert kernel in ext.kernel_names()
        assert ext.kernel_info(kernel).stride == 9
        assert ext.bytes_per_triangle(kernel, "float32") == 36
    for native, kernel in NATIVE.items():
        assert native in ext.kernel_names()
        assert ext.kernel_info(native).lanes == 16 and ext.kernel_info(native).algorithm == kernel


# ------------------------------------------------------- agreement with the reference


@pytest.mark.parametrize("dtype", DTYPES, ids=DTYPE_IDS)
@pytest.mark.parametrize("kernel", KERNELS)
def test_pairs_away_from_edges_agree_with_reference(kernel, dtype):
    o, d, tris = as_dtype(safe_pairs(3000, seed=21), dtype)
    ref = reference_answers(o, d, tris)
    r = ext.intersect(kernel, o, d, tris, "pairs")
    np.testing.assert_array_equal(r.hit, ref.hit)
    hit = r.hit
    np.testing.assert_allclose(r.t[hit], ref.t[hit], rtol=T_RTOL[dtype])
    np.testing.assert_allclose(r.u[hit], ref.u[hit], atol=UV_ATOL[dtype])
    np.testing.assert_allclose(r.v[hit], ref.v[hit], atol=UV_ATOL[dtype])
    assert np.isnan(r.t[~hit]).all()


@functools.cache
def _icosphere_rays():
    """An icosphere and rays whose every plane crossing is far from every edge,
    with the reference's closest hit and its barycentrics."""
    tris = np.ascontiguousarray(trimesh.creation.icosphere(subdivisions=2).triangles)
    rng = np.random.default_rng(5)
    o = rng.normal(size=(500, 3))
    o = 3 * o / np.linalg.norm(o, axis=1)[:, None]
    d = rng.normal(size=(500, 3)) * 0.7 - o
    d /= np.linalg.norm(d, axis=1)[:, None]
    m, k = len(o), len(tris)
    every = reference.intersect_pairs(np.repeat(o, k, 0), np.repeat(d, k, 0), np.tile(tris, (m, 1, 1)))
    near = (np.abs(every.edge_margin) < 1e-3) | (np.abs(every.t) < 1e-3)
    safe = ~near.reshape(m, k).any(axis=1)
    o, d = o[safe], d[safe]
    index, t = reference.intersect_closest(o, d, tris)
    hit = index >= 0
    uv = reference.intersect_pairs(o[hit], d[hit], tris[index[hit]])
    return o, d, tris, index, t, uv.u, uv.v


@pytest.mark.parametrize("dtype", DTYPES, ids=DTYPE_IDS)
@pytest.mark.parametrize(("kernel", "form"), CASES)
def test_closest_on_a_mesh_agrees_with_reference(kernel, dtype, form):
    o, d, tris, ref_index, ref_t, ref_u, ref_v = _icosphere_rays()
    assert len(o) > 250 and 0.2 < (ref_index >= 0).mean() < 0.95
    o, d, tris = as_dtype((o, d, tris), dtype)
    for mode in ("closest", "closest_uv"):
        r = _intersect(kernel, form, o, d, tris, mode)
        np.testing.assert_array_equal(r.index, ref_index)
        hit = r.hit
        np.testing.assert_allclose(r.t[hit], ref_t[hit], rtol=T_RTOL[dtype])
        np.testing.assert_allclose(r.u[hit], ref_u, atol=UV_ATOL[dtype])
        np.testing.assert_allclose(r.v[hit], ref_v, atol=UV_ATOL[dtype])
        assert np.isnan(r.t[~hit]).all()


@pytest.mark.parametrize("dtype", DTYPES, ids=DTYPE_IDS)
@pytest.mark.parametrize(("kernel", "form"), CASES)
def test_any_mode_finds_a_hit_exactly_when_the_reference_does(kernel, dtype, form):
    o, d, tris, ref_index, *_ = _icosphere_rays()
    o, d, tris = as_dtype((o, d, tris), dtype)
    r = _intersect(kernel, form, o, d, tris, "any")
    np.testing.assert_array_equal(r.hit, ref_index >= 0)
    # the triangle it names is one the reference hits
    hit = r.hit
    assert reference.intersect_pairs(o[hit], d[hit], tris[r.index[hit]]).hit.all()


@pytest.mark.parametrize("dtype", DTYPES, ids=DTYPE_IDS)
@pytest.mark.parametrize(("kernel", "form"), CASES)
def test_t_max_bounds_the_hits(kernel, dtype, form):
    o, d, tris, ref_index, ref_t, *_ = _icosphere_rays()
    o, d, tris = as_dtype((o, d, tris), dtype)
    hit = ref_index >= 0
    far = np.where(hit, ref_t * 1.001, 1.0).astype(dtype)
    near = np.where(hit, ref_t * 0.999, 1.0).astype(dtype)
    r = _intersect(kernel, form, o, d, tris, "closest", t_max=far)
    np.testing.assert_array_equal(r.index, ref_index)
    # the closest hit is beyond t_max: nothing counts (a ray's closest is its first)
    assert not _intersect(kernel, form, o, d, tris, "closest", t_max=near).hit.any()
    assert not _intersect(kernel, form, o, d, tris, "any", t_max=near).hit.any()


# ------------------------------------------------------- degenerate and non-finite input

DOWN = np.array([[0.0, 0, -1]])
UNIT_TRI = np.array([[[0.0, 0, 0], [1, 0, 0], [0, 1, 0]]])
DEGENERATE = np.array(
    [
        [[0.0, 0, 0], [1, 0, 0], [2, 0, 0]],  # collinear, ray off the line
        [[0.0, 0, 0], [0.25, 0.25, 0], [1, 1, 0]],  # collinear, ray through the line
        [[0.3, 0.3, 0], [0.3, 0.3, 0], [0.3, 0.3, 0]],  # a point
        [[0.0, 0, 0], [1, 1, 0], [1, 1, 0]],  # two vertices coincide
        [[0.5, 0.5, -1], [0.5, 0.5, 0], [0.5, 0.5, 1]],  # a segment along the ray
    ]
)


@pytest.mark.parametrize("dtype", DTYPES, ids=DTYPE_IDS)
@pytest.mark.parametrize(("kernel", "form"), CASES)
def test_degenerate_triangles_miss(kernel, dtype, form):
    n = len(DEGENERATE)
    o = np.array([[0.3, 0.3, 1], [0.5, 0.5, 1], [0.3, 0.3, 1], [0.5, 0.5, 1], [0.5, 0.5, 2.0]])
    o, d, tris = as_dtype((o, np.repeat(DOWN, n, 0), DEGENERATE), dtype)
    if form == "scalar":
        assert not ext.intersect(kernel, o, d, tris, "pairs").hit.any()
    for i in range(n):
        assert not _intersect(kernel, form, o[i : i + 1], d[i : i + 1], tris).hit[0]


def _nonfinite_cases():
    """Rays (one bad coordinate each in o or d) and triangles (one bad vertex
    coordinate each), every value NaN, +Inf or -Inf, plus a zero direction."""
    o, d, tris = [], [], []
    for value in (np.nan, np.inf, -np.inf):
        for k in range(3):
            for which in (0, 1):
                ray = [np.array([0.25, 0.25, 1.0]), DOWN[0].copy()]
                ray[which][k] = value
                o.append(ray[0])
                d.append(ray[1])
        for k in range(9):
            tri = UNIT_TRI[0].copy().reshape(9)
            tri[k] = value
            tris.append(tri.reshape(3, 3))
    o.append([0.25, 0.25, 1.0])
    d.append([0.0, 0, 0])
    return np.array(o), np.array(d), np.array(tris)


@pytest.mark.parametrize("dtype", DTYPES, ids=DTYPE_IDS)
@pytest.mark.parametrize(("kernel", "form"), CASES)
def test_nonfinite_inputs_are_misses(kernel, dtype, form):
    bad_o, bad_d, bad_tris = as_dtype(_nonfinite_cases(), dtype)
    good_o, good_d, good_tri = as_dtype((np.array([[0.25, 0.25, 1.0]]), DOWN, UNIT_TRI), dtype)
    # a bad ray hits nothing, not even a good triangle
    r = _intersect(kernel, form, bad_o, bad_d, good_tri, allow_nonfinite=True)
    assert not r.hit.any() and np.isnan(r.t).all()
    # a good ray hits no bad triangle, and still finds a good one among them
    r = _intersect(kernel, form, good_o, good_d, bad_tris, allow_nonfinite=True)
    assert not r.hit.any()
    mixed = np.ascontiguousarray(np.concatenate([bad_tris, good_tri]))
    r = _intersect(kernel, form, good_o, good_d, mixed, allow_nonfinite=True)
    assert r.index[0] == len(bad_tris) and r.t[0] == 1
    if form == "scalar":
        n = len(bad_tris)
        o, d = np.repeat(good_o, n, 0), np.repeat(good_d, n, 0)
        r = ext.intersect(kernel, o, d, bad_tris, "pairs", allow_nonfinite=True)
        assert not r.hit.any()


# ------------------------------------------------------------- watertight meshes

CELL = 1 / 8  # grid spacing; every coordinate below is a multiple of CELL / 4
CELLS = 8  # CELLS x CELLS squares, each split in two along alternating diagonals
EDGE_FRACTIONS = (0.25, 0.5, 0.75)
VERTEX_REPEATS = 4
# (in-plane axes and normal axis, offset): the plane z = 0 or x = ... or y = ...
# (a permutation of axes, so every coordinate stays exact), near the origin
# and far from it (coordinates up to ~1024 still need only 16 bits)
MESHES = [
    ((0, 1, 2), (0.375, -1.25, 0.5)),
    ((1, 2, 0), (0.375, -1.25, 0.5)),
    ((2, 0, 1), (0.375, -1.25, 0.5)),
    ((0, 1, 2), (1024.375, -512.0, 77.0)),
    ((1, 2, 0), (-96.5, 1000.25, 3.0)),
    ((2, 0, 1), (5.0, -700.75, 640.5)),
]


def _grid_local():
    """Triangles of the grid in plane coordinates (units of CELL), with
    vertex valences 4 and 8, counter-clockwise."""
    tris = []
    for i in range(CELLS):
        for j in range(CELLS):
            a, b, c, d = (i, j), (i + 1, j), (i + 1, j + 1), (i, j + 1)
            tris += [(a, b, c), (a, c, d)] if (i + j) % 2 == 0 else [(a, b, d), (b, c, d)]
    return np.array(tris, dtype=float)


def _aims_local():
    """Interior shared vertices (each VERTEX_REPEATS times, so they get as
    many rays as the far more numerous edge points) and points of interior
    shared edges (units of CELL), each with the indices of the triangles that
    hold it."""
    tris = _grid_local()
    points = [(i, j) for i in range(1, CELLS) for j in range(1, CELLS)] * VERTEX_REPEATS
    kinds = ["vertex"] * len(points)
    for tri in tris:
        for k in range(3):
            p, q = tri[k], tri[(k + 1) % 3]
            on_border = any(p[axis] == q[axis] and p[axis] in (0, CELLS) for axis in (0, 1))
            if not on_border and tuple(p) < tuple(q):  # each shared edge once
                points += [tuple(p + s * (q - p)) for s in EDGE_FRACTIONS]
                kinds += ["edge"] * len(EDGE_FRACTIONS)
    points = np.array(points)
    # closed point-in-triangle test, exact on these dyadic values
    a, b, c = tris[:, 0], tris[:, 1], tris[:, 2]

    def side(p, q, x):
        return (q[:, 0] - p[:, 0]) * (x[1] - p[:, 1]) - (q[:, 1] - p[:, 1]) * (x[0] - p[:, 0])

    inside = [(side(a, b, x) >= 0) & (side(b, c, x) >= 0) & (side(c, a, x) >= 0) for x in points]
    holders = [np.nonzero(i)[0] for i in inside]
    return points, np.array(kinds), holders


def _embed(local, axes, offset):
    """Plane coordinates (units of CELL) to space: local x, y on axes[0],
    axes[1], the plane at offset[axes[2]]."""
    out = np.empty(local.shape[:-1] + (3,))
    out[..., axes[0]] = offset[axes[0]] + CELL * local[..., 0]
    out[..., axes[1]] = offset[axes[1]] + CELL * local[..., 1]
    out[..., axes[2]] = offset[axes[2]]
    return out


@functools.cache
def _grid_rays(mesh: int, dtype):
    """Triangles and rays of one mesh, each ray aimed at a shared vertex or
    edge point: `exact` rays (dyadic origin, direction aim - origin, so the
    ray passes through the aim exactly), `random_direction` rays (random unit
    directions, origin aim - dist d rounded: through the aim up to rounding)
    and `random_origin` rays (random origins, direction aim - origin rounded).
    Returns tris, o, d, kind ("vertex"/"edge"), family, holders per ray."""
    axes, offset = MESHES[mesh]
    points, kinds, holders = _aims_local()
    tris = _embed(_grid_local(), axes, offset)
    aims = _embed(points, axes, offset)
    normal = np.zeros(3)
    normal[axes[2]] = 1
    rng = np.random.default_rng(100 + mesh)
    o, d, aim_of, family = [], [], [], []
    n = len(aims)
    for scale in (0.25, 2.0, 16.0):  # exact
        g = rng.integers(-3, 4, size=(n, 3)).astype(float)
        g[:, axes[2]] = rng.choice([-3, -2, -1, 1, 2, 3], n)
        o.append((aims + scale * g).astype(dtype))
        d.append((-scale * g).astype(dtype))
        aim_of.append(np.arange(n))
        family += ["exact"] * n
    for dist in (0.5, 4.0, 64.0):  # random directions toward the aim
        for _ in range(2):
            u = rng.normal(size=(n, 3))
            u /= np.linalg.norm(u, axis=1)[:, None]
            cos = u @ normal
            u += normal * ((np.sign(cos) + (cos == 0)) * np.maximum(0, 0.3 - np.abs(cos)))[:, None]
            u /= np.linalg.norm(u, axis=1)[:, None]
            o.append((aims - dist * u).astype(dtype))
            d.append(u.astype(dtype))
            aim_of.append(np.arange(n))
            family += ["random_direction"] * n
    for _ in range(2):  # random origins, direction rounded
        src = aims + rng.normal(size=(n, 3)) * 2
        src += normal * (np.sign(src @ normal - offset[axes[2]])[:, None] + 0.5)
        src = src.astype(dtype)
        o.append(src)
        d.append(aims.astype(dtype) - src)
        aim_of.append(np.arange(n))
        family += ["random_origin"] * n
    aim_of = np.concatenate(aim_of)
    return (
        np.ascontiguousarray(tris, dtype),
        np.ascontiguousarray(np.concatenate(o)),
        np.ascontiguousarray(np.concatenate(d)),
        kinds[aim_of],
        np.array(family),
        [holders[i] for i in aim_of],
    )


@functools.cache
def _cracks(kernel, dtype, form):
    """Rays that hit no triangle, over every mesh: {kind: (cracks, rays)}."""
    counts = {"vertex": [0, 0], "edge": [0, 0]}
    for mesh in range(len(MESHES)):
        tris, o, d, kinds, _, _ = _grid_rays(mesh, dtype)
        missed = ~_intersect(kernel, form, o, d, tris, "closest").hit
        for kind in counts:
            counts[kind][0] += int(missed[kinds == kind].sum())
            counts[kind][1] += int((kinds == kind).sum())
    return {kind: tuple(c) for kind, c in counts.items()}


@pytest.mark.parametrize("dtype", DTYPES, ids=DTYPE_IDS)
@pytest.mark.parametrize(("kernel", "form"), WOOP_CASES)
def test_woop_has_no_cracks(kernel, dtype, form):
    cracks = _cracks(kernel, dtype, form)
    print(f"\n{kernel} {np.dtype(dtype)} {form}: cracks {cracks}")
    assert cracks["vertex"][0] == 0 and cracks["edge"][0] == 0
    assert cracks["vertex"][1] > 10000 and cracks["edge"][1] > 30000


@pytest.mark.parametrize("dtype", DTYPES, ids=DTYPE_IDS)
@pytest.mark.parametrize(("kernel", "form"), PLUCKER_CASES)
def test_plucker_has_no_cracks_through_edges(kernel, dtype, form):
    # watertight by construction through an edge's interior (the shared
    # edge's product is negated exactly, fused or not: see plucker_fma.h);
    # at vertices it is not (see the kernel's header): measured here, and
    # asserted on random fans below
    cracks = _cracks(kernel, dtype, form)
    vertex_cracks, vertex_rays = cracks["vertex"]
    print(f"\n{kernel} {np.dtype(dtype)} {form}: cracks {cracks}, vertex crack rate {vertex_cracks / vertex_rays:.2e}")
    assert cracks["edge"][0] == 0


@pytest.mark.parametrize("dtype", DTYPES, ids=DTYPE_IDS)
def test_the_grid_finds_cracks_in_a_test_that_is_not_watertight(dtype):
    # the control: without it, zero cracks above could mean a blunt workload
    cracks = _cracks("moller_trumbore", dtype, "scalar")
    print(f"\nmoller_trumbore {np.dtype(dtype)}: cracks {cracks}")
    assert cracks["vertex"][0] + cracks["edge"][0] > 100


@pytest.mark.parametrize("dtype", DTYPES, ids=DTYPE_IDS)
@pytest.mark.parametrize("kernel", KERNELS)
def test_every_ray_hits_a_triangle_holding_its_aim(kernel, dtype):
    """Pairs mode, each ray against each triangle holding its aim point: at
    least one must hit (no crack); more than one is a double hit, expected
    (edges are closed) and reported."""
    report = {}
    for mesh in range(len(MESHES)):
        tris, o, d, kinds, family, holders = _grid_rays(mesh, dtype)
        count = np.array([len(h) for h in holders])
        ray = np.repeat(np.arange(len(o)), count)
        holding = np.ascontiguousarray(tris[np.concatenate(holders)])
        hits = ext.intersect(kernel, o[ray], d[ray], holding, "pairs").hit
        per_ray = np.add.reduceat(hits.astype(int), np.r_[0, np.cumsum(count)[:-1]])
        for kind in ("vertex", "edge"):
            for fam in ("exact", "random_direction", "random_origin"):
                sel = (kinds == kind) & (family == fam)
                none, double, n = report.get((kind, fam), (0, 0, 0))
                report[(kind, fam)] = (
                    none + int((per_ray[sel] == 0).sum()),
                    double + int((per_ray[sel] >= 2).sum()),
                    n + int(sel.sum()),
                )
    for (kind, fam), (none, double, n) in sorted(report.items()):
        print(
            f"\n{kind:6s} {fam:16s} {kernel} {np.dtype(dtype)}: no hit {none}/{n}, double hit {double / n:.3f}", end=""
        )
    for (kind, fam), (none, _, _) in report.items():
        if kernel == "woop" or kind == "edge":
            assert none == 0, (kind, fam)


def _fan_rays(seed: int, n_fans: int, rays_per_fan: int, far: bool):
    """Random star-shaped fans around a vertex (exact dyadic coordinates, any
    plane spanned by small integer vectors), rays aimed at the vertex from
    random directions, the origin rounded to float32 and float64. `far`:
    origins 100-10000 fan sizes away, else 0.1-1 fan sizes."""
    rng = np.random.default_rng(seed)
    out = []
    while len(out) < n_fans:
        size = 2.0 ** rng.integers(-8, 2)
        vertex = np.round(rng.uniform(-64, 64, 3) / size) * size
        dist = size * 10 ** rng.uniform(2, 4) if far else size * 10 ** rng.uniform(-1, 0)
        k = int(rng.integers(3, 11))
        angle = np.sort(rng.uniform(0, 2 * np.pi, k))
        if np.diff(np.r_[angle, angle[0] + 2 * np.pi]).max() >= 0.9 * np.pi:
            continue  # the fan must surround its vertex
        radius = rng.uniform(0.5, 1, (k, 1))
        flat = np.round(np.c_[np.cos(angle), np.sin(angle)] * radius * 16) / 16 * size
        span = rng.integers(-2, 3, (2, 3)).astype(float)
        normal = np.cross(span[0], span[1])
        ring = vertex + flat @ span
        tris = np.array([[vertex, ring[i], ring[(i + 1) % k]] for i in range(k)])
        area = np.linalg.norm(np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0]), axis=1)
        if not normal.any() or (area == 0).any():
            continue
        d = rng.normal(size=(rays_per_fan, 3))
        d /= np.linalg.norm(d, axis=1)[:, None]
        d = d[np.abs(d @ normal) > 0.3 * np.linalg.norm(normal)]
        out.append((tris, vertex - dist * d, d))
    return out


def _fan_cracks(kernel, dtype, fans, isa=None):
    """Rays of the fans that hit none of their fan's triangles (pairs mode; a
    native kernel, which has none, runs each fan as a mesh on `isa`)."""
    cracks = rays = 0
    for tris, o, d in fans:
        k, n = len(tris), len(o)
        if ext.kernel_info(kernel).lanes == 16:
            o, d, t = as_dtype((o, d, tris), dtype)
            assert (t == tris).all(), "fan not exact in this precision"
            hit = ext.intersect(kernel, o, d, t, "closest", isa=isa).hit
        else:
            every = np.tile(tris, (n, 1, 1))
            o, d, t = as_dtype((np.repeat(o, k, 0), np.repeat(d, k, 0), every), dtype)
            assert (t == every).all(), "fan not exact in this precision"
            hit = ext.intersect(kernel, o, d, t, "pairs").hit.reshape(n, k).any(axis=1)
        cracks += int((~hit).sum())
        rays += n
    return cracks, rays


@pytest.mark.parametrize("dtype", DTYPES, ids=DTYPE_IDS)
@pytest.mark.parametrize(("kernel", "isa"), [("woop", None)] + [(k, f) for k, f in WOOP_CASES if k != "woop"])
def test_woop_is_watertight_at_vertices_of_random_fans(kernel, isa, dtype):
    for far in (False, True):
        cracks, rays = _fan_cracks(kernel, dtype, _fan_rays(9, 40, 1500, far), isa)
        where = "far" if far else "near"
        print(f"\n{kernel} {isa or 'scalar'} {np.dtype(dtype)} fans {where}: cracks {cracks}/{rays}", end="")
        assert cracks == 0


def _sliver(dtype):
    """A triangle that the ray (0, 0, -1) + t (0, 0, 1) misses by a hair across
    its edge bc, whose rounded edge function is 0 (the two products round to the
    same number), and its neighbour across bc, which the ray hits. The shear is
    exact here (sx = sy = 0), so the 2-D vertices are the x, y coordinates."""
    e = float(np.finfo(dtype).eps)
    b, c = (-(1 + e), -(1 + 2 * e), 0.0), (1.0, 1 + e, 0.0)
    # edge bc = cx by - cy bx = (1 + e)^2 - (1 + 2 e) = e^2 exactly, 0 once rounded
    rounded = dtype(dtype(1 + e) * dtype(1 + e)) - dtype(1 + 2 * e)
    exact = Fraction(1 + e) ** 2 - Fraction(1 + 2 * e)
    assert rounded == 0 and exact == Fraction(e) ** 2
    missed = np.array([[(-1.0, 1.0, 0.0), b, c]], dtype)
    hit = np.array([[(1.0, -1.0, 0.0), c, b]], dtype)
    return np.array([[0, 0, -1.0]], dtype), np.array([[0, 0, 1.0]], dtype), missed, hit


@pytest.mark.parametrize("dtype", DTYPES, ids=DTYPE_IDS)
@pytest.mark.parametrize(("kernel", "form"), WOOP_CASES)
def test_a_zero_edge_function_is_recomputed_in_every_lane(kernel, dtype, form):
    # the paper's fallback: without it the rounded 0 is accepted and the ray
    # hits a triangle it misses; the sliver in each lane of a 16-block (after
    # copies of the neighbour moved off the ray, every lane after it empty or
    # the neighbour, then another copy)
    o, d, missed, hit = _sliver(dtype)
    assert ext.intersect("moller_trumbore", o, d, missed, "closest").hit[0]  # not watertight: hits it
    off = hit + np.array([100, 0, 0], dtype)
    for lane in range(16):
        tris = np.ascontiguousarray(np.concatenate([np.repeat(off, lane, 0), missed]))
        assert not _intersect(kernel, form, o, d, tris, "closest").hit[0], lane
        both = np.ascontiguousarray(np.concatenate([np.repeat(off, lane, 0), missed, hit, off]))
        r = _intersect(kernel, form, o, d, both, "closest")
        assert r.index[0] == lane + 1 and r.t[0] == 1, lane


@pytest.mark.parametrize("dtype", DTYPES, ids=DTYPE_IDS)
@pytest.mark.parametrize(("kernel", "isa"), [("plucker", None)] + [(k, f) for k, f in PLUCKER_CASES if k != "plucker"])
@pytest.mark.xfail(
    strict=True,
    reason="plucker's tolerance is relative to |U+V+W|, not a bound on each product's "
    "error, which grows with the distance to the origin: at a vertex of triangles "
    "100-10000 times their size away, every triangle of the fan can see mixed signs "
    "(plucker_fma keeps the same tolerance rule, so the same holds for it)",
)
def test_plucker_is_watertight_at_vertices_of_far_fans(kernel, isa, dtype):
    near = _fan_cracks(kernel, dtype, _fan_rays(9, 40, 1500, far=False), isa)
    far = _fan_cracks(kernel, dtype, _fan_rays(9, 40, 1500, far=True), isa)
    print(f"\n{kernel} {isa} {np.dtype(dtype)} fans: near cracks {near[0]}/{near[1]}, far cracks {far[0]}/{far[1]}")
    assert far[0] == 0
