/* The kernel registry and the brute-force glue: the table of every kernel
 * (tb_kernels, made from the registration lines of kernels/list.h), and
 * kernel_names, kernel_info, kernel_mix, prepare, run and time, with the
 * argument checks the other glue (bvh.c) shares. This file compiles no loops:
 * it includes declarations.h for the kernels' declarations (stride, ops, flat,
 * mix) and their prepare functions, and core.h declares the loops' entry
 * points, which the other files define. */

#include "core.h"

#include "declarations.h"

static const char *const tb_mode_names[TB_N_MODES] = {"pairs", "any", "closest", "closest_uv"};

/* ------------------------------------------------------------------ registry */

typedef void (*tb_prepare_fn)(const void *, size_t, void *);

static const char *const tb_scalar_isa_names[] = {"scalar"};

/* A kernel's loops for one ISA: untimed (run) and timed (time) per mode;
 * NULL where the form has no such mode (wide kernels have no pairs). */
typedef struct {
    tb_loop_fn run[TB_N_MODES], time[TB_N_MODES];
} tb_loops;

typedef struct {
    tb_prepare_fn prepare; /* the scalar record layout; native kernels transpose it */
    tb_loops isa[TB_MAX_ISAS];
} tb_variant;

/* One registered kernel: what the registration line in kernels/list.h
 * declares, what its file defines (stride, ops, flat), and its loops. */
typedef struct {
    const char *name;
    const char *algorithm;   /* the clean scalar kernel whose algorithm this is a form of (itself
                                for a scalar kernel; a native kernel declares tb_<name>_algorithm) */
    int internal;            /* from TB_INTERNAL_KERNEL_LIST: hidden from the user's list */
    int faces;               /* TB_BOTH_FACES or TB_FRONT_FACES (back faces culled) */
    int watertight;          /* TB_OPEN or TB_WATERTIGHT */
    const char *promised_by; /* the paper that promises watertightness ("" if none) */
    int origin;              /* TB_CLEAN or TB_SEED_REPLAY */
    int flat;     /* TB_FLAT_MISS or TB_FLAT_AS_IS (kernels.h: tb_<name>_flat) */
    int lanes;    /* triangles per record block: 1 scalar early-exit form; 16 a native
                     form (native.h; one vector's worth per ISA) */
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
    {#name, #name, internal, faces, watertight, promised_by, origin, tb_##name##_flat, 1,       \
     tb_##name##_stride, tb_##name##_ops, 1, tb_scalar_isa_names,                            \
     {(tb_prepare_fn)tb_##name##_prepare_f32, TB_SCALAR_LOOPS(name, _f32)},                  \
     {(tb_prepare_fn)tb_##name##_prepare_f64, TB_SCALAR_LOOPS(name, _f64)}},
#define TB_ENTRY(name, faces, watertight, promised_by, origin, wide)                         \
    TB_IF_SCALAR(wide, TB_SCALAR_ENTRY_(name, 0, faces, watertight, promised_by, origin))
#define TB_INTERNAL_ENTRY(name, faces, watertight, promised_by, origin, wide)                \
    TB_IF_SCALAR(wide, TB_SCALAR_ENTRY_(name, 1, faces, watertight, promised_by, origin))

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
    {#name, tb_##name##_algorithm, internal, faces, watertight, promised_by, origin,            \
     tb_##name##_flat, 16,                                                                     \
     tb_##name##_stride, tb_##name##_ops, (int)(sizeof names / sizeof *names), names,          \
     {(tb_prepare_fn)tb_##name##_prepare_f32, {list(TB_NATIVE_LOOPS_F32, name)}},              \
     {(tb_prepare_fn)tb_##name##_prepare_f64, {list(TB_NATIVE_LOOPS_F64, name)}}},
#define TB_NATIVE_FORM(internal, name, faces, watertight, promised_by, origin, wide)          \
    TB_NATIVE_FORM_##wide(name, internal, faces, watertight, promised_by, origin)
#define TB_NATIVE_FORM_TB_SCALAR_ONLY(...)
#define TB_NATIVE_FORM_TB_NATIVE(...) TB_NATIVE_FORM_(__VA_ARGS__, TB_NATIVE_ISA_LIST, tb_native_isa_names)
#define TB_NATIVE_FORM_TB_NATIVE_AVX2(...)                                                       \
    TB_NATIVE_FORM_(__VA_ARGS__, TB_NATIVE_AVX2_ISA_LIST, tb_native_avx2_isa_names)
#define TB_NATIVE_PUBLIC(...) TB_NATIVE_FORM(0, __VA_ARGS__)
#define TB_NATIVE_INTERNAL(...) TB_NATIVE_FORM(1, __VA_ARGS__)

static const tb_kernel tb_kernels[] = {TB_KERNEL_LIST(TB_ENTRY) TB_KERNEL_LIST(TB_NATIVE_PUBLIC)
                                           TB_INTERNAL_KERNEL_LIST(TB_INTERNAL_ENTRY)
                                           TB_INTERNAL_KERNEL_LIST(TB_NATIVE_INTERNAL)};
static const size_t tb_n_kernels = sizeof tb_kernels / sizeof tb_kernels[0];

/* Whether this CPU can run a kernel's ISA of that name (the baseline, scalar
 * and NEON, which every aarch64 CPU has: always). */
static int tb_isa_runnable(const char *isa)
{
#if defined(__x86_64__) || defined(__i386__)
    __builtin_cpu_init();
    if (strcmp(isa, "avx512") == 0)
        return __builtin_cpu_supports("avx512f");
    if (strcmp(isa, "avx2") == 0) /* with FMA (kernels/list.h) */
        return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
#endif
    (void)isa;
    return 1;
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

TB_HIDDEN int tb_check_itemsize(Py_ssize_t itemsize)
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
            if (!tb_isa_runnable(k->isa_names[i])) {
                PyErr_Format(PyExc_ValueError, "kernel '%s': ISA '%s' is not available on this CPU",
                             k->name, isa);
                return NULL;
            }
            return &v->isa[i];
        }
    PyErr_Format(PyExc_ValueError, "kernel '%s' has no ISA '%s'", k->name, isa);
    return NULL;
}

/* The position of ISA `isa` in the list of kernel `name`, -1 if it has none
 * (no Python exception set). */
TB_HIDDEN int tb_isa_index(const char *name, const char *isa)
{
    for (size_t i = 0; i < tb_n_kernels; ++i)
        if (strcmp(tb_kernels[i].name, name) == 0)
            for (int j = 0; j < tb_kernels[i].n_isas; ++j)
                if (strcmp(tb_kernels[i].isa_names[j], isa) == 0)
                    return j;
    return -1;
}

/* out[at] = NaN, in the records' precision */
static void tb_set_nan(void *out, size_t at, Py_ssize_t itemsize)
{
    if (itemsize == 4)
        ((float *)out)[at] = NAN;
    else
        ((double *)out)[at] = NAN;
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
            for (size_t f = 0; f < k->stride; ++f)
                tb_set_nan(out, i * k->stride + f, itemsize);
}

/* Records of a wide kernel: the scalar records of each block of `lanes`
 * (8 or 16) triangles, transposed to structure of arrays (field f of lane l
 * at lanes f + l). Lanes past the last triangle hold the flat triangle's
 * record, NaN: the loops mask them, and NaN fails every kernel's tests on its
 * common path, where zeros (a triangle at the origin, its edge functions
 * exactly 0) sent woop_fma to its exact fallback on every vector holding one. */
static int tb_prepare_blocked(const tb_kernel *k, const tb_variant *v, Py_ssize_t itemsize,
                              const void *vertices, const uint8_t *flat, size_t n, void *out)
{
    size_t stride = k->stride, lanes = (size_t)k->lanes, blocks = (n + lanes - 1) / lanes;
    char *scalar = malloc(n * stride * (size_t)itemsize);
    if (!scalar)
        return -1;
    tb_prepare_scalar(k, v, itemsize, vertices, flat, n, scalar);
    for (size_t i = 0; i < blocks * lanes; ++i)
        for (size_t f = 0; f < stride; ++f) {
            const size_t at = (i / lanes) * lanes * stride + f * lanes + i % lanes;
            if (i < n)
                memcpy((char *)out + at * (size_t)itemsize, scalar + (i * stride + f) * (size_t)itemsize,
                       (size_t)itemsize);
            else
                tb_set_nan(out, at, itemsize);
        }
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
TB_HIDDEN int tb_check_buffer(const Py_buffer *buf, const char *what, Py_ssize_t count,
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
TB_HIDDEN int tb_check_count(const char *what, Py_ssize_t n, Py_ssize_t factor)
{
    if (n < 1 || n > PY_SSIZE_T_MAX / 64 / factor) {
        PyErr_Format(PyExc_ValueError, "%s must be at least 1 and not absurdly large, got %zd",
                     what, n);
        return -1;
    }
    return 0;
}
/* --------------------------------------------------------------- functions */

/* kernel_names(internal=False): registry order, internal kernels only if asked */
TB_HIDDEN PyObject *py_kernel_names(PyObject *Py_UNUSED(self), PyObject *args)
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
TB_HIDDEN PyObject *py_kernel_info(PyObject *Py_UNUSED(self), PyObject *args)
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
                                       tb_isa_runnable(k->isa_names[i]) ? Py_True : Py_False);
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
        "{s:i,s:s,s:n,s:i,s:O,s:N,s:O,s:s,s:s,s:O,s:s,s:N}",
        "lanes", k->lanes, "algorithm", k->algorithm,
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
TB_HIDDEN PyObject *py_prepare(PyObject *Py_UNUSED(self), PyObject *args)
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
    if (job->out_of_memory)
        PyErr_NoMemory();
    return job->interrupted || job->out_of_memory ? -1 : 0;
}

/* Checks the inputs shared by every loop entry point and fills `job`;
 * returns the loop to call, or NULL with a Python exception set. */
TB_HIDDEN tb_loop_fn tb_parse_job(const char *name, Py_ssize_t itemsize, int mode, const char *isa,
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
TB_HIDDEN PyObject *py_run(PyObject *Py_UNUSED(self), PyObject *args)
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
TB_HIDDEN PyObject *py_time(PyObject *Py_UNUSED(self), PyObject *args)
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

/* Each kernel's operations per test by class, tb_<name>_mix beside its code:
 * {fma, mul, add, cmp, div, logic}; the first five sum to its ops (kernels.h's
 * counting rules), logic is the mask and select work those rules leave out. */
typedef struct {
    const char *name;
    int mix[6];
} tb_mix_entry;
#define TB_MIX_ENTRY(name, ...) {#name, tb_##name##_mix},
static const tb_mix_entry tb_mixes[] = {TB_KERNEL_LIST(TB_MIX_ENTRY) TB_INTERNAL_KERNEL_LIST(TB_MIX_ENTRY)};

/* kernel_mix(name) -> (fma, mul, add, cmp, div, logic) per test (and lane) */
TB_HIDDEN PyObject *py_kernel_mix(PyObject *Py_UNUSED(self), PyObject *args)
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
