"""The seed's scene files: reader, writer and the two built-in scenes (text files of ``workloads/data``).

The format, the seed loader's semantics kept here and the checks added to them: docs/methodology.md, "The
seed's replay"; a bad file raises :class:`SceneError` naming the file, the line and what was expected."""

from __future__ import annotations

import difflib
import os
import re
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from ...common import UserError, read_user_text, write_text

__all__ = [
    "BUILTIN_SCENES",
    "DEFAULT_AMBIENT",
    "DEFAULT_BACKGROUND",
    "DEFAULT_MATERIAL",
    "KEYWORDS",
    "Light",
    "Material",
    "Scene",
    "SceneError",
    "builtin_scene",
    "builtin_scene_path",
    "format_scene",
    "load_scene",
    "parse_scene",
    "read_scene",
    "scene03_text",
    "write_scene03",
]

DATA_DIR = Path(__file__).resolve().parent.parent / "data"  # workloads/data
BUILTIN_SCENES = ("scene02", "scene03")

# keyword -> names of its numbers, in order
KEYWORDS: dict[str, tuple[str, ...]] = {
    "fond": ("r", "g", "b"),
    "ambiant": ("r", "g", "b"),
    "source": ("x", "y", "z", "r", "g", "b"),
    "materiau": ("r", "g", "b", "ka", "kd", "ks", "shininess"),
    "plan": ("a", "b", "c", "d"),
    "sphere": ("x", "y", "z", "radius"),
    "tri": ("x1", "y1", "z1", "x2", "y2", "z2", "x3", "y3", "z3"),
}


class SceneError(UserError):
    """A scene file that cannot be read: the message names file, line and what was expected."""


@dataclass(frozen=True)
class Material:
    """Phong material: ``colour`` (r, g, b), ambient/diffuse/specular coefficients, shininess."""

    colour: tuple[float, float, float]
    ka: float
    kd: float
    ks: float
    shininess: float

    @property
    def reflective(self) -> bool:
        """The seed shoots a reflected ray where ``ks != 0`` (``Objet::isSpecular``)."""
        return self.ks != 0.0


@dataclass(frozen=True)
class Light:
    """Point light: ``position`` (x, y, z) and ``intensity`` (r, g, b)."""

    position: tuple[float, float, float]
    intensity: tuple[float, float, float]


DEFAULT_MATERIAL = Material((0.8, 0.8, 0.8), 0.05, 0.5, 0.1, 10.0)
DEFAULT_AMBIENT = (0.2, 0.2, 0.2)
DEFAULT_BACKGROUND = (0.8, 0.8, 0.8)


@dataclass(frozen=True, eq=False)
class Scene:
    """A scene in the seed's model, its geometry read-only float64 arrays.

    ``materials`` are the distinct materials in order of first use, which ``*_material`` index. ``planes`` (P, 4)
    are ``a b c d`` as written (not normalised), ``spheres`` (S, 4) ``x y z radius``, ``triangles`` (K, 3, 3).
    ``objects`` (P + S + K, 2) lists ``(kind, index)`` in file order (kind 0 plane, 1 sphere, 2 triangle): the seed
    tests objects in this order (its shadow test stops at the first occluder; ties in ``t`` go to the earlier)."""

    name: str
    background: tuple[float, float, float]
    ambient: tuple[float, float, float]
    lights: tuple[Light, ...]
    materials: tuple[Material, ...]
    planes: np.ndarray
    plane_material: np.ndarray
    spheres: np.ndarray
    sphere_material: np.ndarray
    triangles: np.ndarray
    triangle_material: np.ndarray
    objects: np.ndarray

    PLANE, SPHERE, TRIANGLE = 0, 1, 2

    @property
    def counts(self) -> dict[str, int]:
        """Objects and lights by kind.

        >>> builtin_scene("scene02").counts
        {'planes': 1, 'spheres': 3, 'triangles': 12, 'lights': 2}
        """
        return {
            "planes": len(self.planes),
            "spheres": len(self.spheres),
            "triangles": len(self.triangles),
            "lights": len(self.lights),
        }


# ------------------------------------------------------------------- reading


# A decimal number as the seed's ``>>`` reads one: no underscores (Python's
# float() reads "1_0" as 10), no hex, no other scripts' digits, no inf/nan.
_DECIMAL = re.compile(r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?", re.ASCII)
_FLOAT32_MAX = float(np.finfo(np.float32).max)


def _number(word: str, where: str, keyword: str, what: str) -> float:
    if not _DECIMAL.fullmatch(word):
        if word.lower().lstrip("+-") in ("inf", "infinity", "nan"):
            raise SceneError(f"{where}: '{keyword}' expects a finite number for {what}, got {word!r}")
        raise SceneError(
            f"{where}: '{keyword}' expects a number for {what}, got {word!r} (a decimal number such as -1.5e3)"
        )
    x = float(word)
    # the seed stores float: a value past float32's range would be inf there
    if not abs(x) <= _FLOAT32_MAX:
        raise SceneError(
            f"{where}: '{keyword}' expects a number within float32's range (the seed stores "
            f"float: magnitudes up to {_FLOAT32_MAX:.3g}) for {what}, got {word!r}"
        )
    return x


def _check_values(keyword: str, v: list[float], where: str) -> None:
    """Value checks beyond the count: the seed would render nonsense or divide by zero."""
    names = KEYWORDS[keyword]
    nonneg = {
        "fond": range(3),
        "ambiant": range(3),
        "source": range(3, 6),
        "materiau": range(7),
    }.get(keyword, ())
    for i in nonneg:
        if v[i] < 0:
            raise SceneError(f"{where}: '{keyword}' expects {names[i]} >= 0, got {v[i]!r}")
    if keyword == "sphere" and not v[3] > 0:
        raise SceneError(f"{where}: 'sphere' expects a positive radius, got {v[3]!r}")
    if keyword == "plan" and v[0] == v[1] == v[2] == 0:
        raise SceneError(f"{where}: 'plan' expects a non-zero normal (a b c), got 0 0 0")
    if keyword == "tri":
        p = np.array(v, dtype=np.float32).reshape(3, 3)  # the seed's float normal
        n = np.cross(p[1] - p[0], p[2] - p[0])
        if not np.any(n != 0):
            q = np.array(v, dtype=np.float64).reshape(3, 3)
            if np.any(np.cross(q[1] - q[0], q[2] - q[0]) != 0):
                raise SceneError(
                    f"{where}: 'tri' is too small for the seed's float32: its normal underflows to 0 "
                    f"(scale the scene up)"
                )
            raise SceneError(f"{where}: 'tri' is degenerate (its three vertices are collinear)")


def _read_line(raw: str, where: str) -> tuple[str, list[float]] | None:
    """One line's keyword and its numbers, every one checked; None for a blank or comment line."""
    line = raw.split("#", 1)[0].strip()
    if not line:
        return None
    words = line.split()
    keyword = words[0].lower()
    if keyword not in KEYWORDS:
        guess = difflib.get_close_matches(keyword, KEYWORDS, n=1)
        hint = f" (did you mean '{guess[0]}'?)" if guess else ""
        raise SceneError(f"{where}: unknown keyword {words[0]!r}{hint}; expected one of " + ", ".join(KEYWORDS))
    names = KEYWORDS[keyword]
    args = words[1:]
    if len(args) != len(names):
        raise SceneError(f"{where}: '{keyword}' expects {len(names)} numbers ({' '.join(names)}), got {len(args)}")
    v = [_number(w, where, keyword, n) for w, n in zip(args, names, strict=True)]
    _check_values(keyword, v, where)
    return keyword, v


def _frozen(rows: list, dtype: type, shape: tuple[int, ...] | None = None) -> np.ndarray:
    """``rows`` as a read-only array (of ``shape`` if given): a Scene's arrays never change after reading."""
    a: np.ndarray = np.array(rows, dtype=dtype)
    if shape is not None:
        a = a.reshape(shape)
    a.flags.writeable = False
    return a


#: The most triangles a scene may hold (the main job's largest mesh): the seed replay traces brute force,
#: as the seed's renderer does, so a larger scene takes hours (docs/decisions.md, "The seed replay's design").
MAX_TRIANGLES = 250_000
_TRIANGLE_LINE = re.compile(r"^[ \t]*tri[ \t]", re.MULTILINE | re.IGNORECASE)


def parse_scene(text: str, name: str = "<string>") -> Scene:
    """Read a scene from the text of a scene file; ``name`` names it and starts its errors (``name:line: ...``).

    >>> s = parse_scene("materiau 1 0 0 0.1 0.5 0 10\\nsphere 0 0 -3 1  # red ball\\n")
    >>> s.spheres.tolist(), s.materials[0].colour
    ([[0.0, 0.0, -3.0, 1.0]], (1.0, 0.0, 0.0))
    >>> parse_scene("sphere 0 0 -3", name="mine.txt")
    Traceback (most recent call last):
    ...
    tribench.workloads.seed.scene.SceneError: mine.txt:1: 'sphere' expects 4 numbers (x y z radius), got 3
    """
    if text.startswith("\ufeff"):
        text = text[1:]
    triangles = sum(1 for _ in _TRIANGLE_LINE.finditer(text))  # counted before parsing: millions take minutes
    if triangles > MAX_TRIANGLES:
        raise SceneError(
            f"{name}: {triangles:,} triangles, more than the {MAX_TRIANGLES:,} a seed scene may hold "
            "(the seed's renderer tests every triangle for every ray)"
        )
    background, ambient, current = DEFAULT_BACKGROUND, DEFAULT_AMBIENT, DEFAULT_MATERIAL
    lights: list[Light] = []
    materials: dict[Material, int] = {}  # in order of first use by an object
    rows: tuple[list[list[float]], ...] = ([], [], [])  # per kind (plane, sphere, triangle): numbers, materials
    mats: tuple[list[int], ...] = ([], [], [])
    objects: list[tuple[int, int]] = []  # (kind, index) in file order
    for lineno, raw in enumerate(text.splitlines(), start=1):
        line = _read_line(raw, f"{name}:{lineno}")
        if line is None:
            continue
        keyword, v = line
        if keyword == "fond":
            background = (v[0], v[1], v[2])
        elif keyword == "ambiant":
            ambient = (v[0], v[1], v[2])
        elif keyword == "source":
            lights.append(Light((v[0], v[1], v[2]), (v[3], v[4], v[5])))
        elif keyword == "materiau":  # the seed applies it to every object that follows
            current = Material((v[0], v[1], v[2]), v[3], v[4], v[5], v[6])
        else:
            kind = ("plan", "sphere", "tri").index(keyword)
            objects.append((kind, len(rows[kind])))
            rows[kind].append(v)
            mats[kind].append(materials.setdefault(current, len(materials)))
    return Scene(
        name=name,
        background=background,
        ambient=ambient,
        lights=tuple(lights),
        materials=tuple(materials),
        planes=_frozen(rows[0], np.float64, (-1, 4)),
        plane_material=_frozen(mats[0], np.int64),
        spheres=_frozen(rows[1], np.float64, (-1, 4)),
        sphere_material=_frozen(mats[1], np.int64),
        triangles=_frozen(rows[2], np.float64, (-1, 3, 3)),
        triangle_material=_frozen(mats[2], np.int64),
        objects=_frozen(objects, np.int64).reshape(-1, 2),
    )


def read_scene(path_or_text: str | os.PathLike, name: str | None = None) -> Scene:
    """Read a scene file (a path), or scene text (a ``str`` holding a newline); :class:`SceneError` when the file
    is missing or unreadable or a line cannot be understood. Its name is ``name``, else the file's stem."""
    if isinstance(path_or_text, str) and "\n" in path_or_text:
        return parse_scene(path_or_text, name or "<string>")
    path = Path(path_or_text)
    text = read_user_text(path, "scene file", SceneError)
    scene = parse_scene(text, str(path_or_text))
    return replace(scene, name=name or path.stem)


def builtin_scene_path(name: str) -> Path:
    """Path of a built-in scene's text file (``scene02``, ``scene03``)."""
    if name not in BUILTIN_SCENES:
        raise UserError(f"unknown built-in scene {name!r}; built-in scenes: {', '.join(BUILTIN_SCENES)}")
    return DATA_DIR / f"{name}.txt"


def builtin_scene(name: str) -> Scene:
    """One of the seed's scenes, read from its committed text file."""
    return read_scene(builtin_scene_path(name), name=name)


def load_scene(name_or_path: str | os.PathLike) -> Scene:
    """A built-in scene by name, else a scene file by path (what a CLI argument means)."""
    if isinstance(name_or_path, str) and name_or_path in BUILTIN_SCENES:
        return builtin_scene(name_or_path)
    return read_scene(name_or_path)


# ------------------------------------------------------------------- writing


def _num(x: float) -> str:
    """Shortest text that reads back as exactly ``x`` (``1.0`` is written ``1``)."""
    s = repr(float(x))
    return s[:-2] if s.endswith(".0") else s


def _line(keyword: str, values) -> str:
    return " ".join([keyword, *(_num(v) for v in values)])


def format_scene(scene: Scene, header: str = "") -> str:
    """The scene as text in the seed's format, objects in ``scene.objects`` order with a ``materiau`` line where
    the material changes, ``header`` as comments; :func:`parse_scene` reads it back exactly.

    >>> s = parse_scene("fond 1 1 1\\nsphere 0 0.1 -3 1\\n")
    >>> print(format_scene(s), end="")
    fond 1 1 1
    ambiant 0.2 0.2 0.2
    materiau 0.8 0.8 0.8 0.05 0.5 0.1 10
    sphere 0 0.1 -3 1
    """
    out = [f"# {h}".rstrip() for h in header.splitlines()]
    out.append(_line("fond", scene.background))
    out.append(_line("ambiant", scene.ambient))
    for light in scene.lights:
        out.append(_line("source", (*light.position, *light.intensity)))
    current = None
    for kind, i in scene.objects.tolist():
        m = (scene.plane_material, scene.sphere_material, scene.triangle_material)[kind][i]
        if m != current:
            mat = scene.materials[m]
            out.append(_line("materiau", (*mat.colour, mat.ka, mat.kd, mat.ks, mat.shininess)))
            current = m
        if kind == Scene.PLANE:
            out.append(_line("plan", scene.planes[i]))
        elif kind == Scene.SPHERE:
            out.append(_line("sphere", scene.spheres[i]))
        else:
            out.append(_line("tri", scene.triangles[i].ravel()))
    return "\n".join(out) + "\n"


# -------------------------------------------------------------------- scene03

_SCENE03_HEADER = """\
scene03: the seed's second scene (Vitse 2022): Suzanne, Blender's monkey head
(968 triangles), on scene02's floor, under scene02's lights and background.
GENERATED by tribench.workloads.seed.scene.write_scene03() from suzanne.obj:
every vertex turned Y-up facing +z, Blender (x, y, z) -> (x, z, -y), then
moved by (0, 0.5, -2). Suzanne's coordinates are multiples of 1/128, so the
numbers below are exact. Do not edit by hand: rerun write_scene03()."""

_SCENE03_SETUP = """\
fond 1 1 1
ambiant 1 1 1
source -2 2 0 2 2 2
source 4 5 0 2 2 2
materiau 0.2 0.2 0.98 0.3 0.5 0.7 10
plan 0 1 0 0.5
materiau 0.2 0.6 0.3 0.2 0.5 0.5 100
"""


def scene03_text() -> str:
    """The text of ``scene03.txt``, built from ``suzanne.obj`` (see :func:`write_scene03`)."""
    import trimesh  # lazy: slow to import

    from ..meshes import SUZANNE_PATH, place

    mesh = trimesh.load(str(SUZANNE_PATH), force="mesh", process=False)  # keep the 507 vertices as made
    assert isinstance(mesh, trimesh.Trimesh)  # force="mesh" gives one
    v = np.asarray(mesh.vertices, dtype=np.float64)
    placed = place("suzanne", v)  # Blender (x, y, z) -> (x, z, -y), then moved as the mesh workloads' Suzanne
    tris = placed[np.asarray(mesh.faces, dtype=np.int64)]
    lines = [f"# {h}".rstrip() for h in _SCENE03_HEADER.splitlines()]
    lines += _SCENE03_SETUP.splitlines()
    lines += [_line("tri", t.ravel()) for t in tris]
    return "\n".join(lines) + "\n"


def write_scene03() -> Path:
    """Write the committed ``scene03.txt`` again: the same bytes from the same ``suzanne.obj``."""
    out = DATA_DIR / "scene03.txt"
    write_text(out, scene03_text())
    return out


if __name__ == "__main__":  # python -m tribench.workloads.seed.scene  -> regenerates scene03.txt
    print(write_scene03())
