/* tribench._core: the kernels' CPython glue.
 *
 * Argument plumbing only: the public, documented and validated API is
 * ext/__init__.py. This layer still checks every buffer's size and alignment
 * against the counts it is given, so even a direct call with wrong arguments
 * raises instead of reading out of bounds. It keeps no state between calls.
 *
 * Arrays cross the boundary without copies through the buffer protocol.
 * Timed loops run with the GIL released, between two CLOCK_MONOTONIC reads;
 * every loop looks for a pending signal (Ctrl-C) about every 0.1 s (tb_poll).
 *
 * This file is the module: its method table, build_info and PyInit__core.
 * The functions are in the other files of the module (core.h lists them). */

#include "core.h"

/* The module's name: _core, or a kernel file's build's own (ext/kernel_files.py),
 * so that both load in one process. */
#ifndef TB_MODULE_NAME
#define TB_MODULE_NAME _core
#endif
#ifndef TB_FILE_CITATION
#define TB_FILE_CITATION "" /* a kernel file's paper (kernels/list.h) */
#endif

#ifndef TB_BUILD_FLAGS
#define TB_BUILD_FLAGS "unknown"
#endif

static PyObject *py_build_info(PyObject *Py_UNUSED(self), PyObject *Py_UNUSED(unused))
{
    struct timespec res;
    clock_getres(CLOCK_MONOTONIC, &res);
    int fast_math = 0, fp_fast_fma = 0, avx2 = 0;
#ifdef __FAST_MATH__
    fast_math = 1;
#endif
#ifdef __FP_FAST_FMA
    fp_fast_fma = 1;
#endif
#ifdef __AVX2__
    avx2 = 1;
#endif
    return Py_BuildValue("{s:s,s:s,s:O,s:O,s:O,s:L}",
#if defined(__clang__)
                         "compiler", "clang " __clang_version__,
#elif defined(__GNUC__)
                         "compiler", "gcc " __VERSION__,
#else
                         "compiler", "unknown",
#endif
                         "flags", TB_BUILD_FLAGS,
                         "fast_math", fast_math ? Py_True : Py_False,
                         "fp_fast_fma", fp_fast_fma ? Py_True : Py_False,
                         "baseline_avx2", avx2 ? Py_True : Py_False,
                         "clock_resolution_ns",
                         (long long)res.tv_sec * 1000000000 + res.tv_nsec);
}

static PyMethodDef tb_methods[] = {
    {"kernel_names", py_kernel_names, METH_VARARGS,
     "kernel_names(internal=False): registered kernel names."},
    {"fma_peak", py_fma_peak, METH_VARARGS,
     "fma_peak(iterations, force_scalar=False) -> (flops, elapsed_ns, isa, sink)."},
    {"kernel_mix", py_kernel_mix, METH_VARARGS,
     "kernel_mix(name) -> (fma, mul, add, cmp, div, logic) operations per test."},
    {"op_probe", py_op_probe, METH_VARARGS,
     "op_probe(isa, itemsize, op, steps) -> (lane_ops, elapsed_ns, sink): one throughput probe."},
    {"probe_isas", py_probe_isas, METH_NOARGS, "probe_isas() -> ((isa, runnable), ...), best first."},
    {"op_classes", py_op_classes, METH_NOARGS, "op_classes() -> the probes' operation classes."},
    {"kernel_info", py_kernel_info, METH_VARARGS,
     "kernel_info(name) -> dict: the registry's declarations of a kernel."},
    {"prepare", py_prepare, METH_VARARGS,
     "prepare(name, itemsize, vertices, n, out, flat): fill a kernel's records."},
    {"run", py_run, METH_VARARGS,
     "run(name, itemsize, mode, isa, o, d, n_rays, t_max, records, n_records, index_out, "
     "t_out, u_out, v_out)."},
    {"time", py_time, METH_VARARGS,
     "time(name, itemsize, mode, isa, o, d, n_rays, t_max, records, n_records, loops) -> "
     "(elapsed_ns, hits, tests, t_sum, uv_sum)."},
    {"build_info", py_build_info, METH_NOARGS, "Compiler, flags and clock of this build."},
    {"bvh_kernels", py_bvh_kernels, METH_NOARGS, "bvh_kernels() -> kernels a BVH takes as leaf test."},
    {"bvh_build", py_bvh_build, METH_VARARGS,
     "bvh_build(itemsize, vertices, n, max_leaf, nodes_out, order_out) -> (n_nodes, n_slots)."},
    {"bvh_check", py_bvh_check, METH_VARARGS,
     "bvh_check(itemsize, nodes, n_nodes, perm, n_slots, vertices, n, max_leaf): raise on a malformed tree."},
    {"bvh_widen", py_bvh_widen, METH_VARARGS, "bvh_widen(itemsize, nodes, n_nodes, wide_out) -> n_wide."},
    {"bvh_run", py_bvh_run, METH_VARARGS,
     "bvh_run(name, itemsize, mode, isa, layout, o, d, n_rays, t_max, nodes, n_nodes, perm, n_slots, records, "
     "index_out, t_out, u_out, v_out, counts_out)."},
    {"bvh_time", py_bvh_time, METH_VARARGS,
     "bvh_time(name, itemsize, mode, isa, layout, o, d, n_rays, t_max, nodes, n_nodes, perm, n_slots, records, "
     "loops, null) -> (elapsed_ns, hits, triangle_tests, t_sum, uv_sum, nodes_visited, box_tests, leaves)."},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef tb_module = {
    PyModuleDef_HEAD_INIT,
    .m_name = TB_STR(TB_MODULE_NAME),
    .m_doc = "Ray-triangle kernels (private: use tribench.ext).",
    .m_size = -1,
    .m_methods = tb_methods,
};

PyMODINIT_FUNC TB_CAT(PyInit_, TB_MODULE_NAME)(void)
{
    PyObject *m = PyModule_Create(&tb_module);
    const char *names[] = {"MAX_BATCH_TESTS", "MAX_PEAK_ITERATIONS", "POLL_NS", "MAX_BVH_BATCH_RAYS",
                           "MAX_BVH_TRIANGLES", "BVH_BUILD_VERSION"};
    const long long values[] = {TB_MAX_BATCH_TESTS, TB_MAX_PEAK_ITERATIONS, TB_POLL_NS, TB_MAX_BVH_BATCH_RAYS,
                                TB_MAX_BVH_TRIANGLES, tb_bvh_build_version};
    for (int i = 0; m && i < 6; ++i) {
        PyObject *value = PyLong_FromLongLong(values[i]);
        if (!value || PyModule_AddObjectRef(m, names[i], value) < 0)
            Py_CLEAR(m);
        Py_XDECREF(value);
    }
    if (m && PyModule_AddStringConstant(m, "FILE_CITATION", TB_FILE_CITATION) < 0)
        Py_CLEAR(m);
    return m;
}
