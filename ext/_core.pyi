# Types of the C module tribench.ext._core (ext/*.c) for mypy; only tribench.ext calls it.
# Keep in step with tb_methods in ext/_core.c and the PyArg_ParseTuple formats of its functions.
from typing import Any

import numpy as np

# the buffers are numpy arrays (any C-contiguous buffer would do, but numpy's
# stubs give ndarray the buffer protocol only from Python 3.12 on)
_In = np.ndarray
_Out = np.ndarray

MAX_BATCH_TESTS: int
MAX_PEAK_ITERATIONS: int
POLL_NS: int
MAX_BVH_BATCH_RAYS: int
MAX_BVH_TRIANGLES: int
BVH_BUILD_VERSION: int

def kernel_names(internal: bool = ..., /) -> tuple[str, ...]: ...
def kernel_info(name: str, /) -> dict[str, Any]: ...
def build_info() -> dict[str, Any]: ...
def prepare(name: str, itemsize: int, vertices: _In, n: int, out: _Out, flat: _In, /) -> None: ...
def run(
    name: str,
    itemsize: int,
    mode: int,
    isa: str,
    o: _In,
    d: _In,
    n_rays: int,
    t_max: _In,
    records: _In,
    n_records: int,
    index_out: _Out,
    t_out: _Out,
    u_out: _Out,
    v_out: _Out,
    /,
) -> None: ...
def time(
    name: str,
    itemsize: int,
    mode: int,
    isa: str,
    o: _In,
    d: _In,
    n_rays: int,
    t_max: _In,
    records: _In,
    n_records: int,
    loops: int,
    /,
) -> tuple[int, int, int, float, float]: ...
def fma_peak(iterations: int, force_scalar: bool = ..., /) -> tuple[float, int, str, float]: ...
def kernel_mix(name: str, /) -> tuple[int, int, int, int, int, int]: ...
def op_probe(isa: str, itemsize: int, op: str, steps: int, /) -> tuple[float, int, float]: ...
def probe_isas() -> tuple[tuple[str, bool], ...]: ...
def op_classes() -> tuple[str, ...]: ...
def bvh_kernels() -> tuple[str, ...]: ...
def bvh_build(
    itemsize: int, vertices: _In, n: int, max_leaf: int, nodes_out: _Out, order_out: _Out, /
) -> tuple[int, int]: ...
def bvh_check(
    itemsize: int, nodes: _In, n_nodes: int, perm: _In, n_slots: int, vertices: _In, n: int, max_leaf: int, /
) -> None: ...
def bvh_widen(itemsize: int, nodes: _In, n_nodes: int, wide_out: _Out, /) -> int: ...
def bvh_run(
    name: str,
    itemsize: int,
    mode: int,
    isa: str,
    layout: int,
    o: _In,
    d: _In,
    n_rays: int,
    t_max: _In,
    nodes: _In,
    n_nodes: int,
    perm: _In,
    n_slots: int,
    records: _In,
    index_out: _Out,
    t_out: _Out,
    u_out: _Out,
    v_out: _Out,
    counts_out: _Out,
    /,
) -> None: ...
def bvh_time(
    name: str,
    itemsize: int,
    mode: int,
    isa: str,
    layout: int,
    o: _In,
    d: _In,
    n_rays: int,
    t_max: _In,
    nodes: _In,
    n_nodes: int,
    perm: _In,
    n_slots: int,
    records: _In,
    loops: int,
    null: bool,
    /,
) -> tuple[int, int, int, float, float, int, int, int]: ...
