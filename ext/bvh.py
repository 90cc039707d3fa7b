"""A bounding volume hierarchy over a triangle array, a native kernel's block test at its leaves: built,
checked and traversed in C (``ext/bvh.h``, ``ext/bvh_trace.h``), kept in numpy arrays between calls."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal, NamedTuple

import numpy as np

from ..common import UserError, UserTypeError
from . import _core
from .checks import check_array, check_flag
from .intersection import Hits, Prepared, check_workload, flat
from .registry import MODES, Mode, check_kernel, core_of, kernel_info, kernel_modules


def bvh_kernel_names() -> tuple[str, ...]:
    """Kernels a :class:`BVH` can take as its leaf test: the native kernels (blocks of 16 triangles).

    >>> "moller_trumbore_fma" in bvh_kernel_names()
    True
    """
    return tuple(k for m in kernel_modules() for k in m.bvh_kernels() if core_of(k) is m)


def _check_leaf_kernel(kernel: str) -> None:
    check_kernel(kernel)
    if kernel not in bvh_kernel_names():
        raise UserError(f"{kernel} cannot be a BVH's leaf test; these can: {', '.join(bvh_kernel_names())}")


#: Columns of :attr:`Trace.counts`: per ray, nodes entered (inner nodes and
#: leaves), ray-box tests, leaves entered, and triangles tested in them.
COUNT_NAMES: tuple[str, ...] = ("nodes", "box_tests", "leaves", "triangle_tests")
#: The most triangles one BVH takes; the most rays x loops one timed BVH batch traces.
MAX_BVH_TRIANGLES: int = _core.MAX_BVH_TRIANGLES
MAX_BVH_BATCH_RAYS: int = _core.MAX_BVH_BATCH_RAYS
#: The version of the tree ext/bvh.h builds (bumped when it changes; the BVH cache names files by it).
BVH_BUILD_VERSION: int = _core.BVH_BUILD_VERSION
#: How a traversal walks the tree: ``wide`` (the default, the faster: 8 children a node in
#: float32, 4 in float64, their boxes tested at once), ``binary`` (the tree as built, two boxes
#: tested one after the other) and ``packets`` (the wide tree, 16 consecutive rays at a time: one
#: box test per child for a packet of rays sharing their origin and direction signs, such as a
#: camera's; others ray by ray); docs/decisions.md, "Wide BVH".
Layout = Literal["wide", "binary", "packets"]
LAYOUTS: tuple[str, ...] = ("wide", "binary", "packets")
#: Bytes of one wide node (ext/bvh.h's tb_bvh_wide).
WIDE_NODE_BYTES: int = 256


class Trace(NamedTuple):
    """Answers of :meth:`BVH.intersect` (as :func:`intersect`'s, in the caller's triangle indices) and, per ray,
    its work: int64 (N, 4), the columns of :data:`COUNT_NAMES`."""

    hits: Hits
    counts: np.ndarray


@dataclass(frozen=True)
class TraceBatch:
    """One timed BVH batch: ``loops`` passes over the rays, timed inside C; ``hits``, ``t_sum`` and ``uv_sum`` as
    in :class:`Batch`, the counts summed over every ray of every pass."""

    elapsed_ns: int
    loops: int
    rays: int
    hits: int
    t_sum: float
    uv_sum: float
    nodes: int
    box_tests: int
    leaves: int
    triangle_tests: int

    @property
    def rays_per_s(self) -> float:
        return self.loops * self.rays / self.elapsed_ns * 1e9 if self.elapsed_ns > 0 else float("nan")


@dataclass(frozen=True, eq=False)
class BVH:
    """A BVH over a triangle array with one native kernel's records at its leaves (:func:`build_bvh`).

    ``ext/bvh.h``'s tree (binned SAH, deterministic, depth first, leaves of at most ``max_leaf`` triangles on
    whole blocks of 16 slots): ``nodes`` (n, 8) in the triangles' precision, box corners then two uint32
    (``nodes.view(np.uint32)``'s columns 6-7 in float32, 12-13 in float64; inner ``(right child, 0)``, leaf
    ``(first slot, triangles)``); ``perm``: slot -> the caller's triangle index (-1: padding); ``prepared``: the
    records in slot order; ``wide``: the same tree as ``tb_bvh_wide`` nodes (``layout="wide"``). Every array is
    read-only; answers are in the caller's indices."""

    kernel: str
    triangles: np.ndarray
    nodes: np.ndarray
    perm: np.ndarray
    prepared: Prepared
    max_leaf: int
    wide: np.ndarray

    @property
    def dtype(self) -> np.dtype:
        return self.triangles.dtype

    @property
    def n_nodes(self) -> int:
        return len(self.nodes)

    @property
    def n_slots(self) -> int:
        return len(self.perm)

    @property
    def leaves(self) -> np.ndarray:
        """(first slot, triangles) of every leaf, in slot order: int64 (L, 2)."""
        return _leaves(self.nodes)

    def _rays(self, origins, directions, mode, t_max, isa, allow_nonfinite, layout):
        _check_leaf_kernel(self.kernel)  # a BVH made by hand may have any kernel
        # one row stands for the triangles (checked finite at the build): dtype and kernel checks only
        checked = check_workload(
            self.kernel, origins, directions, self.triangles[:1], mode, t_max, isa, allow_nonfinite
        )
        if not isinstance(layout, str) or layout not in LAYOUTS:
            raise UserError(f"layout must be one of {', '.join(LAYOUTS)}, got {layout!r}")
        return (*checked, LAYOUTS.index(layout))

    def intersect(
        self,
        origins: np.ndarray,
        directions: np.ndarray,
        mode: Mode = "closest",
        *,
        t_max: np.ndarray | float | None = None,
        isa: str | None = None,
        allow_nonfinite: bool = False,
        layout: Layout = "wide",
    ) -> Trace:
        """Trace every ray (untimed); the arguments are :func:`intersect`'s.

        ``closest`` finds brute force's triangle with the same kernel (ties to the lowest index), up to rounding
        where two hits are within a few ulps; ``any`` stops at the first hit. With ``allow_nonfinite`` a ray with
        NaN or Inf is a miss, not traversed. Every ``layout`` (:data:`LAYOUTS`) gives the same closest hits.

        >>> import numpy as np
        >>> tri = np.array([[[0., 0, 0], [1, 0, 0], [0, 1, 0]], [[0., 0, 1], [1, 0, 1], [0, 1, 1]]])
        >>> bvh = build_bvh("moller_trumbore_fma", tri)
        >>> tr = bvh.intersect(np.array([[0.25, 0.25, 3.0]]), np.array([[0.0, 0, -1]]))
        >>> int(tr.hits.index[0]), float(tr.hits.t[0])
        (1, 2.0)
        """
        o, d, _, tm, isa, which = self._rays(origins, directions, mode, t_max, isa, allow_nonfinite, layout)
        n, dtype = len(o), self.dtype
        hits = Hits(np.empty(n, np.int64), np.empty(n, dtype), np.empty(n, dtype), np.empty(n, dtype))
        counts = np.empty((n, len(COUNT_NAMES)), np.int64)
        core_of(self.kernel).bvh_run(
            self.kernel, dtype.itemsize, MODES.index(mode), isa, which, o, d, n, tm, *self._tree(which), *hits, counts
        )
        return Trace(hits, counts)

    def time(
        self,
        origins: np.ndarray,
        directions: np.ndarray,
        mode: Mode,
        loops: int,
        *,
        t_max: np.ndarray | float | None = None,
        isa: str | None = None,
        null_leaf: bool = False,
        layout: Layout = "wide",
    ) -> TraceBatch:
        """Trace the rays ``loops`` times in C with the GIL released; time it. Inputs must be finite, and
        ``loops * len(origins)`` at most :data:`MAX_BVH_BATCH_RAYS`. ``null_leaf`` puts a compiler barrier in place
        of the leaf test: nothing is hit, so give each ray's closest ``t`` as ``t_max`` to walk as if it found it
        at once."""
        o, d, _, tm, isa, which = self._rays(origins, directions, mode, t_max, isa, False, layout)
        if isinstance(loops, bool) or not isinstance(loops, (int, np.integer)):
            raise UserTypeError(f"loops must be an int, got {type(loops).__name__}")
        if not 1 <= loops <= MAX_BVH_BATCH_RAYS // len(o):
            raise UserError(
                f"loops must be between 1 and {MAX_BVH_BATCH_RAYS // len(o)} for {len(o)} rays, got {loops}"
            )
        null_leaf = check_flag("null_leaf", null_leaf)
        elapsed, hits, tris, t_sum, uv_sum, nodes, boxes, leaves = core_of(self.kernel).bvh_time(
            self.kernel,
            self.dtype.itemsize,
            MODES.index(mode),
            isa,
            which,
            o,
            d,
            len(o),
            tm,
            *self._tree(which),
            int(loops),
            null_leaf,
        )
        return TraceBatch(elapsed, int(loops), len(o), hits, t_sum, uv_sum, nodes, boxes, leaves, tris)

    def _tree(self, layout: int) -> tuple[np.ndarray, int, np.ndarray, int, np.ndarray]:
        nodes = self.nodes if LAYOUTS[layout] == "binary" else self.wide
        return nodes, len(nodes), self.perm, self.n_slots, self.prepared.records


def _leaves(nodes: np.ndarray) -> np.ndarray:
    """(first slot, triangles) of every leaf of a node array, in node order (= slot order)."""
    pair = nodes.view(np.uint32)[:, [6, 7] if nodes.itemsize == 4 else [12, 13]].astype(np.int64)
    return pair[pair[:, 1] > 0]


#: Leaves of at most 32 triangles (two native blocks) by default: ahead of 16 and of smaller
#: leaves on every lane width, 64 not consistently ahead of 32 (docs/decisions.md, "BVH leaf size").
DEFAULT_MAX_LEAF: int = 32


def build_bvh(kernel: str, triangles: np.ndarray, *, max_leaf: int = DEFAULT_MAX_LEAF) -> BVH:
    """A BVH over finite ``triangles`` (K, 3, 3) with ``kernel``'s records at its leaves (one of
    :func:`bvh_kernel_names`), leaves of at most ``max_leaf`` (1..1024) triangles. Exactly flat triangles get
    records no ray hits, as :func:`prepare` makes them; the same input gives the same tree, bit for bit.

    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> bvh = build_bvh("moller_trumbore_fma", rng.normal(size=(1000, 3, 3)))
    >>> sorted(bvh.perm[bvh.perm >= 0].tolist()) == list(range(1000))
    True
    """
    _check_leaf_kernel(kernel)
    if isinstance(max_leaf, bool) or not isinstance(max_leaf, (int, np.integer)):
        raise UserTypeError(f"max_leaf must be an int, got {type(max_leaf).__name__}")
    if not 1 <= max_leaf <= 1024:
        raise UserError(f"max_leaf must be between 1 and 1024, got {max_leaf}")
    tris = check_array("triangles", triangles, (3, 3))
    n = len(tris)
    if n > MAX_BVH_TRIANGLES:
        raise UserError(f"a BVH takes at most {MAX_BVH_TRIANGLES} triangles, got {n}")
    nodes = np.empty((2 * n - 1, 8), dtype=tris.dtype)
    order = np.empty(n, dtype=np.int64)
    n_nodes, n_slots = _core.bvh_build(tris.itemsize, tris, n, int(max_leaf), nodes, order)
    nodes = nodes[:n_nodes].copy()
    # slot of each triangle in leaf order: its leaf's first slot + its place in the leaf
    first, count = _leaves(nodes).T
    slots = np.repeat(first, count) + np.arange(n) - np.repeat(np.cumsum(count) - count, count)
    perm = np.full(n_slots, -1, dtype=np.int64)
    perm[slots] = order
    in_slots = np.zeros((n_slots, 3, 3), dtype=tris.dtype)
    in_slots[slots] = tris[order]
    is_flat = np.ones(n_slots, dtype=np.uint8)  # padding: flat, so a miss for kernels that miss flat triangles
    is_flat[slots] = flat(tris)[order]
    info = kernel_info(kernel)
    records = np.empty((n_slots // info.lanes, info.stride, info.lanes), dtype=tris.dtype)
    core_of(kernel).prepare(kernel, tris.itemsize, in_slots, n_slots, records, is_flat)
    return _frozen_bvh(kernel, tris, nodes, perm, records, int(max_leaf))


#: Where a tree's nodes and records start: a cache line's boundary, so that no node (32, 64 or 256
#: bytes) and no 16-lane field of a leaf block straddles two lines, as in Embree's own allocations.
#: numpy gives 16 bytes; a wide node 16 bytes off its line touches 5 lines, not 4, and an AVX2 load
#: of a block's fields splits 1 in 2: 2-4% of a bounce's trace (docs/decisions.md, "Wide BVH").
LINE_BYTES = 64


def _line_aligned(a: np.ndarray, copy: bool = False) -> np.ndarray:
    """``a`` (unless ``copy``), or a copy of it starting on a :data:`LINE_BYTES` boundary."""
    if not copy and a.ctypes.data % LINE_BYTES == 0:
        return a
    raw = np.empty(a.nbytes + LINE_BYTES, dtype=np.uint8)
    start = -raw.ctypes.data % LINE_BYTES
    out = raw[start : start + a.nbytes].view(a.dtype).reshape(a.shape)
    out[...] = a
    return out


def _frozen_bvh(kernel: str, tris: np.ndarray, nodes: np.ndarray, perm: np.ndarray, records: np.ndarray, max_leaf: int):
    wide = np.empty(((len(nodes) - 1) // 2 + 1, WIDE_NODE_BYTES // nodes.itemsize), dtype=nodes.dtype)
    # copied: the trimmed array, not the room allotted for the most wide nodes a tree can have
    wide = _line_aligned(wide[: _core.bvh_widen(nodes.itemsize, nodes, len(nodes), wide)], copy=True)
    nodes, records = _line_aligned(nodes), _line_aligned(records)
    view = tris.view()
    for a in (view, nodes, perm, records, wide):
        a.flags.writeable = False
    return BVH(kernel, view, nodes, perm, Prepared(kernel, records, len(perm)), max_leaf, wide)


def adopt_bvh(
    kernel: str, triangles: np.ndarray, nodes: np.ndarray, perm: np.ndarray, records: np.ndarray, max_leaf: int
) -> BVH:
    """A :class:`BVH` from arrays made elsewhere (a cache file): a :func:`build_bvh`'s ``nodes``, ``perm`` and
    records over the same ``triangles``, ``kernel`` and ``max_leaf``. Nothing is trusted: C checks every
    structural invariant of the tree, and the records must be, bit for bit, what the kernel prepares for the
    triangles ``perm`` names. Raises :class:`~tribench.common.UserError` naming the first fault.

    >>> import numpy as np
    >>> tri = np.random.default_rng(0).normal(size=(100, 3, 3))
    >>> b = build_bvh("moller_trumbore_fma", tri)
    >>> adopt_bvh(b.kernel, tri, b.nodes, b.perm, b.prepared.records, b.max_leaf).n_nodes == b.n_nodes
    True
    """
    _check_leaf_kernel(kernel)
    if isinstance(max_leaf, bool) or not isinstance(max_leaf, (int, np.integer)) or not 1 <= max_leaf <= 1024:
        raise UserError(f"max_leaf must be an int between 1 and 1024, got {max_leaf!r}")
    tris = check_array("triangles", triangles, (3, 3))
    info = kernel_info(kernel)
    for name, a, dtype, ndim in (("nodes", nodes, tris.dtype, 2), ("perm", perm, np.dtype(np.int64), 1)):
        if not isinstance(a, np.ndarray) or a.dtype != dtype or a.ndim != ndim:
            raise UserError(f"malformed BVH: {name} must be a {ndim}-d {dtype} array")
    if nodes.shape[1:] != (8,) or not len(nodes) or not len(perm) or len(perm) % 16:
        raise UserError(
            f"malformed BVH: nodes must be (N, 8) and perm a multiple of 16 slots, got {nodes.shape}, {perm.shape}"
        )
    shape = (len(perm) // info.lanes, info.stride, info.lanes)
    if not isinstance(records, np.ndarray) or records.dtype != tris.dtype or records.shape != shape:
        raise UserError(f"malformed BVH: {kernel}'s records for {len(perm)} slots must be {tris.dtype} {shape}")
    nodes, perm, records = (np.ascontiguousarray(a) for a in (nodes, perm, records))
    try:
        _core.bvh_check(tris.itemsize, nodes, len(nodes), perm, len(perm), tris, len(tris), int(max_leaf))
    except ValueError as e:
        raise UserError(str(e)) from None
    # the records: prepared again from the triangles perm names, with the same
    # slots marked flat as the stored records say, which must be flat indeed
    slot_flat = np.isnan(records).all(axis=1).ravel()
    used = perm >= 0
    if not flat(tris[perm[used & slot_flat]]).all():
        raise UserError(f"malformed BVH: {kernel}'s records make a triangle that is not flat a miss")
    in_slots = np.zeros((len(perm), 3, 3), dtype=tris.dtype)
    in_slots[used] = tris[perm[used]]
    expected = np.empty_like(records)
    core_of(kernel).prepare(kernel, tris.itemsize, in_slots, len(perm), expected, (slot_flat | ~used).view(np.uint8))
    if not np.array_equal(expected.view(np.uint8), records.view(np.uint8)):
        raise UserError(f"malformed BVH: the records are not {kernel}'s records of the triangles its perm names")
    return _frozen_bvh(kernel, tris, nodes.copy(), perm.copy(), records.copy(), int(max_leaf))
