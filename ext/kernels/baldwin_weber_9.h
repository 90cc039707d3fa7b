/* baldwin_weber_9: Baldwin & Weber's coordinate transformation, 9-real form
 * plus the dropped axis (stride 10).
 *
 * Reference: D. Baldwin, M. Weber, "Fast Ray-Triangle Intersections by
 * Coordinate Transformation", Journal of Computer Graphics Techniques
 * 5(3):39-49, 2016 (the 9-float variant).
 *
 * The map M is baldwin_weber_12's (see baldwin_weber_12.h, which computes
 * it). Its columns for the dropped axis k are always the constants
 * (0, 0, 1), so only the other two columns and the constants are stored:
 * with k1 = (k + 1) % 3, k2 = (k + 2) % 3,
 *   t = -(o_k + W_k1 o_k1 + W_k2 o_k2 + W_c) / (d_k + W_k1 d_k1 + W_k2 d_k2)
 *   u = U_k1 p_k1 + U_k2 p_k2 + U_c,  v = V_k1 p_k1 + V_k2 p_k2 + V_c
 * (p_k is never needed: the test also saves the multiplications by 0 and 1).
 * Record: U_k1 U_k2 U_c, V_k1 V_k2 V_c, W_k1 W_k2 W_c, k (10 reals).
 *
 * Why stride 10, not 9: the test must know k, and the kernel contract gives
 * every triangle one fixed-size record in input order (indices are the
 * caller's), so k lives in the record, as one more real holding 0, 1 or 2.
 * The alternatives cost more than they save: three kernels or a re-sort of
 * the triangles by k would change the triangle indices and the loops;
 * hiding k in mantissa bits would perturb the stored coefficients. So the
 * form stores 40 bytes per triangle in float32 (80 in float64) against
 * baldwin_weber_12's 48 (96), and moller_trumbore's 36 (72).
 *
 * How it differs from the paper (and why): as baldwin_weber_12 (double
 * precomputation, U's and V's constants in a form that does not cancel,
 * closed edges, !(accept) tests, t test doing the parallel test), and:
 *  - k is read as 1 or 2 when the stored real equals 1 or 2 and as 0
 *    otherwise, so no record can index outside the ray;
 *  - a triangle with no usable map (degenerate or non-finite) gets U = V =
 *    (0, 0, -1), W = (0, 0, 0), k = 0: u = -1 (or NaN for a non-finite
 *    point), so every ray misses it.
 * Flat triangles: an exactly flat one (zero area, found in exact arithmetic at
 * prepare time, see kernels.h) gets an all-NaN record and misses every ray.
 */

#define tb_baldwin_weber_9_stride 10 /* reals per prepared triangle, either precision */
#define tb_baldwin_weber_9_ops 31 /* ops per test on the hit path: axis 2, W(o) 5, W(d) 4, t 1, p 4, u 4, v 4, tests 7 */
#define tb_baldwin_weber_9_flat TB_FLAT_MISS /* exactly flat triangles: NaN records, every ray misses */
#define tb_baldwin_weber_9_ray_f32 tb_ray_plain_f32
#define tb_baldwin_weber_9_ray_f64 tb_ray_plain_f64

static void TB_FN(tb_baldwin_weber_9_prepare)(const real *vertices, size_t n, real *out)
{
    for (size_t i = 0; i < n; ++i) {
        real m[12], *rec = out + 10 * i;
        int k = TB_FN(tb_baldwin_weber_map)(vertices + 9 * i, m);
        if (k < 0) {
            static const real miss[10] = {0, 0, -1, 0, 0, -1, 0, 0, 0, 0};
            memcpy(rec, miss, sizeof miss);
            continue;
        }
        const int k1 = (k + 1) % 3, k2 = (k + 2) % 3;
        for (int row = 0; row < 3; ++row) {
            rec[3 * row] = m[4 * row + k1];
            rec[3 * row + 1] = m[4 * row + k2];
            rec[3 * row + 2] = m[4 * row + 3];
        }
        rec[9] = (real)k;
    }
}

static inline int TB_FN(tb_baldwin_weber_9_test)(const tb_ray *restrict r,
                                                 const real *restrict m, real t_max,
                                                 tb_hit *restrict h)
{
    static const int axis[5] = {0, 1, 2, 0, 1};
    /* arithmetic, not ?: (GCC branches on that, and k changes from triangle to triangle) */
    const int k = (m[9] == 1) + 2 * (m[9] == 2), k1 = axis[k + 1], k2 = axis[k + 2];
    const real *o = r->o, *d = r->d;

    /* plane: W(o + t d) = 0, W's k coefficient being 1 */
    real w_o = o[k] + m[6] * o[k1] + m[7] * o[k2] + m[8];
    real w_d = d[k] + m[6] * d[k1] + m[7] * d[k2];
    real t = -w_o / w_d;
    if (!(t > 0 && t < t_max))
        return 0;

    /* barycentrics of the plane point (U and V ignore axis k) */
    real p1 = o[k1] + t * d[k1], p2 = o[k2] + t * d[k2];
    real u = m[0] * p1 + m[1] * p2 + m[2];
    if (!(u >= 0 && u <= 1))
        return 0;
    real v = m[3] * p1 + m[4] * p2 + m[5];
    if (!(v >= 0 && u + v <= 1))
        return 0;
    h->t = t;
    h->u = u;
    h->v = v;
    return 1;
}

/* operations per test by class (fma, mul, add, cmp, div, logic), on the hit path, the split of tb_baldwin_weber_9_ops; see kernels.h */
#define tb_baldwin_weber_9_mix {0, 10, 12, 8, 1, 0}
