"""The workload record: arrays for the kernels plus float64 reference answers.

A :class:`Workload` is what a spec generates and the cache stores, its arrays read-only and C-contiguous:
``origins``, ``directions`` (M, 3; unit length, but a ray file's as given) and ``triangles`` (K, 3, 3) in
the spec's dtype, an optional ``t_max`` (M,) (hits at ``t >= t_max`` do not count), and the float64
answers for the arrays as stored (:mod:`tribench.workloads.reference`): ``ref_hit`` and ``ref_t`` (nan: a
miss) in mode ``"pairs"`` (M == K), else ``ref_index`` (-1: a miss; ties to the lowest index) and ``ref_t``.
``ref_edge_margin`` (the smallest ``|min(u, v, w)|`` over the crossings that decide the answer, negative for a
miss, nan when parallel) and ``ref_edge_clearance`` (:func:`~tribench.workloads.reference.edge_clearance`) say
how near an edge the answer is (docs/decisions.md, "Ambiguous rays")."""

from __future__ import annotations

import hashlib
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..common import UserError
from .spec import Spec

__all__ = ["AMBIGUOUS_MARGIN", "ROUNDING_UNITS", "Workload", "ambiguous_rays", "arrays_sha256", "library_versions"]

#: Default ``|ref_edge_margin|`` below which a ray counts as ambiguous.
AMBIGUOUS_MARGIN = 1e-5
#: ``|ref_edge_clearance|`` below this many epsilons of the workload's precision: ambiguous too. Every kernel
#: decides as the reference does beyond 3.35 (docs/decisions.md, "Ambiguous rays"); 8 leaves room.
ROUNDING_UNITS = 8.0

_ARRAY_NAMES = (
    "origins",
    "directions",
    "triangles",
    "t_max",
    "ref_hit",
    "ref_index",
    "ref_t",
    "ref_edge_margin",
    "ref_edge_clearance",
)


def ambiguous_rays(edge_margin, edge_clearance, dtype: str, margin: float = AMBIGUOUS_MARGIN) -> np.ndarray:
    """Rays whose ``|edge_margin|`` is under ``margin`` or whose ``|edge_clearance|`` is under
    :data:`ROUNDING_UNITS` epsilons of ``dtype``; a parallel pair (nan for both) is not: no crossing exists.

    >>> ambiguous_rays(np.array([0.5, 5e-6, 0.5]), np.array([1e-3, 1e-3, 1e-7]), "float32").tolist()
    [False, True, True]
    >>> ambiguous_rays(np.array([0.5]), np.array([1e-7]), "float64").tolist()
    [False]
    """
    with np.errstate(invalid="ignore"):
        return (np.abs(edge_margin) < margin) | (np.abs(edge_clearance) < ROUNDING_UNITS * np.finfo(dtype).eps)


def arrays_sha256(arrays: Mapping[str, np.ndarray]) -> str:
    """sha256 over named arrays: name, dtype, shape and bytes, in name order.

    >>> a = {"x": np.zeros(2)}
    >>> arrays_sha256(a) == arrays_sha256({"x": np.zeros(2, dtype=np.float32)})
    False
    """
    h = hashlib.sha256()
    for name in sorted(arrays):
        a = np.ascontiguousarray(arrays[name])
        h.update(f"{name}|{a.dtype.str}|{a.shape}|".encode())
        h.update(a.data)
    return h.hexdigest()


def library_versions(*names: str) -> dict[str, str]:
    """Installed versions of the named distributions (recorded with each workload).

    >>> list(library_versions("numpy"))
    ['numpy']
    """
    from importlib.metadata import PackageNotFoundError, version

    out = {}
    for name in names:
        try:
            out[name] = version(name)
        except PackageNotFoundError:
            out[name] = "unknown"
    return out


def _flatten(d: Mapping[str, Any], prefix: str = "") -> dict[str, Any]:
    out: dict[str, Any] = {}
    for k, v in d.items():
        if isinstance(v, Mapping):
            out.update(_flatten(v, f"{prefix}{k}."))
        else:
            out[f"{prefix}{k}"] = v
    return out


@dataclass(frozen=True, eq=False)
class Workload:
    """Arrays, reference answers and achieved figures of one spec: ``achieved`` is keyed like ``spec.targets()``
    for the figures that have a target, plus diagnostics."""

    workload_id: str
    spec: Spec
    origins: np.ndarray
    directions: np.ndarray
    triangles: np.ndarray
    ref_t: np.ndarray
    ref_edge_margin: np.ndarray
    ref_edge_clearance: np.ndarray
    ref_hit: np.ndarray | None = None
    ref_index: np.ndarray | None = None
    t_max: np.ndarray | None = None
    achieved: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        dtype = np.dtype(self.spec.dtype)
        m = len(self.origins)
        want: dict[str, tuple[Any, tuple[int, ...]]] = {
            "origins": (dtype, (m, 3)),
            "directions": (dtype, (m, 3)),
            "triangles": (dtype, (len(self.triangles), 3, 3)),
            "ref_t": (np.float64, (m,)),
            "ref_edge_margin": (np.float64, (m,)),
            "ref_edge_clearance": (np.float64, (m,)),
        }
        if self.mode == "pairs":
            want["ref_hit"] = (np.bool_, (m,))
            if len(self.triangles) != m:
                raise UserError(f"pairs need one triangle per ray, got {len(self.triangles)} for {m}")
        else:
            want["ref_index"] = (np.int64, (m,))
        if self.t_max is not None:
            want["t_max"] = (dtype, (m,))
        for name, (dt, shape) in want.items():
            a = getattr(self, name)
            if a is None or a.dtype != dt or a.shape != shape:
                got = None if a is None else (a.dtype, a.shape)
                raise UserError(f"{name} must be {np.dtype(dt)} {shape}, got {got}")
            a = np.ascontiguousarray(a)
            a.setflags(write=False)  # shared with the cache and the kernels: never modified
            object.__setattr__(self, name, a)

    @property
    def mode(self) -> str:
        """``"pairs"`` (ray i vs triangle i), else ``"closest"``, ``"closest_uv"`` or ``"any"`` (rays x triangles)."""
        return self.spec.mode

    @property
    def hits(self) -> np.ndarray:
        """Boolean mask of the rays (or pairs) that hit, by the reference."""
        ref = self.ref_hit if self.mode == "pairs" else self.ref_index
        assert ref is not None  # __post_init__ checked the mode's reference array
        return ref if self.mode == "pairs" else ref >= 0

    def arrays(self) -> dict[str, np.ndarray]:
        """The stored arrays by name (those that apply to the mode)."""
        return {n: getattr(self, n) for n in _ARRAY_NAMES if getattr(self, n) is not None}

    def checksum(self) -> str:
        return arrays_sha256(self.arrays())

    def expected_checksum(self) -> tuple[int, float]:
        """``(hits, sum of t over the hits)``, the sum exactly rounded (``math.fsum``): a kernel's run should give the
        count exactly and the sum to within its precision."""
        hits = self.hits
        return int(hits.sum()), math.fsum(self.ref_t[hits].tolist())

    def ambiguous(self, margin: float = AMBIGUOUS_MARGIN) -> np.ndarray:
        """Rays within ``margin`` (barycentric) or the dtype's rounding of changing answer (:func:`ambiguous_rays`)."""
        return ambiguous_rays(self.ref_edge_margin, self.ref_edge_clearance, self.spec.dtype, margin)

    def targets(self) -> dict[str, Any]:
        return self.spec.targets()

    def compare(self) -> list[tuple[str, Any, Any]]:
        """``(figure, target, achieved)`` rows, targeted figures first; nested figures are flattened with dotted
        names (``miss_mix.parallel``), and one without a target has target ``None``."""
        targets, achieved = _flatten(self.targets()), _flatten(dict(self.achieved))
        rows = [(k, v, achieved.get(k)) for k, v in targets.items()]
        return rows + [(k, None, v) for k, v in achieved.items() if k not in targets]

    @property
    def kind(self) -> str:
        return self.spec.kind
