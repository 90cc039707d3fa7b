/* tribench._core: the kernels' CPython glue.
 *
 * Argument plumbing only: the public, documented and validated API is
 * ext/__init__.py. This layer still checks every buffer's size and alignment
 * against the counts it is given, so even a direct call with wrong arguments
 * raises instead of reading out of bounds. It keeps no state between calls.
 *
 * Arrays cross the boundary without copies through the buffer protocol.
 * Timed loops run with the GIL released, between two CLOCK_MONOTONIC reads. */

#define PY_SSIZE_T_CLEAN
#include <Python.h>

#include <math.h>
#include <stdint.h>
#include <string.h>
#include <time.h>

#define TB_CAT_(a, b) a##b
#define TB_CAT(a, b) TB_CAT_(a, b)
#define TB_STR_(x) #x
#define TB_STR(x) TB_STR_(x)

#ifndef TB_BUILD_FLAGS
#define TB_BUILD_FLAGS "unknown"
#endif

/* One batch of work for a loop: inputs, outputs, and the checksum it returns. */
typedef struct {
    const void *origins, *directions, *records;
    size_t n_rays, n_records;
    uint64_t loops;
    uint8_t *hit_out;   /* run_pairs */
    int64_t *index_out; /* run_closest */
    void *t_out;        /* run_* */
    uint64_t hits;      /* time_*: hits summed over all passes */
    double t_sum;       /* time_*: t of those hits, summed in double */
} tb_job;

#include "kernels/list.h"

#define TB_REAL float
#define TB_SUFFIX _f32
#include "kernels.h"
#undef TB_REAL
#undef TB_SUFFIX

#define TB_REAL double
#define TB_SUFFIX _f64
#include "kernels.h"
#undef TB_REAL
#undef TB_SUFFIX

/* ------------------------------------------------------------------ registry */

typedef void (*tb_loop_fn)(tb_job *);
typedef void (*tb_prepare_fn)(const void *, size_t, void *);

typedef struct {
    size_t stride; /* reals per prepared record */
    tb_prepare_fn prepare;
    tb_loop_fn run_pairs, run_closest, time_pairs, time_closest;
} tb_variant;

typedef struct {
    const char *name;
    int internal; /* from TB_INTERNAL_KERNEL_LIST: hidden from the user's list */
    tb_variant f32, f64;
} tb_kernel;

#define TB_VARIANT(name, suffix)                                        \
    {                                                                   \
        tb_##name##_stride,                             \
            (tb_prepare_fn)TB_CAT(tb_##name##_prepare, suffix),         \
            TB_CAT(tb_##name##_run_pairs, suffix),                      \
            TB_CAT(tb_##name##_run_closest, suffix),                    \
            TB_CAT(tb_##name##_time_pairs, suffix),                     \
            TB_CAT(tb_##name##_time_closest, suffix),                   \
    }
#define TB_ENTRY(name) {#name, 0, TB_VARIANT(name, _f32), TB_VARIANT(name, _f64)},
#define TB_INTERNAL_ENTRY(name) {#name, 1, TB_VARIANT(name, _f32), TB_VARIANT(name, _f64)},

static const tb_kernel tb_kernels[] = {TB_KERNEL_LIST(TB_ENTRY) TB_INTERNAL_KERNEL_LIST(TB_INTERNAL_ENTRY)};
static const size_t tb_n_kernels = sizeof tb_kernels / sizeof tb_kernels[0];

/* The variant for a kernel name and an item size (4 or 8), or NULL with a
 * Python exception set. */
static const tb_variant *tb_lookup(const char *name, Py_ssize_t itemsize)
{
    for (size_t i = 0; i < tb_n_kernels; ++i)
        if (strcmp(tb_kernels[i].name, name) == 0) {
            if (itemsize == 4)
                return &tb_kernels[i].f32;
            if (itemsize == 8)
                return &tb_kernels[i].f64;
            PyErr_Format(PyExc_ValueError, "itemsize must be 4 or 8, got %zd", itemsize);
            return NULL;
        }
    PyErr_Format(PyExc_ValueError, "unknown kernel '%s'", name);
    return NULL;
}

/* ----------------------------------------------------------- buffer checks */

/* Checks that `buf` holds exactly `count` items of `itemsize` bytes, aligned. */
static int tb_check_buffer(const Py_buffer *buf, const char *what, Py_ssize_t count,
                           Py_ssize_t itemsize)
{
    if (count < 0 || count > PY_SSIZE_T_MAX / itemsize) {
        PyErr_Format(PyExc_ValueError, "%s: count %zd out of range", what, count);
        return -1;
    }
    if (buf->len != count * itemsize) {
        PyErr_Format(PyExc_ValueError, "%s: buffer has %zd bytes, expected %zd", what,
                     buf->len, count * itemsize);
        return -1;
    }
    if ((uintptr_t)buf->buf % (uintptr_t)itemsize != 0) {
        PyErr_Format(PyExc_ValueError, "%s: buffer is not aligned to %zd bytes", what,
                     itemsize);
        return -1;
    }
    return 0;
}

/* Largest count such that count * factor does not overflow Py_ssize_t. */
static int tb_check_count(const char *what, Py_ssize_t n, Py_ssize_t factor)
{
    if (n < 1 || n > PY_SSIZE_T_MAX / 64 / factor) {
        PyErr_Format(PyExc_ValueError, "%s must be at least 1 and not absurdly large, got %zd",
                     what, n);
        return -1;
    }
    return 0;
}

static int64_t tb_now_ns(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (int64_t)ts.tv_sec * 1000000000 + ts.tv_nsec;
}

#include "fma_peak.h"

/* ------------------------------------------------------------- entry points */

/* kernel_names(internal=False): registry order, internal kernels only if asked */
static PyObject *py_kernel_names(PyObject *Py_UNUSED(self), PyObject *args)
{
    int internal = 0;
    if (!PyArg_ParseTuple(args, "|p:kernel_names", &internal))
        return NULL;
    PyObject *names = PyList_New(0);
    if (!names)
        return NULL;
    for (size_t i = 0; i < tb_n_kernels; ++i) {
        if (tb_kernels[i].internal && !internal)
            continue;
        PyObject *s = PyUnicode_FromString(tb_kernels[i].name);
        if (!s || PyList_Append(names, s) < 0) {
            Py_XDECREF(s);
            Py_DECREF(names);
            return NULL;
        }
        Py_DECREF(s);
    }
    PyObject *tuple = PyList_AsTuple(names);
    Py_DECREF(names);
    return tuple;
}

static PyObject *py_stride(PyObject *Py_UNUSED(self), PyObject *args)
{
    const char *name;
    if (!PyArg_ParseTuple(args, "s:stride", &name))
        return NULL;
    const tb_variant *v = tb_lookup(name, 8);
    return v ? PyLong_FromSize_t(v->stride) : NULL;
}

/* prepare(name, itemsize, vertices, n, out) */
static PyObject *py_prepare(PyObject *Py_UNUSED(self), PyObject *args)
{
    const char *name;
    Py_ssize_t itemsize, n;
    Py_buffer vertices = {0}, out = {0};
    PyObject *result = NULL;
    if (!PyArg_ParseTuple(args, "sny*nw*:prepare", &name, &itemsize, &vertices, &n, &out))
        return NULL;
    const tb_variant *v = tb_lookup(name, itemsize);
    if (!v || tb_check_count("n", n, 16) || tb_check_buffer(&vertices, "vertices", 9 * n, itemsize) ||
        tb_check_buffer(&out, "out", (Py_ssize_t)v->stride * n, itemsize))
        goto done;
    Py_BEGIN_ALLOW_THREADS
    v->prepare(vertices.buf, (size_t)n, out.buf);
    Py_END_ALLOW_THREADS
    result = Py_NewRef(Py_None);
done:
    PyBuffer_Release(&vertices);
    PyBuffer_Release(&out);
    return result;
}

/* Checks the inputs shared by every loop entry point and fills `job`. */
static const tb_variant *tb_parse_job(const char *name, Py_ssize_t itemsize, int closest, Py_buffer *o,
                                      Py_buffer *d, Py_ssize_t n_rays, Py_buffer *rec,
                                      Py_ssize_t n_records, tb_job *job)
{
    if (!closest && n_rays != n_records) {
        PyErr_Format(PyExc_ValueError, "pairs need as many records as rays, got %zd and %zd",
                     n_records, n_rays);
        return NULL;
    }
    const tb_variant *v = tb_lookup(name, itemsize);
    if (!v || tb_check_count("n_rays", n_rays, 16) || tb_check_count("n_records", n_records, 16) ||
        tb_check_buffer(o, "origins", 3 * n_rays, itemsize) ||
        tb_check_buffer(d, "directions", 3 * n_rays, itemsize) ||
        tb_check_buffer(rec, "records", (Py_ssize_t)v->stride * n_records, itemsize))
        return NULL;
    memset(job, 0, sizeof *job);
    job->origins = o->buf;
    job->directions = d->buf;
    job->records = rec->buf;
    job->n_rays = (size_t)n_rays;
    job->n_records = (size_t)n_records;
    job->loops = 1;
    return v;
}

/* run(name, itemsize, closest, origins, directions, n_rays, records, n_records,
 *     hit_or_index_out, t_out): closest = 0 writes uint8 hits, 1 int64 indices */
static PyObject *py_run(PyObject *Py_UNUSED(self), PyObject *args)
{
    const char *name;
    Py_ssize_t itemsize, n_rays, n_records;
    int closest;
    Py_buffer o = {0}, d = {0}, rec = {0}, first = {0}, t_out = {0};
    PyObject *result = NULL;
    tb_job job;
    if (!PyArg_ParseTuple(args, "snpy*y*ny*nw*w*:run", &name, &itemsize, &closest, &o, &d,
                          &n_rays, &rec, &n_records, &first, &t_out))
        return NULL;
    const tb_variant *v = tb_parse_job(name, itemsize, closest, &o, &d, n_rays, &rec, n_records, &job);
    if (!v)
        goto done;
    if (tb_check_buffer(&first, closest ? "index_out" : "hit_out", n_rays, closest ? 8 : 1) ||
        tb_check_buffer(&t_out, "t_out", n_rays, itemsize))
        goto done;
    job.t_out = t_out.buf;
    if (closest)
        job.index_out = first.buf;
    else
        job.hit_out = first.buf;
    Py_BEGIN_ALLOW_THREADS
    (closest ? v->run_closest : v->run_pairs)(&job);
    Py_END_ALLOW_THREADS
    result = Py_NewRef(Py_None);
done:
    PyBuffer_Release(&o);
    PyBuffer_Release(&d);
    PyBuffer_Release(&rec);
    PyBuffer_Release(&first);
    PyBuffer_Release(&t_out);
    return result;
}

/* time(name, itemsize, closest, origins, directions, n_rays, records, n_records,
 *      loops) -> (elapsed_ns, hits, t_sum) */
static PyObject *py_time(PyObject *Py_UNUSED(self), PyObject *args)
{
    const char *name;
    Py_ssize_t itemsize, n_rays, n_records;
    long long loops;
    int closest;
    Py_buffer o = {0}, d = {0}, rec = {0};
    PyObject *result = NULL;
    tb_job job;
    if (!PyArg_ParseTuple(args, "snpy*y*ny*nL:time", &name, &itemsize, &closest, &o, &d,
                          &n_rays, &rec, &n_records, &loops))
        return NULL;
    const tb_variant *v = tb_parse_job(name, itemsize, closest, &o, &d, n_rays, &rec, n_records, &job);
    if (!v)
        goto done;
    if (loops < 1) {
        PyErr_Format(PyExc_ValueError, "loops must be at least 1, got %lld", loops);
        goto done;
    }
    job.loops = (uint64_t)loops;
    tb_loop_fn loop = closest ? v->time_closest : v->time_pairs;
    int64_t start, stop;
    Py_BEGIN_ALLOW_THREADS
    start = tb_now_ns();
    loop(&job);
    stop = tb_now_ns();
    Py_END_ALLOW_THREADS
    result = Py_BuildValue("LKd", (long long)(stop - start), (unsigned long long)job.hits,
                           job.t_sum);
done:
    PyBuffer_Release(&o);
    PyBuffer_Release(&d);
    PyBuffer_Release(&rec);
    return result;
}

/* fma_peak(iterations, force_scalar) -> (flops, elapsed_ns, isa, sink) */
static PyObject *py_fma_peak(PyObject *Py_UNUSED(self), PyObject *args)
{
    long long iterations;
    int force_scalar = 0;
    if (!PyArg_ParseTuple(args, "L|p:fma_peak", &iterations, &force_scalar))
        return NULL;
    if (iterations < 1) {
        PyErr_Format(PyExc_ValueError, "iterations must be at least 1, got %lld", iterations);
        return NULL;
    }
    tb_peak r;
    Py_BEGIN_ALLOW_THREADS
    r = tb_fma_peak((uint64_t)iterations, force_scalar);
    Py_END_ALLOW_THREADS
    return Py_BuildValue("dLsd", r.flops, (long long)r.elapsed_ns, r.isa, r.sink);
}

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
    {"stride", py_stride, METH_VARARGS, "stride(name): reals per prepared triangle."},
    {"prepare", py_prepare, METH_VARARGS,
     "prepare(name, itemsize, vertices, n, out): fill a kernel's records."},
    {"run", py_run, METH_VARARGS,
     "run(name, itemsize, closest, o, d, n_rays, records, n_records, first_out, t_out)."},
    {"time", py_time, METH_VARARGS,
     "time(name, itemsize, closest, o, d, n_rays, records, n_records, loops) -> "
     "(elapsed_ns, hits, t_sum)."},
    {"build_info", py_build_info, METH_NOARGS, "Compiler, flags and clock of this build."},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef tb_module = {
    PyModuleDef_HEAD_INIT,
    .m_name = "_core",
    .m_doc = "Ray-triangle kernels (private: use tribench.ext).",
    .m_size = -1,
    .m_methods = tb_methods,
};

PyMODINIT_FUNC PyInit__core(void)
{
    return PyModule_Create(&tb_module);
}
