/* moller_seed: Moller-Trumbore, divide-first, as the seed's code wrote it.
 *
 * Reference: T. Moller, B. Trumbore, "Fast, Minimum Storage Ray-Triangle
 * Intersection", Journal of Graphics Tools 2(1):21-28, 1997 (the seed cites it
 * as 2012). Seed: M. Vitse, ULCO 2022 (Triangle.cpp, MOLLER branch), which
 * follows the paper's first listing (no culling, division first).
 *
 * Faithful to the seed, on purpose:
 *  - raw vertices, edges recomputed per test (prepared data: 9 reals);
 *  - parallel test |det| < 1e-4 on the unnormalised determinant: an absolute
 *    epsilon, so a small enough triangle is missed by every ray;
 *  - inv_det = 1 / det computed before the inside tests, u and v scaled by it;
 *  - bounds as written: u < 0 || u > 1, then v < 0 || u + v > 1 reject, so
 *    edges are inside; t > 1e-4 accepts;
 *  - a NaN anywhere fails the final t > 1e-4 and so is a miss.
 *  - flat (zero-area) triangles are left to that test (tb_moller_seed_flat
 *    is TB_FLAT_AS_IS): det is exactly 0 for dyadic ones, which miss, but
 *    for coordinates that are not dyadic det is rounding noise, which grows
 *    with the coordinates and passes |det| >= 1e-4 on some of them beyond
 *    about 100 units: those rays hit (tribench validate measures it).
 * The seed's code has no t_max (its caller compares t with the closest hit so
 * far); here the comparison t < t_max follows the seed's test, unchanged.
 * Deviation: the seed keeps det, u, v and t in float and its vectors in float;
 * the float32 form is the faithful replay, the float64 form the same code in
 * double.
 * Not done, on purpose: a test before the division that rejects only what
 * u < 0 || u > 1 would (|s.p - det/2| > |det/2| (1 + 2^-19)) skips the division
 * on ~96% of the camera workload's tests, with the same answers, and took this
 * kernel from about 7.1 to 6.1 ns/test (bench/seed_speed.py); but a kernel that
 * does not divide first is moller_trumbore's late division, not the seed's. */

#define tb_moller_seed_stride 9 /* reals per prepared triangle, either precision */
#define tb_moller_seed_ops 60 /* ops per test on the hit path: edges 6, p 9, det 5, 1/det 1, s 3, u 6, q 9, v 6, t 6, tests 9 */
#define tb_moller_seed_flat TB_FLAT_AS_IS /* exactly flat triangles: the seed's own test decides (see above) */
#define tb_moller_seed_prepare_f32 tb_prepare_vertices_f32
#define tb_moller_seed_prepare_f64 tb_prepare_vertices_f64
#define tb_moller_seed_ray_f32 tb_ray_plain_f32
#define tb_moller_seed_ray_f64 tb_ray_plain_f64

static inline int TB_FN(tb_moller_seed_test)(const tb_ray *restrict r, const real *restrict tri,
                                             real t_max, tb_hit *restrict h)
{
    const real *o = r->o, *d = r->d;
    const real eps = (real)1e-4;
    real e1[3], e2[3], p[3], s[3], q[3];

    /* determinant, with the seed's absolute epsilon */
    TB_FN(sub3)(tri + 3, tri, e1);
    TB_FN(sub3)(tri + 6, tri, e2);
    TB_FN(cross3)(d, e2, p);
    real det = TB_FN(dot3)(e1, p);
    if (det > -eps && det < eps)
        return 0;
    real inv_det = 1 / det;

    /* u, then v, divided first */
    TB_FN(sub3)(o, tri, s);
    real u = TB_FN(dot3)(s, p) * inv_det;
    if (u < 0 || u > 1)
        return 0;
    TB_FN(cross3)(s, e1, q);
    real v = TB_FN(dot3)(q, d) * inv_det;
    if (v < 0 || u + v > 1)
        return 0;

    /* distance */
    real t = TB_FN(dot3)(e2, q) * inv_det;
    if (t > eps) {
        h->t = t;
        h->u = u;
        h->v = v;
        return t < t_max;
    }
    return 0;
}

/* operations per test by class (fma, mul, add, cmp, div, logic), on the hit path, the split of tb_moller_seed_ops; see kernels.h */
#define tb_moller_seed_mix {0, 27, 23, 9, 1, 0}
