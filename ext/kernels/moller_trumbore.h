/* moller_trumbore: Moller-Trumbore with late division, no epsilon.
 *
 * Reference: T. Moller, B. Trumbore, "Fast, Minimum Storage Ray-Triangle
 * Intersection", Journal of Graphics Tools 2(1):21-28, 1997; the paper's
 * second listing (test the scaled barycentrics against det, divide once on a
 * hit), without back-face culling.
 *
 * How it differs from the paper and from moller_seed (and why):
 *  - no epsilon on det: only det == 0 (a ray in the plane, or a degenerate
 *    triangle) is rejected there, so small triangles are not erased; a
 *    near-parallel ray fails the bounds instead;
 *  - the sign of det is folded into U, V, T (multiplying by +-1 is exact), so
 *    one set of bounds serves front and back faces;
 *  - edge rule: closed triangle, 0 <= U, 0 <= V, U + V <= |det| (points on an
 *    edge or vertex are inside), the same rule as the float64 reference;
 *  - 0 < t < t_max accepts: the scaled t is compared with t_max |det| before
 *    the division (a farther hit costs no division), then t itself, so a t
 *    rounded up to t_max, overflowing to infinity, or rounded to 0 (an
 *    infinite det from an infinite direction) is a miss;
 *  - every rejection is written as !(accept condition), so a NaN is a miss;
 *  - det == 0 rejects a ray in the plane, and a flat triangle when
 *    rounding leaves det exactly 0; with coordinates that are not dyadic
 *    det is rounding noise, and about 1% of rays aimed at a flat triangle
 *    hit it: hence the NaN record below.
 * Prepared data: the raw vertices (9 reals).
 * Flat triangles: an exactly flat one (zero area, found in exact arithmetic at
 * prepare time, see kernels.h) gets an all-NaN record and misses every ray.
 */

#define tb_moller_trumbore_stride 9 /* reals per prepared triangle, either precision */
#define tb_moller_trumbore_ops 65 /* ops per test on the hit path: edges 6, p 9, det 5, sign 2, s 3, u 6, q 9, v 6, t 6, tests 9, divide 4 */
#define tb_moller_trumbore_flat TB_FLAT_MISS /* exactly flat triangles: NaN records, every ray misses */
#define tb_moller_trumbore_prepare_f32 tb_prepare_vertices_f32
#define tb_moller_trumbore_prepare_f64 tb_prepare_vertices_f64
#define tb_moller_trumbore_ray_f32 tb_ray_plain_f32
#define tb_moller_trumbore_ray_f64 tb_ray_plain_f64

static inline int TB_FN(tb_moller_trumbore_test)(const tb_ray *restrict r, const real *restrict tri,
                                                 real t_max, tb_hit *restrict h)
{
    const real *o = r->o, *d = r->d;
    real e1[3], e2[3], p[3], s[3], q[3];

    /* determinant */
    TB_FN(sub3)(tri + 3, tri, e1);
    TB_FN(sub3)(tri + 6, tri, e2);
    TB_FN(cross3)(d, e2, p);
    real det = TB_FN(dot3)(e1, p);
    if (det == 0)
        return 0;
    real sign = det < 0 ? -1 : 1;
    real abs_det = sign * det;

    /* scaled barycentrics against |det| */
    TB_FN(sub3)(o, tri, s);
    real u = sign * TB_FN(dot3)(s, p);
    if (!(u >= 0 && u <= abs_det))
        return 0;
    TB_FN(cross3)(s, e1, q);
    real v = sign * TB_FN(dot3)(d, q);
    if (!(v >= 0 && u + v <= abs_det))
        return 0;

    /* distance, one division on a hit */
    real scaled_t = sign * TB_FN(dot3)(e2, q);
    if (!(scaled_t > 0 && scaled_t < t_max * abs_det))
        return 0;
    return TB_FN(tb_divide_hit)(scaled_t, u, v, abs_det, t_max, h);
}

/* operations per test by class (fma, mul, add, cmp, div, logic), on the hit path, the split of tb_moller_trumbore_ops; see kernels.h */
#define tb_moller_trumbore_mix {0, 30, 24, 10, 1, 0}
