/* baldwin_weber_12_x8: baldwin_weber_12, branchless, one ray against 8
 * triangles.
 *
 * Reference: as baldwin_weber_12.h (Baldwin & Weber, JCGT 5(3), 2016). The
 * same arithmetic in the same order on 8 lanes, so each lane's answer is the
 * scalar kernel's bit for bit: the t test and the barycentric tests are all
 * evaluated and combined into one mask, with no early exit. Records:
 * baldwin_weber_12's 12 reals (rows U, V, W), in blocks of 8 triangles,
 * structure of arrays.
 * Flat triangles: the scalar form's NaN records, a miss in every lane.
 */

/* per lane and test (rules in kernels.h): plane row on o 6 and on d 5, t 1, hit point 6, u 6, v 6, tests 7 */
#define tb_baldwin_weber_12_x8_ops 37

TB_WIDE vmask TB_FN(tb_baldwin_weber_12_x8_test)(const tb_vray *restrict r,
                                                 const real *restrict block, vreal t_max,
                                                 tb_vhit *restrict h)
{
    vreal row_u[3], row_v[3], row_w[3];
    const vreal *o = r->o, *d = r->d;
    TB_FN(vload3)(block, 0, row_u);
    vreal const_u = TB_FN(vload)(block + 8 * 3);
    TB_FN(vload3)(block, 4, row_v);
    vreal const_v = TB_FN(vload)(block + 8 * 7);
    TB_FN(vload3)(block, 8, row_w);
    vreal const_w = TB_FN(vload)(block + 8 * 11);
    vreal w_o = TB_FN(vdot3)(row_w, o) + const_w;
    vreal w_d = TB_FN(vdot3)(row_w, d);
    vreal t = -w_o / w_d;
    vreal p[3];
    for (int k = 0; k < 3; ++k)
        p[k] = o[k] + t * d[k];
    vreal u = TB_FN(vdot3)(row_u, p) + const_u;
    vreal v = TB_FN(vdot3)(row_v, p) + const_v;
    vmask hit = (t > 0) & (t < t_max) & (u >= 0) & (u <= 1) & (v >= 0) & (u + v <= 1);
    h->t = t;
    h->u = u;
    h->v = v;
    return hit;
}

/* operations per test by class (fma, mul, add, cmp, div, logic), per lane, counted in the compiled AVX2 block loop (tests/test_ext_build.py); see kernels.h */
#define tb_baldwin_weber_12_x8_mix {0, 15, 15, 6, 1, 13}
