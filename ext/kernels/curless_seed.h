/* curless_seed: Curless's plane-then-inside test, as the seed's code wrote it.
 *
 * Reference: B. Curless, "Ray-triangle intersection", University of Washington
 * CSE 457 lecture notes, 2004. Seed: M. Vitse, "Curless versus Moller pour
 * l'intersection d'un triangle avec un rayon", ULCO, 2022 (Triangle.cpp,
 * branch without MOLLER).
 *
 * Faithful to the seed, on purpose:
 *  - the unit normal n = normalise((v1 - v0) x (v2 - v0)) is stored per
 *    triangle (prepared data: v0 v1 v2 n, 12 reals); n.v0 is recomputed per test;
 *  - exact-zero parallel test (n.d == 0), then t = (n.v0 - n.o) / n.d;
 *  - t < 1e-4 rejects, before the inside tests (absolute epsilon);
 *  - q = o + t d, then three edge tests ((b - a) x (q - a)).n, rejecting on
 *    <= 0, so points on an edge miss (strict interior), in the order
 *    v0v1, v1v2, v2v0;
 *  - comparisons written as the seed wrote them: a NaN or Inf in the ray
 *    slips past every test with t = NaN; only the final t < t_max (the
 *    seed's caller comparing t with the closest hit so far) drops it.
 * The seed computes no barycentrics and has no t_max (its caller compares t
 * with the closest hit so far); here t < t_max follows the seed's test, and
 * u, v are the edge values over their sum, computed on a hit only.
 * Deviations from the seed:
 *  - a degenerate triangle (zero-length or non-finite normal) stores n = 0,
 *    so the parallel test rejects every ray; the seed divides by zero and
 *    stores NaN, which makes every ray "hit" it at t = NaN;
 *  - otherwise flat (zero-area) triangles are left to the seed's test
 *    (tb_curless_seed_flat is TB_FLAT_AS_IS): one whose rounded normal is
 *    not exactly 0 (collinear vertices that are not dyadic) gets a unit
 *    normal made of rounding noise and can be hit (tribench validate
 *    measures it);
 *  - the seed's Vecteur holds float, so its arithmetic is single precision:
 *    the float32 form is the faithful replay, the float64 form is the same
 *    code in double. */

#define tb_curless_seed_stride 12 /* reals per prepared triangle, either precision */
#define tb_curless_seed_ops 89 /* ops per test on the hit path: n.d 5, n.v0 5, n.o 5, t 2, q 6, edge sides 60, tests 6 */
#define tb_curless_seed_flat TB_FLAT_AS_IS /* exactly flat triangles: the seed's own test decides (see above) */
#define tb_curless_seed_ray_f32 tb_ray_plain_f32
#define tb_curless_seed_ray_f64 tb_ray_plain_f64

static void TB_FN(tb_curless_seed_prepare)(const real *vertices, size_t n, real *out)
{
    for (size_t i = 0; i < n; ++i) {
        const real *v = vertices + 9 * i;
        real *rec = out + 12 * i;
        real e1[3], e2[3], nrm[3];
        memcpy(rec, v, 9 * sizeof(real));
        TB_FN(sub3)(v + 3, v, e1);
        TB_FN(sub3)(v + 6, v, e2);
        TB_FN(cross3)(e1, e2, nrm);
        real len = (real)sqrt((double)TB_FN(dot3)(nrm, nrm));
        for (int k = 0; k < 3; ++k)
            rec[9 + k] = len > 0 ? nrm[k] / len : 0;
    }
}

static inline int TB_FN(tb_curless_seed_test)(const tb_ray *restrict r, const real *restrict tri,
                                              real t_max, tb_hit *restrict h)
{
    const real *o = r->o, *d = r->d;
    const real eps = (real)1e-4;
    const real *a = tri, *b = tri + 3, *c = tri + 6, *n = tri + 9;

    /* plane: parallel test on the exact zero, then t, rejected below eps */
    real nd = TB_FN(dot3)(n, d);
    if (nd == 0)
        return 0;
    real t = (TB_FN(dot3)(n, a) - TB_FN(dot3)(n, o)) / nd;
    if (t < eps)
        return 0;

    /* point on the plane */
    real q[3] = {o[0] + t * d[0], o[1] + t * d[1], o[2] + t * d[2]};

    /* three inside tests, strict: on an edge is outside */
    real side_ab = TB_FN(edge_side)(a, b, q, n), side_bc, side_ca;
    if (side_ab <= 0 || (side_bc = TB_FN(edge_side)(b, c, q, n)) <= 0 ||
        (side_ca = TB_FN(edge_side)(c, a, q, n)) <= 0)
        return 0;

    real sum = side_ab + side_bc + side_ca;
    h->t = t;
    h->u = side_ca / sum;
    h->v = side_ab / sum;
    return t < t_max;
}

/* operations per test by class (fma, mul, add, cmp, div, logic), on the hit path, the split of tb_curless_seed_ops; see kernels.h */
#define tb_curless_seed_mix {0, 39, 43, 6, 1, 0}
