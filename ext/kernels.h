/* Kernels and their batch loops for one precision.
 *
 * No include guard: a file of the module (core.h lists them) includes this
 * file once per precision it compiles, with TB_REAL = float, TB_SUFFIX = _f32
 * or with TB_REAL = double, TB_SUFFIX = _f64, so every kernel is written once
 * over `real` (one typedef for the precision, as pbrt does) and every symbol
 * gets the precision as a suffix.
 *
 * Which loops the including file compiles, each 0 or 1, all four defined:
 *   TB_EMIT_SCALAR    the scalar kernels' entry points (isa_baseline_<p>.c)
 *   TB_EMIT_avx512, TB_EMIT_avx2, TB_EMIT_baseline
 *                     the _x8 forms', the native kernels' and the BVH
 *                     traversal's entry points for that ISA (isa_<isa>.c)
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
 * A wide kernel file kernels/<name>_x8.h adds, for a kernel of the same name:
 *   vmask tb_<name>_x8_test(const tb_vray *r, const real *lanes, vreal t_max, tb_vhit *h)
 *                        the same test, branchless, on one vector's worth of
 *                        the triangles of a block of 8 (field f of lane l at
 *                        lanes[8 f + l]: the block, or its second half for
 *                        double); a lane of the mask is all ones on a hit
 *   tb_<name>_x8_ops     macro: operations per test and lane
 * and reuses the scalar stride, prepare and ray. The loops below are
 * instantiated once per kernel, mode and ISA, so tests inline into them and
 * dispatch happens once per batch. The loops pass the best t so far as
 * t_max, as a ray tracer shrinks its interval; a kernel that reads u and v
 * only for the closest_uv mode has their arithmetic removed elsewhere as
 * dead code.
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

#if !defined(TB_EMIT_SCALAR) || !defined(TB_EMIT_avx512) || !defined(TB_EMIT_avx2) || !defined(TB_EMIT_baseline)
#error "define TB_EMIT_SCALAR, TB_EMIT_avx512, TB_EMIT_avx2 and TB_EMIT_baseline (0 or 1) before kernels.h"
#endif
/* TB_IF_EMIT(isa, ...): the rest of the arguments if this file compiles that ISA's loops */
#define TB_IF_EMIT(isa, ...) TB_CAT(TB_IF_EMIT_, TB_EMIT_##isa)(__VA_ARGS__)
#define TB_IF_EMIT_0(...)
#define TB_IF_EMIT_1(...) __VA_ARGS__

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
#define tb_vhit TB_FN(tb_vhit)
#define tb_vray TB_FN(tb_vray)

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
 * register), and masks of the same width (lane = all ones or zero, as vector
 * comparisons yield). GCC/Clang vector extensions: the compiler lowers them to
 * the ISA of the function they are used in. A block of 8 triangles is one
 * vector of floats or two of doubles. (Wider generic vectors are no gain:
 * GCC lowers a 64-byte vector comparison to scalar compares without
 * AVX-512, which made an 8-double form 7x slower than the 8-float one.) */
typedef real vreal __attribute__((vector_size(32)));
#define mask_elem TB_FN(tb_mask_elem)
#if TB_REAL_IS_DOUBLE
typedef int64_t mask_elem;
#else
typedef int32_t mask_elem;
#endif
typedef mask_elem vmask __attribute__((vector_size(32)));
#define TB_VLANES ((int)(sizeof(vreal) / sizeof(real))) /* lanes per vector */
#define TB_VPB (8 / TB_VLANES)                           /* vectors per block */

typedef struct {
    vreal t, u, v;
} tb_vhit;

/* A ray with every real field in every lane, built once per ray by the wide
 * loop: a splat written inside a kernel is redone for every block (the
 * compiler does not hoist it out of the triangle loop), which cost MT_x8
 * about a third of its time. */
typedef struct {
    vreal o[3], d[3];
    int kx, ky, kz;
    vreal sx, sy, sz;
} tb_vray;

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

#include "kernels/curless_x8.h"
#include "kernels/moller_trumbore_x8.h"
#include "kernels/moller_trumbore_cull_x8.h"
#include "kernels/baldwin_weber_12_x8.h"
#include "kernels/baldwin_weber_9_x8.h"
#include "kernels/havel_herout_x8.h"
#include "kernels/woop_x8.h"
#include "kernels/plucker_x8.h"
#endif

typedef int (*TB_FN(tb_test_fn))(const tb_ray *restrict, const real *restrict, real,
                                 tb_hit *restrict);
typedef void (*TB_FN(tb_ray_fn))(const real *, const real *, tb_ray *);
typedef vmask (*TB_FN(tb_wide_fn))(const tb_vray *restrict, const real *restrict, vreal,
                                   tb_vhit *restrict);

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

/* One batch of a wide kernel: each ray against blocks of 8 triangles, one
 * vector (float) or two (double) at a time. Each lane keeps its own closest
 * hit (its t is that lane's t_max for the next block), so lanes never talk to
 * each other inside the triangle loop; one reduction per ray picks the
 * closest lane, ties to the lowest index. Lanes past the last triangle are
 * masked off. Pairs are not a wide mode (one ray against one triangle has no
 * triangles to spread over lanes). Signals: as the scalar loop. */
static inline __attribute__((always_inline)) void
TB_FN(tb_wide_loop)(TB_FN(tb_wide_fn) test, TB_FN(tb_ray_fn) make_ray, size_t stride,
                    tb_job *job, const int mode, const int timed)
{
    const real *o = job->origins, *d = job->directions, *rec = job->records;
    const real *t_max = job->t_max;
    const size_t n_blocks = (job->n_records + 7) / 8;
    vmask lane[TB_VPB], tail[TB_VPB]; /* triangle index within a block; lanes in use in the last */
    for (int v = 0; v < TB_VPB; ++v)
        for (int l = 0; l < TB_VLANES; ++l) {
            size_t in_block = (size_t)(v * TB_VLANES + l);
            lane[v][l] = (mask_elem)in_block;
            tail[v][l] = (n_blocks - 1) * 8 + in_block < job->n_records ? -1 : 0;
        }
    uint64_t hits = 0, tests = 0, rays = 0, poll_at = 1;
    double t_sum = 0, uv_sum = 0;
    const uint64_t loops = timed ? job->loops : 1;
    for (uint64_t pass = 0; pass < loops; ++pass)
        for (size_t i = 0; i < job->n_rays; ++i) {
            if (++rays == poll_at && !(poll_at = tb_poll(job, rays)))
                goto stop;
            tb_ray scalar_ray;
            tb_vray r;
            make_ray(o + 3 * i, d + 3 * i, &scalar_ray);
            TB_FN(vray_splat)(&scalar_ray, &r);
            tb_vhit best[TB_VPB];
            vmask index[TB_VPB];
            for (int v = 0; v < TB_VPB; ++v) {
                best[v].t = TB_FN(vsplat)(t_max[i]);
                best[v].u = best[v].v = TB_FN(vsplat)((real)NAN);
                index[v] = lane[v] * 0 - 1;
            }
            size_t b = 0;
            for (; b < n_blocks; ++b) {
                int found = 0;
                for (int v = 0; v < TB_VPB; ++v) {
                    tb_vhit h;
                    vmask m = test(&r, rec + stride * 8 * b + v * TB_VLANES, best[v].t, &h);
                    if (b == n_blocks - 1)
                        m &= tail[v];
                    /* most blocks have no hit: skip the bookkeeping on one branch */
                    if (!TB_FN(vany)(m))
                        continue;
                    best[v].t = TB_FN(vselect)(m, h.t, best[v].t);
                    if (mode == TB_CLOSEST_UV || !timed) {
                        best[v].u = TB_FN(vselect)(m, h.u, best[v].u);
                        best[v].v = TB_FN(vselect)(m, h.v, best[v].v);
                    }
                    index[v] = (m & (lane[v] + (mask_elem)(8 * b))) | (~m & index[v]);
                    found = 1;
                }
                if (mode == TB_ANY && found) {
                    ++b;
                    break;
                }
            }
            /* triangles tested (the masked lanes of the last block are not tests) */
            tests += b < n_blocks ? 8 * b : job->n_records;
            /* the closest lane; ties to the lowest triangle index */
            int best_v = -1, best_l = -1;
            for (int v = 0; v < TB_VPB; ++v)
                for (int l = 0; l < TB_VLANES; ++l)
                    if (index[v][l] >= 0 &&
                        (best_v < 0 || best[v].t[l] < best[best_v].t[best_l] ||
                         (best[v].t[l] == best[best_v].t[best_l] &&
                          index[v][l] < index[best_v][best_l]))) {
                        best_v = v;
                        best_l = l;
                    }
            if (timed) {
                if (best_v >= 0) {
                    ++hits;
                    t_sum += best[best_v].t[best_l];
                    if (mode == TB_CLOSEST_UV)
                        uv_sum += (double)best[best_v].u[best_l] + best[best_v].v[best_l];
                }
            } else {
                real *t_out = job->t_out, *u_out = job->u_out, *v_out = job->v_out;
                int found = best_v >= 0;
                job->index_out[i] = found ? (int64_t)index[best_v][best_l] : -1;
                t_out[i] = found ? best[best_v].t[best_l] : (real)NAN;
                u_out[i] = found ? best[best_v].u[best_l] : (real)NAN;
                v_out[i] = found ? best[best_v].v[best_l] : (real)NAN;
            }
        }
stop:
    job->hits = hits;
    job->tests = tests;
    job->t_sum = t_sum;
    job->uv_sum = uv_sum;
}

/* Entry points of one scalar kernel: the only place loops meet kernels.
 * run_<kernel> handles every mode (untimed: speed does not matter);
 * time_<kernel>_<mode> is one function per mode. */
#define TB_SCALAR_ENTRY(name, fn_mode, mode, timed)                                         \
    TB_HIDDEN TB_ENTRY_ATTR void TB_FN(tb_##name##_##fn_mode)(tb_job *job)                  \
    {                                                                                       \
        TB_FN(tb_scalar_loop)(TB_FN(tb_##name##_test), TB_FN(tb_##name##_ray),              \
                              tb_##name##_stride, job, mode, timed);                        \
    }
#define TB_INSTANTIATE_(name)                                        \
    TB_SCALAR_ENTRY(name, run_pairs, TB_PAIRS, 0)                    \
    TB_SCALAR_ENTRY(name, run_any, TB_ANY, 0)                        \
    TB_SCALAR_ENTRY(name, run_closest, TB_CLOSEST_UV, 0)             \
    TB_SCALAR_ENTRY(name, time_pairs, TB_PAIRS, 1)                   \
    TB_SCALAR_ENTRY(name, time_any, TB_ANY, 1)                       \
    TB_SCALAR_ENTRY(name, time_closest, TB_CLOSEST, 1)               \
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
#ifndef TB_KERNEL_FILE
#include "kernels/moller_trumbore_twice.h" /* its own entry points, from moller_trumbore's */
#include "kernels/moller_trumbore_same.h"  /* the same */
#include "kernels/seed_objects.h"         /* the seed's program around its tests: their own loop */
#include "kernels/moller_seed_object.h"
#include "kernels/curless_seed_object.h"
#endif

/* Entry points of one wide kernel for one ISA: the same source compiled
 * for each instruction set by a target attribute (the kernels and helpers
 * are always_inline, so they are compiled with their caller's ISA). */
#define TB_WIDE_ENTRY(name, isa, target, fn_mode, mode, timed)                              \
    target TB_HIDDEN void TB_FN(tb_##name##_x8_##fn_mode##_##isa)(tb_job *job)              \
    {                                                                                       \
        TB_FN(tb_wide_loop)(TB_FN(tb_##name##_x8_test), TB_FN(tb_##name##_ray),             \
                            tb_##name##_stride, job, mode, timed);                          \
    }
#define TB_WIDE_ISA(name, isa, target)                                               \
    TB_IF_EMIT(isa, TB_WIDE_ENTRY(name, isa, target, run_any, TB_ANY, 0)             \
               TB_WIDE_ENTRY(name, isa, target, run_closest, TB_CLOSEST_UV, 0)       \
               TB_WIDE_ENTRY(name, isa, target, time_any, TB_ANY, 1)                 \
               TB_WIDE_ENTRY(name, isa, target, time_closest, TB_CLOSEST, 1)         \
               TB_WIDE_ENTRY(name, isa, target, time_closest_uv, TB_CLOSEST_UV, 1))
#define TB_INSTANTIATE_WIDE(name, faces, watertight, promised_by, origin, wide) \
    TB_IF_X8(wide, TB_ISA_LIST(TB_WIDE_ISA, name))
TB_KERNEL_LIST(TB_INSTANTIATE_WIDE)
#undef TB_INSTANTIATE_WIDE

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

#undef TB_VPB
#undef TB_VLANES
#undef tb_vhit
#undef tb_vray
#undef vmask
#undef mask_elem
#undef vreal
#undef tb_hit
#undef tb_ray
#undef TB_FN
#undef real

#pragma GCC diagnostic pop
#undef TB_IF_EMIT_1
#undef TB_IF_EMIT_0
#undef TB_IF_EMIT
