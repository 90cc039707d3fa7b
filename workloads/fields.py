"""The checks and hashes the workload specs share: field validators, canonical JSON, a file's sha256."""

from __future__ import annotations

import json
import math
import numbers
import re
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from ..common import UserError
from ..common.files import file_sha256

__all__ = [
    "DTYPES",
    "MAX_RAYS",
    "canonical_json",
    "check_choice",
    "check_float",
    "check_hit_rate",
    "check_int",
    "check_sha256",
    "checked_mesh_file",
    "file_sha256",
]

#: The precisions every workload is made in.
DTYPES = ("float32", "float64")
#: At most this many rays in one workload.
MAX_RAYS = 50_000_000


def check_int(name: str, value: Any, lo: int, hi: int) -> int:
    if (  # numpy's integers and floats are numbers.Integral and numbers.Real too
        isinstance(value, bool)
        or not isinstance(value, numbers.Real)
        or (not isinstance(value, numbers.Integral) and not float(value).is_integer())
    ):
        raise UserError(f"{name} must be an integer, got {value!r}")
    number = int(value) if isinstance(value, numbers.Integral) else int(float(value))
    if not lo <= number <= hi:
        raise UserError(f"{name} must be between {lo} and {hi}, got {number}")
    return number


def check_float(name: str, value: Any) -> float:
    """A finite real number as a float: numpy's scalars too (``np.float32(0.2)``, ``np.int64(1)``), never a bool."""
    number = value
    if isinstance(value, numbers.Integral) and not isinstance(value, bool):
        number = float(value) if abs(int(value)) < 2**1000 else math.inf  # an int past float64's range is not finite
    elif isinstance(value, numbers.Real) and not isinstance(value, bool):
        number = float(value)
    if not isinstance(number, float) or not math.isfinite(number):
        raise UserError(f"{name} must be a finite number, got {value!r:.80}")
    return float(number)


def check_hit_rate(value: Any) -> float:
    h = check_float("hit_rate", value)
    if not 0.0 <= h <= 1.0:
        raise UserError(f"hit_rate must be in [0, 1], got {h}")
    return h


def check_sha256(name: str, value: Any) -> None:
    if not (isinstance(value, str) and re.fullmatch(r"[0-9a-f]{64}", value)):
        raise UserError(f"{name} must be 64 hexadecimal digits, got {value!r:.80}")


def check_choice(name: str, value: Any, choices: Sequence[str]) -> str:
    if not isinstance(value, str) or value not in choices:
        raise UserError(f"unknown {name} {value!r}: choose one of {', '.join(choices)}")
    return value


def checked_mesh_file(path: str, names: Sequence[str], dtype: str = "float64") -> str:
    """Absolute path of a readable mesh file, or a UserError saying what is wrong."""
    p = Path(path).expanduser()
    if p.is_dir():
        raise UserError(f"mesh {path!r} is a folder: give a mesh file trimesh reads, or one of {', '.join(names)}")
    if not p.is_file():
        raise UserError(f"unknown mesh {path!r}: not one of {', '.join(names)} and no such file")
    from .meshes import read_mesh_file  # lazy: trimesh is slow to import

    read_mesh_file(p, dtype)  # raises UserError when trimesh cannot make a mesh of it, or dtype cannot hold it
    return str(p.resolve())


def canonical_json(obj: Any) -> str:
    """Sorted, compact JSON: equal values give equal strings.

    >>> canonical_json({"b": 1, "a": [0.1, "x"]})
    '{"a":[0.1,"x"],"b":1}'
    """
    return json.dumps(obj, sort_keys=True, separators=(",", ":"), allow_nan=False)
