/* havel_herout: Havel & Herout's three-plane test, one division on a hit.
 *
 * Reference: J. Havel, A. Herout, "Yet Faster Ray-Triangle Intersection
 * (Using SSE4)", IEEE Transactions on Visualization and Computer Graphics
 * 16(3):434-438, 2010.
 *
 * Per triangle, three planes (n = e1 x e2):
 *   N  = n / |n|,                     N_c  = N . v0       the triangle's plane
 *   N1 = (e2 x n) / |n|^2,            N1_c = -N1 . v0     u = N1 . p + N1_c
 *   N2 = (n x e1) / |n|^2,            N2_c = -N2 . v0     v = N2 . p + N2_c
 * Per test, everything scaled by det (no division):
 *   det = N . d,  t' = N_c - N . o,  P' = det o + t' d  (= det times the
 *   plane point), u' = N1 . P' + det N1_c,  v' = N2 . P' + det N2_c;
 * hit iff t', u', v' and det - u' - v' all have det's sign; then one
 * division: t = t'/det, u = u'/det, v = v'/det.
 * Record: N N_c, N1 N1_c, N2 N2_c (12 reals).
 *
 * How it differs from the paper (and why):
 *  - the planes are computed in double from the vertices and rounded once to
 *    `real` (their constants are differences of products of coordinates,
 *    which float32 loses far from the origin);
 *  - N is stored normalised (the paper keeps n): t = t'/det and the sign
 *    tests do not depend on N's length, and unit length keeps a float32
 *    record clear of overflow and underflow for huge or tiny triangles;
 *  - the paper's sign-bit comparisons (XOR of the sign bits of det and each
 *    quantity) become comparisons after multiplying each quantity by the
 *    sign of det (+-1, exact): a sign bit test would make the edge rule
 *    depend on the sign of a zero, and would let a NaN through as positive
 *    or negative; here the edge rule is closed (u' >= 0, v' >= 0,
 *    det - u' - v' >= 0 after the sign fold: points on an edge or vertex are
 *    inside), as the float64 reference, t' > 0 is strict, det == 0 misses,
 *    and every rejection is !(accept), so a NaN is a miss;
 *  - the scalar form exits early: after t', after u', then the rest (the
 *    paper tests all four signs at once; havel_herout_fma does);
 *  - 0 < t < t_max: t' is compared with t_max |det| before the division,
 *    t itself after it (t rounded to t_max, or to 0 by underflow or an
 *    infinite det, is a miss);
 *  - a degenerate triangle (n == 0) or one whose planes are not finite
 *    (non-finite vertices, overflow), in double or after rounding to `real`,
 *    gets an all-zero record: det == 0, so every ray misses it.
 * Flat triangles: an exactly flat one (zero area, found in exact arithmetic at
 * prepare time, see kernels.h) gets an all-NaN record and misses every ray.
 */

#define tb_havel_herout_stride 12 /* reals per prepared triangle, either precision */
#define tb_havel_herout_ops 52 /* ops per test on the hit path: det 5, scaled t 6, sign 3, p 9, u 8, v 8, tests 9, divide 4 */
#define tb_havel_herout_flat TB_FLAT_MISS /* exactly flat triangles: NaN records, every ray misses */
#define tb_havel_herout_ray_f32 tb_ray_plain_f32
#define tb_havel_herout_ray_f64 tb_ray_plain_f64

static void TB_FN(tb_havel_herout_prepare)(const real *vertices, size_t n_tris, real *out)
{
    for (size_t i = 0; i < n_tris; ++i) {
        const real *vtx = vertices + 9 * i;
        real *rec = out + 12 * i;
        const tb_frame f = TB_FN(tb_frame_of)(vtx);
        const double *v0 = f.v0, *e1 = f.e1, *e2 = f.e2, *n = f.n;
        /* |n| and the unit normal through n / max|n_k|, and N1, N2 as (e2 x unit) / |n|, (unit x e1) / |n|:
         * |n|^2 itself overflows double for coordinates past about 1e77 */
        double big = fmax(fabs(n[0]), fmax(fabs(n[1]), fabs(n[2])));
        double s[3] = {n[0] / big, n[1] / big, n[2] / big};
        double s_len = sqrt(s[0] * s[0] + s[1] * s[1] + s[2] * s[2]), len = big * s_len;
        double u[3] = {s[0] / s_len, s[1] / s_len, s[2] / s_len};
        double n1[3] = {(e2[1] * u[2] - e2[2] * u[1]) / len,
                        (e2[2] * u[0] - e2[0] * u[2]) / len,
                        (e2[0] * u[1] - e2[1] * u[0]) / len};
        double n2[3] = {(u[1] * e1[2] - u[2] * e1[1]) / len,
                        (u[2] * e1[0] - u[0] * e1[2]) / len,
                        (u[0] * e1[1] - u[1] * e1[0]) / len};
        double planes[12] = {u[0], u[1], u[2], 0,
                             n1[0], n1[1], n1[2], -(n1[0] * v0[0] + n1[1] * v0[1] + n1[2] * v0[2]),
                             n2[0], n2[1], n2[2], -(n2[0] * v0[0] + n2[1] * v0[1] + n2[2] * v0[2])};
        planes[3] = planes[0] * v0[0] + planes[1] * v0[1] + planes[2] * v0[2];
        int usable = big > 0;
        for (int k = 0; k < 12; ++k) {
            rec[k] = (real)planes[k];
            usable &= isfinite(rec[k]) != 0;
        }
        if (!usable)
            memset(rec, 0, 12 * sizeof(real));
    }
}

static inline int TB_FN(tb_havel_herout_test)(const tb_ray *restrict r, const real *restrict rec,
                                              real t_max, tb_hit *restrict h)
{
    const real *o = r->o, *d = r->d;
    const real *plane = rec, *plane_u = rec + 4, *plane_v = rec + 8;

    /* distance, scaled by det; det's sign folded in (multiplying by +-1 is exact) */
    real det = TB_FN(dot3)(plane, d);
    real scaled_t = plane[3] - TB_FN(dot3)(plane, o);
    real sign = det < 0 ? -1 : 1;
    real abs_det = sign * det;
    real t_s = sign * scaled_t;
    if (!(det != 0 && t_s > 0 && t_s < t_max * abs_det))
        return 0;

    /* scaled barycentrics of det times the plane point */
    real p[3] = {det * o[0] + scaled_t * d[0], det * o[1] + scaled_t * d[1],
                 det * o[2] + scaled_t * d[2]};
    real u = sign * (TB_FN(dot3)(plane_u, p) + det * plane_u[3]);
    if (!(u >= 0))
        return 0;
    real v = sign * (TB_FN(dot3)(plane_v, p) + det * plane_v[3]);
    if (!(v >= 0 && abs_det - u - v >= 0))
        return 0;

    /* one division on a hit */
    return TB_FN(tb_divide_hit)(t_s, u, v, abs_det, t_max, h);
}

/* operations per test by class (fma, mul, add, cmp, div, logic), on the hit path, the split of tb_havel_herout_ops; see kernels.h */
#define tb_havel_herout_mix {0, 26, 16, 9, 1, 0}
