/* moller_trumbore_yardstick: a plain AVX2 intrinsics Moller-Trumbore, as
 * anyone would first write it: the yardstick bench/yardstick.py times the
 * kernels against (an internal kernel: timed by the same loop, checked
 * against the same reference).
 *
 * Reference: Moller & Trumbore 1997, the textbook form: edges recomputed per
 * test from the raw vertices, no FMA, every lane through all the work, one
 * division (1 / det) per vector, then u, v, t divided and tested against
 * [0, 1] and (0, t_max). AVX2 only: 8 float / 4 double lanes (native.h's
 * loop, AVX2 pass), written with _mm256 intrinsics. It hands the loop its
 * divided t, u, v over a denominator of 1 (dividing by 1 is exact).
 * Prepared data: the raw vertices (9 reals). Flat triangles: NaN records.
 */

#if TB_NFIRST
#define tb_moller_trumbore_yardstick_algorithm "moller_trumbore" /* the clean scalar kernel it is a form of */
#define tb_moller_trumbore_yardstick_stride 9
#define tb_moller_trumbore_yardstick_flat TB_FLAT_MISS
#define tb_moller_trumbore_yardstick_prepare_f32 tb_prepare_vertices_f32
#define tb_moller_trumbore_yardstick_prepare_f64 tb_prepare_vertices_f64
#define tb_moller_trumbore_yardstick_ray_f32 tb_ray_plain_f32
#define tb_moller_trumbore_yardstick_ray_f64 tb_ray_plain_f64
/* per lane and test: edges 6, p 9, det 5, s 3, u 5, q 9, v 5, t 5, 1/det 1,
 * u v t 3, u + v 1, tests 5 (the loop's division by 1 and its two tests
 * fold into these) */
#define tb_moller_trumbore_yardstick_ops 57
#endif

#if TB_NISA_ID == 1
#if TB_REAL_IS_DOUBLE
#define TB_Y(op) _mm256_##op##_pd
#else
#define TB_Y(op) _mm256_##op##_ps
#endif
TB_NWIDE nmask TB_NFN(tb_moller_trumbore_yardstick_test)(const tb_nray *restrict r,
                                                         const real *restrict lanes, nreal t_max,
                                                         tb_nhit *restrict h)
{
    nreal a[3], e1[3], e2[3], p[3], s[3], q[3];
    for (int k = 0; k < 3; ++k) {
        a[k] = TB_Y(loadu)(lanes + TB_NBLOCK * k);
        e1[k] = TB_Y(sub)(TB_Y(loadu)(lanes + TB_NBLOCK * (3 + k)), a[k]);
        e2[k] = TB_Y(sub)(TB_Y(loadu)(lanes + TB_NBLOCK * (6 + k)), a[k]);
    }
    const nreal *o = r->o, *d = r->d;
#define TB_YCROSS(x, y, out)                                                                 \
    for (int k = 0; k < 3; ++k)                                                              \
        out[k] = TB_Y(sub)(TB_Y(mul)(x[(k + 1) % 3], y[(k + 2) % 3]),                        \
                           TB_Y(mul)(x[(k + 2) % 3], y[(k + 1) % 3]));
#define TB_YDOT(x, y)                                                                        \
    TB_Y(add)(TB_Y(add)(TB_Y(mul)(x[0], y[0]), TB_Y(mul)(x[1], y[1])), TB_Y(mul)(x[2], y[2]))
    TB_YCROSS(d, e2, p)
    nreal det = TB_YDOT(e1, p);
    for (int k = 0; k < 3; ++k)
        s[k] = TB_Y(sub)(o[k], a[k]);
    TB_YCROSS(s, e1, q)
    const nreal one = TB_Y(set1)(1), zero = TB_Y(setzero)();
    nreal inv_det = TB_Y(div)(one, det);
    nreal u = TB_Y(mul)(TB_YDOT(s, p), inv_det);
    nreal v = TB_Y(mul)(TB_YDOT(d, q), inv_det);
    nreal t = TB_Y(mul)(TB_YDOT(e2, q), inv_det);
#undef TB_YDOT
#undef TB_YCROSS
    nmask hit = TB_Y(and)(TB_Y(and)(TB_Y(cmp)(u, zero, _CMP_GE_OQ), TB_Y(cmp)(v, zero, _CMP_GE_OQ)),
                          TB_Y(cmp)(TB_Y(add)(u, v), one, _CMP_LE_OQ));
    hit = TB_Y(and)(hit, TB_Y(and)(TB_Y(cmp)(t, zero, _CMP_GT_OQ), TB_Y(cmp)(t, t_max, _CMP_LT_OQ)));
    h->t = t;
    h->u = u;
    h->v = v;
    h->den = one;
    return hit;
}
#undef TB_Y
#endif

/* operations per test by class (fma, mul, add, cmp, div, logic), per lane: the count above by class
 * (mul 27, add 24, cmp 5, div 1); logic from its compiled AVX2 loop (27 per 16 lanes); see kernels.h */
#define tb_moller_trumbore_yardstick_mix {0, 27, 24, 5, 1, 14}
