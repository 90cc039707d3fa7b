/* woop: Woop, Benthin & Wald's watertight test.
 *
 * Reference: S. Woop, C. Benthin, I. Wald, "Watertight Ray/Triangle
 * Intersection", Journal of Computer Graphics Techniques 2(1):65-82, 2013;
 * the paper's listing without back-face culling.
 *
 * Per ray (tb_woop_ray): kz = the axis of the largest |d| (the first on a
 * tie), kx, ky the next two cyclically, swapped when d[kz] < 0 so the winding
 * is kept; shear Sx = d[kx]/d[kz], Sy = d[ky]/d[kz], Sz = 1/d[kz]. Per
 * triangle: vertices minus the origin, permuted and sheared so the ray runs
 * along +z through the 2-D origin; 2-D edge functions; mixed signs miss;
 * det = their sum; the scaled t from the sheared z; one division on a hit.
 * Watertight because each vertex is transformed the same way in every
 * triangle that holds it, and each edge function's sign is exact for the
 * transformed vertices: fl(a*b) > fl(c*d) implies a*b > c*d (rounding is
 * monotonic), so a rounded edge function is either of the right sign or 0,
 * and a 0 is recomputed exactly (a 0 left is accepted either way, below).
 * Measured: no crack on the grids and random fans of
 * tests/test_kernels_watertight.py, either precision, scalar or wide.
 *
 * How it differs from the paper (and why):
 *  - written once over `real`. float32: the paper's fallback, the three edge
 *    functions recomputed in double when one is 0 (products of floats are
 *    exact in double), then rounded back to float as the paper does (a value
 *    below float's smallest subnormal stays 0, which is accepted as on the
 *    edge). float64: no wider type is guaranteed (x87 long double is not
 *    exact for products of doubles, and other targets have none), so a 0 is
 *    resolved exactly instead: fl(a*b) - fl(c*d) == 0 means the two products
 *    rounded to the same double, so a*b - c*d is the difference of their
 *    rounding errors, which Dekker's two-product gives exactly (no libm fma:
 *    the baseline x86-64 build has no FMA instruction; exact away from
 *    overflow and underflow). Nonzero values are kept: their sign is exact;
 *  - edge rule as the paper's: a 0 edge function is accepted with either
 *    sign (closed triangle, no culling), so a ray through a shared edge or
 *    vertex can hit both triangles, never neither;
 *  - 0 < t < t_max, both strict (the paper accepts T == 0 and t == hit.t):
 *    the scaled t, sign of det folded in by multiplying by +-1 (exact, the
 *    paper xors the sign bit), is compared with t_max |det| before the
 *    division, then t itself, so a t rounded onto t_max, to 0, or
 *    overflowing is a miss;
 *  - det == 0 misses (the paper's listing also does): a degenerate triangle,
 *    or one seen edge-on, whose edge functions cancel; a triangle that is
 *    degenerate in space but not after the ray's shear is a tiny triangle;
 *  - every rejection is written as !(accept), so a NaN anywhere is a miss.
 *    The axis choice ignores NaN (the indices are always valid); a zero
 *    direction gives Sx = NaN, a miss; an infinite component of d gives
 *    Sz = 0, so T = 0, a miss; an infinite vertex or origin makes an edge
 *    function NaN or infinite, so det or t is not finite, a miss;
 *  - hit: the contract's u, v are the weights of v1, v2 (the paper's V/det,
 *    W/det).
 * Prepared data: the raw vertices (9 reals).
 * Flat triangles: an exactly flat one (zero area, found in exact arithmetic at
 * prepare time, see kernels.h) gets an all-NaN record and misses every ray.
 */

#define tb_woop_stride 9 /* reals per prepared triangle, either precision */
#define tb_woop_ops 57 /* ops per test on the hit path: shift 9, shear 12, edges 9, zero tests 3, signs 3, det 2, scaled t 8, sign 2, tests 5, divide 4 */
#define tb_woop_flat TB_FLAT_MISS /* exactly flat triangles: NaN records, every ray misses */
#define tb_woop_prepare_f32 tb_prepare_vertices_f32
#define tb_woop_prepare_f64 tb_prepare_vertices_f64

static inline void TB_FN(tb_woop_ray)(const real *o, const real *d, tb_ray *r)
{
    real abs_d[3];
    for (int k = 0; k < 3; ++k) {
        r->o[k] = o[k];
        r->d[k] = d[k];
        abs_d[k] = d[k] < 0 ? -d[k] : d[k];
    }
    int kz = 0;
    if (abs_d[1] > abs_d[kz])
        kz = 1;
    if (abs_d[2] > abs_d[kz])
        kz = 2;
    int kx = kz == 2 ? 0 : kz + 1;
    int ky = kx == 2 ? 0 : kx + 1;
    /* keep the winding: a mirrored frame would flip every edge function */
    if (d[kz] < 0) {
        int swap = kx;
        kx = ky;
        ky = swap;
    }
    r->kx = kx;
    r->ky = ky;
    r->kz = kz;
    r->sx = d[kx] / d[kz];
    r->sy = d[ky] / d[kz];
    r->sz = 1 / d[kz];
}

#if TB_REAL_IS_DOUBLE
/* Dekker's split: x = hi + lo exactly, each half fitting 26 bits */
static inline void TB_FN(tb_woop_split)(double x, double *hi, double *lo)
{
    double scaled = 134217729.0 * x; /* 2^27 + 1 */
    *hi = scaled - (scaled - x);
    *lo = x - *hi;
}

/* a*b - fl(a*b), exactly (Dekker's two-product; needs -ffp-contract=off) */
static inline double TB_FN(tb_woop_product_error)(double a, double b, double product)
{
    double a_hi, a_lo, b_hi, b_lo;
    TB_FN(tb_woop_split)(a, &a_hi, &a_lo);
    TB_FN(tb_woop_split)(b, &b_hi, &b_lo);
    return ((a_hi * b_hi - product) + a_hi * b_lo + a_lo * b_hi) + a_lo * b_lo;
}
#endif

/* a*b - c*d with its exact sign: the paper's fallback for a 0 edge function */
static inline real TB_FN(tb_woop_edge_exact)(real a, real b, real c, real d)
{
#if TB_REAL_IS_DOUBLE
    double ab = a * b, cd = c * d;
    if (ab != cd)
        return ab - cd;
    return TB_FN(tb_woop_product_error)(a, b, ab) - TB_FN(tb_woop_product_error)(c, d, cd);
#else
    return (float)((double)a * b - (double)c * d);
#endif
}

static inline int TB_FN(tb_woop_test)(const tb_ray *restrict r, const real *restrict tri,
                                      real t_max, tb_hit *restrict h)
{
    const int kx = r->kx, ky = r->ky, kz = r->kz;
    real a[3], b[3], c[3];

    /* vertices relative to the origin, sheared: the ray is the +z axis */
    TB_FN(sub3)(tri, r->o, a);
    TB_FN(sub3)(tri + 3, r->o, b);
    TB_FN(sub3)(tri + 6, r->o, c);
    real ax = a[kx] - r->sx * a[kz], ay = a[ky] - r->sy * a[kz];
    real bx = b[kx] - r->sx * b[kz], by = b[ky] - r->sy * b[kz];
    real cx = c[kx] - r->sx * c[kz], cy = c[ky] - r->sy * c[kz];

    /* 2-D edge functions at the origin: each is the scaled barycentric of
     * the vertex opposite its edge */
    real edge_bc = cx * by - cy * bx;
    real edge_ca = ax * cy - ay * cx;
    real edge_ab = bx * ay - by * ax;
    if (edge_bc == 0 || edge_ca == 0 || edge_ab == 0) {
        edge_bc = TB_FN(tb_woop_edge_exact)(cx, by, cy, bx);
        edge_ca = TB_FN(tb_woop_edge_exact)(ax, cy, ay, cx);
        edge_ab = TB_FN(tb_woop_edge_exact)(bx, ay, by, ax);
    }

    /* edge tests: one sign, zeros accepted with either (no culling) */
    if (!((edge_bc >= 0 && edge_ca >= 0 && edge_ab >= 0) ||
          (edge_bc <= 0 && edge_ca <= 0 && edge_ab <= 0)))
        return 0;
    real det = edge_bc + edge_ca + edge_ab;
    if (det == 0)
        return 0;

    /* depth test on the scaled t, sign of det folded in */
    real az = r->sz * a[kz], bz = r->sz * b[kz], cz = r->sz * c[kz];
    real scaled_t = edge_bc * az + edge_ca * bz + edge_ab * cz;
    real sign = det < 0 ? -1 : 1;
    real abs_det = sign * det;
    if (!(sign * scaled_t > 0 && sign * scaled_t < t_max * abs_det))
        return 0;

    /* one division on a hit */
    return TB_FN(tb_divide_hit)(scaled_t, edge_ca, edge_ab, det, t_max, h);
}

/* operations per test by class (fma, mul, add, cmp, div, logic), on the hit path, the split of tb_woop_ops; see kernels.h */
#define tb_woop_mix {0, 20, 22, 14, 1, 0}
