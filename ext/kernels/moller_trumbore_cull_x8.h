/* moller_trumbore_cull_x8: moller_trumbore_cull, branchless, one ray against
 * 8 triangles.
 *
 * Reference: as moller_trumbore_cull.h (Moller & Trumbore 1997, culling
 * branch, late division; front = det > 0). The same arithmetic in the same
 * order on 8 lanes, so each lane's answer is the scalar kernel's bit for
 * bit: every accept condition is evaluated on all lanes and combined into
 * one mask, with no early exit; the division is done for all lanes (its
 * result is only kept where the mask is set). Records: moller_trumbore's 9
 * reals, in blocks of 8 triangles, structure of arrays.
 * Flat triangles: the scalar form's NaN records, a miss in every lane.
 */

/* per lane and test (rules in kernels.h): edges 6, d x e2 9, det 5, s 3, u 5, q 9, v 5, t 5, 1/det and t 2, tests 11 */
#define tb_moller_trumbore_cull_x8_ops 60

TB_WIDE vmask TB_FN(tb_moller_trumbore_cull_x8_test)(const tb_vray *restrict r,
                                                     const real *restrict block, vreal t_max,
                                                     tb_vhit *restrict h)
{
    vreal a[3], b[3], c[3];
    const vreal *o = r->o, *d = r->d;
    TB_FN(vload3)(block, 0, a);
    TB_FN(vload3)(block, 3, b);
    TB_FN(vload3)(block, 6, c);
    vreal e1[3], e2[3], p[3], s[3], q[3];
    TB_FN(vsub3)(b, a, e1);
    TB_FN(vsub3)(c, a, e2);
    TB_FN(vcross3)(d, e2, p);
    vreal det = TB_FN(vdot3)(e1, p);

    TB_FN(vsub3)(o, a, s);
    vreal u = TB_FN(vdot3)(s, p);
    TB_FN(vcross3)(s, e1, q);
    vreal v = TB_FN(vdot3)(d, q);
    vreal scaled_t = TB_FN(vdot3)(e2, q);

    vreal inv_det = TB_FN(vsplat)(1) / det;
    vreal t = scaled_t * inv_det;
    vmask hit = (det > 0) & (u >= 0) & (u <= det) & (v >= 0) & (u + v <= det) &
                (scaled_t > 0) & (scaled_t < t_max * det) & (t > 0) & (t < t_max);
    h->t = t;
    h->u = u * inv_det;
    h->v = v * inv_det;
    return hit;
}

/* operations per test by class (fma, mul, add, cmp, div, logic), per lane, counted in the compiled AVX2 block loop (tests/test_ext_build.py); see kernels.h */
#define tb_moller_trumbore_cull_x8_mix {0, 26, 24, 9, 1, 15}
