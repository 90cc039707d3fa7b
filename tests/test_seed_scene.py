"""The seed's scene format: reader, writer, built-in scenes."""

from __future__ import annotations

import numpy as np
import pytest

from tribench.workloads.seed import scene as seed_scene
from tribench.workloads.seed.scene import (
    DEFAULT_MATERIAL,
    SceneError,
    builtin_scene,
    builtin_scene_path,
    format_scene,
    load_scene,
    parse_scene,
    read_scene,
    scene03_text,
)

GOOD = """\
# a hand-written scene
fond 1 1 1
\tambiant   0.5 0.5 0.5   # tabs and extra spaces are fine

source -2 2 0  2 2 2
SOURCE 4 5 0 1 1 1\r
materiau 0.2 0.2 0.98 0.3 0.5 0.7 10
plan 0 1 0 0.5
materiau 0.9 0.2 0.2 0.2 0.2 0.7 100
sphere 0 1 -3 1   # the red one
tri 1 -0.4 -3  3 -0.4 -3  2 1 -4
"""


def test_reads_a_good_file_with_tabs_blank_lines_and_comments(tmp_path):
    path = tmp_path / "mine.txt"
    path.write_text(GOOD)
    s = read_scene(path)
    assert s.name == "mine"
    assert s.background == (1, 1, 1) and s.ambient == (0.5, 0.5, 0.5)
    assert [light.position for light in s.lights] == [(-2, 2, 0), (4, 5, 0)]
    assert s.lights[1].intensity == (1, 1, 1)
    assert s.planes.tolist() == [[0, 1, 0, 0.5]]
    assert s.spheres.tolist() == [[0, 1, -3, 1]]
    assert s.triangles.shape == (1, 3, 3) and s.triangles[0, 2].tolist() == [2, 1, -4]
    assert s.materials[s.plane_material[0]].colour == (0.2, 0.2, 0.98)
    assert s.materials[s.sphere_material[0]].ks == 0.7
    assert s.triangle_material[0] == s.sphere_material[0]  # the material applies to all that follow
    assert s.objects.tolist() == [[0, 0], [1, 0], [2, 0]]
    # the same text, given as a string
    assert read_scene(GOOD).spheres.tolist() == s.spheres.tolist()


def test_defaults_follow_the_seed():
    s = parse_scene("sphere 0 0 -3 1\n")
    assert s.materials == (DEFAULT_MATERIAL,)  # an object before any 'materiau': Materiau()
    assert s.ambient == (0.2, 0.2, 0.2) and s.background == (0.8, 0.8, 0.8)
    assert parse_scene("fond 1 0 0\nfond 0 1 0\n").background == (0, 1, 0)  # the last one wins
    empty = parse_scene("# nothing\n\n")
    assert empty.triangles.shape == (0, 3, 3) and empty.spheres.shape == (0, 4)


@pytest.mark.parametrize(
    "line, message",
    [
        ("spher 0 0 0 1", "unknown keyword 'spher' (did you mean 'sphere'?)"),
        ("cube 0 0 0 1", "unknown keyword 'cube'; expected one of fond, ambiant"),
        ("sphere 0 0 -3", "'sphere' expects 4 numbers (x y z radius), got 3"),
        ("sphere 0 0 -3 1 2", "'sphere' expects 4 numbers (x y z radius), got 5"),
        ("fond 1 1", "'fond' expects 3 numbers (r g b), got 2"),
        ("ambiant 1 1 1 1", "'ambiant' expects 3 numbers (r g b), got 4"),
        ("source 0 0 0 1 1", "'source' expects 6 numbers (x y z r g b), got 5"),
        ("materiau 1 1 1 0.1 0.5 0.5", "'materiau' expects 7 numbers (r g b ka kd ks shininess), got 6"),
        ("plan 0 1 0", "'plan' expects 4 numbers (a b c d), got 3"),
        ("tri 0 0 0 1 0 0 0 1", "'tri' expects 9 numbers (x1 y1 z1 x2 y2 z2 x3 y3 z3), got 8"),
        ("sphere 0 0 abc 1", "'sphere' expects a number for z, got 'abc'"),
        ("sphere 0 0 1,5 1", "'sphere' expects a number for z, got '1,5'"),
        ("sphere 0 0 nan 1", "'sphere' expects a finite number for z, got 'nan'"),
        ("sphere 0 0 -3 -1", "'sphere' expects a positive radius, got -1.0"),
        ("sphere 0 0 -3 0", "'sphere' expects a positive radius, got 0.0"),
        ("plan 0 0 0 1", "'plan' expects a non-zero normal (a b c), got 0 0 0"),
        ("tri 0 0 0 1 1 1 2 2 2", "'tri' is degenerate"),
        ("materiau 1 1 1 -0.1 0.5 0.5 10", "'materiau' expects ka >= 0, got -0.1"),
        ("source 0 0 0 1 -1 1", "'source' expects g >= 0, got -1.0"),
        ("fond -1 0 0", "'fond' expects r >= 0, got -1.0"),
    ],
)
def test_malformed_lines_name_file_line_and_expectation(tmp_path, line, message):
    path = tmp_path / "scene02.txt"
    path.write_text("# header\nfond 1 1 1\n\n" + line + "  # trailing comment\n")
    with pytest.raises(SceneError) as err:
        read_scene(path)
    assert str(err.value).startswith(f"{path}:4: ")
    assert message in str(err.value)


def test_file_errors(tmp_path):
    with pytest.raises(SceneError, match="no such scene file"):
        read_scene(tmp_path / "missing.txt")
    with pytest.raises(SceneError, match="is a folder"):
        read_scene(tmp_path)
    binary = tmp_path / "bin.txt"
    binary.write_bytes(b"\xff\xfe\x00sphere")
    with pytest.raises(SceneError, match="not a text file"):
        read_scene(binary)
    assert issubclass(SceneError, ValueError)


def test_builtin_scenes_have_the_stated_contents():
    s2 = builtin_scene("scene02")
    assert s2.counts == {"planes": 1, "spheres": 3, "triangles": 12, "lights": 2}
    assert s2.background == (1, 1, 1) and s2.ambient == (1, 1, 1)
    assert [light.position for light in s2.lights] == [(-2, 2, 0), (4, 5, 0)]
    assert all(light.intensity == (2, 2, 2) for light in s2.lights)
    assert s2.spheres.tolist() == [[0, 1, -3, 1], [0, 0, -2, 0.5], [0.5, 0, -1.8, 0.5]]
    assert [m.colour for m in s2.materials] == [
        (0.2, 0.2, 0.98),
        (0.9, 0.2, 0.2),
        (0.2, 0.9, 0.2),
        (0.2, 0.2, 0.9),
        (0.8, 0.2, 0.2),
        (0.8, 0.7, 0.2),
    ]
    assert s2.materials[3].ks == 0.0  # the blue sphere does not reflect
    # the pyramids: every triangle's normal points away from its pyramid's centre
    for group in (s2.triangles[:6], s2.triangles[6:]):
        centre = group.reshape(-1, 3).mean(axis=0)
        n = np.cross(group[:, 1] - group[:, 0], group[:, 2] - group[:, 0])
        assert (np.einsum("ij,ij->i", n, group.mean(axis=1) - centre) > 0).all()
    assert np.isclose(s2.triangles[:, :, 1].min(), -0.4) and s2.triangles[:, :, 1].max() == 1

    s3 = builtin_scene("scene03")
    assert s3.counts == {"planes": 1, "spheres": 0, "triangles": 968, "lights": 2}
    assert s3.materials[s3.triangle_material[0]] == seed_scene.Material((0.2, 0.6, 0.3), 0.2, 0.5, 0.5, 100)
    # Y up, on the floor (y = -0.5), in front of the camera
    lo, hi = s3.triangles.reshape(-1, 3).min(axis=0), s3.triangles.reshape(-1, 3).max(axis=0)
    assert lo.tolist() == [-175 / 128, -0.5 + 2 / 128, -2 - 109 / 128]
    assert hi.tolist() == [175 / 128, 0.5 + 126 / 128, -2 + 109 / 128]
    assert load_scene("scene02").name == "scene02"
    assert load_scene(builtin_scene_path("scene03")).name == "scene03"


def test_scene03_file_is_reproducible_and_exact():
    assert builtin_scene_path("scene03").read_text() == scene03_text()
    s3 = builtin_scene("scene03")
    assert np.array_equal(s3.triangles * 128, np.round(s3.triangles * 128))  # multiples of 1/128


@pytest.mark.parametrize("name", ["scene02", "scene03"])
def test_format_round_trips_exactly(name):
    s = builtin_scene(name)
    t = parse_scene(format_scene(s, header="round trip"), name)
    for f in ("planes", "spheres", "triangles", "objects", "plane_material", "sphere_material", "triangle_material"):
        assert np.array_equal(getattr(s, f), getattr(t, f)), f
    assert (t.background, t.ambient, t.lights, t.materials) == (s.background, s.ambient, s.lights, s.materials)
    odd = parse_scene("sphere 0.1 1e-300 -3.0000000000000004 0.30000000000000004\n")
    assert parse_scene(format_scene(odd)).spheres.tolist() == odd.spheres.tolist()


@pytest.mark.parametrize(
    "line, message",
    [
        ("tri 1e200 0 0 1 0 0 0 1 0", "'tri' expects a number within float32's range"),
        ("sphere 0 0 -3 1e39", "'sphere' expects a number within float32's range"),
        ("sphere 0 0 1_0 1", "'sphere' expects a number for z, got '1_0'"),
        ("sphere 0 0 0x10 1", "'sphere' expects a number for z, got '0x10'"),
        ("sphere 0 0 \u0661 1", "'sphere' expects a number for z"),  # an Arabic-Indic digit: float() reads 1
        ("sphere 0 0 -inf 1", "'sphere' expects a finite number for z, got '-inf'"),
        ("sphere 0 0 Infinity 1", "'sphere' expects a finite number for z, got 'Infinity'"),
        ("tri 0 0 0 1e-30 0 0 0 1e-30 0", "'tri' is too small for the seed's float32"),  # its normal underflows
    ],
)
def test_values_the_seed_cannot_store_name_file_and_line(tmp_path, line, message):
    path = tmp_path / "scene.txt"
    path.write_text("fond 1 1 1\n" + line + "\n")
    with pytest.raises(SceneError, match=f"^{path}:2: ") as err:
        read_scene(path)
    assert message in str(err.value)


def test_numbers_as_the_seed_writes_them_are_read():
    scene = parse_scene("sphere +1 -2.5 .5e1 3.4e38\ntri 0 0 0 1. 0 0 0 1E0 0\n")
    assert scene.spheres.tolist() == [[1.0, -2.5, 5.0, 3.4e38]]


def test_a_folder_given_as_a_scene_is_named_a_folder(tmp_path):
    from tribench.workloads.seed.workload import SeedSpec

    with pytest.raises(SceneError, match=f"{tmp_path}: is a folder, not a scene file"):
        SeedSpec(scene=str(tmp_path))
    with pytest.raises(ValueError, match="no such file"):
        SeedSpec(scene=str(tmp_path / "missing.txt"))
