"""Ray-triangle intersection kernels in C, behind a validated Python API.

Every array is checked here (type, dtype, shape, contiguity, alignment,
finiteness, emptiness) before the compiled module sees it, and the compiled
module checks buffer sizes again, so no input from Python can crash the
process. Precision follows the arrays: all float32 or all float64.

Kernels (see ``kernel_names()``; each C file's header cites its paper):

* ``curless_seed``, ``moller_seed``: the seed paper's two tests, as its code
  wrote them (absolute epsilons 1e-4, divide-first Moller, stored unit normal
  and strict edges for Curless);
* ``curless``, ``moller_trumbore``: clean versions (no absolute epsilon,
  late division, closed triangles);
* ``moller_trumbore_cull`` (back faces culled), ``baldwin_weber_12`` and
  ``baldwin_weber_9`` (Baldwin & Weber 2016, 12- and 9-float storage),
  ``havel_herout`` (Havel & Herout 2010), ``woop`` (Woop, Benthin & Wald
  2013, watertight), ``plucker`` (origin-shifted Pluecker tests);
* ``<name>_x8``: the wide form of a kernel (branchless, one ray against
  blocks of 8 triangles stored structure of arrays), compiled for several
  instruction sets and run with the best one this CPU has (see
  ``kernel_info``; ``TRIBENCH_ISA=baseline`` forces the build's baseline);
* ``moller_trumbore_fma`` and ``moller_trumbore_fma_exit``: native wide
  kernels (no scalar form): Moller-Trumbore at the widest vector the CPU
  has (16 float lanes with AVX-512, 8 with AVX2 + FMA), fused
  multiply-adds, stored edges, blocks of 16 triangles; held to the
  reference with an error bound, not bit for bit to ``moller_trumbore``;
* ``woop_fma``: ``woop`` as a native wide kernel, watertight as ``woop``
  (the shear and the scaled t fused, the edge functions not, a 0 edge
  function recomputed exactly), leaving a vector when no lane is inside all
  three edges; held to the reference with the same error bound;
* ``baldwin_weber_12_fma`` and ``baldwin_weber_9_fma``: Baldwin & Weber
  as native wide kernels, fused, on the scalar forms' records, branchless
  (an exit after the u test mispredicted more than it saved); held to the
  reference with their own bound;
* ``havel_herout_fma`` and ``plucker_fma``: the same treatment of Havel &
  Herout (its 12-real planes, branchless) and of the Plucker test
  (vertices, edges and normal stored, early exit after the edge tests).

Internal kernels, for the harness's honesty checks (listed only by
``kernel_names(internal=True)``, accepted everywhere a kernel name is):

* ``moller_trumbore_aa``, ``moller_seed_aa``: identical copies of
  ``moller_trumbore`` and ``moller_seed`` under other names, each with code
  of its own (A/A calibration; the main job's margin);
* ``moller_trumbore_same``: ``moller_trumbore``'s own code under another
  name (a cost ratio of exactly 1, for checking the intervals);
* ``moller_trumbore_twice``: ``moller_trumbore`` doing every test twice (a
  known 2x effect);
* ``moller_trumbore_yardstick``: a plain AVX2 intrinsics Moller-Trumbore
  (AVX2 only), the yardstick of ``bench/yardstick.py``.

``fma_peak()`` measures the core's arithmetic peak with a short loop of
independent 8-lane FMAs.

Modes (what a call answers per ray): ``pairs`` (ray i against triangle i),
``any`` (some hit, as shadow rays ask), ``closest`` (the closest hit's t),
``closest_uv`` (its t, u, v). Every ray may carry a ``t_max``: only hits
with ``0 < t < t_max`` count. A miss has index ``-1`` and ``t = u = v =
nan``. Conventions of the clean kernels match ``tribench.workloads.reference``.

``tribench.ext`` owns the kernels, their registration and the checked C
boundary. It may import ``tribench.common`` only: it knows nothing of
workloads, statistics or run folders.

The modules, by job (this package re-exports every public name): ``checks``
(argument and array checks), ``registry`` (kernel names, :class:`KernelInfo`,
modes, build), ``intersection`` (:func:`prepare`, :func:`flat`,
:func:`intersect`), ``timing`` (:func:`make_job`, :func:`time_batch`),
``probes`` (:func:`fma_peak`, :func:`op_throughput`), ``bvh``
(:func:`build_bvh`, :class:`BVH`, :func:`adopt_bvh`) and ``kernel_files``
(:func:`load_kernels`: a user's kernel file compiled as the built-in kernels
are, into a module of its own beside ``_core``, by ``toolchain``) and
``builds`` (:func:`use_build`: the built-in kernels compiled by another
compiler or with other flags), over ``_core``, the C module. Each imports
only modules listed before it, never this package.

Examples
--------
>>> import numpy as np
>>> tri = np.array([[[0., 0, 0], [1, 0, 0], [0, 1, 0]]])
>>> hit, t = intersect_pairs("moller_trumbore", np.array([[0.25, 0.25, 1.0]]),
...                          np.array([[0.0, 0, -1]]), tri)
>>> bool(hit[0]), float(t[0])
(True, 1.0)
"""

from __future__ import annotations

from ..common import UserError, UserTypeError
from .builds import INSTALLED, BuildError, build_record, check_builds, load_build, parse_builds, use_build
from .bvh import (
    BVH,
    BVH_BUILD_VERSION,
    COUNT_NAMES,
    DEFAULT_MAX_LEAF,
    LAYOUTS,
    MAX_BVH_BATCH_RAYS,
    MAX_BVH_TRIANGLES,
    Trace,
    TraceBatch,
    adopt_bvh,
    build_bvh,
    bvh_kernel_names,
)
from .intersection import Hits, Prepared, flat, intersect, intersect_closest, intersect_pairs, prepare
from .kernel_files import KernelFile, KernelFileError, kernel_file_of, load_kernels, loaded_kernel_files
from .probes import MAX_PEAK_ITERATIONS, OP_CLASSES, OpThroughput, Peak, fma_peak, op_throughput, probe_isas
from .registry import (
    MODES,
    KernelInfo,
    Mode,
    build_info,
    bytes_per_triangle,
    extension_sha256,
    kernel_info,
    kernel_names,
)
from .timing import MAX_BATCH_TESTS, Batch, Job, make_job, time_batch

__all__ = [
    "INSTALLED",
    "BuildError",
    "build_record",
    "check_builds",
    "load_build",
    "parse_builds",
    "use_build",
    "MAX_BATCH_TESTS",
    "MAX_PEAK_ITERATIONS",
    "MODES",
    "Batch",
    "Hits",
    "Job",
    "KernelFile",
    "KernelFileError",
    "KernelInfo",
    "Peak",
    "Prepared",
    "UserError",
    "UserTypeError",
    "Mode",
    "build_info",
    "extension_sha256",
    "BVH",
    "COUNT_NAMES",
    "MAX_BVH_BATCH_RAYS",
    "MAX_BVH_TRIANGLES",
    "BVH_BUILD_VERSION",
    "LAYOUTS",
    "Trace",
    "TraceBatch",
    "adopt_bvh",
    "build_bvh",
    "DEFAULT_MAX_LEAF",
    "bvh_kernel_names",
    "bytes_per_triangle",
    "flat",
    "fma_peak",
    "OP_CLASSES",
    "OpThroughput",
    "op_throughput",
    "probe_isas",
    "intersect",
    "intersect_closest",
    "intersect_pairs",
    "kernel_file_of",
    "kernel_info",
    "kernel_names",
    "load_kernels",
    "loaded_kernel_files",
    "make_job",
    "prepare",
    "time_batch",
]
