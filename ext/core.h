/* What the C files of tribench._core share: the job a loop runs, the signal
 * poll, the limits, the loops' entry points and the glue's helpers.
 *
 * The module is several translation units so that a build compiles them in
 * parallel (setup.py): _core.c (the module and its method table), registry.c
 * (the kernel registry, prepare, run and time), bvh.c (the BVH's build and
 * glue), probes.c (the FMA peak and the throughput probes), and one file of
 * loops per ISA and precision, isa_<isa>_<f32|f64>.c (the native kernels
 * and their BVH traversal compiled for that ISA, and with the baseline the
 * scalar kernels: about 95% of the build's work). A file
 * that compiles loops includes kernels.h once per precision, after saying
 * which parts it compiles (TB_EMIT_*, see kernels.h); the registry finds
 * their entry points through the declarations below, made from the same
 * registration lines (kernels/list.h). Everything not static is hidden: the
 * module exports PyInit__core alone. */

#ifndef TB_CORE_H
#define TB_CORE_H

#define PY_SSIZE_T_CLEAN
#include <Python.h>

#include <float.h>
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
#elif defined(__aarch64__)
#include <arm_neon.h>
#endif

#define TB_CAT_(a, b) a##b
#define TB_CAT(a, b) TB_CAT_(a, b)
#define TB_STR_(x) #x
#define TB_STR(x) TB_STR_(x)

/* shared between this module's files, invisible outside it */
#define TB_HIDDEN __attribute__((visibility("hidden")))
/* An A/A twin's entry points: GCC's identical-code folding (-fipa-icf, on at
 * -O2) would make them jumps into the original's code, so the "twin" would be
 * the same code at the same address. Clang folds nothing at -O3. */
#if defined(__GNUC__) && !defined(__clang__)
#define TB_NO_ICF __attribute__((no_icf))
#else
#define TB_NO_ICF
#endif
/* A loop shared by a kernel's untimed entry points, which pass their mode to
 * it: out of line and, in GCC, not cloned per constant argument (which would
 * compile one copy per mode again). */
#if defined(__GNUC__) && !defined(__clang__)
#define TB_SHARED_LOOP __attribute__((noinline, noclone))
#else
#define TB_SHARED_LOOP __attribute__((noinline))
#endif

/* What a loop answers per ray: pairs (ray i against triangle i), any hit,
 * the closest hit's t, or the closest hit's t, u and v. */
enum { TB_PAIRS, TB_ANY, TB_CLOSEST, TB_CLOSEST_UV, TB_N_MODES };

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
    int out_of_memory;                 /* a loop that allocates (seed_objects.h) could not */
} tb_job;

/* One batch of BVH traversal: the brute-force job (rays, t_max, the leaf
 * records as `records`, outputs and checksums) and the tree (bvh.h). */
typedef struct {
    tb_job base;
    const void *nodes;
    const int64_t *perm;   /* slot -> input triangle index (-1: padding) */
    size_t n_nodes, n_slots;
    int64_t *counts_out;   /* run: per ray, nodes visited, box tests, leaves, triangle tests */
    uint64_t counts[4];    /* time: the same, summed over all passes */
    int packets;           /* the wide tree walked by packets of rays that share an origin */
    int bad_tree;          /* a node pointed out of range: the loop stopped */
} tb_bvh_job;

typedef void (*tb_loop_fn)(tb_job *);
typedef void (*tb_bvh_fn)(tb_bvh_job *);
#define TB_MAX_ISAS 3 /* the most ISAs a kernel is compiled for (kernels/list.h) */

/* static, not shared: each file's loops inline their own copy, as they did
 * when the module was one file (unused: the glue's files call neither) */
__attribute__((unused)) static int64_t tb_now_ns(void)
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
__attribute__((unused)) static uint64_t tb_poll(tb_job *job, uint64_t rays)
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
/* The most rays (x loops) one timed BVH batch may trace: a minute even at 0.1 us per ray. */
#define TB_MAX_BVH_BATCH_RAYS 600000000LL
#define TB_MAX_BVH_TRIANGLES (1LL << 27) /* 16 slots per triangle at most: slots fit 32 bits */

#include "kernels/list.h"

/* ------------------------------------------------- the loops' entry points
 * Defined by kernels.h, native.h and bvh.h in the file that compiles each
 * part; declared here, from the registration lines, for the registry. */

/* a scalar kernel's, per precision */
#define TB_DECLARE_SCALAR_(name, sfx)                                                              \
    TB_HIDDEN void tb_##name##_run_pairs##sfx(tb_job *);                                           \
    TB_HIDDEN void tb_##name##_run_any##sfx(tb_job *);                                             \
    TB_HIDDEN void tb_##name##_run_closest##sfx(tb_job *);                                         \
    TB_HIDDEN void tb_##name##_time_pairs##sfx(tb_job *);                                          \
    TB_HIDDEN void tb_##name##_time_any##sfx(tb_job *);                                            \
    TB_HIDDEN void tb_##name##_time_closest##sfx(tb_job *);                                        \
    TB_HIDDEN void tb_##name##_time_closest_uv##sfx(tb_job *);
#define TB_DECLARE_SCALAR(name, faces, watertight, promised_by, origin, wide)                      \
    TB_IF_SCALAR(wide, TB_DECLARE_SCALAR_(name, _f32) TB_DECLARE_SCALAR_(name, _f64))
TB_KERNEL_LIST(TB_DECLARE_SCALAR)
TB_INTERNAL_KERNEL_LIST(TB_DECLARE_SCALAR)
#undef TB_DECLARE_SCALAR
#undef TB_DECLARE_SCALAR_

/* a native kernel's five, per ISA and precision, and (public TB_NATIVE
 * kernels) its BVH traversals' six per tree (wide, binary_; bvh.py's
 * "packets" is the wide one's with job->packets) */
#define TB_DECLARE_NATIVE_(name, isa, sfx)                                                         \
    TB_HIDDEN void tb_##name##_run_any_##isa##sfx(tb_job *);                                       \
    TB_HIDDEN void tb_##name##_run_closest_##isa##sfx(tb_job *);                                   \
    TB_HIDDEN void tb_##name##_time_any_##isa##sfx(tb_job *);                                      \
    TB_HIDDEN void tb_##name##_time_closest_##isa##sfx(tb_job *);                                  \
    TB_HIDDEN void tb_##name##_time_closest_uv_##isa##sfx(tb_job *);
#define TB_DECLARE_NATIVE_ISA(name, isa) TB_DECLARE_NATIVE_(name, isa, _f32) TB_DECLARE_NATIVE_(name, isa, _f64)
#define TB_DECLARE_BVH_TREE(name, tree, isa, sfx)                                                  \
    TB_HIDDEN void tb_##name##_bvh_##tree##run_any_##isa##sfx(tb_bvh_job *);                       \
    TB_HIDDEN void tb_##name##_bvh_##tree##run_closest_##isa##sfx(tb_bvh_job *);                   \
    TB_HIDDEN void tb_##name##_bvh_##tree##time_any_##isa##sfx(tb_bvh_job *);                      \
    TB_HIDDEN void tb_##name##_bvh_##tree##time_closest_##isa##sfx(tb_bvh_job *);                  \
    TB_HIDDEN void tb_##name##_bvh_##tree##time_closest_uv_##isa##sfx(tb_bvh_job *);               \
    TB_HIDDEN void tb_##name##_bvh_##tree##time_null_##isa##sfx(tb_bvh_job *);
#define TB_DECLARE_BVH_(name, isa, sfx)                                                            \
    TB_DECLARE_BVH_TREE(name, , isa, sfx) TB_DECLARE_BVH_TREE(name, binary_, isa, sfx)
#define TB_DECLARE_BVH_ISA(name, isa) TB_DECLARE_BVH_(name, isa, _f32) TB_DECLARE_BVH_(name, isa, _f64)
#define TB_DECLARE_NATIVE(name, faces, watertight, promised_by, origin, wide) TB_DECLARE_NATIVE_##wide(name)
#define TB_DECLARE_NATIVE_TB_SCALAR_ONLY(name)
#define TB_DECLARE_NATIVE_TB_NATIVE(name)                                                          \
    TB_NATIVE_ISA_LIST(TB_DECLARE_NATIVE_ISA, name) TB_NATIVE_ISA_LIST(TB_DECLARE_BVH_ISA, name)
#define TB_DECLARE_NATIVE_TB_NATIVE_AVX2(name) TB_NATIVE_AVX2_ISA_LIST(TB_DECLARE_NATIVE_ISA, name)
TB_KERNEL_LIST(TB_DECLARE_NATIVE)
/* an internal native kernel has no BVH traversal */
#undef TB_DECLARE_NATIVE_TB_NATIVE
#define TB_DECLARE_NATIVE_TB_NATIVE(name) TB_NATIVE_ISA_LIST(TB_DECLARE_NATIVE_ISA, name)
TB_INTERNAL_KERNEL_LIST(TB_DECLARE_NATIVE)
#undef TB_DECLARE_NATIVE_TB_NATIVE_AVX2
#undef TB_DECLARE_NATIVE_TB_NATIVE
#undef TB_DECLARE_NATIVE_TB_SCALAR_ONLY
#undef TB_DECLARE_NATIVE
#undef TB_DECLARE_BVH_ISA
#undef TB_DECLARE_BVH_
#undef TB_DECLARE_NATIVE_ISA
#undef TB_DECLARE_NATIVE_

/* ------------------------------------------------------ the glue's helpers */

/* registry.c: argument checks (each 0, or -1 with a Python exception set) */
TB_HIDDEN int tb_check_itemsize(Py_ssize_t itemsize);
TB_HIDDEN int tb_check_buffer(const Py_buffer *buf, const char *what, Py_ssize_t count, Py_ssize_t itemsize);
TB_HIDDEN int tb_check_count(const char *what, Py_ssize_t n, Py_ssize_t factor);
/* registry.c: the checks shared by every loop entry point, filling `job`:
 * the loop to call, or NULL with a Python exception set */
TB_HIDDEN tb_loop_fn tb_parse_job(const char *name, Py_ssize_t itemsize, int mode, const char *isa, int timed,
                                  Py_buffer *o, Py_buffer *d, Py_ssize_t n_rays, Py_buffer *t_max, Py_buffer *rec,
                                  Py_ssize_t n_records, tb_job *job);
/* registry.c: the position of an ISA in a kernel's list, -1 if it has none */
TB_HIDDEN int tb_isa_index(const char *name, const char *isa);
/* bvh.c: the build's version (bvh.h), a module constant */
TB_HIDDEN extern const long long tb_bvh_build_version;

/* the module's functions (tb_methods in _core.c), by file */
#define TB_PY_FN(name) TB_HIDDEN PyObject *py_##name(PyObject *self, PyObject *args);
TB_PY_FN(kernel_names) /* registry.c */
TB_PY_FN(kernel_info)
TB_PY_FN(kernel_mix)
TB_PY_FN(prepare)
TB_PY_FN(run)
TB_PY_FN(time)
TB_PY_FN(bvh_kernels) /* bvh.c */
TB_PY_FN(bvh_build)
TB_PY_FN(bvh_check)
TB_PY_FN(bvh_widen)
TB_PY_FN(bvh_run)
TB_PY_FN(bvh_time)
TB_PY_FN(fma_peak) /* probes.c */
TB_PY_FN(op_probe)
TB_PY_FN(probe_isas)
TB_PY_FN(op_classes)
#undef TB_PY_FN

#endif /* TB_CORE_H */
