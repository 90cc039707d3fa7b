/* shevtsov: Shevtsov, Soupikov & Kapustin's projection test: a precomputed
 * record laid out for SIMD, the plane scaled so its dropped-axis coefficient
 * is 1, and the two barycentric edge equations premultiplied so that u and v
 * are one 2-D dot product each with the hit point's offset from v0.
 *
 * Reference: M. Shevtsov, A. Soupikov, A. Kapustin, "Ray-Triangle
 * Intersection Algorithm for Modern CPU Architectures", Proceedings of
 * GraphiCon 2007, pp. 33-39. Written from the paper's idea, not its listing.
 * Checked against the paper's abstract (studylib.net, doc 18260988: the test
 * is vectorised for ray packets; axis-orthogonal triangles are detected and
 * handled apart) and against two public implementations that follow its
 * record and test (bjourne/embree, kernels/geometry/triangle.h init_shev and
 * triangle_intersector_shev.h; a second with the same 48-byte TriAccel):
 * the record nu nv np pu pv ci e0u e0v e1u e1v and two pads (there
 * e0 = v1 - v0, e1 = v2 - v0, scaled by 1 / n_k; here e1, e2); the two kept
 * axes in ascending order, the scaled edges negated when k = 1; per test
 *   det = nu d_u + nv d_v + d_k, dett = np - (nu o_u + nv o_v + o_k),
 *   Du = d_u dett - (pu - o_u) det, Dv likewise,
 *   detu = e1v Du - e1u Dv, detv = e0u Dv - e0v Du,
 * a miss when the sign bits of det - detu - detv, detu and detv are not all
 * equal, then 1 / det, t = dett / det tested, u and v scaled on a hit.
 *
 * Per triangle (precomputed, in double): n = e1 x e2, the dropped axis
 * k = argmax |n_i|, the kept axes u = k + 1, v = k + 2 (cyclic); the plane
 * scaled by 1 / n_k: n_u' = n_u / n_k, n_v' = n_v / n_k, n_d = n' . v0; v0's kept
 * coordinates p_u, p_v; and the edge equations of the 2-D system
 * q = U e1 + V e2 (q = hit - v0 on the u, v plane, whose determinant is n_k),
 * premultiplied by 1 / n_k: U = (e2_v q_u - e2_u q_v) / n_k,
 * V = (e1_u q_v - e1_v q_u) / n_k. Per test, without a division until a hit:
 *   det = n_u' d_u + n_v' d_v + d_k,  dett = n_d - (n_u' o_u + n_v' o_v + o_k)
 *   (= t det, both summed in the paper's order),
 *   D_u = dett d_u - det (p_u - o_u) (= det q_u), D_v likewise,
 *   U' = U(D), V' = V(D) (= det U, det V);
 * hit iff U', V', det - U' - V' share det's sign and 0 < dett / det < t_max
 * (u = U, v = V: the weights of v1 and v2).
 * Record: n_u' n_v' n_d k p_u p_v U_u U_v V_u V_v (10 reals).
 *
 * How it differs from the paper (and why):
 *  - the record: 10 reals, no pads (the paper's 48 bytes pad 10 4-byte
 *    fields to 12); k in slot 3, not 5; the edge coefficients stored with
 *    their signs as used, U_u U_v V_u V_v = (e2_v, -e2_u, -e1_v, e1_u) / n_k,
 *    where the paper stores the scaled edges (e0u e0v e1u e1v) and subtracts
 *    (the negations are exact: the same products);
 *  - the kept axes in cyclic order (k + 1, k + 2, as wald), which keeps the
 *    2-D orientation without the paper's negated edges for k = 1;
 *  - the paper vectorises over ray packets (one triangle's record against
 *    several rays); the native form (shevtsov_fma) instead lays
 *    the records of 16 triangles out in blocks of lanes against one ray, as
 *    every native record in tribench;
 *  - no separate path for axis-orthogonal triangles (the paper flags them in
 *    ci): every triangle takes the general test;
 *  - det's sign folded into U', V', dett (a +-1 multiplication, exact), then
 *    closed-triangle compares against |det| (points on an edge or vertex are
 *    inside, as the float64 reference): the paper's integer sign-bit test of
 *    the three values does the same for nonzero values;
 *  - t: dett compared with t_max |det| before the one division on a hit,
 *    then t itself, 0 < t < t_max strict; det == 0 fails 0 < dett < 0;
 *  - no epsilon; every rejection is !(accept), so a NaN is a miss;
 *  - k is read as 1 or 2 when the stored real equals 1 or 2 and as 0
 *    otherwise (as wald), so no record indexes outside the ray;
 *  - a triangle with no usable record (n_k == 0 in double, or a value not
 *    finite once rounded to `real`) gets an all-NaN record, as a flat one.
 * Flat triangles: an exactly flat one (zero area, found in exact arithmetic at
 * prepare time, see kernels.h) gets an all-NaN record and misses every ray.
 */

#define tb_shevtsov_stride 10 /* reals per prepared triangle, either precision */
/* ops per test on the hit path: axis 2, det 4, dett 5, D_u 4, D_v 4, U' 3,
 * V' 3, sign 1, fold 4, U' V' tests 4, t tests 3, divide 4 */
#define tb_shevtsov_ops 41
#define tb_shevtsov_flat TB_FLAT_MISS /* exactly flat triangles: NaN records, every ray misses */
#define tb_shevtsov_ray_f32 tb_ray_plain_f32
#define tb_shevtsov_ray_f64 tb_ray_plain_f64

static void TB_FN(tb_shevtsov_prepare)(const real *vertices, size_t n_tris, real *out)
{
    for (size_t i = 0; i < n_tris; ++i) {
        const real *vtx = vertices + 9 * i;
        real *rec = out + 10 * i;
        const tb_frame f = TB_FN(tb_frame_of)(vtx);
        const double *v0 = f.v0, *e1 = f.e1, *e2 = f.e2, *n = f.n;
        const int k = f.k;
        const int u = (k + 1) % 3, v = (k + 2) % 3;
        const double nk = n[k];
        double m[10];
        m[0] = n[u] / nk;
        m[1] = n[v] / nk;
        m[2] = v0[k] + m[0] * v0[u] + m[1] * v0[v];
        m[3] = k;
        m[4] = v0[u];
        m[5] = v0[v];
        m[6] = e2[v] / nk;
        m[7] = -e2[u] / nk;
        m[8] = -e1[v] / nk;
        m[9] = e1[u] / nk;
        int usable = nk != 0;
        for (int j = 0; j < 10; ++j) {
            rec[j] = (real)m[j];
            usable &= isfinite(rec[j]) != 0;
        }
        if (!usable)
            for (int j = 0; j < 10; ++j)
                rec[j] = (real)NAN;
    }
}

static inline int TB_FN(tb_shevtsov_test)(const tb_ray *restrict r, const real *restrict m, real t_max,
                                          tb_hit *restrict h)
{
    static const int axis[5] = {0, 1, 2, 0, 1};
    /* arithmetic, not ?: (GCC branches on that, and k changes from triangle to triangle) */
    const int k = (m[3] == 1) + 2 * (m[3] == 2), u = axis[k + 1], v = axis[k + 2];
    const real *o = r->o, *d = r->d;

    /* the plane, its k coefficient 1: det and t det, summed in the paper's
     * order (the u and v terms, then the k one) */
    real det = m[0] * d[u] + m[1] * d[v] + d[k];
    real dett = m[2] - (m[0] * o[u] + m[1] * o[v] + o[k]);

    /* the hit point's offset from v0 on the u, v plane, times det, and the
     * premultiplied edge equations: det U, det V */
    real du = dett * d[u] - det * (m[4] - o[u]);
    real dv = dett * d[v] - det * (m[5] - o[v]);
    real su = m[6] * du + m[7] * dv;
    real sv = m[8] * du + m[9] * dv;

    /* one sign for U', V' and det - U' - V' (det's sign folded in) */
    real sign = det < 0 ? -1 : 1;
    real abs_det = sign * det;
    su *= sign;
    sv *= sign;
    if (!(su >= 0 && sv >= 0 && su + sv <= abs_det))
        return 0;
    real scaled_t = sign * dett;
    if (!(scaled_t > 0 && scaled_t < t_max * abs_det))
        return 0;
    return TB_FN(tb_divide_hit)(scaled_t, su, sv, abs_det, t_max, h);
}

/* operations per test by class (fma, mul, add, cmp, div, logic), on the hit path, the split of tb_shevtsov_ops; see kernels.h */
#define tb_shevtsov_mix {0, 18, 12, 10, 1, 0}
