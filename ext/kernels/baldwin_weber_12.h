/* baldwin_weber_12: Baldwin & Weber's coordinate transformation, 12-real form.
 *
 * Reference: D. Baldwin, M. Weber, "Fast Ray-Triangle Intersections by
 * Coordinate Transformation", Journal of Computer Graphics Techniques
 * 5(3):39-49, 2016.
 *
 * Per triangle, a 3x4 affine map M (rows U, V, W) from world space to a
 * frame where v0, v1, v2 go to (0,0,0), (1,0,0), (0,1,0) and the free vector,
 * the unit axis k of the largest |n_k| (n = e1 x e2, ties to the lower axis),
 * goes to (0,0,1):
 *   U = ((e2 x f) . p + (v2 x v0)_k) / n_k     weight of v1
 *   V = ((f x e1) . p + (v0 x v1)_k) / n_k     weight of v2
 *   W = (n . p - n . v0) / n_k                 distance to the plane along f
 * Per test: t = -W(o) / W(d) (the paper's transS / transD), p = o + t d,
 * u = U(p), v = V(p); hit iff 0 < t < t_max, u >= 0, v >= 0, u + v <= 1.
 * Record: U, V, W rows, 4 reals each (x, y, z, constant); the k columns hold
 * the exact constants 0, 0, 1 (see baldwin_weber_9 for the form without them).
 *
 * How it differs from the paper (and why):
 *  - M is computed in double from the vertices and rounded once to `real`:
 *    a float32 computation of the constants ((v2 x v0)_k is a difference of
 *    products of coordinates) loses all of u's digits far from the origin,
 *    and about half of the rays aimed at centroids miss near 1e4;
 *  - U's and V's constants are computed as the equal (e2 x v0)_k and
 *    (v0 x e1)_k, not as the paper's (v2 x v0)_k and (v0 x v1)_k: those
 *    subtract products of size |v0|^2 that cancel to size |v0| s (s the
 *    triangle's size), so even in double their rounding, about eps |v0|^2,
 *    divided by n_k ~ s^2, moves u and v by eps |v0|^2 / |n_k|: above 1 for
 *    triangles of 1e-9 and smaller half a unit from the origin, which every
 *    ray then misses (37.5% of validate's tiny triangles in float64). The e2
 *    form's products are of size |v0| s: error about eps |v0| / s, the order
 *    of the per-test rounding of u = U . p + U_c; no cost per test
 *    (tests/test_baldwin_weber.py);
 *  - a triangle with no usable map (n_k == 0: zero area, collinear or
 *    repeated vertices; or any entry non-finite, in double or after rounding
 *    to `real`: non-finite vertices, overflow) gets the record U = V =
 *    (0, 0, 0, -1), W = (0, 0, 0, 1): u = -1 (or NaN for a non-finite
 *    point), so every ray misses it;
 *  - no test of W(d) == 0: a ray parallel to the plane gets t = +-inf or NaN,
 *    which the t test rejects (t < t_max fails for +inf even when t_max is
 *    +inf);
 *  - edge rule: closed triangle (u >= 0, v >= 0, u + v <= 1: points on an
 *    edge or vertex are inside), as the float64 reference;
 *  - the paper's `ta <= 0 || ta >= tmax` and bounds are written as
 *    !(accept condition), so a NaN anywhere (non-finite ray) is a miss;
 *  - u is tested against [0, 1] before v is computed (an earlier exit; the
 *    bound u <= 1 is implied by the others, so the answers do not change).
 * Flat triangles: an exactly flat one (zero area, found in exact arithmetic at
 * prepare time, see kernels.h) gets an all-NaN record and misses every ray.
 */

#define tb_baldwin_weber_12_stride 12 /* reals per prepared triangle, either precision */
#define tb_baldwin_weber_12_ops 37 /* ops per test on the hit path: W(o) 6, W(d) 5, t 1, p 6, u 6, v 6, tests 7 */
#define tb_baldwin_weber_12_flat TB_FLAT_MISS /* exactly flat triangles: NaN records, every ray misses */
#define tb_baldwin_weber_12_ray_f32 tb_ray_plain_f32
#define tb_baldwin_weber_12_ray_f64 tb_ray_plain_f64

/* Baldwin & Weber's map of one triangle (9 reals), computed in double and
 * rounded to `real`, into m (rows U, V, W of 4). Returns the dropped axis k,
 * or -1 when the triangle has no usable map (m then holds the miss record). */
static int TB_FN(tb_baldwin_weber_map)(const real *vertices, real m[12])
{
    const tb_frame f = TB_FN(tb_frame_of)(vertices);
    const double *v0 = f.v0, *e1 = f.e1, *e2 = f.e2, *n = f.n;
    const int k = f.k;
    const int k1 = (k + 1) % 3, k2 = (k + 2) % 3;
    const double nk = n[k];

    double full[12] = {0};
    full[k1] = e2[k2] / nk;
    full[k2] = -e2[k1] / nk;
    /* the constants (v2 x v0)_k and (v0 x v1)_k, written as the equal (e2 x v0)_k
     * and (v0 x e1)_k: products of size |v0| s, not |v0|^2 (see the header) */
    full[3] = (e2[k1] * v0[k2] - e2[k2] * v0[k1]) / nk;
    full[4 + k1] = -e1[k2] / nk;
    full[4 + k2] = e1[k1] / nk;
    full[7] = (v0[k1] * e1[k2] - v0[k2] * e1[k1]) / nk;
    full[8 + k] = 1;
    full[8 + k1] = n[k1] / nk;
    full[8 + k2] = n[k2] / nk;
    full[11] = -(n[0] * v0[0] + n[1] * v0[1] + n[2] * v0[2]) / nk;

    int usable = nk != 0;
    for (int i = 0; i < 12; ++i) {
        m[i] = (real)full[i];
        usable &= isfinite(m[i]) != 0;
    }
    if (usable)
        return k;
    static const real miss[12] = {0, 0, 0, -1, 0, 0, 0, -1, 0, 0, 0, 1};
    memcpy(m, miss, sizeof miss);
    return -1;
}

static void TB_FN(tb_baldwin_weber_12_prepare)(const real *vertices, size_t n, real *out)
{
    for (size_t i = 0; i < n; ++i)
        TB_FN(tb_baldwin_weber_map)(vertices + 9 * i, out + 12 * i);
}

static inline int TB_FN(tb_baldwin_weber_12_test)(const tb_ray *restrict r,
                                                  const real *restrict m, real t_max,
                                                  tb_hit *restrict h)
{
    const real *o = r->o, *d = r->d;
    const real *row_u = m, *row_v = m + 4, *row_w = m + 8;

    /* plane: W(o + t d) = 0 */
    real w_o = TB_FN(dot3)(row_w, o) + row_w[3];
    real w_d = TB_FN(dot3)(row_w, d);
    real t = -w_o / w_d;
    if (!(t > 0 && t < t_max))
        return 0;

    /* barycentrics of the plane point */
    real p[3] = {o[0] + t * d[0], o[1] + t * d[1], o[2] + t * d[2]};
    real u = TB_FN(dot3)(row_u, p) + row_u[3];
    if (!(u >= 0 && u <= 1))
        return 0;
    real v = TB_FN(dot3)(row_v, p) + row_v[3];
    if (!(v >= 0 && u + v <= 1))
        return 0;
    h->t = t;
    h->u = u;
    h->v = v;
    return 1;
}

/* operations per test by class (fma, mul, add, cmp, div, logic), on the hit path, the split of tb_baldwin_weber_12_ops; see kernels.h */
#define tb_baldwin_weber_12_mix {0, 15, 15, 6, 1, 0}
