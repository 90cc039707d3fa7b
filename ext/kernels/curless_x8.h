/* curless_x8: curless, branchless, one ray against 8 triangles.
 *
 * Reference: as curless.h (Curless's CSE 457 notes, 2004). The same
 * arithmetic in the same order on 8 lanes, so each lane's answer is the
 * scalar kernel's bit for bit: the plane test and the three edge tests are
 * all evaluated and combined into one mask, with no early exit. Records:
 * curless's 13 reals (v0 v1 v2, n, n.v0), in blocks of 8 triangles,
 * structure of arrays.
 * Flat triangles: the scalar form's NaN records, a miss in every lane.
 */

/* ((b - a) x (q - a)) . n on 8 lanes (see edge_side in vec.h) */
TB_WIDE vreal TB_FN(tb_curless_x8_side)(const vreal *a, const vreal *b, const vreal *q,
                                        const vreal *n)
{
    vreal edge[3], toq[3], side[3];
    TB_FN(vsub3)(b, a, edge);
    TB_FN(vsub3)(q, a, toq);
    TB_FN(vcross3)(edge, toq, side);
    return TB_FN(vdot3)(side, n);
}

/* per lane and test (rules in kernels.h): n.d 5, t 7, hit point 6, three edge sides 60, tests 6 */
#define tb_curless_x8_ops 84

TB_WIDE vmask TB_FN(tb_curless_x8_test)(const tb_vray *restrict r, const real *restrict block,
                                        vreal t_max, tb_vhit *restrict h)
{
    vreal a[3], b[3], c[3], n[3];
    const vreal *o = r->o, *d = r->d;
    TB_FN(vload3)(block, 0, a);
    TB_FN(vload3)(block, 3, b);
    TB_FN(vload3)(block, 6, c);
    TB_FN(vload3)(block, 9, n);
    vreal plane = TB_FN(vload)(block + 8 * 12);
    vreal nd = TB_FN(vdot3)(n, d);
    vreal t = (plane - TB_FN(vdot3)(n, o)) / nd;
    vreal q[3];
    for (int k = 0; k < 3; ++k)
        q[k] = o[k] + t * d[k];
    vreal side_ab = TB_FN(tb_curless_x8_side)(a, b, q, n);
    vreal side_bc = TB_FN(tb_curless_x8_side)(b, c, q, n);
    vreal side_ca = TB_FN(tb_curless_x8_side)(c, a, q, n);
    vmask hit = (nd != 0) & (t > 0) & (t < t_max) & (side_ab >= 0) & (side_bc >= 0) &
                (side_ca >= 0);
    vreal sum = side_ab + side_bc + side_ca;
    h->t = t;
    h->u = side_ca / sum;
    h->v = side_ab / sum;
    return hit;
}

/* operations per test by class (fma, mul, add, cmp, div, logic), per lane, counted in the compiled AVX2 block loop (tests/test_ext_build.py); see kernels.h */
#define tb_curless_x8_mix {0, 36, 41, 6, 1, 12}
