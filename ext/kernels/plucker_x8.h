/* plucker_x8: plucker, branchless, one ray against 8 triangles.
 *
 * Reference: as plucker.h (Plucker edge tests, Jones 2000, Amanatides & Choi
 * 1997; origin-shifted as in Wald et al., Embree, ACM TOG 33(4), 2014). The
 * same arithmetic in the same order on 8 lanes, so each lane's answer is the
 * scalar kernel's bit for bit: every accept condition is evaluated on all
 * lanes and combined into one mask, with no early exit; both divisions are
 * done for all lanes (kept only where the mask is set). Records: plucker's
 * 9 reals (raw vertices), in blocks of 8 triangles, structure of arrays.
 * Flat triangles: the scalar form's NaN records, a miss in every lane.
 */

/* ((q - p) x (p + q)) . d on 8 lanes (see tb_plucker_side) */
TB_WIDE vreal TB_FN(tb_plucker_x8_side)(const vreal *p, const vreal *q, const vreal *edge,
                                        const vreal *d)
{
    vreal through[3] = {p[0] + q[0], p[1] + q[1], p[2] + q[2]}, moment[3];
    TB_FN(vcross3)(edge, through, moment);
    return TB_FN(vdot3)(moment, d);
}

/* per lane and test (rules in kernels.h): translate 9, edges 9, sides 51, sum 2, tolerance 2, signs 6, normal 9, den 5, scaled t 5, sign 2, t 2, tests 8 */
#define tb_plucker_x8_ops 110

TB_WIDE vmask TB_FN(tb_plucker_x8_test)(const tb_vray *restrict r, const real *restrict block,
                                        vreal t_max, tb_vhit *restrict h)
{
    vreal a[3], b[3], c[3];
    const vreal *o = r->o, *d = r->d;
    TB_FN(vload3)(block, 0, a);
    TB_FN(vload3)(block, 3, b);
    TB_FN(vload3)(block, 6, c);
    /* vertices relative to the origin, and the edges a -> b -> c -> a */
    TB_FN(vsub3)(a, o, a);
    TB_FN(vsub3)(b, o, b);
    TB_FN(vsub3)(c, o, c);
    vreal ab[3], bc[3], ca[3];
    TB_FN(vsub3)(b, a, ab);
    TB_FN(vsub3)(c, b, bc);
    TB_FN(vsub3)(a, c, ca);

    /* edge tests: one sign within the tolerance, zeros either way */
    vreal side_bc = TB_FN(tb_plucker_x8_side)(b, c, bc, d);
    vreal side_ca = TB_FN(tb_plucker_x8_side)(c, a, ca, d);
    vreal side_ab = TB_FN(tb_plucker_x8_side)(a, b, ab, d);
    vreal sum = side_bc + side_ca + side_ab;
    vreal zero = TB_FN(vsplat)(0);
    vreal abs_sum = TB_FN(vselect)(sum < zero, -sum, sum);
    vreal tolerance = TB_FN(vsplat)(TB_FN(tb_plucker_tolerance)) * abs_sum;
    vmask same_sign =
        ((side_bc >= -tolerance) & (side_ca >= -tolerance) & (side_ab >= -tolerance)) |
        ((side_bc <= tolerance) & (side_ca <= tolerance) & (side_ab <= tolerance));

    /* depth test on the plane of the geometric normal, sign folded in */
    vreal n[3];
    TB_FN(vcross3)(ca, ab, n);
    vreal den = TB_FN(vdot3)(n, d);
    vreal scaled_t = TB_FN(vdot3)(n, a);
    vreal one = TB_FN(vsplat)(1);
    vreal sign = TB_FN(vselect)(den < zero, -one, one);
    vreal abs_den = sign * den;

    vreal t = scaled_t * (one / den);
    vreal inv_sum = one / sum;
    vmask hit = same_sign & (sum != zero) & (den != zero) & (sign * scaled_t > zero) &
                (sign * scaled_t < t_max * abs_den) & (t > zero) & (t < t_max);
    h->t = t;
    h->u = side_ca * inv_sum;
    h->v = side_ab * inv_sum;
    return hit;
}

/* operations per test by class (fma, mul, add, cmp, div, logic), per lane, counted in the compiled AVX2 block loop (tests/test_ext_build.py); see kernels.h */
#define tb_plucker_x8_mix {0, 44, 51, 14, 1, 20}
