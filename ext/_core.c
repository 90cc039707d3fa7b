/* tribench._core: the kernels' CPython glue.
 *
 * Argument plumbing only: the public, documented and validated API is
 * ext/__init__.py. This layer still checks every buffer's size and alignment
 * against the counts it is given, so even a direct call with wrong arguments
 * raises instead of reading out of bounds. It keeps no state between calls.
 *
 * Arrays cross the boundary without copies through the buffer protocol.
 * Timed loops run with the GIL released, between two CLOCK_MONOTONIC reads;
 * every loop looks for a pending signal (Ctrl-C) about every 0.1 s (tb_poll). */

#define PY_SSIZE_T_CLEAN
#include <Python.h>

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <stdint.h>
#include <string.h>
#include <time.h>
#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
#endif

#define TB_CAT_(a, b) a##b
#define TB_CAT(a, b) TB_CAT_(a, b)
#define TB_STR_(x) #x
#define TB_STR(x) TB_STR_(x)

#ifndef TB_BUILD_FLAGS
#define TB_BUILD_FLAGS "unknown"
#endif

/* What a loop answers per ray: pairs (ray i against triangle i), any hit,
 * the closest hit's t, or the closest hit's t, u and v. */
enum { TB_PAIRS, TB_ANY, TB_CLOSEST, TB_CLOSEST_UV, TB_N_MODES };
static const char *const tb_mode_names[TB_N_MODES] = {"pairs", "any", "closest", "closest_uv"};

/* What prepare does with an exactly flat triangle (see kernels.h, tb_<name>_flat). */
enum { TB_FLAT_AS_IS, TB_FLAT_MISS };

/* One batch of work for a loop: inputs, outputs, and the checksum it returns. */
typedef struct {
    const void *origins, *directions, *records;
    const void *t_max; /* per ray: hits must have t < t_max (may be +inf) */
    size_t n_rays, n_records;
    uint64_t loops;
    int64_t *index_out;                /* run: triangle hit, -1 on a miss */
    void *t_out, *u_out, *v_out;       /* run: NaN on a miss */
    uint64_t hits, tests;              /* time: hits and tests summed over all passes */
    double t_sum, uv_sum;              /* time: their t, and u + v (closest_uv), in double */
    PyThreadState *thread;             /* the caller's, while the loop runs without the GIL */
    int64_t start_ns, polled_ns;       /* when the loop started, and last looked for a signal */
    int interrupted;                   /* a signal handler raised: the loop stopped early */
} tb_job;

static int64_t tb_now_ns(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (int64_t)ts.tv_sec * 1000000000 + ts.tv_nsec;
}

/* How often a loop looks for a pending signal. */
#define TB_POLL_NS 100000000 /* 0.1 s */

/* Called by a loop (GIL released) after `rays` rays, when it asked to be:
 * once TB_POLL_NS have passed since the last look, takes the GIL back for
 * Python's signal handlers (a Ctrl-C raises KeyboardInterrupt there) and
 * releases it again. Returns the ray count at which to be called next, or 0
 * to stop (job->interrupted set, the handler's exception pending). Calls
 * come at rays 1, 2, 4, 8, ... until TB_POLL_NS have passed, then about
 * twice per TB_POLL_NS: a batch of the harness's length (~8 ms) reads the
 * clock some 20 times and never takes the GIL. */
static uint64_t tb_poll(tb_job *job, uint64_t rays)
{
    int64_t now = tb_now_ns();
    if (now - job->polled_ns >= TB_POLL_NS) {
        job->polled_ns = now;
        PyEval_RestoreThread(job->thread);
        int failed = PyErr_CheckSignals();
        job->thread = PyEval_SaveThread();
        if (failed) {
            job->interrupted = 1;
            return 0;
        }
    }
    int64_t elapsed = now - job->start_ns;
    if (elapsed < TB_POLL_NS)
        return 2 * rays;
    double rays_per_ns = (double)rays / (double)elapsed;
    return rays + 1 + (uint64_t)(rays_per_ns * (TB_POLL_NS / 2));
}

/* The longest timed batch: TB_MAX_BATCH_TESTS tests take a minute even at
 * 0.1 ns per test (the fastest kernels here take about 1 ns), and a
 * harness batch is about 8 ms; more is a mistake, refused up front. */
#define TB_MAX_BATCH_TESTS 600000000000LL
/* The most FMA-peak iterations: about a second on this project's machines,
 * AVX2 or scalar (200 000, the default, take under 1 ms). The probe does not
 * poll for Ctrl-C, so this bound is what keeps it interruptible within about
 * a second. */
#define TB_MAX_PEAK_ITERATIONS (1LL << 28)

#include "kernels/list.h"

#define TB_REAL float
#define TB_REAL_IS_DOUBLE 0
#define TB_SUFFIX _f32
#include "kernels.h"
#undef TB_REAL
#undef TB_REAL_IS_DOUBLE
#undef TB_SUFFIX

#define TB_REAL double
#define TB_REAL_IS_DOUBLE 1
#define TB_SUFFIX _f64
#include "kernels.h"
#undef TB_REAL
#undef TB_REAL_IS_DOUBLE
#undef TB_SUFFIX

/* ------------------------------------------------------------------ registry */

typedef void (*tb_loop_fn)(tb_job *);
typedef void (*tb_prepare_fn)(const void *, size_t, void *);

#define TB_MAX_ISAS 3
static const char *const tb_isa_names[] = TB_ISA_NAMES;
static const char *const tb_scalar_isa_names[] = {"scalar"};

/* A kernel's loops for one ISA: untimed (run) and timed (time) per mode;
 * NULL where the form has no such mode (wide kernels have no pairs). */
typedef struct {
    tb_loop_fn run[TB_N_MODES], time[TB_N_MODES];
} tb_loops;

typedef struct {
    tb_prepare_fn prepare; /* the scalar record layout; wide kernels transpose it */
    tb_loops isa[TB_MAX_ISAS];
} tb_variant;

/* One registered kernel: what the registration line in kernels/list.h
 * declares, what its file defines (stride, ops, flat), and its loops. */
typedef struct {
    const char *name;
    const char *scalar_form; /* a wide form: the kernel it is the wide form of; else NULL */
    const char *algorithm;   /* the clean scalar kernel whose algorithm this is a form of (itself
                                for a scalar kernel; a native kernel declares tb_<name>_algorithm) */
    int internal;            /* from TB_INTERNAL_KERNEL_LIST: hidden from the user's list */
    int faces;               /* TB_BOTH_FACES or TB_FRONT_FACES (back faces culled) */
    int watertight;          /* TB_OPEN or TB_WATERTIGHT */
    const char *promised_by; /* the paper that promises watertightness ("" if none) */
    int origin;              /* TB_CLEAN or TB_SEED_REPLAY */
    int flat;     /* TB_FLAT_MISS or TB_FLAT_AS_IS (kernels.h: tb_<name>_flat) */
    int lanes;    /* triangles per record block: 1 scalar early-exit form; 8 an _x8 form;
                     16 a native form (native.h; one vector's worth per ISA) */
    int fma;      /* its AVX2 loops use FMA too (native forms) */
    size_t stride; /* reals per prepared triangle */
    int ops;       /* arithmetic operations per test (and lane), see kernels.h */
    int n_isas;
    const char *const *isa_names;
    tb_variant f32, f64;
} tb_kernel;

#define TB_SCALAR_LOOPS(name, sfx)                                                           \
    {{{TB_CAT(tb_##name##_run_pairs, sfx), TB_CAT(tb_##name##_run_any, sfx),                 \
       TB_CAT(tb_##name##_run_closest, sfx), TB_CAT(tb_##name##_run_closest, sfx)},          \
      {TB_CAT(tb_##name##_time_pairs, sfx), TB_CAT(tb_##name##_time_any, sfx),               \
       TB_CAT(tb_##name##_time_closest, sfx), TB_CAT(tb_##name##_time_closest_uv, sfx)}}}
#define TB_SCALAR_ENTRY_(name, internal, faces, watertight, promised_by, origin)             \
    {#name, NULL, #name, internal, faces, watertight, promised_by, origin, tb_##name##_flat, 1, 0, \
     tb_##name##_stride, tb_##name##_ops, 1, tb_scalar_isa_names,                            \
     {(tb_prepare_fn)tb_##name##_prepare_f32, TB_SCALAR_LOOPS(name, _f32)},                  \
     {(tb_prepare_fn)tb_##name##_prepare_f64, TB_SCALAR_LOOPS(name, _f64)}},
#define TB_ENTRY(name, faces, watertight, promised_by, origin, wide)                         \
    TB_IF_SCALAR(wide, TB_SCALAR_ENTRY_(name, 0, faces, watertight, promised_by, origin))
/* an internal kernel has no _x8 form: TB_X8 in its line does not compile */
#define TB_INTERNAL_ENTRY(name, faces, watertight, promised_by, origin, wide)                \
    TB_NO_X8_##wide TB_IF_SCALAR(wide, TB_SCALAR_ENTRY_(name, 1, faces, watertight, promised_by, origin))
#define TB_NO_X8_TB_SCALAR_ONLY
#define TB_NO_X8_TB_NATIVE
#define TB_NO_X8_TB_NATIVE_AVX2

#define TB_WIDE_LOOPS(name, isa, target, sfx)                                                \
    {{NULL, TB_CAT(tb_##name##_x8_run_any_##isa, sfx), TB_CAT(tb_##name##_x8_run_closest_##isa, sfx), \
      TB_CAT(tb_##name##_x8_run_closest_##isa, sfx)},                                        \
     {NULL, TB_CAT(tb_##name##_x8_time_any_##isa, sfx),                                      \
      TB_CAT(tb_##name##_x8_time_closest_##isa, sfx),                                        \
      TB_CAT(tb_##name##_x8_time_closest_uv_##isa, sfx)}},
#define TB_WIDE_LOOPS_F32(name, isa, target) TB_WIDE_LOOPS(name, isa, target, _f32)
#define TB_WIDE_LOOPS_F64(name, isa, target) TB_WIDE_LOOPS(name, isa, target, _f64)
/* The wide form <name>_x8 of a line with TB_X8: its kernel's declared
 * properties, stride, flat and prepare; its own ops and loops. */
#define TB_WIDE_FORM_ENTRY_(name, faces, watertight, promised_by, origin)                         \
    {#name "_x8", #name, #name, 0, faces, watertight, promised_by, origin, tb_##name##_flat, 8, 0, \
     tb_##name##_stride, tb_##name##_x8_ops,                                                 \
     (int)(sizeof tb_isa_names / sizeof *tb_isa_names), tb_isa_names,                        \
     {(tb_prepare_fn)tb_##name##_prepare_f32, {TB_ISA_LIST(TB_WIDE_LOOPS_F32, name)}},        \
     {(tb_prepare_fn)tb_##name##_prepare_f64, {TB_ISA_LIST(TB_WIDE_LOOPS_F64, name)}}},
#define TB_WIDE_FORM_ENTRY(name, faces, watertight, promised_by, origin, wide)                    \
    TB_IF_X8(wide, TB_WIDE_FORM_ENTRY_(name, faces, watertight, promised_by, origin))


/* A native kernel (wide column TB_NATIVE or TB_NATIVE_AVX2): its own stride,
 * ops, flat, prepare and loops, one set per ISA of its list. */
#define TB_NATIVE_LOOPS(name, isa, sfx)                                                     \
    {{NULL, TB_CAT(tb_##name##_run_any_##isa, sfx), TB_CAT(tb_##name##_run_closest_##isa, sfx), \
      TB_CAT(tb_##name##_run_closest_##isa, sfx)},                                          \
     {NULL, TB_CAT(tb_##name##_time_any_##isa, sfx),                                        \
      TB_CAT(tb_##name##_time_closest_##isa, sfx),                                          \
      TB_CAT(tb_##name##_time_closest_uv_##isa, sfx)}},
#define TB_NATIVE_LOOPS_F32(name, isa) TB_NATIVE_LOOPS(name, isa, _f32)
#define TB_NATIVE_LOOPS_F64(name, isa) TB_NATIVE_LOOPS(name, isa, _f64)
#define TB_NATIVE_ISA_NAME(name, isa) #isa,
static const char *const tb_native_isa_names[] = {TB_NATIVE_ISA_LIST(TB_NATIVE_ISA_NAME, )};
static const char *const tb_native_avx2_isa_names[] = {TB_NATIVE_AVX2_ISA_LIST(TB_NATIVE_ISA_NAME, )};
#define TB_NATIVE_FORM_(name, internal, faces, watertight, promised_by, origin, list, names)   \
    {#name, NULL, tb_##name##_algorithm, internal, faces, watertight, promised_by, origin,      \
     tb_##name##_flat, 16, 1,                                                                  \
     tb_##name##_stride, tb_##name##_ops, (int)(sizeof names / sizeof *names), names,          \
     {(tb_prepare_fn)tb_##name##_prepare_f32, {list(TB_NATIVE_LOOPS_F32, name)}},              \
     {(tb_prepare_fn)tb_##name##_prepare_f64, {list(TB_NATIVE_LOOPS_F64, name)}}},
#define TB_NATIVE_FORM(internal, name, faces, watertight, promised_by, origin, wide)          \
    TB_NATIVE_FORM_##wide(name, internal, faces, watertight, promised_by, origin)
#define TB_NATIVE_FORM_TB_SCALAR_ONLY(...)
#define TB_NATIVE_FORM_TB_X8(...)
#define TB_NATIVE_FORM_TB_NATIVE(...) TB_NATIVE_FORM_(__VA_ARGS__, TB_NATIVE_ISA_LIST, tb_native_isa_names)
#define TB_NATIVE_FORM_TB_NATIVE_AVX2(...)                                                       \
    TB_NATIVE_FORM_(__VA_ARGS__, TB_NATIVE_AVX2_ISA_LIST, tb_native_avx2_isa_names)
#define TB_NATIVE_PUBLIC(...) TB_NATIVE_FORM(0, __VA_ARGS__)
#define TB_NATIVE_INTERNAL(...) TB_NATIVE_FORM(1, __VA_ARGS__)

static const tb_kernel tb_kernels[] = {TB_KERNEL_LIST(TB_ENTRY) TB_KERNEL_LIST(TB_WIDE_FORM_ENTRY)
                                           TB_KERNEL_LIST(TB_NATIVE_PUBLIC)
                                           TB_INTERNAL_KERNEL_LIST(TB_INTERNAL_ENTRY)
                                           TB_INTERNAL_KERNEL_LIST(TB_NATIVE_INTERNAL)};
static const size_t tb_n_kernels = sizeof tb_kernels / sizeof tb_kernels[0];

/* Whether this CPU can run ISA `i` of a wide kernel (scalar kernels: always). */
static int tb_isa_runnable(const tb_kernel *k, int i)
{
    if (k->lanes == 1)
        return 1;
#if defined(__x86_64__) || defined(__i386__)
    __builtin_cpu_init();
#endif
    /* by name: a native kernel's list is not the _x8 forms' */
    const char *const names[] = TB_ISA_NAMES;
    const int runnable[] = TB_ISA_RUNNABLE;
    for (size_t j = 0; j < sizeof names / sizeof *names; ++j)
        if (strcmp(names[j], k->isa_names[i]) == 0) {
#if defined(__x86_64__) || defined(__i386__)
            if (k->fma && strcmp(names[j], "avx2") == 0)
                return runnable[j] && __builtin_cpu_supports("fma");
#endif
            return runnable[j];
        }
    return 0;
}

/* The kernel for a name, or NULL with a Python exception set. */
static const tb_kernel *tb_find(const char *name)
{
    for (size_t i = 0; i < tb_n_kernels; ++i)
        if (strcmp(tb_kernels[i].name, name) == 0)
            return &tb_kernels[i];
    PyErr_Format(PyExc_ValueError, "unknown kernel '%s'", name);
    return NULL;
}

static int tb_check_itemsize(Py_ssize_t itemsize)
{
    if (itemsize == 4 || itemsize == 8)
        return 0;
    PyErr_Format(PyExc_ValueError, "itemsize must be 4 or 8, got %zd", itemsize);
    return -1;
}

/* The loops of a kernel at an item size (4 or 8) and an ISA name, checked
 * runnable; NULL with a Python exception set. */
static const tb_loops *tb_lookup(const tb_kernel *k, Py_ssize_t itemsize, const char *isa)
{
    if (tb_check_itemsize(itemsize))
        return NULL;
    const tb_variant *v = itemsize == 4 ? &k->f32 : &k->f64;
    for (int i = 0; i < k->n_isas; ++i)
        if (strcmp(k->isa_names[i], isa) == 0) {
            if (!tb_isa_runnable(k, i)) {
                PyErr_Format(PyExc_ValueError, "kernel '%s': ISA '%s' is not available on this CPU",
                             k->name, isa);
                return NULL;
            }
            return &v->isa[i];
        }
    PyErr_Format(PyExc_ValueError, "kernel '%s' has no ISA '%s'", k->name, isa);
    return NULL;
}

/* Scalar records of n triangles: the kernel's prepare, then NaN in every
 * real of an exactly flat triangle's record if the kernel misses those. */
static void tb_prepare_scalar(const tb_kernel *k, const tb_variant *v, Py_ssize_t itemsize,
                              const void *vertices, const uint8_t *flat, size_t n, void *out)
{
    v->prepare(vertices, n, out);
    if (k->flat != TB_FLAT_MISS)
        return;
    for (size_t i = 0; i < n; ++i)
        if (flat[i])
            for (size_t f = 0; f < k->stride; ++f) {
                if (itemsize == 4)
                    ((float *)out)[i * k->stride + f] = NAN;
                else
                    ((double *)out)[i * k->stride + f] = NAN;
            }
}

/* Records of a wide kernel: the scalar records of each block of `lanes`
 * (8 or 16) triangles, transposed to structure of arrays (field f of lane l
 * at lanes f + l); lanes past the last triangle are zero (the loops mask them). */
static int tb_prepare_blocked(const tb_kernel *k, const tb_variant *v, Py_ssize_t itemsize,
                              const void *vertices, const uint8_t *flat, size_t n, void *out)
{
    size_t stride = k->stride, lanes = (size_t)k->lanes, blocks = (n + lanes - 1) / lanes;
    char *scalar = malloc(n * stride * (size_t)itemsize);
    if (!scalar)
        return -1;
    tb_prepare_scalar(k, v, itemsize, vertices, flat, n, scalar);
    memset(out, 0, blocks * lanes * stride * (size_t)itemsize);
    for (size_t i = 0; i < n; ++i)
        for (size_t f = 0; f < stride; ++f)
            memcpy((char *)out + ((i / lanes) * lanes * stride + f * lanes + i % lanes) * (size_t)itemsize,
                   scalar + (i * stride + f) * (size_t)itemsize, (size_t)itemsize);
    free(scalar);
    return 0;
}

/* Reals a kernel's records take for n triangles (wide: whole blocks). */
static Py_ssize_t tb_record_reals(const tb_kernel *k, Py_ssize_t n)
{
    return (Py_ssize_t)k->stride * ((n + k->lanes - 1) / k->lanes * k->lanes);
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

#include "fma_peak.h"
#include "probes.h"

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

/* kernel_info(name) -> dict of what the registry says of the kernel (the
 * keys: tribench.ext.KernelInfo's fields) */
static PyObject *py_kernel_info(PyObject *Py_UNUSED(self), PyObject *args)
{
    const char *name;
    if (!PyArg_ParseTuple(args, "s:kernel_info", &name))
        return NULL;
    const tb_kernel *k = tb_find(name);
    if (!k)
        return NULL;
    PyObject *isas = PyTuple_New(k->n_isas);
    if (!isas)
        return NULL;
    for (int i = 0; i < k->n_isas; ++i) {
        PyObject *item = Py_BuildValue("(sO)", k->isa_names[i],
                                       tb_isa_runnable(k, i) ? Py_True : Py_False);
        if (!item) {
            Py_DECREF(isas);
            return NULL;
        }
        PyTuple_SET_ITEM(isas, i, item);
    }
    const char *variants[2];
    int n_variants = 0;
    if (k->f32.prepare)
        variants[n_variants++] = "float32";
    if (k->f64.prepare)
        variants[n_variants++] = "float64";
    PyObject *precisions = PyTuple_New(n_variants);
    for (int i = 0; precisions && i < n_variants; ++i) {
        PyObject *s = PyUnicode_FromString(variants[i]);
        if (!s)
            Py_CLEAR(precisions);
        else
            PyTuple_SET_ITEM(precisions, i, s);
    }
    if (!precisions) {
        Py_DECREF(isas);
        return NULL;
    }
    return Py_BuildValue(
        "{s:i,s:z,s:s,s:n,s:i,s:O,s:N,s:O,s:s,s:s,s:O,s:s,s:N}",
        "lanes", k->lanes, "scalar_form", k->scalar_form, "algorithm", k->algorithm,
        "stride", (Py_ssize_t)k->stride,
        "ops", k->ops, "internal", k->internal ? Py_True : Py_False, "isas", isas,
        "culls_back_faces", k->faces == TB_FRONT_FACES ? Py_True : Py_False,
        "watertight", k->watertight == TB_WATERTIGHT ? "edges_and_vertices" : "none",
        "watertight_source", k->promised_by,
        "seed_replay", k->origin == TB_SEED_REPLAY ? Py_True : Py_False,
        "flat", k->flat == TB_FLAT_MISS ? "miss" : "as_is", "precisions", precisions);
}

/* prepare(name, itemsize, vertices, n, out, flat): flat holds one byte per
 * triangle, nonzero for an exactly flat one (tribench.ext decides) */
static PyObject *py_prepare(PyObject *Py_UNUSED(self), PyObject *args)
{
    const char *name;
    Py_ssize_t itemsize, n;
    Py_buffer vertices = {0}, out = {0}, flat = {0};
    PyObject *result = NULL;
    if (!PyArg_ParseTuple(args, "sny*nw*y*:prepare", &name, &itemsize, &vertices, &n, &out, &flat))
        return NULL;
    const tb_kernel *k = tb_find(name);
    if (!k || tb_check_itemsize(itemsize) || tb_check_count("n", n, 64) ||
        tb_check_buffer(&vertices, "vertices", 9 * n, itemsize) ||
        tb_check_buffer(&out, "out", tb_record_reals(k, n), itemsize) ||
        tb_check_buffer(&flat, "flat", n, 1))
        goto done;
    const tb_variant *v = itemsize == 4 ? &k->f32 : &k->f64;
    int failed = 0;
    Py_BEGIN_ALLOW_THREADS
    if (k->lanes == 1)
        tb_prepare_scalar(k, v, itemsize, vertices.buf, flat.buf, (size_t)n, out.buf);
    else
        failed = tb_prepare_blocked(k, v, itemsize, vertices.buf, flat.buf, (size_t)n, out.buf);
    Py_END_ALLOW_THREADS
    if (failed)
        PyErr_NoMemory();
    else
        result = Py_NewRef(Py_None);
done:
    PyBuffer_Release(&vertices);
    PyBuffer_Release(&out);
    PyBuffer_Release(&flat);
    return result;
}

/* Runs a loop without the GIL, looking for signals (tb_poll); returns 0, or
 * -1 with the signal handler's exception (KeyboardInterrupt) set. */
static int tb_run_loop(tb_loop_fn loop, tb_job *job)
{
    job->start_ns = job->polled_ns = tb_now_ns();
    job->thread = PyEval_SaveThread();
    loop(job);
    PyEval_RestoreThread(job->thread);
    return job->interrupted ? -1 : 0;
}

/* Checks the inputs shared by every loop entry point and fills `job`;
 * returns the loop to call, or NULL with a Python exception set. */
static tb_loop_fn tb_parse_job(const char *name, Py_ssize_t itemsize, int mode, const char *isa,
                               int timed, Py_buffer *o, Py_buffer *d, Py_ssize_t n_rays,
                               Py_buffer *t_max, Py_buffer *rec, Py_ssize_t n_records, tb_job *job)
{
    if (mode < 0 || mode >= TB_N_MODES) {
        PyErr_Format(PyExc_ValueError, "mode must be 0..%d, got %d", TB_N_MODES - 1, mode);
        return NULL;
    }
    if (mode == TB_PAIRS && n_rays != n_records) {
        PyErr_Format(PyExc_ValueError, "pairs need as many records as rays, got %zd and %zd",
                     n_records, n_rays);
        return NULL;
    }
    const tb_kernel *k = tb_find(name);
    const tb_loops *loops = k ? tb_lookup(k, itemsize, isa) : NULL;
    if (!loops || tb_check_count("n_rays", n_rays, 16) || tb_check_count("n_records", n_records, 64) ||
        tb_check_buffer(o, "origins", 3 * n_rays, itemsize) ||
        tb_check_buffer(d, "directions", 3 * n_rays, itemsize) ||
        tb_check_buffer(t_max, "t_max", n_rays, itemsize) ||
        tb_check_buffer(rec, "records", tb_record_reals(k, n_records), itemsize))
        return NULL;
    /* wide float32 loops carry triangle indices in 32-bit lanes */
    if (k->lanes > 1 && n_records > INT32_MAX - 8) {
        PyErr_Format(PyExc_ValueError, "wide kernels take at most %d triangles", INT32_MAX - 8);
        return NULL;
    }
    tb_loop_fn loop = timed ? loops->time[mode] : loops->run[mode];
    if (!loop) {
        PyErr_Format(PyExc_ValueError, "kernel '%s' has no '%s' mode", name, tb_mode_names[mode]);
        return NULL;
    }
    memset(job, 0, sizeof *job);
    job->origins = o->buf;
    job->directions = d->buf;
    job->t_max = t_max->buf;
    job->records = rec->buf;
    job->n_rays = (size_t)n_rays;
    job->n_records = (size_t)n_records;
    job->loops = 1;
    return loop;
}

/* run(name, itemsize, mode, isa, origins, directions, n_rays, t_max, records,
 *     n_records, index_out, t_out, u_out, v_out) */
static PyObject *py_run(PyObject *Py_UNUSED(self), PyObject *args)
{
    const char *name, *isa;
    Py_ssize_t itemsize, n_rays, n_records;
    int mode;
    Py_buffer o = {0}, d = {0}, t_max = {0}, rec = {0}, index = {0}, t = {0}, u = {0}, v = {0};
    PyObject *result = NULL;
    tb_job job;
    if (!PyArg_ParseTuple(args, "snisy*y*ny*y*nw*w*w*w*:run", &name, &itemsize, &mode, &isa, &o,
                          &d, &n_rays, &t_max, &rec, &n_records, &index, &t, &u, &v))
        return NULL;
    tb_loop_fn loop = tb_parse_job(name, itemsize, mode, isa, 0, &o, &d, n_rays, &t_max, &rec,
                                   n_records, &job);
    if (!loop || tb_check_buffer(&index, "index_out", n_rays, 8) ||
        tb_check_buffer(&t, "t_out", n_rays, itemsize) || tb_check_buffer(&u, "u_out", n_rays, itemsize) ||
        tb_check_buffer(&v, "v_out", n_rays, itemsize))
        goto done;
    job.index_out = index.buf;
    job.t_out = t.buf;
    job.u_out = u.buf;
    job.v_out = v.buf;
    if (tb_run_loop(loop, &job) == 0)
        result = Py_NewRef(Py_None);
done:
    PyBuffer_Release(&o);
    PyBuffer_Release(&d);
    PyBuffer_Release(&t_max);
    PyBuffer_Release(&rec);
    PyBuffer_Release(&index);
    PyBuffer_Release(&t);
    PyBuffer_Release(&u);
    PyBuffer_Release(&v);
    return result;
}

/* time(name, itemsize, mode, isa, origins, directions, n_rays, t_max, records,
 *      n_records, loops) -> (elapsed_ns, hits, tests, t_sum, uv_sum) */
static PyObject *py_time(PyObject *Py_UNUSED(self), PyObject *args)
{
    const char *name, *isa;
    Py_ssize_t itemsize, n_rays, n_records;
    long long loops;
    int mode;
    Py_buffer o = {0}, d = {0}, t_max = {0}, rec = {0};
    PyObject *result = NULL;
    tb_job job;
    if (!PyArg_ParseTuple(args, "snisy*y*ny*y*nL:time", &name, &itemsize, &mode, &isa, &o, &d,
                          &n_rays, &t_max, &rec, &n_records, &loops))
        return NULL;
    tb_loop_fn loop = tb_parse_job(name, itemsize, mode, isa, 1, &o, &d, n_rays, &t_max, &rec,
                                   n_records, &job);
    if (!loop)
        goto done;
    /* tests in the batch: loops x rays (pairs) or loops x rays x triangles, in
     * double (exact below 2^53, and the bound is far below) */
    double tests = (double)loops * (double)n_rays * (mode == TB_PAIRS ? 1.0 : (double)n_records);
    if (loops < 1 || tests > (double)TB_MAX_BATCH_TESTS) {
        PyErr_Format(PyExc_ValueError,
                     "loops must be at least 1 and loops x tests per pass at most %lld, got %lld loops",
                     TB_MAX_BATCH_TESTS, loops);
        goto done;
    }
    job.loops = (uint64_t)loops;
    int64_t start = tb_now_ns();
    if (tb_run_loop(loop, &job) < 0)
        goto done;
    int64_t stop = tb_now_ns();
    result = Py_BuildValue("LKKdd", (long long)(stop - start), (unsigned long long)job.hits,
                           (unsigned long long)job.tests, job.t_sum, job.uv_sum);
done:
    PyBuffer_Release(&o);
    PyBuffer_Release(&d);
    PyBuffer_Release(&t_max);
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
    if (iterations < 1 || iterations > TB_MAX_PEAK_ITERATIONS) {
        PyErr_Format(PyExc_ValueError, "iterations must be between 1 and %lld, got %lld",
                     TB_MAX_PEAK_ITERATIONS, iterations);
        return NULL;
    }
    tb_peak r;
    Py_BEGIN_ALLOW_THREADS
    r = tb_fma_peak((uint64_t)iterations, force_scalar);
    Py_END_ALLOW_THREADS
    return Py_BuildValue("dLsd", r.flops, (long long)r.elapsed_ns, r.isa, r.sink);
}

/* op_probe(isa, itemsize, op, steps) -> (lane_ops, elapsed_ns, sink): one
 * throughput probe (probes.h), timed here with the GIL released */
static PyObject *py_op_probe(PyObject *Py_UNUSED(self), PyObject *args)
{
    const char *isa, *op;
    Py_ssize_t itemsize;
    long long steps;
    if (!PyArg_ParseTuple(args, "snsL:op_probe", &isa, &itemsize, &op, &steps))
        return NULL;
    int i = 0, o = 0;
    while (i < TB_N_PROBE_ISAS && strcmp(tb_probe_isas[i], isa) != 0)
        ++i;
    while (o < TB_N_OPS && strcmp(tb_op_names[o], op) != 0)
        ++o;
    if (i == TB_N_PROBE_ISAS || !tb_probe_runnable(i)) {
        PyErr_Format(PyExc_ValueError, "probe ISA '%s' is not built or not runnable on this CPU", isa);
        return NULL;
    }
    if (o == TB_N_OPS) {
        PyErr_Format(PyExc_ValueError, "unknown operation class '%s'", op);
        return NULL;
    }
    if (tb_check_itemsize(itemsize))
        return NULL;
    if (steps < 1 || steps > TB_MAX_PEAK_ITERATIONS) {
        PyErr_Format(PyExc_ValueError, "steps must be between 1 and %lld, got %lld", TB_MAX_PEAK_ITERATIONS, steps);
        return NULL;
    }
    static const tb_probe_fn fns[][2] = TB_PROBE_FNS;
    tb_probe_fn fn = fns[i][itemsize == 8];
    const void *c = tb_probe_constants((int)itemsize);
    double lane_ops = 0, sink;
    int64_t start, stop;
    Py_BEGIN_ALLOW_THREADS
    start = tb_now_ns();
    sink = fn(o, (uint64_t)steps, c, &lane_ops);
    stop = tb_now_ns();
    Py_END_ALLOW_THREADS
    return Py_BuildValue("dLd", lane_ops, (long long)(stop - start), sink);
}

/* probe_isas() -> ((name, runnable), ...) best first; op_classes() -> names */
static PyObject *py_probe_isas(PyObject *Py_UNUSED(self), PyObject *Py_UNUSED(unused))
{
    PyObject *out = PyTuple_New(TB_N_PROBE_ISAS);
    for (int i = 0; out && i < TB_N_PROBE_ISAS; ++i) {
        PyObject *item = Py_BuildValue("(sO)", tb_probe_isas[i], tb_probe_runnable(i) ? Py_True : Py_False);
        if (!item)
            Py_CLEAR(out);
        else
            PyTuple_SET_ITEM(out, i, item);
    }
    return out;
}

static PyObject *py_op_classes(PyObject *Py_UNUSED(self), PyObject *Py_UNUSED(unused))
{
    PyObject *out = PyTuple_New(TB_N_OPS);
    for (int o = 0; out && o < TB_N_OPS; ++o) {
        PyObject *s = PyUnicode_FromString(tb_op_names[o]);
        if (!s)
            Py_CLEAR(out);
        else
            PyTuple_SET_ITEM(out, o, s);
    }
    return out;
}

/* Each kernel's operations per test by class, tb_<name>_mix beside its code:
 * {fma, mul, add, cmp, div, logic}; the first five sum to its ops (kernels.h's
 * counting rules), logic is the mask and select work those rules leave out. */
typedef struct {
    const char *name;
    int mix[6];
} tb_mix_entry;
#define TB_MIX_ENTRY(name, ...) {#name, tb_##name##_mix},
#define TB_MIX_WIDE_ENTRY(name, faces, watertight, promised_by, origin, wide) \
    TB_IF_X8(wide, {#name "_x8", tb_##name##_x8_mix},)
static const tb_mix_entry tb_mixes[] = {TB_KERNEL_LIST(TB_MIX_ENTRY) TB_KERNEL_LIST(TB_MIX_WIDE_ENTRY)
                                            TB_INTERNAL_KERNEL_LIST(TB_MIX_ENTRY)};

/* kernel_mix(name) -> (fma, mul, add, cmp, div, logic) per test (and lane) */
static PyObject *py_kernel_mix(PyObject *Py_UNUSED(self), PyObject *args)
{
    const char *name;
    if (!PyArg_ParseTuple(args, "s:kernel_mix", &name))
        return NULL;
    for (size_t i = 0; i < sizeof tb_mixes / sizeof *tb_mixes; ++i)
        if (strcmp(tb_mixes[i].name, name) == 0) {
            const int *m = tb_mixes[i].mix;
            return Py_BuildValue("(iiiiii)", m[0], m[1], m[2], m[3], m[4], m[5]);
        }
    PyErr_Format(PyExc_ValueError, "unknown kernel '%s'", name);
    return NULL;
}

/* ---------------------------------------------------------------------- BVH
 * The tree is built here (bvh.h) and lives in Python-owned arrays between
 * calls: nodes (8 reals each), perm (slot -> input index) and the kernel's
 * records in slot order. Traversal checks every node it follows against the
 * counts it is given, so a malformed tree raises instead of reading out of
 * bounds. */

enum { TB_BVH_RUN_ANY, TB_BVH_RUN_CLOSEST, TB_BVH_TIME_ANY, TB_BVH_TIME_CLOSEST, TB_BVH_TIME_CLOSEST_UV,
       TB_BVH_TIME_NULL, TB_BVH_N_FNS };
typedef void (*tb_bvh_fn)(tb_bvh_job *);
typedef struct {
    const char *name;
    tb_bvh_fn f32[TB_MAX_ISAS][TB_BVH_N_FNS], f64[TB_MAX_ISAS][TB_BVH_N_FNS];
} tb_bvh_kernel;
#define TB_BVH_FNS(name, isa, sfx)                                                                     \
    {TB_CAT(tb_##name##_bvh_run_any_##isa, sfx), TB_CAT(tb_##name##_bvh_run_closest_##isa, sfx),       \
     TB_CAT(tb_##name##_bvh_time_any_##isa, sfx), TB_CAT(tb_##name##_bvh_time_closest_##isa, sfx),     \
     TB_CAT(tb_##name##_bvh_time_closest_uv_##isa, sfx), TB_CAT(tb_##name##_bvh_time_null_##isa, sfx)},
#define TB_BVH_FNS_F32(name, isa) TB_BVH_FNS(name, isa, _f32)
#define TB_BVH_FNS_F64(name, isa) TB_BVH_FNS(name, isa, _f64)
#define TB_BVH_KERNEL(name, faces, watertight, promised_by, origin, wide) TB_BVH_KERNEL_##wide(name)
#define TB_BVH_KERNEL_TB_SCALAR_ONLY(name)
#define TB_BVH_KERNEL_TB_X8(name)
#define TB_BVH_KERNEL_TB_NATIVE_AVX2(name)
#define TB_BVH_KERNEL_TB_NATIVE(name) \
    {#name, {TB_NATIVE_ISA_LIST(TB_BVH_FNS_F32, name)}, {TB_NATIVE_ISA_LIST(TB_BVH_FNS_F64, name)}},
static const tb_bvh_kernel tb_bvh_kernels[] = {TB_KERNEL_LIST(TB_BVH_KERNEL)};

/* bvh_kernels() -> the kernels a BVH can take as its leaf test, registry order */
static PyObject *py_bvh_kernels(PyObject *Py_UNUSED(self), PyObject *Py_UNUSED(unused))
{
    size_t n = sizeof tb_bvh_kernels / sizeof *tb_bvh_kernels;
    PyObject *out = PyTuple_New((Py_ssize_t)n);
    for (size_t i = 0; out && i < n; ++i) {
        PyObject *s = PyUnicode_FromString(tb_bvh_kernels[i].name);
        if (!s)
            Py_CLEAR(out);
        else
            PyTuple_SET_ITEM(out, (Py_ssize_t)i, s);
    }
    return out;
}

/* The most rays (x loops) one timed BVH batch may trace: a minute even at 0.1 us per ray. */
#define TB_MAX_BVH_BATCH_RAYS 600000000LL
#define TB_MAX_BVH_TRIANGLES (1LL << 27) /* 16 slots per triangle at most: slots fit 32 bits */

/* bvh_build(itemsize, vertices, n, max_leaf, nodes_out, order_out) -> (n_nodes, n_slots):
 * nodes_out has room for 2n - 1 nodes (8 reals each), order_out for n int64 */
static PyObject *py_bvh_build(PyObject *Py_UNUSED(self), PyObject *args)
{
    Py_ssize_t itemsize, n;
    int max_leaf;
    Py_buffer vertices = {0}, nodes = {0}, order = {0};
    PyObject *result = NULL;
    if (!PyArg_ParseTuple(args, "ny*niw*w*:bvh_build", &itemsize, &vertices, &n, &max_leaf, &nodes, &order))
        return NULL;
    if (tb_check_itemsize(itemsize) || tb_check_count("n", n, 64))
        goto done;
    if (n > TB_MAX_BVH_TRIANGLES || max_leaf < 1 || max_leaf > 1024) {
        PyErr_Format(PyExc_ValueError, "bvh_build: n must be at most %lld and max_leaf 1..1024, got %zd and %d",
                     TB_MAX_BVH_TRIANGLES, n, max_leaf);
        goto done;
    }
    if (tb_check_buffer(&vertices, "vertices", 9 * n, itemsize) ||
        tb_check_buffer(&nodes, "nodes_out", TB_BVH_NODE_REALS * (2 * n - 1), itemsize) ||
        tb_check_buffer(&order, "order_out", n, 8))
        goto done;
    size_t n_nodes = 0, n_slots = 0;
    int failed;
    Py_BEGIN_ALLOW_THREADS
    failed = itemsize == 4 ? tb_bvh_build_f32(vertices.buf, (size_t)n, max_leaf, nodes.buf, order.buf, &n_nodes, &n_slots)
                           : tb_bvh_build_f64(vertices.buf, (size_t)n, max_leaf, nodes.buf, order.buf, &n_nodes, &n_slots);
    Py_END_ALLOW_THREADS
    if (failed)
        PyErr_NoMemory();
    else
        result = Py_BuildValue("nn", (Py_ssize_t)n_nodes, (Py_ssize_t)n_slots);
done:
    PyBuffer_Release(&vertices);
    PyBuffer_Release(&nodes);
    PyBuffer_Release(&order);
    return result;
}

/* bvh_check(itemsize, nodes, n_nodes, perm, n_slots, vertices, n, max_leaf): raises
 * ValueError naming the first broken invariant of a tree made outside this
 * process (bvh.h's tb_bvh_check), so a malformed tree is never traversed. */
static PyObject *py_bvh_check(PyObject *Py_UNUSED(self), PyObject *args)
{
    Py_ssize_t itemsize, n_nodes, n_slots, n;
    int max_leaf;
    Py_buffer nodes = {0}, perm = {0}, vertices = {0};
    PyObject *result = NULL;
    if (!PyArg_ParseTuple(args, "ny*ny*ny*ni:bvh_check", &itemsize, &nodes, &n_nodes, &perm, &n_slots, &vertices, &n,
                          &max_leaf))
        return NULL;
    if (tb_check_itemsize(itemsize) || tb_check_count("n", n, 64) || tb_check_count("n_nodes", n_nodes, 64) ||
        tb_check_count("n_slots", n_slots, 64) || tb_check_buffer(&nodes, "nodes", TB_BVH_NODE_REALS * n_nodes, itemsize) ||
        tb_check_buffer(&perm, "perm", n_slots, 8) || tb_check_buffer(&vertices, "vertices", 9 * n, itemsize))
        goto done;
    if (n > TB_MAX_BVH_TRIANGLES || max_leaf < 1 || max_leaf > 1024) {
        PyErr_Format(PyExc_ValueError, "bvh_check: n must be at most %lld and max_leaf 1..1024, got %zd and %d",
                     TB_MAX_BVH_TRIANGLES, n, max_leaf);
        goto done;
    }
    size_t where = 0;
    const char *fault;
    Py_BEGIN_ALLOW_THREADS
    fault = itemsize == 4 ? tb_bvh_check_f32(nodes.buf, (size_t)n_nodes, perm.buf, (size_t)n_slots, vertices.buf,
                                             (size_t)n, max_leaf, &where)
                          : tb_bvh_check_f64(nodes.buf, (size_t)n_nodes, perm.buf, (size_t)n_slots, vertices.buf,
                                             (size_t)n, max_leaf, &where);
    Py_END_ALLOW_THREADS
    if (fault && !*fault)
        PyErr_NoMemory();
    else if (fault)
        PyErr_Format(PyExc_ValueError, "malformed BVH: %s (at node or slot %zu)", fault, where);
    else
        result = Py_NewRef(Py_None);
done:
    PyBuffer_Release(&nodes);
    PyBuffer_Release(&perm);
    PyBuffer_Release(&vertices);
    return result;
}

/* Checks a BVH call (the brute-force job's checks, with the slots as the
 * records, then the tree's buffers) and fills `job`; returns the traversal
 * to call, or NULL with a Python exception set. */
static tb_bvh_fn tb_parse_bvh_job(const char *name, Py_ssize_t itemsize, int mode, const char *isa, int timed,
                                  int null, Py_buffer *o, Py_buffer *d, Py_ssize_t n_rays, Py_buffer *t_max,
                                  Py_buffer *nodes, Py_ssize_t n_nodes, Py_buffer *perm, Py_ssize_t n_slots,
                                  Py_buffer *rec, tb_bvh_job *job)
{
    if (mode == TB_PAIRS) {
        PyErr_SetString(PyExc_ValueError, "a BVH has no 'pairs' mode");
        return NULL;
    }
    if (!tb_parse_job(name, itemsize, mode, isa, timed, o, d, n_rays, t_max, rec, n_slots, &job->base))
        return NULL;
    const tb_bvh_kernel *bk = NULL;
    for (size_t i = 0; i < sizeof tb_bvh_kernels / sizeof *tb_bvh_kernels; ++i)
        if (strcmp(tb_bvh_kernels[i].name, name) == 0)
            bk = &tb_bvh_kernels[i];
    if (!bk) {
        PyErr_Format(PyExc_ValueError, "kernel '%s' has no BVH traversal (native kernels only)", name);
        return NULL;
    }
    if (n_slots % 16 || tb_check_count("n_nodes", n_nodes, 64) ||
        tb_check_buffer(nodes, "nodes", TB_BVH_NODE_REALS * n_nodes, itemsize) ||
        tb_check_buffer(perm, "perm", n_slots, 8)) {
        if (!PyErr_Occurred())
            PyErr_Format(PyExc_ValueError, "n_slots must be a multiple of 16, got %zd", n_slots);
        return NULL;
    }
    const tb_kernel *k = tb_find(name);
    int i = 0;
    while (strcmp(k->isa_names[i], isa) != 0) /* found: tb_parse_job checked it */
        ++i;
    job->nodes = nodes->buf;
    job->perm = perm->buf;
    job->n_nodes = (size_t)n_nodes;
    job->n_slots = (size_t)n_slots;
    job->counts_out = NULL;
    memset(job->counts, 0, sizeof job->counts);
    job->bad_tree = 0;
    const tb_bvh_fn *fns = itemsize == 4 ? bk->f32[i] : bk->f64[i];
    if (!timed)
        return fns[mode == TB_ANY ? TB_BVH_RUN_ANY : TB_BVH_RUN_CLOSEST];
    if (null)
        return fns[TB_BVH_TIME_NULL];
    return fns[mode == TB_ANY ? TB_BVH_TIME_ANY : mode == TB_CLOSEST ? TB_BVH_TIME_CLOSEST : TB_BVH_TIME_CLOSEST_UV];
}

/* Runs a traversal as tb_run_loop runs a loop; -1 with an exception set on a
 * signal or a malformed tree. */
static int tb_run_bvh(tb_bvh_fn fn, tb_bvh_job *job)
{
    job->base.start_ns = job->base.polled_ns = tb_now_ns();
    job->base.thread = PyEval_SaveThread();
    fn(job);
    PyEval_RestoreThread(job->base.thread);
    if (job->base.interrupted)
        return -1;
    if (job->bad_tree) {
        PyErr_SetString(PyExc_ValueError, "malformed BVH: a node points out of range or the tree is too deep");
        return -1;
    }
    return 0;
}

/* bvh_run(name, itemsize, mode, isa, o, d, n_rays, t_max, nodes, n_nodes, perm, n_slots,
 *         records, index_out, t_out, u_out, v_out, counts_out) */
static PyObject *py_bvh_run(PyObject *Py_UNUSED(self), PyObject *args)
{
    const char *name, *isa;
    Py_ssize_t itemsize, n_rays, n_nodes, n_slots;
    int mode;
    Py_buffer o = {0}, d = {0}, t_max = {0}, nodes = {0}, perm = {0}, rec = {0}, index = {0}, t = {0}, u = {0},
              v = {0}, counts = {0};
    PyObject *result = NULL;
    tb_bvh_job job;
    if (!PyArg_ParseTuple(args, "snisy*y*ny*y*ny*ny*w*w*w*w*w*:bvh_run", &name, &itemsize, &mode, &isa, &o, &d,
                          &n_rays, &t_max, &nodes, &n_nodes, &perm, &n_slots, &rec, &index, &t, &u, &v, &counts))
        return NULL;
    tb_bvh_fn fn = tb_parse_bvh_job(name, itemsize, mode, isa, 0, 0, &o, &d, n_rays, &t_max, &nodes, n_nodes, &perm,
                                    n_slots, &rec, &job);
    if (!fn || tb_check_buffer(&index, "index_out", n_rays, 8) || tb_check_buffer(&t, "t_out", n_rays, itemsize) ||
        tb_check_buffer(&u, "u_out", n_rays, itemsize) || tb_check_buffer(&v, "v_out", n_rays, itemsize) ||
        tb_check_buffer(&counts, "counts_out", 4 * n_rays, 8))
        goto done;
    job.base.index_out = index.buf;
    job.base.t_out = t.buf;
    job.base.u_out = u.buf;
    job.base.v_out = v.buf;
    job.counts_out = counts.buf;
    if (tb_run_bvh(fn, &job) == 0)
        result = Py_NewRef(Py_None);
done:
    PyBuffer_Release(&o);
    PyBuffer_Release(&d);
    PyBuffer_Release(&t_max);
    PyBuffer_Release(&nodes);
    PyBuffer_Release(&perm);
    PyBuffer_Release(&rec);
    PyBuffer_Release(&index);
    PyBuffer_Release(&t);
    PyBuffer_Release(&u);
    PyBuffer_Release(&v);
    PyBuffer_Release(&counts);
    return result;
}

/* bvh_time(name, itemsize, mode, isa, o, d, n_rays, t_max, nodes, n_nodes, perm, n_slots,
 *          records, loops, null) -> (elapsed_ns, hits, triangle_tests, t_sum, uv_sum,
 *          nodes_visited, box_tests, leaves) */
static PyObject *py_bvh_time(PyObject *Py_UNUSED(self), PyObject *args)
{
    const char *name, *isa;
    Py_ssize_t itemsize, n_rays, n_nodes, n_slots;
    long long loops;
    int mode, null;
    Py_buffer o = {0}, d = {0}, t_max = {0}, nodes = {0}, perm = {0}, rec = {0};
    PyObject *result = NULL;
    tb_bvh_job job;
    if (!PyArg_ParseTuple(args, "snisy*y*ny*y*ny*ny*Lp:bvh_time", &name, &itemsize, &mode, &isa, &o, &d, &n_rays,
                          &t_max, &nodes, &n_nodes, &perm, &n_slots, &rec, &loops, &null))
        return NULL;
    tb_bvh_fn fn = tb_parse_bvh_job(name, itemsize, mode, isa, 1, null, &o, &d, n_rays, &t_max, &nodes, n_nodes,
                                    &perm, n_slots, &rec, &job);
    if (!fn)
        goto done;
    if (loops < 1 || (double)loops * (double)n_rays > (double)TB_MAX_BVH_BATCH_RAYS) {
        PyErr_Format(PyExc_ValueError, "loops must be at least 1 and loops x rays at most %lld, got %lld loops",
                     TB_MAX_BVH_BATCH_RAYS, loops);
        goto done;
    }
    job.base.loops = (uint64_t)loops;
    int64_t start = tb_now_ns();
    if (tb_run_bvh(fn, &job) < 0)
        goto done;
    int64_t stop = tb_now_ns();
    result = Py_BuildValue("LKKddKKK", (long long)(stop - start), (unsigned long long)job.base.hits,
                           (unsigned long long)job.base.tests, job.base.t_sum, job.base.uv_sum,
                           (unsigned long long)job.counts[0], (unsigned long long)job.counts[1],
                           (unsigned long long)job.counts[2]);
done:
    PyBuffer_Release(&o);
    PyBuffer_Release(&d);
    PyBuffer_Release(&t_max);
    PyBuffer_Release(&nodes);
    PyBuffer_Release(&perm);
    PyBuffer_Release(&rec);
    return result;
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
    {"bvh_run", py_bvh_run, METH_VARARGS,
     "bvh_run(name, itemsize, mode, isa, o, d, n_rays, t_max, nodes, n_nodes, perm, n_slots, records, "
     "index_out, t_out, u_out, v_out, counts_out)."},
    {"bvh_time", py_bvh_time, METH_VARARGS,
     "bvh_time(name, itemsize, mode, isa, o, d, n_rays, t_max, nodes, n_nodes, perm, n_slots, records, "
     "loops, null) -> (elapsed_ns, hits, triangle_tests, t_sum, uv_sum, nodes_visited, box_tests, leaves)."},
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
    PyObject *m = PyModule_Create(&tb_module);
    const char *names[] = {"MAX_BATCH_TESTS", "MAX_PEAK_ITERATIONS", "POLL_NS", "MAX_BVH_BATCH_RAYS",
                           "MAX_BVH_TRIANGLES", "BVH_BUILD_VERSION"};
    const long long values[] = {TB_MAX_BATCH_TESTS, TB_MAX_PEAK_ITERATIONS, TB_POLL_NS, TB_MAX_BVH_BATCH_RAYS,
                                TB_MAX_BVH_TRIANGLES, TB_BVH_BUILD_VERSION};
    for (int i = 0; m && i < 6; ++i) {
        PyObject *value = PyLong_FromLongLong(values[i]);
        if (!value || PyModule_AddObjectRef(m, names[i], value) < 0)
            Py_CLEAR(m);
        Py_XDECREF(value);
    }
    return m;
}
