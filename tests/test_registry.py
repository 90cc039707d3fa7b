"""The kernel registry: every property declared once in C (ext/kernels/list.h), read
from the extension, consistent; no code infers a property from a name; and adding a
kernel touches exactly the three places docs/kernels.md names."""

from __future__ import annotations

import ast
import dataclasses
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from tribench import ext
from tribench.harness.jobs import validate

ROOT = Path(__file__).resolve().parents[1]
KERNELS = ext.kernel_names(internal=True)
INFO = {k: ext.kernel_info(k) for k in KERNELS}

# ----------------------------------------------------------- the declarations


def test_every_property_is_a_field_read_from_the_extension():
    fields = {f.name for f in dataclasses.fields(ext.KernelInfo)}
    assert {
        "lanes",
        "stride",
        "ops",
        "internal",
        "algorithm",
        "culls_back_faces",
        "watertight",
        "watertight_source",
        "seed_replay",
        "flat",
        "precisions",
    } <= fields
    for k, info in INFO.items():
        assert info.name == k and info.lanes in (1, 16) and info.stride > 0 and info.ops > 0
        assert isinstance(info.culls_back_faces, bool) and isinstance(info.seed_replay, bool)
        assert info.watertight in ("none", "edges_and_vertices")
        assert bool(info.watertight_source) == (info.watertight != "none"), k  # a promise names its paper
        assert info.flat in ("miss", "as_is")
        assert info.precisions == ("float32", "float64")
        assert info.internal == (k not in ext.kernel_names())
        with pytest.raises(dataclasses.FrozenInstanceError):
            info.culls_back_faces = not info.culls_back_faces  # type: ignore[misc]


def test_bytes_per_triangle_is_stride_times_itemsize():
    for k, info in INFO.items():
        for p in info.precisions:
            want = info.stride * np.dtype(p).itemsize
            assert info.bytes_per_triangle[p] == want == ext.bytes_per_triangle(k, p), (k, p)


def test_a_native_kernel_is_wide_and_every_other_scalar():
    native = {cols[0] for rows in _registration_lines().values() for cols in rows if cols[5].startswith("TB_NATIVE")}
    assert native and all(INFO[k].lanes == 16 for k in native)
    assert all(INFO[k].lanes == 1 for k in KERNELS if k not in native)


def test_every_kernel_is_a_form_of_a_scalar_kernel_with_its_promises():
    """kernel_info(k).algorithm: what rankings by algorithm group by."""
    for k, info in INFO.items():
        alg = INFO[info.algorithm]
        assert alg.lanes == 1 and alg.algorithm == info.algorithm, k  # a scalar kernel, its own algorithm
        assert (info.algorithm == k) == (info.lanes == 1), k
        for prop in ("culls_back_faces", "watertight", "seed_replay"):
            assert getattr(info, prop) == getattr(alg, prop), (k, prop)
        assert alg.internal <= info.internal, k  # a public kernel is a form of a public algorithm


def test_seed_replays_keep_the_seeds_flat_triangles_and_nothing_else_does():
    for k, info in INFO.items():
        assert (info.flat == "as_is") == info.seed_replay, k


def test_python_judges_by_the_declarations():
    for k, info in INFO.items():
        assert validate.culls(k) == info.culls_back_faces
        promised = validate.promise(k, "shared_edges")[1] == 0.0
        assert promised == (info.watertight == "edges_and_vertices"), k
        for test in ("nonfinite", "degenerate_triangles", "parallel_rays"):  # a seed replay is never judged
            assert (validate.promise(k, test)[1] is None) == info.seed_replay, (k, test)
    assert set(validate.WATERTIGHT) == {k for k, i in INFO.items() if i.watertight != "none"}


def test_the_declarations_say_what_the_readme_and_the_papers_say():
    # the kernels whose documentation makes these claims (docs/kernels.md's table, each header)
    assert {k for k, i in INFO.items() if i.culls_back_faces} == {
        "moller_trumbore_cull",
        "moller_trumbore_cull_fma",
    }
    assert {k for k, i in INFO.items() if i.watertight != "none"} == {"woop", "woop_fma"}
    assert {k for k, i in INFO.items() if i.seed_replay} == {
        "curless_seed",
        "moller_seed",
        "moller_seed_aa",
        "moller_seed_object",
        "curless_seed_object",
    }
    assert {k for k, i in INFO.items() if i.internal} == {
        "moller_trumbore_aa",
        "moller_seed_aa",
        "moller_seed_object",
        "curless_seed_object",
        "moller_trumbore_same",
        "moller_trumbore_twice",
        "moller_trumbore_yardstick",
    }


# ------------------------------------------------------ no inference from names


def _pieces() -> tuple[set[str], set[str]]:
    """Pieces of the registered names: fragments that carry their underscore ("_fma",
    "_cull_fma", "moller_"), and runs of whole parts ("fma", "cull", "moller_trumbore")."""
    fragments, runs = set(), set()
    for k in KERNELS:
        parts = k.split("_")
        for i in range(len(parts)):
            for j in range(i + 1, len(parts) + 1):
                run = "_".join(parts[i:j])
                if run != k:
                    runs.add(run)
                if i > 0:
                    fragments.add("_" + run)
                if j < len(parts):
                    fragments.add(run + "_")
    return fragments, runs


_FRAGMENTS, _RUNS = _pieces()
_STRING_TESTS = {
    "startswith",
    "endswith",
    "removeprefix",
    "removesuffix",
    "replace",
    "split",
    "rsplit",
    "partition",
    "rpartition",
    "find",
    "index",
    "count",
}
# file: why a name fragment is legitimate there (one line each)
ALLOWED: dict[str, str] = {
    "common/renamed.py": "'seed' in a dict is the old key of an RNG seed (#52), not a name's piece",
    "tests/test_rng_seed.py": "'seed' in a dict or a signature is the old key of an RNG seed (#52)",
}


def _name_inferences(path: Path, root: Path = ROOT) -> list[str]:
    """Lines of ``path`` that take a kernel name apart: a string literal that is a piece of
    a kernel name (``"_fma"``, ``"moller_"``), or a string test against any prefix, suffix
    or part of one (``name.startswith("woop")``, ``"cull" in name``)."""
    tree = ast.parse(path.read_text(), str(path))
    found = []

    def piece(node: ast.AST, names_too: bool) -> str | None:
        """The literal if it is a piece of a name; a whole registered name only counts
        where ``names_too`` (a string test; ``"woop" in kernels`` is list membership)."""
        if isinstance(node, ast.Constant) and isinstance(node.value, str):
            v = node.value
            if v in _FRAGMENTS or v in _RUNS and (names_too or v not in KERNELS):
                return v
        return None

    for node in ast.walk(tree):
        if isinstance(node, ast.Constant) and isinstance(node.value, str) and node.value in _FRAGMENTS:
            found.append(f"{path.relative_to(root)}:{node.lineno}: {node.value!r}")
        elif isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and node.func.attr in _STRING_TESTS:
            if node.args and (v := piece(node.args[0], True)) is not None:
                found.append(f"{path.relative_to(root)}:{node.lineno}: .{node.func.attr}({v!r})")
        elif isinstance(node, ast.Compare) and any(isinstance(op, (ast.In, ast.NotIn)) for op in node.ops):
            if (v := piece(node.left, False)) is not None:
                found.append(f"{path.relative_to(root)}:{node.lineno}: {v!r} in ...")
    return found


def _python_files() -> list[Path]:
    skip = {".venv", "build", ".git"}
    return [
        p
        for p in sorted(ROOT.rglob("*.py"))
        if not (set(p.relative_to(ROOT).parts) & skip) and not p.relative_to(ROOT).parts[0].startswith(".")
    ]


def test_the_detector_finds_the_old_tricks(tmp_path):
    old = tmp_path / "old.py"
    old.write_text(
        'def f(kernel):\n    a = "_cull" in kernel\n    b = kernel.endswith("_seed")\n'
        '    c = kernel.removesuffix("_fma")\n    d = kernel + "_fma"\n    e = kernel.startswith("woop")\n'
        '    return "moller_trumbore" == kernel\n'
    )
    found = _name_inferences(old, tmp_path)
    assert sorted({int(line.split(":")[1]) for line in found}) == [2, 3, 4, 5, 6], found


def test_no_python_file_infers_a_property_from_a_kernel_name():
    files = _python_files()
    assert len(files) > 50 and Path(__file__).resolve() in files
    found = [hit for p in files if str(p.relative_to(ROOT)) not in ALLOWED for hit in _name_inferences(p)]
    assert not found, "kernel properties come from ext.kernel_info, not from names:\n" + "\n".join(found)


# --------------------------------------------------------- adding a kernel


def _registration_lines() -> dict[str, list[list[str]]]:
    """list.h's registration lines per list: the columns of each X(...)."""
    text = (ROOT / "ext" / "kernels" / "list.h").read_text()
    lists = {}
    for name, body in re.findall(r"#define (TB_\w*KERNEL_LIST)\(X\)((?:.*\\\n)*.*\n)", text):
        lists[name] = [
            [c.strip() for c in re.split(r',(?=(?:[^"]*"[^"]*")*[^"]*$)', args)]
            for args in re.findall(r"\bX\((.*?)\)\s*\\?\n", body)
        ]
    return lists


def test_every_kernel_file_is_included_and_registered_once_and_has_a_row_in_the_kernels_table():
    lines = _registration_lines()
    assert set(lines) == {"TB_KERNEL_LIST", "TB_INTERNAL_KERNEL_LIST"}
    registered = [cols[0] for rows in lines.values() for cols in rows]
    assert len(registered) == len(set(registered)), "a kernel is registered twice"
    assert sorted(registered) == sorted(KERNELS)

    # one file per registered kernel, and no file that is not one
    helpers = {"vec", "list", "seed_objects"}
    files = {p.stem for p in (ROOT / "ext" / "kernels").glob("*.h")} - helpers
    assert files == set(KERNELS), f"unregistered files {files - set(KERNELS)}, missing {set(KERNELS) - files}"
    # kernels.h includes the scalar files, native.h (included once per ISA) the native ones
    includes = re.findall(
        r'#include "kernels/(\w+)\.h"', "".join((ROOT / "ext" / f).read_text() for f in ("kernels.h", "native.h"))
    )
    assert sorted(set(includes) - helpers) == sorted(files) and len(includes) == len(set(includes))

    # a row of docs/kernels.md's table for each: in the name or native-form column, once
    doc = (ROOT / "docs" / "kernels.md").read_text(encoding="utf-8")
    table = doc.split("\n## The kernels\n\n", 1)[1].split("\n\n", 1)[0]
    assert table.startswith("| name | native form |"), "docs/kernels.md: the table follows '## The kernels'"
    named = [n for row in table.splitlines()[2:] for cell in row.split("|")[1:3] for n in re.findall(r"`(\w+)`", cell)]
    assert sorted(named) == sorted(KERNELS), "docs/kernels.md's table: one mention per registered kernel"


def test_the_registration_lines_are_what_python_reads():
    for rows in _registration_lines().values():
        for name, faces, watertight, promised_by, origin, wide in rows:
            info = ext.kernel_info(name)
            assert info.culls_back_faces == (faces == "TB_FRONT_FACES"), name
            assert (info.watertight != "none") == (watertight == "TB_WATERTIGHT"), name
            assert info.watertight_source == promised_by.strip('"'), name
            assert info.seed_replay == (origin == "TB_SEED_REPLAY"), name
            assert (info.lanes == 16) == wide.startswith("TB_NATIVE"), name


def test_info_shows_the_declared_properties():
    script = Path(sys.executable).parent / "tribench"  # the installed command, wherever its module lives
    done = subprocess.run([script, "info"], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    row = re.compile(r"^(\w+)\s+(?:scalar|\d+/block)\s+(\d+)\s+(\d+)\s+(both|front)\s+(yes|-)\s+(seed|clean)\s")
    shown = {m[1]: m.groups()[1:] for m in map(row.match, done.stdout.splitlines()) if m}
    assert sorted(shown) == sorted(ext.kernel_names())
    for k, (f32, f64, faces, watertight, code) in shown.items():
        info = INFO[k]
        assert (int(f32), int(f64)) == (info.bytes_per_triangle["float32"], info.bytes_per_triangle["float64"])
        assert faces == ("front" if info.culls_back_faces else "both"), k
        assert watertight == ("yes" if info.watertight != "none" else "-"), k
        assert code == ("seed" if info.seed_replay else "clean"), k
