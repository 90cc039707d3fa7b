/* Kernels and their batch loops for one precision.
 *
 * No include guard: _core.c includes this file twice, with TB_REAL = float,
 * TB_SUFFIX = _f32 and with TB_REAL = double, TB_SUFFIX = _f64, so every
 * kernel is written once over `real` (one typedef for the precision, as pbrt
 * does) and every symbol gets the precision as a suffix.
 *
 * A kernel file defines, for the current precision:
 *   tb_<name>_stride              macro: reals per prepared triangle record
 *   void   tb_<name>_prepare(const real *vertices, size_t n, real *out)
 *   int    tb_<name>_test(o, d, record, &t)   1 and t on a hit, 0 on a miss
 * and nothing else; the loops below are instantiated once per kernel, so the
 * test inlines into them and dispatch happens once per batch. */

#define real TB_REAL
#define TB_FN(name) TB_CAT(name, TB_SUFFIX)

#include "kernels/vec.h"
#include "kernels/curless_seed.h"
#include "kernels/moller_seed.h"
#include "kernels/curless.h"
#include "kernels/moller_trumbore.h"
#include "kernels/moller_trumbore_aa.h"
#include "kernels/moller_trumbore_twice.h"

/* The four loops of one kernel. `always_inline` plus a constant function
 * pointer lets GCC and Clang inline the test into each instantiation. */
typedef int (*TB_FN(tb_test_fn))(const real *restrict, const real *restrict,
                                 const real *restrict, real *restrict);

/* ray i against record i, writing hit and t (t = NaN on a miss) */
static inline __attribute__((always_inline)) void
TB_FN(tb_run_pairs)(TB_FN(tb_test_fn) test, size_t stride, const tb_job *job)
{
    const real *o = job->origins, *d = job->directions, *tri = job->records;
    real *t_out = job->t_out;
    for (size_t i = 0; i < job->n_rays; ++i) {
        real t = (real)NAN;
        job->hit_out[i] = (uint8_t)test(o + 3 * i, d + 3 * i, tri + stride * i, &t);
        t_out[i] = job->hit_out[i] ? t : (real)NAN;
    }
}

/* every ray against every record; the closest hit, ties to the lowest index */
static inline __attribute__((always_inline)) void
TB_FN(tb_run_closest)(TB_FN(tb_test_fn) test, size_t stride, const tb_job *job)
{
    const real *o = job->origins, *d = job->directions, *tri = job->records;
    real *t_out = job->t_out;
    for (size_t i = 0; i < job->n_rays; ++i) {
        real best = (real)INFINITY, t;
        int64_t index = -1;
        for (size_t j = 0; j < job->n_records; ++j)
            if (test(o + 3 * i, d + 3 * i, tri + stride * j, &t) && t < best) {
                best = t;
                index = (int64_t)j;
            }
        job->index_out[i] = index;
        t_out[i] = index >= 0 ? best : (real)NAN;
    }
}

/* timed form of run_pairs: `loops` passes, results folded into a checksum
 * (the checksum also keeps the compiler from deleting the work) */
static inline __attribute__((always_inline)) void
TB_FN(tb_time_pairs)(TB_FN(tb_test_fn) test, size_t stride, tb_job *job)
{
    const real *o = job->origins, *d = job->directions, *tri = job->records;
    uint64_t hits = 0;
    double t_sum = 0;
    for (uint64_t pass = 0; pass < job->loops; ++pass)
        for (size_t i = 0; i < job->n_rays; ++i) {
            real t;
            if (test(o + 3 * i, d + 3 * i, tri + stride * i, &t)) {
                ++hits;
                t_sum += t;
            }
        }
    job->hits = hits;
    job->t_sum = t_sum;
}

/* timed form of run_closest */
static inline __attribute__((always_inline)) void
TB_FN(tb_time_closest)(TB_FN(tb_test_fn) test, size_t stride, tb_job *job)
{
    const real *o = job->origins, *d = job->directions, *tri = job->records;
    uint64_t hits = 0;
    double t_sum = 0;
    for (uint64_t pass = 0; pass < job->loops; ++pass)
        for (size_t i = 0; i < job->n_rays; ++i) {
            real best = (real)INFINITY, t;
            int found = 0;
            for (size_t j = 0; j < job->n_records; ++j)
                if (test(o + 3 * i, d + 3 * i, tri + stride * j, &t) && t < best) {
                    best = t;
                    found = 1;
                }
            if (found) {
                ++hits;
                t_sum += best;
            }
        }
    job->hits = hits;
    job->t_sum = t_sum;
}

/* One set of entry points per kernel: the only place loops meet kernels. */
#define TB_INSTANTIATE(name)                                                              \
    static void TB_FN(tb_##name##_run_pairs)(tb_job *job)                                 \
    {                                                                                     \
        TB_FN(tb_run_pairs)(TB_FN(tb_##name##_test), tb_##name##_stride, job);    \
    }                                                                                     \
    static void TB_FN(tb_##name##_run_closest)(tb_job *job)                               \
    {                                                                                     \
        TB_FN(tb_run_closest)(TB_FN(tb_##name##_test), tb_##name##_stride, job);  \
    }                                                                                     \
    static void TB_FN(tb_##name##_time_pairs)(tb_job *job)                                \
    {                                                                                     \
        TB_FN(tb_time_pairs)(TB_FN(tb_##name##_test), tb_##name##_stride, job);   \
    }                                                                                     \
    static void TB_FN(tb_##name##_time_closest)(tb_job *job)                              \
    {                                                                                     \
        TB_FN(tb_time_closest)(TB_FN(tb_##name##_test), tb_##name##_stride, job); \
    }
TB_KERNEL_LIST(TB_INSTANTIATE)
TB_INTERNAL_KERNEL_LIST(TB_INSTANTIATE)
#undef TB_INSTANTIATE

#undef TB_FN
#undef real
