/* moller_trumbore_twice: moller_trumbore with every timed pass done twice,
 * for the harness's known-effect check.
 *
 * Internal kernel (TB_INTERNAL_KERNEL_LIST). The measurement protocol asks
 * that a kernel doing each test twice come out 2.0x slower than
 * moller_trumbore within its confidence interval. For that check to test the
 * harness, the true ratio must be known exactly, so the doubling is done
 * where it cannot change the code: a timed batch of `loops` passes runs
 * moller_trumbore's own loop for 2 x loops passes and reports the tests,
 * hits and sums of `loops` passes. Every cost per pass (tests, loop
 * overhead, cache traffic) doubles; only the two clock reads per batch do
 * not, which at the harness's batch length (milliseconds) moves the ratio by
 * under 1e-4. (An earlier form ran each test twice back to back behind
 * compiler barriers: the barriers changed the code, which then cost 2.03x
 * the instructions and 2.07x the time, so its true ratio was unknown.)
 * Untimed runs give moller_trumbore's answers. Included by kernels.h after
 * moller_trumbore's entry points exist (its entry points too are defined
 * only where those are, TB_EMIT_SCALAR). */

#define tb_moller_trumbore_twice_stride tb_moller_trumbore_stride
#define tb_moller_trumbore_twice_ops (2 * tb_moller_trumbore_ops)
#define tb_moller_trumbore_twice_flat tb_moller_trumbore_flat
#define tb_moller_trumbore_twice_prepare_f32 tb_prepare_vertices_f32
#define tb_moller_trumbore_twice_prepare_f64 tb_prepare_vertices_f64

#define TB_TWICE_RUN(fn_mode)                                               \
    TB_HIDDEN void TB_FN(tb_moller_trumbore_twice_##fn_mode)(tb_job *job)   \
    {                                                                       \
        TB_FN(tb_moller_trumbore_##fn_mode)(job);                           \
    }
/* halving is exact for the counts; the sums of 2 x loops passes halved
 * equal the sums of loops passes to rounding */
#define TB_TWICE_TIME(fn_mode)                                              \
    TB_HIDDEN void TB_FN(tb_moller_trumbore_twice_##fn_mode)(tb_job *job)   \
    {                                                                       \
        job->loops *= 2;                                                    \
        TB_FN(tb_moller_trumbore_##fn_mode)(job);                           \
        job->loops /= 2;                                                    \
        job->tests /= 2;                                                    \
        job->hits /= 2;                                                     \
        job->t_sum /= 2;                                                    \
        job->uv_sum /= 2;                                                   \
    }
#if TB_EMIT_SCALAR /* in the file that compiles moller_trumbore's (kernels.h) */
TB_TWICE_RUN(run_pairs)
TB_TWICE_RUN(run_any)
TB_TWICE_RUN(run_closest)
TB_TWICE_TIME(time_pairs)
TB_TWICE_TIME(time_any)
TB_TWICE_TIME(time_closest)
TB_TWICE_TIME(time_closest_uv)
#endif
#undef TB_TWICE_RUN
#undef TB_TWICE_TIME

/* per class: twice moller_trumbore's (fma, mul, add, cmp, div, logic) */
#define tb_moller_trumbore_twice_mix {0, 60, 48, 20, 2, 0}
