/* havel_herout_x8: havel_herout, branchless, one ray against 8 triangles.
 *
 * Reference: as havel_herout.h (Havel & Herout, IEEE TVCG 16(3), 2010). The
 * paper's own form: all sign tests combined into one mask, as its SSE4 code
 * does, here as comparisons after the sign fold. The same arithmetic in the
 * same order as the scalar kernel on 8 lanes, so each lane's answer is the
 * scalar's bit for bit; the division is done for all lanes (its result is
 * only kept where the mask is set). Records: havel_herout's 12 reals, in
 * blocks of 8 triangles, structure of arrays.
 * Flat triangles: the scalar form's NaN records, a miss in every lane.
 */

/* per lane and test (rules in kernels.h): det 5, scaled t 6, sign 3, p 9, u 8, v 8, 1/det and t 2, tests 11 */
#define tb_havel_herout_x8_ops 52

TB_WIDE vmask TB_FN(tb_havel_herout_x8_test)(const tb_vray *restrict r, const real *restrict block,
                                             vreal t_max, tb_vhit *restrict h)
{
    vreal plane[3], plane_u[3], plane_v[3];
    const vreal *o = r->o, *d = r->d;
    TB_FN(vload3)(block, 0, plane);
    vreal plane_c = TB_FN(vload)(block + 8 * 3);
    TB_FN(vload3)(block, 4, plane_u);
    vreal plane_u_c = TB_FN(vload)(block + 8 * 7);
    TB_FN(vload3)(block, 8, plane_v);
    vreal plane_v_c = TB_FN(vload)(block + 8 * 11);
    vreal det = TB_FN(vdot3)(plane, d);
    vreal scaled_t = plane_c - TB_FN(vdot3)(plane, o);
    vreal one = TB_FN(vsplat)(1);
    vreal sign = TB_FN(vselect)(det < 0, -one, one);
    vreal abs_det = sign * det;
    vreal t_s = sign * scaled_t;

    vreal p[3];
    for (int k = 0; k < 3; ++k)
        p[k] = det * o[k] + scaled_t * d[k];
    vreal u = sign * (TB_FN(vdot3)(plane_u, p) + det * plane_u_c);
    vreal v = sign * (TB_FN(vdot3)(plane_v, p) + det * plane_v_c);

    vreal inv_det = one / abs_det;
    vreal t = t_s * inv_det;
    vmask hit = (det != 0) & (t_s > 0) & (t_s < t_max * abs_det) & (u >= 0) & (v >= 0) &
                (abs_det - u - v >= 0) & (t > 0) & (t < t_max);
    h->t = t;
    h->u = u * inv_det;
    h->v = v * inv_det;
    return hit;
}

/* operations per test by class (fma, mul, add, cmp, div, logic), per lane, counted in the compiled AVX2 block loop (tests/test_ext_build.py); see kernels.h */
#define tb_havel_herout_x8_mix {0, 26, 16, 9, 1, 14}
