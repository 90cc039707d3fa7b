/* segura_feito: Segura & Feito's test by the signs of determinants: three
 * signed volumes of the ray against the triangle's edges, then the plane only
 * for a crossing.
 *
 * Reference: R. J. Segura, F. R. Feito, "Algorithms to test ray-triangle
 * intersection. Comparative study", Journal of WSCG 9(3), 2001 (WSCG 2001,
 * Plzen). Written from the paper's idea, not from any listing.
 *
 * The paper tests a segment q1 -> q2: the signs of the three determinants
 * [q1, q2, v_i, v_j] (six times the signed volumes of the tetrahedra the
 * segment makes with each edge) decide whether its line crosses the triangle
 * (all of one sign), and the signs of [q1, v0, v1, v2] and [q2, v0, v1, v2]
 * whether the segment reaches the plane. For a ray o + t d the segment's
 * second point is o + d: with the vertices shifted by -o (a, b, c), the edge
 * determinants are the triple products
 *   w0 = (b x c) . d,  w1 = (c x a) . d,  w2 = (a x b) . d
 * (the volumes against the edges v1v2, v2v0, v0v1), which are the barycentric
 * weights of v0, v1, v2 at the crossing scaled by their sum
 * (= n . d, n = e1 x e2). Hit iff they share a sign (zeros either way), then
 * the plane: t = (n . a) / (n . d) (n . a = a . (b x c), the paper's volume of
 * the origin against the triangle, whose sign against n . d says whether the
 * crossing lies ahead of the origin).
 *
 * How it differs from the paper (and why):
 *  - a ray, not a segment: the second point is o + d, and the two endpoint
 *    determinants become t's numerator and denominator, formed only for a
 *    crossing (0 < t < t_max replaces the segment's two end tests);
 *  - each edge determinant is evaluated with one row subtracted from the
 *    other, (x x y) . d = (x x (y - x)) . d: the edge's length, not the
 *    distance to the origin, then sets its rounding (the literal (x x y) . d
 *    missed 28% of float32 and 16% of float64 rays at `tribench validate
 *    --quick`'s tiny triangles, 100 ulps across);
 *  - the endpoint volume a . (b x c) is formed as n . a with n from the
 *    same edges, (a - c) x (b - a): the triple product of three long
 *    vectors loses everything far from the triangle, n . a cancels only
 *    the origin's offset once (as plucker);
 *  - no epsilon, closed triangle: zeros count with either sign (a point on an
 *    edge or vertex is inside), as the float64 reference; a crossing whose
 *    weights sum to 0, or n . d == 0, misses;
 *  - early exits: two edge determinants and their signs, the third against
 *    the sum of the first two (which carries their common sign), then the
 *    plane. The paper's own order could not be checked (its text was not
 *    at hand); the one public port found, bjourne/embree's
 *    kernels/geometry/triangle_intersector_sf01.h, also takes the three
 *    edge signs first (compared pairwise) and the plane after;
 *  - u, v are w1 and w2 over their sum, divided on a hit only;
 *  - every rejection is written as !(accept), so a NaN anywhere is a miss.
 * Prepared data: the raw vertices (9 reals).
 * Flat triangles: an exactly flat one (zero area, found in exact arithmetic at
 * prepare time, see kernels.h) gets an all-NaN record and misses every ray.
 */

#define tb_segura_feito_stride 9 /* reals per prepared triangle, either precision */
/* ops per test on the hit path: shift 9, edges 9, three volumes 42, first
 * signs 2, partial sum 1, third sign 2, sum 1, sum == 0 1, n 9, n.d 5, n.a 5,
 * sign 1, fold 2, den != 0 1, t tests 3, divide 4 */
#define tb_segura_feito_ops 97
#define tb_segura_feito_flat TB_FLAT_MISS /* exactly flat triangles: NaN records, every ray misses */
#define tb_segura_feito_prepare_f32 tb_prepare_vertices_f32
#define tb_segura_feito_prepare_f64 tb_prepare_vertices_f64
#define tb_segura_feito_ray_f32 tb_ray_plain_f32
#define tb_segura_feito_ray_f64 tb_ray_plain_f64

/* (x x e) . d for the edge x -> x + e: six times the signed volume of
 * (0, d, x, x + e), with the edge's row subtracted first */
static inline real TB_FN(tb_segura_feito_volume)(const real *x, const real *e, const real *d)
{
    real m[3];
    TB_FN(cross3)(x, e, m);
    return TB_FN(dot3)(m, d);
}

static inline int TB_FN(tb_segura_feito_test)(const tb_ray *restrict r, const real *restrict tri,
                                              real t_max, tb_hit *restrict h)
{
    const real *d = r->d;
    real a[3], b[3], c[3], ab[3], bc[3], ca[3];

    /* the vertices relative to the origin, and the edges a -> b -> c -> a */
    TB_FN(sub3)(tri, r->o, a);
    TB_FN(sub3)(tri + 3, r->o, b);
    TB_FN(sub3)(tri + 6, r->o, c);
    TB_FN(sub3)(b, a, ab);
    TB_FN(sub3)(c, b, bc);
    TB_FN(sub3)(a, c, ca);

    /* the edge determinants: one sign, zeros either way */
    real w2 = TB_FN(tb_segura_feito_volume)(a, ab, d);
    real w0 = TB_FN(tb_segura_feito_volume)(b, bc, d);
    if (!((w2 >= 0 && w0 >= 0) || (w2 <= 0 && w0 <= 0)))
        return 0;
    real w1 = TB_FN(tb_segura_feito_volume)(c, ca, d);
    real partial = w2 + w0; /* the sign both share, or 0 */
    if (!((w1 >= 0 && partial >= 0) || (w1 <= 0 && partial <= 0)))
        return 0;
    real sum = partial + w1;
    if (sum == 0)
        return 0;

    /* the plane, only for a crossing: t = (n . a) / (n . d), sign folded in */
    real n[3];
    TB_FN(cross3)(ca, ab, n); /* (a - c) x (b - a) = (b - a) x (c - a) */
    real den = TB_FN(dot3)(n, d);
    real scaled_t = TB_FN(dot3)(n, a);
    real sign = den < 0 ? -1 : 1;
    real abs_den = sign * den;
    scaled_t *= sign;
    if (!(den != 0 && scaled_t > 0 && scaled_t < t_max * abs_den))
        return 0;

    /* divisions on a hit */
    real t = scaled_t * (1 / abs_den);
    if (!(t > 0 && t < t_max))
        return 0;
    real inv_sum = 1 / sum;
    h->t = t;
    h->u = w1 * inv_sum;
    h->v = w2 * inv_sum;
    return 1;
}

/* operations per test by class (fma, mul, add, cmp, div, logic), on the hit path, the split of tb_segura_feito_ops; see kernels.h */
#define tb_segura_feito_mix {0, 43, 42, 11, 1, 0}
