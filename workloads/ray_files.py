"""A user's own rays: an ``.npz`` file checked before any array reaches a kernel, its headers before its data, and
again once rounded to the workload's precision (the format and every check: docs/own-rays.md)."""

from __future__ import annotations

import hashlib
import io
import zipfile
import zlib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..common import UserError

__all__ = ["ARRAYS", "MAX_FILE_BYTES", "MAX_FILE_RAYS", "RayFile", "check_rays", "describe", "read_ray_file"]

#: The arrays a ray file may hold; the first two are required.
ARRAYS = ("origins", "directions", "t_max")
#: At most a 4096 x 4096 frame's rays (docs/decisions.md, "Ray files").
MAX_FILE_RAYS = 1 << 24
#: The largest such file uncompressed (seven float64 per ray), plus room for the zip's structure.
MAX_FILE_BYTES = MAX_FILE_RAYS * 7 * 8 + (1 << 20)

_FLOATS = (np.dtype(np.float32).itemsize, np.dtype(np.float64).itemsize)
_HEADER_READERS = {(1, 0): np.lib.format.read_array_header_1_0, (2, 0): np.lib.format.read_array_header_2_0}


@dataclass(frozen=True, eq=False)
class RayFile:
    """The checked arrays of a ray file, as float64, and the sha256 of the bytes they were read from."""

    origins: np.ndarray
    directions: np.ndarray
    t_max: np.ndarray | None
    sha256: str


def _fail(path: Path, message: str) -> UserError:
    return UserError(f"ray file {path}: {message}")


def _header(z: zipfile.ZipFile, member: str, path: Path) -> tuple[tuple[int, ...], np.dtype]:
    """Shape and dtype of one ``.npy`` member, from its header only."""
    name = member[: -len(".npy")]
    try:
        with z.open(member) as f:
            version = np.lib.format.read_magic(f)
            if version not in _HEADER_READERS:
                raise ValueError(f".npy format version {version}")
            shape, _, dtype = _HEADER_READERS[version](f)
    except (ValueError, OSError, EOFError, zipfile.BadZipFile, zlib.error) as e:
        raise _fail(path, f"array {name!r} is corrupt or not a numpy array ({e})") from None
    return shape, dtype


def _check_headers(z: zipfile.ZipFile, path: Path) -> int:
    """The ray count, once every member is a known float array of the right shape."""
    members = z.namelist()
    names = [m[: -len(".npy")] if m.endswith(".npy") else m for m in members]
    unknown = sorted(set(names) - set(ARRAYS))
    if unknown or len(set(names)) < len(names):
        what = f"unknown array(s) {', '.join(map(repr, unknown))}" if unknown else "an array saved twice"
        raise _fail(path, f"{what}: a ray file holds origins, directions and optionally t_max")
    for required in ARRAYS[:2]:
        if required not in names:
            raise _fail(path, f"no {required!r} array: save origins and directions, each (N, 3)")
    rows = {}
    for member, name in zip(members, names, strict=True):
        shape, dtype = _header(z, member, path)
        if dtype.kind != "f" or dtype.itemsize not in _FLOATS:
            raise _fail(path, f"array {name!r} must be float32 or float64, got {dtype}")
        want = (3,) if name != "t_max" else ()
        if len(shape) != 1 + len(want) or tuple(shape[1:]) != want:
            form = "(N, 3)" if want else "(N,)"
            raise _fail(path, f"array {name!r} must have shape {form}, got {tuple(shape)}")
        rows[name] = shape[0]
    n = rows["origins"]
    if any(r != n for r in rows.values()):
        raise _fail(path, "arrays have different numbers of rows: " + ", ".join(f"{k} {v}" for k, v in rows.items()))
    if not 1 <= n <= MAX_FILE_RAYS:
        raise _fail(path, f"{n} rays: a ray file holds 1 to {MAX_FILE_RAYS} rays")
    return n


def _first_bad(name: str, a: np.ndarray, bad: Any, why: str, where: str) -> None:
    if np.any(bad):
        row = int(np.argmax(bad))
        raise UserError(f"{where}: {name} row {row} {why} ({a[row].tolist()!r})")


def check_rays(origins: np.ndarray, directions: np.ndarray, t_max: np.ndarray | None, where: str) -> None:
    """Raise a UserError (prefixed ``where``) at the first non-finite row, zero direction or bad t_max."""
    _first_bad("origins", origins, ~np.isfinite(origins).all(axis=1), "is not finite", where)
    _first_bad("directions", directions, ~np.isfinite(directions).all(axis=1), "is not finite", where)
    _first_bad("directions", directions, ~directions.any(axis=1), "is zero: a ray needs a direction", where)
    if t_max is not None:
        _first_bad("t_max", t_max, ~np.greater(t_max, 0), "is not > 0 (inf is no limit)", where)


def read_ray_file(path: str | Path) -> RayFile:
    """The checked rays of ``path`` (see the module docstring), as float64."""
    path = Path(path)
    size = path.stat().st_size
    if size > MAX_FILE_BYTES:
        raise _fail(path, f"{size / 1e6:.0f} MB: at most {MAX_FILE_BYTES / 1e6:.0f} MB ({MAX_FILE_RAYS} rays)")
    data = path.read_bytes()
    if data.startswith(b"\x93NUMPY"):
        raise _fail(path, "a single .npy array: save origins and directions together with numpy.savez")
    try:
        with zipfile.ZipFile(io.BytesIO(data)) as z:
            _check_headers(z, path)
        with np.load(io.BytesIO(data), allow_pickle=False) as npz:
            arrays = {name: npz[name].astype(np.float64) for name in ARRAYS if name in npz.files}
    except UserError:
        raise
    except (zipfile.BadZipFile, zlib.error) as e:
        raise _fail(path, f"not an .npz file, or a corrupt one ({e}): write it with numpy.savez") from None
    except (ValueError, OSError, EOFError, KeyError) as e:
        raise _fail(path, f"corrupt array data ({type(e).__name__}: {e})") from None
    t_max = arrays.get("t_max")
    check_rays(arrays["origins"], arrays["directions"], t_max, f"ray file {path}")
    return RayFile(arrays["origins"], arrays["directions"], t_max, hashlib.sha256(data).hexdigest())


def rounded(rays: RayFile, dtype: str, where: str) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """The rays rounded to ``dtype`` (as float64), checked again: rounding can make a value zero or infinite."""
    with np.errstate(over="ignore"):
        o, d = (np.asarray(a, dtype=dtype).astype(np.float64) for a in (rays.origins, rays.directions))
        t = None if rays.t_max is None else np.asarray(rays.t_max, dtype=dtype).astype(np.float64)
    check_rays(o, d, t, f"{where} (rounded to {dtype})")
    return o, d, t


_described: dict[tuple[str, int, int, str], tuple[int, str]] = {}


def describe(path: str | Path, dtype: str) -> tuple[int, str]:
    """``(ray count, sha256)`` of a checked ray file at ``dtype``, remembered while the file is unchanged (a
    sweep makes one spec per mesh, size and precision from one file)."""
    path = Path(path)
    st = path.stat()
    key = (str(path), st.st_size, st.st_mtime_ns, dtype)
    if key not in _described:
        rays = read_ray_file(path)
        rounded(rays, dtype, f"ray file {path}")
        _described[key] = (len(rays.origins), rays.sha256)
    return _described[key]
