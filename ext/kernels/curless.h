/* curless: Curless's plane-then-inside test, cleaned up.
 *
 * Reference: B. Curless, "Ray-triangle intersection", University of Washington
 * CSE 457 lecture notes, 2004.
 *
 * How it differs from curless_seed (and why):
 *  - prepared data v0 v1 v2, the unnormalised normal n = (v1-v0) x (v2-v0) and
 *    the plane offset n.v0 (13 reals), computed in double and rounded, so the
 *    float32 form's plane is as good as float32 can store;
 *  - no absolute epsilon: t > 0 accepts, so small and far triangles are kept;
 *  - edge rule: the triangle is closed, an edge test rejects only on < 0
 *    (points on an edge or vertex are inside), the same rule as the float64
 *    reference and moller_trumbore;
 *  - every rejection is written as !(accept condition), so a NaN anywhere is
 *    a miss, and a t that overflows to infinity is a miss;
 *  - degenerate triangles have n = 0 and miss through the parallel test;
 *  - 0 < t < t_max is checked on the plane, before the inside tests;
 *  - u, v (which Curless's notes derive from the same edge values) are the
 *    edge values over their sum, computed on a hit only.
 * Flat triangles: an exactly flat one (zero area, found in exact arithmetic at
 * prepare time, see kernels.h) gets an all-NaN record and misses every ray.
 */

#define tb_curless_stride 13 /* reals per prepared triangle, either precision */
#define tb_curless_ops 84 /* ops per test on the hit path: n.d 5, t 7, q 6, edge sides 60, tests 6 */
#define tb_curless_flat TB_FLAT_MISS /* exactly flat triangles: NaN records, every ray misses */
#define tb_curless_ray_f32 tb_ray_plain_f32
#define tb_curless_ray_f64 tb_ray_plain_f64

static void TB_FN(tb_curless_prepare)(const real *vertices, size_t n, real *out)
{
    for (size_t i = 0; i < n; ++i) {
        const real *v = vertices + 9 * i;
        real *rec = out + 13 * i;
        double a[3], e1[3], e2[3];
        for (int k = 0; k < 3; ++k) {
            a[k] = v[k];
            e1[k] = (double)v[3 + k] - v[k];
            e2[k] = (double)v[6 + k] - v[k];
        }
        double nrm[3] = {e1[1] * e2[2] - e1[2] * e2[1],
                         e1[2] * e2[0] - e1[0] * e2[2],
                         e1[0] * e2[1] - e1[1] * e2[0]};
        memcpy(rec, v, 9 * sizeof(real));
        for (int k = 0; k < 3; ++k)
            rec[9 + k] = (real)nrm[k];
        rec[12] = (real)(nrm[0] * a[0] + nrm[1] * a[1] + nrm[2] * a[2]);
    }
}

static inline int TB_FN(tb_curless_test)(const tb_ray *restrict r, const real *restrict tri,
                                         real t_max, tb_hit *restrict h)
{
    const real *o = r->o, *d = r->d;
    const real *a = tri, *b = tri + 3, *c = tri + 6, *n = tri + 9;

    /* plane: parallel rays (and degenerate triangles) have n.d == 0 */
    real nd = TB_FN(dot3)(n, d);
    if (nd == 0)
        return 0;
    real t = (tri[12] - TB_FN(dot3)(n, o)) / nd;
    if (!(t > 0 && t < t_max))
        return 0;

    /* point on the plane */
    real q[3] = {o[0] + t * d[0], o[1] + t * d[1], o[2] + t * d[2]};

    /* three inside tests, closed triangle */
    real side_ab = TB_FN(edge_side)(a, b, q, n), side_bc, side_ca;
    if (!(side_ab >= 0 && (side_bc = TB_FN(edge_side)(b, c, q, n)) >= 0 &&
          (side_ca = TB_FN(edge_side)(c, a, q, n)) >= 0))
        return 0;

    real sum = side_ab + side_bc + side_ca;
    h->t = t;
    h->u = side_ca / sum;
    h->v = side_ab / sum;
    return 1;
}

/* operations per test by class (fma, mul, add, cmp, div, logic), on the hit path, the split of tb_curless_ops; see kernels.h */
#define tb_curless_mix {0, 36, 41, 6, 1, 0}
