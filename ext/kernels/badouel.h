/* badouel: Badouel's projection test: the plane first, then 2-D barycentric
 * coordinates on the coordinate plane that drops the normal's largest axis.
 *
 * Reference: D. Badouel, "An Efficient Ray-Polygon Intersection", in
 * A. S. Glassner (ed.), Graphics Gems, Academic Press, 1990, pp. 390-393.
 * Checked against the Gem's code as distributed with the book
 * (erich666/GraphicsGems, gems/RayPolygon.c: the inside test, t given).
 *
 * Per triangle (precomputed): the plane (unit normal N, constant N_c = N . v0)
 * and the dropped axis k = argmax |n_i| (n = e1 x e2), with a, b = the other
 * two axes in cyclic order (k + 1, k + 2), and the three vertices' a and b
 * coordinates. Per test:
 *   t = (N_c - N . o) / (N . d), then the hit point's a and b coordinates
 *   p_a = o_a + t d_a, p_b = o_b + t d_b; with (u0, v0) = p - v0,
 *   (u1, v1) = v1 - v0, (u2, v2) = v2 - v0 on that plane (the paper's names),
 *   alpha = (u0 v2 - v0 u2) / det, beta = (u1 v0 - v1 u0) / det,
 *   det = u1 v2 - u2 v1;
 * hit iff alpha >= 0, beta >= 0, alpha + beta <= 1 (u = alpha, v = beta: the
 * weights of v1 and v2).
 * Record: N N_c, k, v0_a v0_b v1_a v1_b v2_a v2_b (11 reals).
 *
 * How it differs from the paper (and why):
 *  - the plane is computed in double from the vertices and rounded once to
 *    `real` (N_c is a sum of products of coordinates, which float32 loses far
 *    from the origin), and N is stored normalised (as havel_herout: t and the
 *    signs do not depend on its length, and a float32 record stays clear of
 *    overflow for huge or tiny triangles);
 *  - the paper keeps the polygon's 3-D vertices (a renderer stores them
 *    anyway) and reads two coordinates of each; the record holds just those
 *    six, in the order a, b of the triangle's own k: the edges (u1, v1),
 *    (u2, v2) are still formed per test, as in the paper;
 *  - both barycentrics by Cramer's rule with one division by det: the paper
 *    computes beta by Cramer's rule and then alpha = (u0 - beta u2) / u1
 *    (when u1 == 0 exactly: beta = u0 / u2, alpha = (v0 - beta v2) / v1), a
 *    second division, by u1, which amplifies beta's error without bound as
 *    u1 nears 0 (an edge nearly parallel to an axis of the projection plane);
 *  - no epsilon, closed triangle: alpha >= 0, beta >= 0, alpha + beta <= 1
 *    (points on an edge or vertex are inside), as the float64 reference;
 *    0 < t < t_max strict; every rejection is !(accept), so a NaN (N . d = 0
 *    with the ray in the plane, det rounded to 0) is a miss;
 *  - the paper's order, with early exits: t, then beta (and beta <= 1), then
 *    alpha;
 *  - k is read as 1 or 2 when the stored real equals 1 or 2 and as 0
 *    otherwise (as baldwin_weber_9), so no record indexes outside the ray;
 *  - a triangle with no usable plane (n == 0 in double, or anything not
 *    finite, in double or after rounding to `real`) gets an all-zero record:
 *    N . d = 0 and N_c - N . o = 0, so t is NaN and every ray misses it.
 * Flat triangles: an exactly flat one (zero area, found in exact arithmetic at
 * prepare time, see kernels.h) gets an all-NaN record and misses every ray.
 */

#define tb_badouel_stride 11 /* reals per prepared triangle, either precision */
/* ops per test on the hit path: axis 2, N.d 5, N_c - N.o 6, t 1, t tests 2,
 * p 4, p - v0 2, edges 4, det 3, beta' 3, 1/det 1, beta 1, beta tests 2,
 * alpha' 3, alpha 1, alpha tests 3 */
#define tb_badouel_ops 43
#define tb_badouel_flat TB_FLAT_MISS /* exactly flat triangles: NaN records, every ray misses */
#define tb_badouel_ray_f32 tb_ray_plain_f32
#define tb_badouel_ray_f64 tb_ray_plain_f64

static void TB_FN(tb_badouel_prepare)(const real *vertices, size_t n_tris, real *out)
{
    for (size_t i = 0; i < n_tris; ++i) {
        const real *vtx = vertices + 9 * i;
        real *rec = out + 11 * i;
        const tb_frame f = TB_FN(tb_frame_of)(vtx);
        const double *v0 = f.v0, *n = f.n;
        const int k = f.k;
        const int a = (k + 1) % 3, b = (k + 2) % 3;
        /* the unit normal through n / |n_k| (|n|^2 itself can overflow double) */
        double big = fabs(n[k]);
        double s[3] = {n[0] / big, n[1] / big, n[2] / big};
        double s_len = sqrt(s[0] * s[0] + s[1] * s[1] + s[2] * s[2]);
        double plane[4] = {s[0] / s_len, s[1] / s_len, s[2] / s_len, 0};
        plane[3] = plane[0] * v0[0] + plane[1] * v0[1] + plane[2] * v0[2];
        int usable = big > 0;
        for (int j = 0; j < 4; ++j) {
            rec[j] = (real)plane[j];
            usable &= isfinite(rec[j]) != 0;
        }
        rec[4] = (real)k;
        for (int j = 0; j < 3; ++j) {
            rec[5 + 2 * j] = vtx[3 * j + a];
            rec[6 + 2 * j] = vtx[3 * j + b];
            usable &= isfinite(rec[5 + 2 * j]) && isfinite(rec[6 + 2 * j]);
        }
        if (!usable)
            memset(rec, 0, 11 * sizeof(real));
    }
}

static inline int TB_FN(tb_badouel_test)(const tb_ray *restrict r, const real *restrict rec,
                                         real t_max, tb_hit *restrict h)
{
    static const int axis[5] = {0, 1, 2, 0, 1};
    /* arithmetic, not ?: (GCC branches on that, and k changes from triangle to triangle) */
    const int k = (rec[4] == 1) + 2 * (rec[4] == 2), a = axis[k + 1], b = axis[k + 2];
    const real *o = r->o, *d = r->d;

    /* the plane */
    real t = (rec[3] - TB_FN(dot3)(rec, o)) / TB_FN(dot3)(rec, d);
    if (!(t > 0 && t < t_max))
        return 0;

    /* the hit point and the edges on the plane that drops axis k */
    real u0 = o[a] + t * d[a] - rec[5], v0 = o[b] + t * d[b] - rec[6];
    real u1 = rec[7] - rec[5], v1 = rec[8] - rec[6];
    real u2 = rec[9] - rec[5], v2 = rec[10] - rec[6];
    real inv_det = 1 / (u1 * v2 - u2 * v1);
    real beta = (u1 * v0 - v1 * u0) * inv_det;
    if (!(beta >= 0 && beta <= 1))
        return 0;
    real alpha = (u0 * v2 - v0 * u2) * inv_det;
    if (!(alpha >= 0 && alpha + beta <= 1))
        return 0;
    h->t = t;
    h->u = alpha;
    h->v = beta;
    return 1;
}

/* operations per test by class (fma, mul, add, cmp, div, logic), on the hit path, the split of tb_badouel_ops; see kernels.h */
#define tb_badouel_mix {0, 16, 17, 8, 2, 0}
