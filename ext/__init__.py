"""Ray-triangle intersection kernels in C, behind a validated Python API: every input is checked before C
sees it, so none can crash the process (docs/architecture.md, "The C extension from Python").

A kernel is named in one place, ``ext/kernels/list.h`` (what each is: docs/kernels.md); the internal ones,
the harness's honesty checks, are listed only by ``kernel_names(internal=True)``. Only hits with
``0 < t < t_max`` count; the clean kernels' conventions are ``tribench.workloads.reference``'s. This package
may import ``tribench.common`` only and re-exports its modules' public names; each module imports only those
before it in ``checks``, ``registry``, ``intersection``, ``timing``, ``probes``, ``bvh``, ``toolchain``,
``kernel_files``, ``builds``, over ``_core`` (the C module).

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
