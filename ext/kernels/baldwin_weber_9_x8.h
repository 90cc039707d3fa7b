/* baldwin_weber_9_x8: baldwin_weber_9, branchless, one ray against 8
 * triangles.
 *
 * Reference: as baldwin_weber_9.h (Baldwin & Weber, JCGT 5(3), 2016, the
 * 9-float variant). The dropped axis k differs from lane to lane, so the ray
 * is permuted per lane instead of branching on k: from two masks (k == 1,
 * k == 2; anything else reads as 0, as in the scalar kernel) each of o_k,
 * o_k1, o_k2, d_k, d_k1, d_k2 is picked from the three splatted components
 * with two selects. Cost per block of 8 triangles: 2 compares and 12
 * selects (AND/ANDN/OR, or blends), where baldwin_weber_12_x8 instead loads
 * three more fields and does 5 more multiply-adds per lane (the 0 and 1
 * columns). After the permutation, the same arithmetic in the same order as
 * the scalar kernel, so each lane's answer is the scalar's bit for bit; all
 * tests are combined into one mask, with no early exit. Records:
 * baldwin_weber_9's 10 reals, in blocks of 8 triangles, structure of
 * arrays.
 * Flat triangles: the scalar form's NaN records, a miss in every lane.
 */

/* per lane and test (rules in kernels.h): axis 2, plane row on o 5 and on d 4, t 1, hit point 4, u 4, v 4, tests 7 */
#define tb_baldwin_weber_9_x8_ops 31

TB_WIDE vmask TB_FN(tb_baldwin_weber_9_x8_test)(const tb_vray *restrict r,
                                                const real *restrict block, vreal t_max,
                                                tb_vhit *restrict h)
{
    vreal m[9];
    for (int f = 0; f < 9; ++f)
        m[f] = TB_FN(vload)(block + 8 * f);
    vreal axis = TB_FN(vload)(block + 8 * 9);
    vmask is1 = axis == 1, is2 = axis == 2;

    /* the ray in each lane's axis order k, k1, k2 */
    vreal o_k[3], d_k[3];
    for (int j = 0; j < 3; ++j) {
        /* component (j + k) % 3 for k = 0, 1, 2 */
        vreal o0 = r->o[j], o1 = r->o[(j + 1) % 3],
              o2 = r->o[(j + 2) % 3];
        vreal d0 = r->d[j], d1 = r->d[(j + 1) % 3],
              d2 = r->d[(j + 2) % 3];
        o_k[j] = TB_FN(vselect)(is1, o1, TB_FN(vselect)(is2, o2, o0));
        d_k[j] = TB_FN(vselect)(is1, d1, TB_FN(vselect)(is2, d2, d0));
    }

    vreal w_o = o_k[0] + m[6] * o_k[1] + m[7] * o_k[2] + m[8];
    vreal w_d = d_k[0] + m[6] * d_k[1] + m[7] * d_k[2];
    vreal t = -w_o / w_d;
    vreal p1 = o_k[1] + t * d_k[1], p2 = o_k[2] + t * d_k[2];
    vreal u = m[0] * p1 + m[1] * p2 + m[2];
    vreal v = m[3] * p1 + m[4] * p2 + m[5];
    vmask hit = (t > 0) & (t < t_max) & (u >= 0) & (u <= 1) & (v >= 0) & (u + v <= 1);
    h->t = t;
    h->u = u;
    h->v = v;
    return hit;
}

/* operations per test by class (fma, mul, add, cmp, div, logic), per lane, counted in the compiled AVX2 block loop (tests/test_ext_build.py); see kernels.h */
#define tb_baldwin_weber_9_x8_mix {0, 10, 12, 8, 1, 13}
