"""The seed's Whitted tracer: ray counts by hand, shading, and Curless vs Moller pictures."""

from __future__ import annotations

import numpy as np
import pytest

from tribench.workloads.seed.records import PLANE, TRIANGLE
from tribench.workloads.seed.scene import builtin_scene, parse_scene
from tribench.workloads.seed.trace import (
    camera_rays,
    difference_mask,
    pixel_edge_margins,
    save_mask_png,
    trace,
)

pytestmark = pytest.mark.slow  # the seed's scenes traced at full size: CI runs it

# Two big facing mirrors: one at z = -1 (facing +z, reflective), one at z = 3
# behind the eye (facing -z). The 2 x 2 camera's rays aim at (+-0.5, +-0.5, 0),
# direction (+-1/4, +-1/4, -1) per unit of z, so every ray bounces between them.
MIRRORS = """\
fond 0 0 0
ambiant 1 1 1
source 0 0 1  1 1 1
source 0 0.5 1  1 1 1
materiau 1 1 1 0.1 0.5 {front_ks} 10
tri -50 -50 -1   50 -50 -1   0 50 -1
materiau 1 1 1 0.1 0.5 {back_ks} 10
tri -50 -50 3   0 50 3   50 -50 3
"""


def test_camera_is_the_seeds():
    o, d = camera_rays(512, 512)
    assert (o == [0, 0, 2]).all()
    assert np.allclose(np.linalg.norm(d, axis=1), 1)
    # pixel (i, j) aims at (-1 + (i + 1/2) * 2/512, 1 - (j + 1/2) * 2/512, 0); row-major from the top left
    for i, j in [(0, 0), (511, 0), (0, 511), (300, 17)]:
        target = np.array([-1 + (i + 0.5) * 2 / 512, 1 - (j + 0.5) * 2 / 512, 0.0])
        want = (target - [0, 0, 2]) / np.linalg.norm(target - [0, 0, 2])
        assert np.allclose(d[j * 512 + i], want, rtol=0, atol=1e-15)


@pytest.mark.parametrize("kernel, dtype", [("moller_seed", "float32"), ("curless_seed", "float64"), (None, "float64")])
def test_ray_counts_by_hand(kernel, dtype):
    # Both mirrors reflective, depth 2: each of the 4 pixels shoots
    #   1 primary (hits z = -1), 1st reflected (hits z = 3), 2nd reflected (hits z = -1);
    #   3 hit points x 2 lights = 6 shadow rays.
    s = parse_scene(MIRRORS.format(front_ks=0.5, back_ks=0.5))
    tr = trace(s, kernel, dtype, width=2, height=2)
    assert tr.counts == {"primary": 4, "reflected": 8, "shadow": 24, "total": 36}
    assert (tr.primary.hit_index == 0).all() and tr.primary.hit.all()
    assert sorted(tr.reflected.depth.tolist()) == [1] * 4 + [2] * 4
    assert (tr.reflected.hit_index[tr.reflected.depth == 1] == 1).all()
    assert (tr.reflected.hit_index[tr.reflected.depth == 2] == 0).all()
    # shadow rays go from the hit point to the light, not normalised (t = 1 at the light)
    sh = tr.shadow
    light = np.array([[0, 0, 1], [0, 0.5, 1]])[sh.light]
    assert np.allclose(sh.origins + sh.directions, light)
    # both mirrors lie beyond the lights (t > 1 on every shadow ray): with no
    # upper bound on t, each shadows every light from the other
    assert sh.hit.all() and (sh.hit_kind == TRIANGLE).all()
    assert (sh.hit_index == np.where(sh.depth == 1, 0, 1)).all()
    # the seed's order: per pixel (columns first), primary, its shadows, reflected, ...
    kind, idx = tr.seed_order()
    assert kind[:9].tolist() == [0, 2, 2, 1, 2, 2, 1, 2, 2]
    assert tr.primary.pixel[idx[0]] == 0 and tr.primary.pixel[idx[9]] == 2  # pixel (0, 1) is next
    assert len(kind) == 36

    # Back mirror not reflective: the 1st reflected ray's hit reflects no further.
    tr = trace(parse_scene(MIRRORS.format(front_ks=0.5, back_ks=0)), kernel, dtype, width=2, height=2)
    assert tr.counts == {"primary": 4, "reflected": 4, "shadow": 16, "total": 24}
    # Depth 0: no reflection at all; ks = 0 everywhere: the same.
    tr = trace(s, kernel, dtype, width=2, height=2, depth=0)
    assert tr.counts == {"primary": 4, "reflected": 0, "shadow": 8, "total": 12}
    tr = trace(parse_scene(MIRRORS.format(front_ks=0, back_ks=0.5)), kernel, dtype, width=2, height=2)
    assert tr.counts == {"primary": 4, "reflected": 0, "shadow": 8, "total": 12}


def test_shading_by_hand():
    # One diffuse triangle facing +z at z = -1, a light straight in front: the pixel
    # centre ray hits it, colour = ka c A + kd c (n.l) I + ks (v.r)^s I.
    s = parse_scene(
        "fond 0 0 0\nambiant 0.5 0.5 0.5\nsource 0 0 1  1 1 1\n"
        "materiau 0.5 0.25 1  0.2 0.6 0.3 8\ntri -9 -9 -1  9 -9 -1  0 9 -1\n"
    )
    tr = trace(s, "moller_seed", "float64", width=1, height=1)
    c = np.array([0.5, 0.25, 1])
    # p = (0, 0, -1), l = n = v = (0, 0, 1): n.l = 1, r = n, v.r = 1
    assert np.allclose(tr.image[0, 0], 0.2 * c * 0.5 + 0.6 * c + 0.3)
    assert tr.counts == {"primary": 1, "reflected": 1, "shadow": 1, "total": 3}
    assert tr.to_uint8()[0, 0].tolist() == [int(x * 255) if x <= 1 else 255 for x in tr.image[0, 0]]
    # a miss takes the background; planes cast no shadows
    s = parse_scene("fond 0.5 0 0\nsource 0 5 -3 1 1 1\nplan 0 1 0 0.5\nplan 0 -1 0 3\n")
    tr = trace(s, "moller_seed", "float64", width=4, height=4, depth=0)
    assert not tr.shadow.hit.any()


def test_reference_agrees_with_the_kernels_on_a_small_scene02():
    s = builtin_scene("scene02")
    ref = trace(s, None, width=24, height=24)
    mol = trace(s, "moller_seed", "float64", width=24, height=24)
    assert ref.counts == mol.counts
    assert (ref.primary_triangle == mol.primary_triangle).all()


def test_pictures_look_like_the_seeds(tmp_path):
    tr = trace(builtin_scene("scene03"), "moller_seed", "float32", width=48, height=48)
    path = tr.to_png(tmp_path / "scene03.png")
    assert path.stat().st_size > 1000
    seen = tr.primary_triangle
    assert (seen >= 0).sum() > 0.15 * seen.size  # Suzanne fills a good part of the frame
    assert (seen[:4] == -1).all() and (tr.to_uint8()[0] == 255).all()  # white sky at the top
    assert (tr.primary.hit_kind[tr.primary.pixel >= 47 * 48] == PLANE).all()  # floor at the bottom


def _check_differences_on_edges(name, dtype, size, tmp_path):
    s = builtin_scene(name)
    a = trace(s, "curless_seed", dtype, width=size, height=size)
    b = trace(s, "moller_seed", dtype, width=size, height=size)
    mask, count = difference_mask(a, b)
    assert count == int(mask.sum()) and count < 1e-3 * size * size
    save_mask_png(mask, tmp_path / f"{name}_diff.png", b.to_uint8())
    if count == 0:
        return count
    # Every differing pixel has a ray (in either render) passing next to a
    # triangle's boundary, or its colours differ only in the last bits (a
    # truncation to 8 bits flipped by a last-bit difference in t).
    margin = np.minimum(pixel_edge_margins(a, mask), pixel_edge_margins(b, mask))
    tiny = np.abs(a.image - b.image)[mask].max(axis=1) < 1e-5
    tol = 1e-9 if dtype == "float64" else 5e-3  # float32 rounding and the seeds' absolute epsilons
    assert ((margin < tol) | tiny).all(), (margin, tiny)
    return count


@pytest.mark.parametrize("dtype", ["float32", "float64"])
def test_curless_and_moller_differ_only_on_edges_scene02_full_size(dtype, tmp_path):
    assert _check_differences_on_edges("scene02", dtype, 512, tmp_path) > 0


@pytest.mark.parametrize("dtype", ["float32", "float64"])
def test_curless_and_moller_differ_only_on_edges_scene03(dtype, tmp_path):
    _check_differences_on_edges("scene03", dtype, 128, tmp_path)


def test_bad_arguments():
    s = builtin_scene("scene02")
    with pytest.raises(ValueError, match="unknown kernel"):
        trace(s, "nope", width=2, height=2)
    with pytest.raises(ValueError, match="dtype"):
        trace(s, "moller_seed", "float16", width=2, height=2)
    with pytest.raises(ValueError, match="width and height"):
        trace(s, "moller_seed", width=0, height=2)
    with pytest.raises(ValueError, match="smaller image"):
        trace(builtin_scene("scene03"), None, width=512, height=512)
    a = trace(s, "moller_seed", width=2, height=2)
    b = trace(s, "moller_seed", width=4, height=4)
    with pytest.raises(ValueError, match="differ in size"):
        difference_mask(a, b)
