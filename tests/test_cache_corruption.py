"""Every corruption of a cache file is detected: `list` marks it, `load` and
`make` rebuild it (with a CacheWarning) and never use what it holds.

Corruptions: a flipped bit anywhere, a cut at any length, zero length, bytes
appended, metadata edited (an achieved figure, the spec, a version), arrays
swapped or edited, another workload's file under this one's name.
"""

from __future__ import annotations

import io
import json
import os
import subprocess
import sys
import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from tribench.common import UserError
from tribench.workloads import CacheWarning, list_cached, load, make
from tribench.workloads.spec import PairSpec

SPEC = PairSpec(n=40, hit_rate=0.5, rng_seed=3)
OTHER = PairSpec(n=40, hit_rate=0.25, rng_seed=3)


class Pristine(tuple):
    """(cache folder, path of SPEC's file, its bytes, OTHER's bytes, SPEC's fresh checksum)."""

    def __repr__(self) -> str:  # keeps a failure report short
        return f"Pristine({self[1]})"


@pytest.fixture(scope="module")
def pristine(tmp_path_factory):
    folder = tmp_path_factory.mktemp("cache")
    old = os.environ.get("TRIBENCH_CACHE")
    os.environ["TRIBENCH_CACHE"] = str(folder)
    try:
        w, other = make(SPEC), make(OTHER)
        path = folder / f"{w.workload_id}.npz"
        yield Pristine(
            (folder, path, path.read_bytes(), (folder / f"{other.workload_id}.npz").read_bytes(), w.checksum())
        )
    finally:
        if old is None:
            del os.environ["TRIBENCH_CACHE"]
        else:
            os.environ["TRIBENCH_CACHE"] = old


def _rewritten(data: bytes, edit) -> bytes:
    """The npz of ``data`` with ``edit(members)`` applied, written as plain np.savez (no seal)."""
    with np.load(io.BytesIO(data)) as z:
        members = {k: z[k] for k in z.files}
    meta = json.loads(str(members["meta"][()]))
    edit(members, meta)
    members["meta"] = np.array(json.dumps(meta))
    buf = io.BytesIO()
    np.savez(buf, **members)
    return buf.getvalue()


def _edit_achieved(m, meta):
    meta["achieved"]["hits"] += 1


def _edit_spec(m, meta):
    meta["spec"]["hit_rate"] = 0.75


def _edit_version(m, meta):
    meta["version"] += 1


def _swap_arrays(m, meta):
    m["origins"], m["directions"] = m["directions"], m["origins"]


def _edit_array(m, meta):
    m["ref_t"] = m["ref_t"] + 1e-9


def _drop_array(m, meta):
    del m["ref_edge_margin"]
    meta["arrays"].remove("ref_edge_margin")


def _extra_array(m, meta):
    m["extra"] = np.zeros(3)


def _unchanged(m, meta):
    pass  # the same content, written without the seal


_EDITS = [_edit_achieved, _edit_spec, _edit_version, _swap_arrays, _edit_array, _drop_array, _extra_array, _unchanged]


@st.composite
def corruption(draw, data: bytes, other: bytes) -> bytes:
    how = draw(st.sampled_from(["flip", "cut", "empty", "append", "edit", "other"]))
    if how == "flip":
        i, bit = draw(st.integers(0, len(data) - 1)), draw(st.integers(0, 7))
        return data[:i] + bytes([data[i] ^ (1 << bit)]) + data[i + 1 :]
    if how == "cut":
        return data[: draw(st.integers(0, len(data) - 1))]
    if how == "empty":
        return b""
    if how == "append":
        return data + draw(st.binary(min_size=1, max_size=64))
    if how == "edit":
        return _rewritten(data, draw(st.sampled_from(_EDITS)))
    return other


def _detected(folder, path, fresh_checksum) -> None:
    """`list` marks the file; `load` rebuilds it from the spec it still holds, or
    refuses it naming the file when the spec is lost too; `make` rebuilds it."""
    listed = {c.workload_id: c for c in list_cached()}
    assert listed[path.stem].problem is not None
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            assert load(path.stem).checksum() == fresh_checksum
        except UserError as exc:
            assert f"cache file {path} is invalid" in str(exc) and "make the workload again" in str(exc)
            assert make(SPEC).checksum() == fresh_checksum
    assert [str(w.message) for w in caught if w.category is CacheWarning][0].startswith(f"cache file {path} is invalid")
    assert {c.workload_id: c.problem for c in list_cached()}[path.stem] is None  # rebuilt whole
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert make(SPEC).checksum() == fresh_checksum


@pytest.mark.slow
@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_every_random_corruption_is_detected(pristine, data):
    folder, path, good, other, fresh = pristine
    os.environ["TRIBENCH_CACHE"] = str(folder)
    bad = data.draw(corruption(good, other))
    assert bad != good
    path.write_bytes(bad)
    _detected(folder, path, fresh)


@pytest.mark.parametrize("edit", _EDITS, ids=lambda f: f.__name__)
def test_every_metadata_and_array_edit_is_detected_by_make(pristine, edit):
    folder, path, good, _, fresh = pristine
    os.environ["TRIBENCH_CACHE"] = str(folder)
    path.write_bytes(_rewritten(good, edit))
    with pytest.warns(CacheWarning, match="invalid"):
        assert make(SPEC).checksum() == fresh
    assert path.read_bytes() == good  # rebuilt exactly: generation is deterministic


def test_an_intact_file_is_used_as_it_is(pristine):
    folder, path, good, _, fresh = pristine
    os.environ["TRIBENCH_CACHE"] = str(folder)
    path.write_bytes(good)
    assert {c.workload_id: c.problem for c in list_cached()}[path.stem] is None
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        w = load(path.stem)
    assert w.checksum() == fresh and w.achieved["hits"] == 20


@pytest.mark.slow
def test_the_command_line_marks_and_rebuilds_a_corrupt_file(pristine, tmp_path):
    folder, path, good, _, _ = pristine
    path.write_bytes(_rewritten(good, _edit_achieved))
    env = {**os.environ, "TRIBENCH_CACHE": str(folder)}
    cli = [sys.executable, "-m", "tribench.cli", "workloads"]
    listed = subprocess.run([*cli, "list"], capture_output=True, text=True, env=env, timeout=120)
    line = next(x for x in listed.stdout.splitlines() if x.startswith(path.stem))
    assert listed.returncode == 0 and "checksum does not match" in line
    shown = subprocess.run([*cli, "show", path.stem], capture_output=True, text=True, env=env, timeout=120)
    assert shown.returncode == 0 and f"cache file {path} is invalid" in shown.stderr
    assert shown.stderr.count("\n") == 1, "the rebuild is said in one line"
    assert "Traceback" not in shown.stderr and path.read_bytes() == good


def test_a_pipe_a_link_out_and_a_dangling_link_in_the_cache_are_listed_never_opened(tmp_path):
    cache = folder = tmp_path / "cache"
    folder.mkdir()
    os.mkfifo(folder / "pipe.npz")  # opening it would block every reader
    (folder / "out.npz").symlink_to("/etc")
    (folder / "gone.npz").symlink_to(tmp_path / "nothing")
    env = {**os.environ, "TRIBENCH_CACHE": str(cache)}
    for args in (["workloads", "list"], ["cache", "list"]):
        done = subprocess.run(
            [sys.executable, "-m", "tribench.cli", *args], capture_output=True, text=True, timeout=60, env=env
        )
        assert done.returncode == 0 and "Traceback" not in done.stderr, done.stderr
        for name in ("pipe", "out", "gone"):
            assert name in done.stdout, (args, done.stdout)
        assert "3 unusable" in done.stdout or done.stdout.count("not a regular file") == 3


def test_a_cache_path_that_is_a_file_stops_nothing(tmp_path, monkeypatch):
    blocked = tmp_path / "afile"
    blocked.write_text("not a folder")
    monkeypatch.setenv("TRIBENCH_CACHE", str(blocked))
    with pytest.warns(CacheWarning, match="is a file, not a folder: the workload is kept in memory"):
        w = make(PairSpec(n=50, rng_seed=7))
    assert len(w.triangles) == 50 and blocked.read_text() == "not a folder"
