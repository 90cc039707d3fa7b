"""Brute force: a kernel's prepared records (:func:`prepare`) and every ray against every triangle
(:func:`intersect`); :func:`check_workload` is every check of a call, shared with the timed batches and the BVH."""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction
from typing import NamedTuple

import numpy as np

from ..common import UserError, UserTypeError
from .checks import check_array, check_name, check_same_dtype, check_t_max
from .registry import MODES, Mode, core_of, kernel_info


@dataclass(frozen=True)
class Prepared:
    """A kernel's per-triangle records, computed once outside any timed loop.

    ``records`` is (K, stride) for a scalar kernel; a wide kernel's are in blocks of L = ``lanes`` triangles,
    structure of arrays, (ceil(K / L), stride, L), lanes past the last triangle NaN. An exactly flat triangle's
    record is all NaN (every ray misses it), but for the seed replays, which keep the seed's behaviour."""

    kernel: str
    records: np.ndarray
    n_triangles: int

    @property
    def dtype(self) -> np.dtype:
        return self.records.dtype


def prepare(kernel: str, triangles: np.ndarray, *, allow_nonfinite: bool = False) -> Prepared:
    """``kernel``'s records for ``triangles`` (K, 3, 3). Exactly flat triangles (:func:`flat`) are found here,
    once, and get a record no ray can hit (but for the seed replays): the promise costs no time per test."""
    info = kernel_info(kernel)
    tris = check_array("triangles", triangles, (3, 3), allow_nonfinite)
    n = len(tris)
    shape = (n, info.stride) if info.lanes == 1 else (-(-n // info.lanes), info.stride, info.lanes)
    records = np.empty(shape, dtype=tris.dtype)
    core_of(kernel).prepare(kernel, tris.itemsize, tris, n, records, flat(tris).view(np.uint8))
    records.flags.writeable = False
    return Prepared(kernel, records, n)


# The float filter of flat(): |computed cross component| above this fraction of
# |left| + |right| (its two products) cannot come from an exact zero. Rounding
# the two differences, the two products and their difference moves the result by
# at most about 5 units of 2**-53 of |left| + |right|; 2**-48 is 32 of them.
# The absolute term covers products that underflow (errors of 2**-1075 each).
_FILTER_RELATIVE = 2.0**-48
_FILTER_ABSOLUTE = 2.0**-1000


def flat(triangles: np.ndarray) -> np.ndarray:
    """Which triangles have exactly zero area (a point, a repeated vertex, three vertices on a line) in exact
    arithmetic on the stored values (a non-finite vertex: not flat); a float64 cross product with an error bound
    settles most, ``fractions.Fraction`` the rest.

    >>> import numpy as np
    >>> a = np.array([0.1, 0.2, 0.3])  # not dyadic
    >>> line = np.array([a, 2 * a, 4 * a])  # exactly on the line through 0 and a
    >>> flat(np.stack([line, line + [[0, 0, 0], [0, 0, 0], [0, 0, 1e-15]], [a, a, a]])).tolist()
    [True, False, True]
    """
    try:
        v = np.asarray(triangles, dtype=np.float64)
    except (TypeError, ValueError):
        raise UserTypeError(f"triangles must be an array of real numbers, got {type(triangles).__name__}") from None
    if v.ndim < 2 or v.shape[-2:] != (3, 3):
        raise UserError(f"triangles must have shape (N, 3, 3), got {v.shape}")
    v = v.reshape(-1, 3, 3)
    with np.errstate(all="ignore"):  # overflow and NaN only leave a triangle undecided
        e, f = v[:, 1] - v[:, 0], v[:, 2] - v[:, 0]
        left = e[:, [1, 2, 0]] * f[:, [2, 0, 1]]
        right = e[:, [2, 0, 1]] * f[:, [1, 2, 0]]
        clearly_not = (np.abs(left - right) > _FILTER_RELATIVE * (np.abs(left) + np.abs(right)) + _FILTER_ABSOLUTE).any(
            axis=1
        )
    out = np.zeros(len(v), dtype=bool)
    for i in np.flatnonzero(~clearly_not & np.isfinite(v).all(axis=(1, 2))):
        a, b, c = ([Fraction(float(x)) for x in vertex] for vertex in v[i])
        e_i, f_i = [q - p for p, q in zip(a, b, strict=True)], [q - p for p, q in zip(a, c, strict=True)]
        out[i] = all(e_i[j] * f_i[k] == e_i[k] * f_i[j] for j, k in ((1, 2), (2, 0), (0, 1)))
    return out


def check_workload(kernel, origins, directions, triangles, mode, t_max, isa, allow_nonfinite):
    """Every check of a kernel call on a workload: (o, d, triangles, t_max, isa), ``t_max`` an array of the
    workload's precision (new for None or a number), ``isa`` checked."""
    info = kernel_info(kernel)
    check_name("mode", mode, MODES)
    if mode not in info.modes:
        raise UserError(f"{kernel} has no {mode!r} mode (its modes: {', '.join(info.modes)})")
    if isa is None:
        isa = info.isa
    else:
        check_name("isa", isa, tuple(info.isas))
        if not info.isas[isa]:
            raise UserError(f"{kernel}: isa {isa!r} is not available on this CPU")
    o = check_array("origins", origins, (3,), allow_nonfinite)
    d = check_array("directions", directions, (3,), allow_nonfinite)
    if len(o) != len(d):
        raise UserError(f"origins and directions differ in length: {len(o)} and {len(d)}")
    tris = check_array("triangles", triangles, (3, 3), allow_nonfinite)
    dtype = check_same_dtype(origins=o, directions=d, triangles=tris)
    if mode == "pairs" and len(tris) != len(o):
        raise UserError(f"triangles: pairs need one triangle per ray, got {len(tris)} for {len(o)} rays")
    return o, d, tris, check_t_max(t_max, len(o), dtype), isa


class Hits(NamedTuple):
    """Per-ray answers of :func:`intersect`: ``index`` of the triangle hit (``-1`` for a miss; ties in the closest
    modes to the lowest index; ``any``: some hit; ``pairs``: ``i``), and its ``t``, ``u``, ``v`` in the input
    precision (the point ``(1-u-v) v0 + u v1 + v v2``; nan for a miss)."""

    index: np.ndarray  # type: ignore[assignment]  # the field hides tuple.index, as meant
    t: np.ndarray
    u: np.ndarray
    v: np.ndarray

    @property
    def hit(self) -> np.ndarray:
        return self.index >= 0


def intersect(
    kernel: str,
    origins: np.ndarray,
    directions: np.ndarray,
    triangles: np.ndarray,
    mode: Mode = "closest",
    *,
    t_max: np.ndarray | float | None = None,
    isa: str | None = None,
    allow_nonfinite: bool = False,
) -> Hits:
    """Run ``kernel`` on a workload (untimed) and return every ray's answer.

    All arrays float32 or all float64, the kernel's precision (``pairs``: K == N); ``closest`` and
    ``closest_uv`` both return u and v here (they differ when timed); ``t_max``: None (+inf), a number, or one
    per ray; ``isa``: ``kernel_info(kernel).isa`` by default. NaN or Inf is an error unless ``allow_nonfinite``:
    then the kernel's header says what it does (the clean kernels report a miss).

    >>> import numpy as np
    >>> tri = np.array([[[0., 0, 0], [1, 0, 0], [0, 1, 0]]])
    >>> r = intersect("moller_trumbore_fma", np.array([[0.25, 0.5, 1.0]]),
    ...               np.array([[0.0, 0, -1]]), tri)
    >>> int(r.index[0]), float(r.t[0]), float(r.u[0]), float(r.v[0])
    (0, 1.0, 0.25, 0.5)
    """
    o, d, tris, tm, isa = check_workload(kernel, origins, directions, triangles, mode, t_max, isa, allow_nonfinite)
    prepared = prepare(kernel, tris, allow_nonfinite=allow_nonfinite)
    n, dtype = len(o), tris.dtype
    out = Hits(np.empty(n, np.int64), np.empty(n, dtype), np.empty(n, dtype), np.empty(n, dtype))
    core_of(kernel).run(kernel, dtype.itemsize, MODES.index(mode), isa, o, d, n, tm, prepared.records, len(tris), *out)
    return out


def intersect_pairs(kernel, origins, directions, triangles, **options) -> tuple[np.ndarray, np.ndarray]:
    """Ray ``i`` against triangle ``i``: ``(hit, t)`` (see ``intersect``)."""
    r = intersect(kernel, origins, directions, triangles, "pairs", **options)
    return r.hit, r.t


def intersect_closest(kernel, origins, directions, triangles, **options) -> tuple[np.ndarray, np.ndarray]:
    """Closest hit of every ray against every triangle: ``(index, t)`` (see ``intersect``)."""
    r = intersect(kernel, origins, directions, triangles, "closest", **options)
    return r.index, r.t
