/* Kernels and their batch loops for one precision.
 *
 * No include guard: a file of the module (core.h lists them) includes this
 * file once per precision it compiles, with TB_REAL = float, TB_SUFFIX = _f32
 * or with TB_REAL = double, TB_SUFFIX = _f64, so every kernel is written once
 * over `real` (one typedef for the precision, as pbrt does) and every symbol
 * gets the precision as a suffix.
 *
 * Which loops the including file compiles, each 0 or 1, all five defined:
 *   TB_EMIT_SCALAR    the scalar kernels' entry points (isa_baseline_<p>.c)
 *   TB_EMIT_avx512, TB_EMIT_avx2, TB_EMIT_neon, TB_EMIT_baseline
 *                     the native kernels' and the BVH traversal's entry
 *                     points for that ISA (isa_<isa>.c)
 * The declarations (types, every kernel's stride, ops, flat, mix and
 * prepare) come with every inclusion; the files that compile no loops
 * (registry.c, bvh.c) include them alone, through declarations.h. Entry
 * points are hidden, not static (core.h declares them), so the registry in
 * another file can list them; a kernel's prepare is static and is compiled
 * where it is used (the registry's file), as is every other static function
 * here.
 *
 * A scalar kernel file kernels/<name>.h defines, for the current precision:
 *   tb_<name>_stride     macro: reals per prepared triangle record
 *   tb_<name>_ops        macro: arithmetic operations per test (see below)
 *   tb_<name>_flat       macro: what becomes of an exactly flat triangle (zero
 *                        area: its vertices exactly collinear, a repeated
 *                        vertex or a point; decided once per triangle in exact
 *                        arithmetic by tribench.ext.prepare, which passes the
 *                        verdicts to the glue): TB_FLAT_MISS, the glue fills
 *                        its record with NaN after prepare, and the test, which
 *                        rejects a NaN anywhere, misses it on every ray at no
 *                        cost per test; or TB_FLAT_AS_IS, the record is left
 *                        as prepare made it and the test decides (the seed
 *                        replays, which do what the seed's code did)
 *   void tb_<name>_prepare(const real *vertices, size_t n, real *out)
 *   void tb_<name>_ray(const real *o, const real *d, tb_ray *r)
 *                        per-ray precomputation, done once per ray outside
 *                        the triangle loop (most kernels: tb_ray_plain)
 *   int  tb_<name>_test(const tb_ray *r, const real *record, real t_max, tb_hit *h)
 *                        1 on a hit with 0 < t < t_max, writing t, u, v
 *                        (the hit point is (1-u-v) v0 + u v1 + v v2); 0 else
 * A native kernel's file defines the same names, its test over a vector of
 * triangles (native.h). The loops are instantiated once per kernel, mode and
 * ISA, so tests inline into them and dispatch happens once per batch. The
 * loops pass the best t so far as t_max, as a ray tracer shrinks its
 * interval; a kernel that reads u and v only for the closest_uv mode has
 * their arithmetic removed elsewhere as dead code.
 *
 * Operation counts (the work behind `tribench info --peak`'s bound): every
 * floating-point add, subtract, multiply, divide, square root, comparison
 * and min/max one test does counts 1; loads, selects, mask logic, sign flips
 * and fabs (bit operations), the per-ray and per-triangle precomputations,
 * and the arithmetic only the u and v outputs use do not count. A scalar
 * kernel counts the path of a hit (every stage runs); a test that exits
 * early does less. A wide kernel does every operation on every lane; its
 * count equals the vector arithmetic instructions of its compiled triangle
 * loop per vector (tests/test_ext_build.py checks this). The kernels are
 * built without FMA contraction, so each operation is one instruction.
 * By class (tb_<name>_mix: fma, mul, add, cmp, div, logic), the first five
 * sum to the count; logic, outside it, is the compiled loop's bit operations,
 * blends and selects: AVX2's and/or/xor/blendv, AVX-512's mask-register
 * operations, ternary logic, mask blends and masked register moves. */

#if !defined(TB_EMIT_SCALAR) || !defined(TB_EMIT_avx512) || !defined(TB_EMIT_avx2) || !defined(TB_EMIT_neon) || \
    !defined(TB_EMIT_baseline)
#error "define TB_EMIT_SCALAR, TB_EMIT_avx512, TB_EMIT_avx2, TB_EMIT_neon and TB_EMIT_baseline (0 or 1) before kernels.h"
#endif

/* Each file compiles only some of the static functions below (a kernel's
 * prepare in the registry's file, its test where its loops are): the rest
 * are unused there, and the compiler drops them without generating code. */
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wunused-function"

#define real TB_REAL
#define TB_FN(name) TB_CAT(name, TB_SUFFIX)
#define tb_ray TB_FN(tb_ray)
#define tb_hit TB_FN(tb_hit)
#define vreal TB_FN(tb_vreal)
#define vmask TB_FN(tb_vmask)

/* A ray as the kernels see it: origin, direction, and the per-ray
 * precomputation of the kernels that have one (Woop's axes and shear). */
typedef struct {
    real o[3], d[3];
    int kx, ky, kz;
    real sx, sy, sz;
} tb_ray;

typedef struct {
    real t, u, v;
} tb_hit;

/* One 32-byte vector of the precision (8 floats or 4 doubles: one AVX
 * register, a wide BVH node's children: bvh.h), and masks of the same width
 * (lane = all ones or zero, as vector comparisons yield). GCC/Clang vector
 * extensions: the compiler lowers them to the ISA of the function they are
 * used in. */
typedef real vreal __attribute__((vector_size(32)));
#define mask_elem TB_FN(tb_mask_elem)
#if TB_REAL_IS_DOUBLE
typedef int64_t mask_elem;
#else
typedef int32_t mask_elem;
#endif
typedef mask_elem vmask __attribute__((vector_size(32)));

#include "kernels/vec.h"
#ifdef TB_KERNEL_FILE /* a build of a user's kernel file (kernels/list.h): its scalar part */
#define TB_SCALAR_PART 1
#include TB_KERNEL_FILE
#undef TB_SCALAR_PART
#else
#include "kernels/curless_seed.h"
#include "kernels/moller_seed.h"
#include "kernels/curless.h"
#include "kernels/moller_trumbore.h"
#include "kernels/moller_trumbore_aa.h"
#include "kernels/moller_seed_aa.h"
#include "kernels/moller_trumbore_cull.h"
#include "kernels/baldwin_weber_12.h"
#include "kernels/baldwin_weber_9.h"
#include "kernels/havel_herout.h"
#include "kernels/woop.h"
#include "kernels/plucker.h"
#include "kernels/badouel.h"
#include "kernels/wald.h"
#include "kernels/segura_feito.h"
#include "kernels/kensler_shirley.h"
#include "kernels/shevtsov.h"
#endif

typedef int (*TB_FN(tb_test_fn))(const tb_ray *restrict, const real *restrict, real,
                                 tb_hit *restrict);
typedef void (*TB_FN(tb_ray_fn))(const real *, const real *, tb_ray *);

/* One batch of a scalar kernel. `mode` and `timed` are constants at every
 * call site, so each instantiation keeps only its own branch. Untimed, the
 * loop writes index, t, u, v per ray (NaN and -1 on a miss); timed, it runs
 * `loops` passes and folds the answers into the job's checksum (which also
 * keeps the compiler from deleting the work). Both count the tests done:
 * every triangle for closest, up to the first hit for any. Closest: ties go to the lowest
 * index (a later triangle must be strictly closer). After each ray, a counter
 * against the next count tb_poll asked for: when they meet, tb_poll reads the
 * clock and looks for a signal, and the loop stops if one was raised. */
static inline __attribute__((always_inline)) void
TB_FN(tb_scalar_loop)(TB_FN(tb_test_fn) test, TB_FN(tb_ray_fn) make_ray, size_t stride,
                      tb_job *job, const int mode, const int timed)
{
    const real *o = job->origins, *d = job->directions, *rec = job->records;
    const real *t_max = job->t_max;
    uint64_t hits = 0, tests = 0, rays = 0, poll_at = 1;
    double t_sum = 0, uv_sum = 0;
    const uint64_t loops = timed ? job->loops : 1;
    for (uint64_t pass = 0; pass < loops; ++pass)
        for (size_t i = 0; i < job->n_rays; ++i) {
            if (++rays == poll_at && !(poll_at = tb_poll(job, rays)))
                goto stop;
            tb_ray r;
            make_ray(o + 3 * i, d + 3 * i, &r);
            tb_hit best = {t_max[i], (real)NAN, (real)NAN}, h;
            int64_t index = -1;
            if (mode == TB_PAIRS) {
                if (test(&r, rec + stride * i, t_max[i], &h)) {
                    best = h;
                    index = (int64_t)i;
                }
                tests += 1;
            } else {
                size_t j = 0;
                for (; j < job->n_records; ++j)
                    if (test(&r, rec + stride * j, best.t, &h)) {
                        best = h;
                        index = (int64_t)j;
                        if (mode == TB_ANY) {
                            ++j;
                            break;
                        }
                    }
                tests += j;
            }
            if (timed) {
                if (index >= 0) {
                    ++hits;
                    t_sum += best.t;
                    if (mode == TB_CLOSEST_UV)
                        uv_sum += (double)best.u + best.v;
                }
            } else {
                real *t_out = job->t_out, *u_out = job->u_out, *v_out = job->v_out;
                job->index_out[i] = index;
                t_out[i] = index >= 0 ? best.t : (real)NAN;
                u_out[i] = index >= 0 ? best.u : (real)NAN;
                v_out[i] = index >= 0 ? best.v : (real)NAN;
            }
        }
stop:
    job->hits = hits;
    job->tests = tests;
    job->t_sum = t_sum;
    job->uv_sum = uv_sum;
}

/* Entry points of one scalar kernel: the only place loops meet kernels.
 * time_<kernel>_<mode> is one function per mode, with the mode compiled in;
 * the untimed run_<kernel>_<mode> share one loop that takes it (speed does
 * not matter there, compile time does). */
#define TB_SCALAR_ENTRY(name, fn_mode, mode, timed)                                         \
    TB_HIDDEN TB_ENTRY_ATTR void TB_FN(tb_##name##_##fn_mode)(tb_job *job)                  \
    {                                                                                       \
        TB_FN(tb_scalar_loop)(TB_FN(tb_##name##_test), TB_FN(tb_##name##_ray),              \
                              tb_##name##_stride, job, mode, timed);                        \
    }
#define TB_SCALAR_RUN(name, fn_mode, mode)                                                  \
    TB_HIDDEN TB_ENTRY_ATTR void TB_FN(tb_##name##_##fn_mode)(tb_job *job)                  \
    {                                                                                       \
        TB_FN(tb_##name##_run)(job, mode);                                                  \
    }
#define TB_INSTANTIATE_(name)                                                               \
    static TB_SHARED_LOOP void TB_FN(tb_##name##_run)(tb_job *job, int mode)                \
    {                                                                                       \
        TB_FN(tb_scalar_loop)(TB_FN(tb_##name##_test), TB_FN(tb_##name##_ray),              \
                              tb_##name##_stride, job, mode, 0);                            \
    }                                                                                       \
    TB_SCALAR_RUN(name, run_pairs, TB_PAIRS)                                                \
    TB_SCALAR_RUN(name, run_any, TB_ANY)                                                    \
    TB_SCALAR_RUN(name, run_closest, TB_CLOSEST_UV)                                         \
    TB_SCALAR_ENTRY(name, time_pairs, TB_PAIRS, 1)                                          \
    TB_SCALAR_ENTRY(name, time_any, TB_ANY, 1)                                              \
    TB_SCALAR_ENTRY(name, time_closest, TB_CLOSEST, 1)                                      \
    TB_SCALAR_ENTRY(name, time_closest_uv, TB_CLOSEST_UV, 1)
#define TB_INSTANTIATE(name, faces, watertight, promised_by, origin, wide) \
    TB_IF_SCALAR(wide, TB_INSTANTIATE_(name)) /* a registration line (list.h) */
#if TB_EMIT_SCALAR
#define TB_ENTRY_ATTR
TB_KERNEL_LIST(TB_INSTANTIATE)
#undef TB_ENTRY_ATTR
#ifndef TB_KERNEL_FILE /* the internal kernels (list.h) */
#define TB_ENTRY_ATTR TB_NO_ICF /* the A/A twins: code of their own */
TB_INSTANTIATE_(moller_trumbore_aa)
TB_INSTANTIATE_(moller_seed_aa)
#undef TB_ENTRY_ATTR
#endif
#endif
#undef TB_INSTANTIATE
#undef TB_INSTANTIATE_
#undef TB_SCALAR_RUN
#undef TB_SCALAR_ENTRY
#ifndef TB_KERNEL_FILE
#include "kernels/moller_trumbore_twice.h" /* its own entry points, from moller_trumbore's */
#include "kernels/moller_trumbore_same.h"  /* the same */
#include "kernels/seed_objects.h"         /* the seed's program around its tests: their own loop */
#include "kernels/moller_seed_object.h"
#include "kernels/curless_seed_object.h"
#endif

/* The native kernels (native.h), one pass per ISA whose loops this file
 * compiles; the first pass of each precision also defines their
 * per-precision parts (TB_NFIRST). A file that compiles none of their ISAs
 * still makes one pass (baseline, no entry points) for those parts. */
#define TB_NFIRST 1
#if (defined(__x86_64__) || defined(__i386__)) && TB_EMIT_avx512
#define TB_NISA avx512
#define TB_NISA_ID 2
#define TB_NTARGET TB_TARGET_AVX512_FMA
#include "native.h"
#undef TB_NTARGET
#undef TB_NISA_ID
#undef TB_NISA
#undef TB_NFIRST
#define TB_NFIRST 0
#endif
#if (defined(__x86_64__) || defined(__i386__)) && TB_EMIT_avx2
#define TB_NISA avx2
#define TB_NISA_ID 1
#define TB_NTARGET TB_TARGET_AVX2_FMA
#include "native.h"
#undef TB_NTARGET
#undef TB_NISA_ID
#undef TB_NISA
#undef TB_NFIRST
#define TB_NFIRST 0
#endif
#if defined(__aarch64__) && TB_EMIT_neon
#define TB_NISA neon
#define TB_NISA_ID 3
#define TB_NTARGET /* AdvSIMD: in every aarch64 build, no attribute needed */
#include "native.h"
#undef TB_NTARGET
#undef TB_NISA_ID
#undef TB_NISA
#undef TB_NFIRST
#define TB_NFIRST 0
#endif
#if TB_EMIT_baseline || TB_NFIRST
#define TB_NISA baseline
#define TB_NISA_ID 0
#define TB_NTARGET
#include "native.h"
#undef TB_NTARGET
#undef TB_NISA_ID
#undef TB_NISA
#endif
#undef TB_NFIRST

#undef vmask
#undef mask_elem
#undef vreal
#undef tb_hit
#undef tb_ray
#undef TB_FN
#undef real

#pragma GCC diagnostic pop
