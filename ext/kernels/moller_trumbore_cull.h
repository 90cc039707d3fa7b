/* moller_trumbore_cull: Moller-Trumbore with back-face culling, late division.
 *
 * Reference: T. Moller, B. Trumbore, "Fast, Minimum Storage Ray-Triangle
 * Intersection", Journal of Graphics Tools 2(1):21-28, 1997; the paper's
 * culling branch (TEST_CULL): reject det <= 0, test the scaled barycentrics
 * against det, divide once on a hit.
 *
 * Which side is front: det = e1 . (d x e2) = -d . n with n = e1 x e2 =
 * (v1-v0) x (v2-v0). Front means det > 0: the ray travels against n, i.e.
 * seen from the origin the vertices v0, v1, v2 run counter-clockwise. A ray
 * with det <= 0 (back face, parallel ray, degenerate triangle) misses.
 *
 * How it differs from the paper (and why):
 *  - no epsilon on det: only det <= 0 is rejected, so small front-facing
 *    triangles are not erased (the paper rejects det < EPSILON);
 *  - edge rule: closed triangle, 0 <= U, 0 <= V, U + V <= det (points on an
 *    edge or vertex are inside), as the float64 reference;
 *  - 0 < t < t_max: the scaled t is compared with t_max det before the
 *    division, then t itself after it, so a t that rounds to t_max, to 0
 *    (underflow) or to 0 from an infinite det is a miss;
 *  - every rejection is written as !(accept condition), so a NaN anywhere
 *    (non-finite ray or vertex) is a miss.
 * Prepared data: the raw vertices (9 reals).
 * Flat triangles: an exactly flat one (zero area, found in exact arithmetic at
 * prepare time, see kernels.h) gets an all-NaN record and misses every ray.
 */

#define tb_moller_trumbore_cull_stride 9 /* reals per prepared triangle, either precision */
#define tb_moller_trumbore_cull_ops 60 /* ops per test on the hit path: edges 6, p 9, det 5, s 3, u 5, q 9, v 5, t 5, tests 9, divide 4 */
#define tb_moller_trumbore_cull_flat TB_FLAT_MISS /* exactly flat triangles: NaN records, every ray misses */
#define tb_moller_trumbore_cull_prepare_f32 tb_prepare_vertices_f32
#define tb_moller_trumbore_cull_prepare_f64 tb_prepare_vertices_f64
#define tb_moller_trumbore_cull_ray_f32 tb_ray_plain_f32
#define tb_moller_trumbore_cull_ray_f64 tb_ray_plain_f64

static inline int TB_FN(tb_moller_trumbore_cull_test)(const tb_ray *restrict r,
                                                      const real *restrict tri, real t_max,
                                                      tb_hit *restrict h)
{
    const real *o = r->o, *d = r->d;
    real e1[3], e2[3], p[3], s[3], q[3];

    /* determinant: front faces only */
    TB_FN(sub3)(tri + 3, tri, e1);
    TB_FN(sub3)(tri + 6, tri, e2);
    TB_FN(cross3)(d, e2, p);
    real det = TB_FN(dot3)(e1, p);
    if (!(det > 0))
        return 0;

    /* scaled barycentrics against det */
    TB_FN(sub3)(o, tri, s);
    real u = TB_FN(dot3)(s, p);
    if (!(u >= 0 && u <= det))
        return 0;
    TB_FN(cross3)(s, e1, q);
    real v = TB_FN(dot3)(d, q);
    if (!(v >= 0 && u + v <= det))
        return 0;

    /* distance, one division on a hit */
    real scaled_t = TB_FN(dot3)(e2, q);
    if (!(scaled_t > 0 && scaled_t < t_max * det))
        return 0;
    return TB_FN(tb_divide_hit)(scaled_t, u, v, det, t_max, h);
}

/* operations per test by class (fma, mul, add, cmp, div, logic), on the hit path, the split of tb_moller_trumbore_cull_ops; see kernels.h */
#define tb_moller_trumbore_cull_mix {0, 26, 24, 9, 1, 0}
