/* moller_trumbore_twice: every test done twice, for the harness's known-effect check.
 *
 * Internal kernel (TB_INTERNAL_KERNEL_LIST). The measurement protocol asks
 * that a kernel doing each test twice come out 2.0x slower than
 * moller_trumbore within its confidence interval; this is that kernel.
 *
 * How the compiler is kept from merging the two tests:
 *  - the second test reads its inputs through pointers passed through an empty
 *    asm barrier, so the compiler cannot prove they are the first test's
 *    inputs and must load and compute everything again;
 *  - the first test's answer (hit and t) is consumed by an empty volatile asm,
 *    so it cannot be dropped as dead code, nor cut short after a miss.
 * Each barrier is an empty instruction string: no instruction is executed,
 * only the optimiser is blinded. Answers are the second test's, which are
 * moller_trumbore's. Prepared data: the raw vertices (9 reals). */

/* Consume an int and a real without executing anything: in registers where
 * the target has a constraint for floating-point registers ("x": SSE/AVX on
 * x86, "w": SIMD&FP on AArch64), else anywhere ("g" may go through memory).
 * Defined once; kernels.h includes this file for each precision. */
#ifndef TB_KEEP
#if defined(__x86_64__) || defined(__i386__)
#define TB_KEEP(i, r) __asm__ volatile("" : : "r"(i), "x"(r))
#elif defined(__aarch64__)
#define TB_KEEP(i, r) __asm__ volatile("" : : "r"(i), "w"(r))
#else
#define TB_KEEP(i, r) __asm__ volatile("" : : "g"(i), "g"(r))
#endif
#endif

#define tb_moller_trumbore_twice_stride 9 /* reals per prepared triangle, either precision */
#define tb_moller_trumbore_twice_prepare_f32 tb_prepare_vertices_f32
#define tb_moller_trumbore_twice_prepare_f64 tb_prepare_vertices_f64

static inline int TB_FN(tb_moller_trumbore_twice_test)(const real *restrict o,
                                                       const real *restrict d,
                                                       const real *restrict tri,
                                                       real *restrict t_out)
{
    /* first test: its answer is kept alive by the asm, then forgotten */
    real t_first = 0;
    int hit_first = TB_FN(tb_moller_trumbore_test)(o, d, tri, &t_first);
    TB_KEEP(hit_first, t_first);

    /* second test on the same inputs, reached through opaque pointers */
    const real *o2 = o, *d2 = d, *tri2 = tri;
    __asm__ volatile("" : "+r"(o2), "+r"(d2), "+r"(tri2));
    return TB_FN(tb_moller_trumbore_test)(o2, d2, tri2, t_out);
}
