/* woop_x8: woop, branchless, one ray against 8 triangles.
 *
 * Reference: as woop.h (Woop, Benthin & Wald, JCGT 2(1):65-82, 2013). The
 * same arithmetic in the same order on 8 lanes, so each lane's answer is the
 * scalar kernel's bit for bit: every accept condition is evaluated on all
 * lanes and combined into one mask, with no early exit; the division is done
 * for all lanes (kept only where the mask is set). The axes kx, ky, kz are
 * the ray's, so the permutation is a choice of which fields to load.
 *
 * Deviation from branchless: the paper's fallback for a 0 edge function is
 * one branch, taken only when some lane has a 0 (rare off exactly
 * representable edges and vertices); it redoes those lanes, and only those,
 * one at a time with the scalar kernel's tb_woop_edge_exact, so they stay
 * bit for bit the scalar answer. Records: woop's 9 reals (raw vertices), in
 * blocks of 8 triangles, structure of arrays.
 * Flat triangles: the scalar form's NaN records, a miss in every lane.
 */

/* per lane and test (rules in kernels.h): translate 9, shear 12, edges 9, zero edges 3, signs 6, det 2, scaled t 8, sign 2, 1/det and t 2, tests 7 */
#define tb_woop_x8_ops 60

TB_WIDE vmask TB_FN(tb_woop_x8_test)(const tb_vray *restrict r, const real *restrict block,
                                     vreal t_max, tb_vhit *restrict h)
{
    const int kx = r->kx, ky = r->ky, kz = r->kz;
    /* vertex v's coordinate k is field 3 v + k, minus the origin's */
    vreal o_x = r->o[kx], o_y = r->o[ky],
          o_z = r->o[kz];
    vreal a_x = TB_FN(vload)(block + 8 * (0 + kx)) - o_x;
    vreal a_y = TB_FN(vload)(block + 8 * (0 + ky)) - o_y;
    vreal a_z = TB_FN(vload)(block + 8 * (0 + kz)) - o_z;
    vreal b_x = TB_FN(vload)(block + 8 * (3 + kx)) - o_x;
    vreal b_y = TB_FN(vload)(block + 8 * (3 + ky)) - o_y;
    vreal b_z = TB_FN(vload)(block + 8 * (3 + kz)) - o_z;
    vreal c_x = TB_FN(vload)(block + 8 * (6 + kx)) - o_x;
    vreal c_y = TB_FN(vload)(block + 8 * (6 + ky)) - o_y;
    vreal c_z = TB_FN(vload)(block + 8 * (6 + kz)) - o_z;

    /* shear: the ray is the +z axis */
    vreal sx = r->sx, sy = r->sy,
          sz = r->sz;
    vreal ax = a_x - sx * a_z, ay = a_y - sy * a_z;
    vreal bx = b_x - sx * b_z, by = b_y - sy * b_z;
    vreal cx = c_x - sx * c_z, cy = c_y - sy * c_z;

    /* 2-D edge functions; lanes with a 0 redone exactly, as the scalar does */
    vreal edge_bc = cx * by - cy * bx;
    vreal edge_ca = ax * cy - ay * cx;
    vreal edge_ab = bx * ay - by * ax;
    vmask redo = (edge_bc == 0) | (edge_ca == 0) | (edge_ab == 0);
    if (TB_FN(vany)(redo))
        for (int l = 0; l < TB_VLANES; ++l)
            if (redo[l]) {
                edge_bc[l] = TB_FN(tb_woop_edge_exact)(cx[l], by[l], cy[l], bx[l]);
                edge_ca[l] = TB_FN(tb_woop_edge_exact)(ax[l], cy[l], ay[l], cx[l]);
                edge_ab[l] = TB_FN(tb_woop_edge_exact)(bx[l], ay[l], by[l], ax[l]);
            }
    vreal zero = TB_FN(vsplat)(0);
    vmask same_sign = ((edge_bc >= zero) & (edge_ca >= zero) & (edge_ab >= zero)) |
                      ((edge_bc <= zero) & (edge_ca <= zero) & (edge_ab <= zero));
    vreal det = edge_bc + edge_ca + edge_ab;

    /* depth test on the scaled t, sign of det folded in */
    vreal az = sz * a_z, bz = sz * b_z, cz = sz * c_z;
    vreal scaled_t = edge_bc * az + edge_ca * bz + edge_ab * cz;
    vreal one = TB_FN(vsplat)(1);
    vreal sign = TB_FN(vselect)(det < zero, -one, one);
    vreal abs_det = sign * det;

    vreal inv_det = one / det;
    vreal t = scaled_t * inv_det;
    vmask hit = same_sign & (det != zero) & (sign * scaled_t > zero) &
                (sign * scaled_t < t_max * abs_det) & (t > zero) & (t < t_max);
    h->t = t;
    h->u = edge_ca * inv_det;
    h->v = edge_ab * inv_det;
    return hit;
}

/* operations per test by class (fma, mul, add, cmp, div, logic), per lane, counted in the compiled AVX2 block loop (tests/test_ext_build.py); see kernels.h */
#define tb_woop_x8_mix {0, 22, 22, 15, 1, 19}
