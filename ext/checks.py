"""Argument checks shared by the kernel calls: each raises a UserError (a bad value) or UserTypeError (a bad
type) naming the argument, and returns the value as the calls use it. Kernel names and whole workloads are
checked by :func:`tribench.ext.registry.check_kernel` and :func:`tribench.ext.intersection.check_workload`."""

from __future__ import annotations

from typing import Any

import numpy as np

from ..common import UserError, UserTypeError

#: The precisions the kernels are compiled for (native byte order).
DTYPES = (np.dtype(np.float32), np.dtype(np.float64))


def check_dtype_name(dtype: Any) -> np.dtype:
    """A precision given by name or type (``"float32"``, ``np.float64``...), as one of :data:`DTYPES`."""
    if dtype is None:  # numpy reads None as float64: a precision must be named
        raise UserTypeError("dtype must be float32 or float64, got None")
    try:
        dt = np.dtype(dtype)
    except Exception as exc:  # numpy raises TypeError, ValueError or SyntaxError for a bad spec
        raise UserTypeError(f"dtype must be float32 or float64, got {dtype!r:.80}") from exc
    if dt not in DTYPES:
        raise UserTypeError(f"dtype must be float32 or float64 (native byte order), got {dt}")
    return dt


def check_name(name: str, value: object, choices: tuple[str, ...]) -> str:
    """``value`` is one of ``choices`` (a str: a list or an array is not a name)."""
    if not isinstance(value, str):
        raise UserTypeError(f"{name} must be a str, one of {', '.join(choices)}; got {type(value).__name__}")
    if value not in choices:
        raise UserError(f"{name} must be one of {', '.join(choices)}; got {value!r:.80}")
    return value


def check_flag(name: str, value: object) -> bool:
    """A bool (or numpy bool), as a bool: a truthy number or string is refused."""
    if not isinstance(value, (bool, np.bool_)):
        raise UserTypeError(f"{name} must be True or False, got {type(value).__name__}")
    return bool(value)


def plain_array(name: str, a: np.ndarray) -> np.ndarray:
    """``a`` as a plain ndarray view (never a copy). A masked array is refused: the kernels read every value, so
    its mask would be ignored silently (and a NaN under it would pass the finiteness check)."""
    if isinstance(a, np.ma.MaskedArray):
        raise UserTypeError(
            f"{name} is a numpy.ma.MaskedArray: the kernels would read the masked values "
            f"too; pass {name}.filled(...) or only the unmasked rows"
        )
    return a if type(a) is np.ndarray else a.view(np.ndarray)


def check_array(name: str, a: object, tail: tuple[int, ...], allow_nonfinite: bool = False) -> np.ndarray:
    """Check one input array; return it as a plain ndarray (a view, never a copy)."""
    allow_nonfinite = check_flag("allow_nonfinite", allow_nonfinite)
    if not isinstance(a, np.ndarray):
        raise UserTypeError(f"{name} must be a numpy.ndarray, got {type(a).__name__}")
    a = plain_array(name, a)
    if a.dtype not in DTYPES:
        raise UserTypeError(f"{name} must have dtype float32 or float64 (native byte order), got {a.dtype}")
    shape = "(N, " + ", ".join(map(str, tail)) + ")"
    if a.ndim != 1 + len(tail) or a.shape[1:] != tail:
        raise UserError(f"{name} must have shape {shape}, got {a.shape}")
    if a.shape[0] == 0:
        raise UserError(f"{name} is empty")
    if not a.flags.c_contiguous:
        raise UserError(f"{name} must be C-contiguous (use numpy.ascontiguousarray)")
    if not a.flags.aligned:
        raise UserError(f"{name} is not aligned to its dtype")
    if not allow_nonfinite:
        bad = ~np.isfinite(a.reshape(len(a), -1)).all(axis=1)
        if bad.any():
            raise UserError(f"{name} contains NaN or Inf (first at row {int(np.argmax(bad))})")
    return a


def check_same_dtype(**arrays: np.ndarray) -> np.dtype:
    dtypes = {a.dtype for a in arrays.values()}
    if len(dtypes) != 1:
        listed = ", ".join(f"{k}={v.dtype}" for k, v in arrays.items())
        raise UserTypeError(f"arrays must share one precision, got {listed}")
    return dtypes.pop()


def check_t_max(t_max, n: int, dtype: np.dtype) -> np.ndarray:
    """t_max per ray: None means +inf, a real number applies to every ray. NaN and values <= 0 are errors (no hit
    could count); a number past the dtype's range rounds to inf, which is what it means: no limit."""
    if t_max is None:
        return np.full(n, np.inf, dtype=dtype)
    if isinstance(t_max, (int, float, np.integer, np.floating)) and not isinstance(t_max, (bool, np.bool_)):
        try:
            value = float(t_max)
        except OverflowError:  # an int past float64's range: no limit either way
            value = np.inf if t_max > 0 else -np.inf
        with np.errstate(over="ignore"):
            t_max = np.full(n, value, dtype=dtype)
    elif not isinstance(t_max, np.ndarray):
        raise UserTypeError(f"t_max must be None, a real number or a numpy.ndarray, got {type(t_max).__name__}")
    t_max = plain_array("t_max", t_max)
    if t_max.shape != (n,):
        raise UserError(f"t_max must have shape ({n},), one per ray, got {t_max.shape}")
    if t_max.dtype != dtype:
        raise UserTypeError(f"t_max must have the rays' dtype {dtype}, got {t_max.dtype}")
    if not (t_max > 0).all():
        raise UserError(f"t_max must be > 0 (inf allowed), got {t_max[~(t_max > 0)][0]!r}")
    if not t_max.flags.aligned:  # as check_array's inputs: C reads it as whole reals
        raise UserError("t_max is not aligned to its dtype")
    return np.ascontiguousarray(t_max)
