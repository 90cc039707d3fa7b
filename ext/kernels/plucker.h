/* plucker: origin-shifted Plucker test, as in Embree's robust intersector.
 *
 * References: the Plucker-coordinate edge test, R. Jones, "Intersecting a
 * Ray and a Triangle with Plucker Coordinates", Ray Tracing News 13(1),
 * 2000, and J. Amanatides, K. Choi, "Ray Tracing Triangular Meshes", Western
 * Computer Graphics Symposium, 1997; its origin-shifted, watertight-along-
 * edges form: I. Wald, S. Woop, C. Benthin, G. S. Johnson, M. Ernst,
 * "Embree: A Kernel Framework for Efficient CPU Ray Tracing", ACM
 * Transactions on Graphics 33(4):143, 2014. Written from the math below.
 *
 * Shift the vertices by -o, so the ray is the line through 0 along d. The
 * Plucker product of that line with the edge line p -> q is d . (q x p);
 * it is computed as ((q - p) x (p + q)) . d (= 2 d . (q x p)), because the
 * same expression for the edge q -> p is then the exact negation of it
 * (q - p is negated exactly, p + q is the same sum): two triangles sharing
 * an edge see opposite signs, or both 0, so no ray slips between them
 * through the edge's interior. The three products are the barycentrics of
 * the crossing scaled by their sum; hit iff they share a sign.
 *
 * How it differs from the papers (and why):
 *  - tolerance: the sign test accepts products up to TB_PLUCKER_TOLERANCE
 *    machine epsilons of |sum| on the other side (Embree's robust mode has
 *    a tolerance of this kind), and zeros with either sign (closed
 *    triangle, no culling). Through the interior of an edge (farther from
 *    its ends than rounding) the test is watertight without it. At a shared
 *    vertex it is not watertight by
 *    construction: the products of the edges around the vertex are all
 *    near 0 there, with independent rounding errors of about
 *    epsilon |q - p| |p + q| |d|, which grow with the distance to the
 *    origin while |sum| does not, so every triangle of a fan can see mixed
 *    signs. 4 epsilons: a few, as cheap as Embree's. Measured on random
 *    fans, rays aimed at the vertex, float32 and float64 alike: cracks
 *    ~3e-5 with the origin within a fan size (~1e-2 with no tolerance),
 *    ~2e-4 at 1-10 sizes, ~1e-3 at 10-100, ~1e-2 at 1000 and more (see
 *    tests/test_kernels_watertight.py). A bound on each product's error
 *    would close every vertex, at some 30 more flops a test: a separate
 *    kernel if wanted;
 *  - t from the geometric normal n = (v1 - v0) x (v2 - v0) of the shifted
 *    edges: t = (n . (v0 - o)) / (n . d), compared with t_max |n . d| before
 *    the division (sign folded in by multiplying by +-1, exact), then t
 *    itself; 0 < t < t_max, strict; a t rounded to 0 or t_max is a miss;
 *  - n . d == 0 (a degenerate triangle's n is 0, or the ray is parallel)
 *    or a sum of 0 misses; a triangle degenerate in space whose rounded
 *    edges are not parallel is a tiny triangle;
 *  - u, v are the products of the edges opposite v1 and v2 over their sum,
 *    divided on a hit only;
 *  - every rejection is written as !(accept), so a NaN anywhere is a miss;
 *    an infinite input makes a product or the normal non-finite, so the sum
 *    or t is NaN, infinite or 0: a miss.
 * Prepared data: the raw vertices (9 reals).
 * Flat triangles: an exactly flat one (zero area, found in exact arithmetic at
 * prepare time, see kernels.h) gets an all-NaN record and misses every ray.
 */

#define tb_plucker_stride 9 /* reals per prepared triangle, either precision */
#define tb_plucker_ops 107 /* ops per test on the hit path: shift 9, edges 9, sides 51, sum 2, tol 2, signs 3, n 9, n.d 5, n.a 5, sign 2, t 2, tests 8 */
#define tb_plucker_flat TB_FLAT_MISS /* exactly flat triangles: NaN records, every ray misses */
#define tb_plucker_prepare_f32 tb_prepare_vertices_f32
#define tb_plucker_prepare_f64 tb_prepare_vertices_f64
#define tb_plucker_ray_f32 tb_ray_plain_f32
#define tb_plucker_ray_f64 tb_ray_plain_f64

/* machine epsilons of |sum| a product may stray to the other sign */
#define TB_PLUCKER_TOLERANCE 4
#define tb_plucker_tolerance_f32 (TB_PLUCKER_TOLERANCE * 0x1p-23f)
#define tb_plucker_tolerance_f64 (TB_PLUCKER_TOLERANCE * 0x1p-52)

/* ((q - p) x (p + q)) . d for the edge p -> q (the edge q - p given) */
static inline real TB_FN(tb_plucker_side)(const real *p, const real *q, const real *edge,
                                          const real *d)
{
    real through[3] = {p[0] + q[0], p[1] + q[1], p[2] + q[2]}, moment[3];
    TB_FN(cross3)(edge, through, moment);
    return TB_FN(dot3)(moment, d);
}

static inline int TB_FN(tb_plucker_test)(const tb_ray *restrict r, const real *restrict tri,
                                         real t_max, tb_hit *restrict h)
{
    const real *d = r->d;
    real a[3], b[3], c[3], ab[3], bc[3], ca[3];

    /* vertices relative to the origin, and the edges a -> b -> c -> a */
    TB_FN(sub3)(tri, r->o, a);
    TB_FN(sub3)(tri + 3, r->o, b);
    TB_FN(sub3)(tri + 6, r->o, c);
    TB_FN(sub3)(b, a, ab);
    TB_FN(sub3)(c, b, bc);
    TB_FN(sub3)(a, c, ca);

    /* edge tests: one sign within the tolerance, zeros either way */
    real side_bc = TB_FN(tb_plucker_side)(b, c, bc, d);
    real side_ca = TB_FN(tb_plucker_side)(c, a, ca, d);
    real side_ab = TB_FN(tb_plucker_side)(a, b, ab, d);
    real sum = side_bc + side_ca + side_ab;
    real tolerance = TB_FN(tb_plucker_tolerance) * (sum < 0 ? -sum : sum);
    if (!((side_bc >= -tolerance && side_ca >= -tolerance && side_ab >= -tolerance) ||
          (side_bc <= tolerance && side_ca <= tolerance && side_ab <= tolerance)))
        return 0;
    if (sum == 0)
        return 0;

    /* depth test on the plane of the geometric normal, sign folded in */
    real n[3];
    TB_FN(cross3)(ca, ab, n); /* (a - c) x (b - a) = (b - a) x (c - a) */
    real den = TB_FN(dot3)(n, d);
    real scaled_t = TB_FN(dot3)(n, a);
    real sign = den < 0 ? -1 : 1;
    real abs_den = sign * den;
    if (!(den != 0 && sign * scaled_t > 0 && sign * scaled_t < t_max * abs_den))
        return 0;

    /* divisions on a hit */
    real t = scaled_t * (1 / den);
    if (!(t > 0 && t < t_max))
        return 0;
    real inv_sum = 1 / sum;
    h->t = t;
    h->u = side_ca * inv_sum;
    h->v = side_ab * inv_sum;
    return 1;
}

/* operations per test by class (fma, mul, add, cmp, div, logic), on the hit path, the split of tb_plucker_ops; see kernels.h */
#define tb_plucker_mix {0, 44, 51, 11, 1, 0}
