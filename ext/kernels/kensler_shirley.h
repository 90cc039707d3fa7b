/* kensler_shirley: the direct test Kensler & Shirley's automated search
 * found: edges and normal from the vertices, then t and the barycentrics as
 * triple products that share their cross products.
 *
 * Reference: A. Kensler, P. Shirley, "Optimizing Ray-Triangle Intersection
 * via Automated Search", IEEE Symposium on Interactive Ray Tracing 2006,
 * pp. 33-38. Written from the paper's idea, not from its listing. Checked
 * against the single-ray test in Manta, the Utah ray tracer the authors
 * worked on (Model/Primitives/KenslerShirleyTriangle.cc, the non-SSE path;
 * public copy: github.com/jeffamstutz/rfManta): edge0 = v1 - v0,
 * edge1 = v0 - v2, normal = edge0 x edge1, one reciprocal of normal . d,
 * t from normal . (v0 - o) tested first, then (v0 - o) x d dotted with
 * edge1 (u, tested) and with edge0 (v, tested with u + v). The paper's own
 * text past its abstract could not be read for this check; below, "Manta's"
 * is that file's test.
 *
 * With the edges f = v0 - v1, g = v2 - v0 and the normal n = g x f
 * (= (v1 - v0) x (v2 - v0)), formed per test from the raw vertices, and
 * c = v0 - o, i = c x d:
 *   den = n . d,  t = (n . c) / den,  u = (g . i) / den,  v = (f . i) / den
 * (u, v the weights of v1 and v2): two cross products per test, n and i, and
 * every quantity one dot product with one of them, the sharing the search
 * converged to. Hit iff 0 < t < t_max, u >= 0, v >= 0, u + v <= 1.
 *
 * How it differs from the paper (and why):
 *  - Manta's order and single reciprocal: 1 / den once, then t tested
 *    first (a miss in depth costs no barycentric), then u, then v; kept
 *    (the last test is written v >= 0 && u + v <= 1, Manta's two compares
 *    in the other order: the same branch);
 *  - both edges negated (f = -edge0, g = -edge1, so n = -normal): every
 *    negation is exact and each of t, u, v is a product of two negated
 *    values, so the results are Manta's, bit for bit in the same
 *    evaluation order;
 *  - no epsilon and no t_min: 0 < t < t_max strict, closed triangle (u, v >= 0,
 *    u + v <= 1: points on an edge or vertex are inside), as the float64
 *    reference; Manta accepts eps < t < t_hit - eps, an epsilon at both
 *    ends;
 *  - den == 0 is not tested: its reciprocal is infinite and t becomes
 *    infinite or NaN, a miss through !(t < t_max) (t_max is finite or, at
 *    infinity, never exceeded);
 *  - every rejection is written as !(accept), so a NaN anywhere is a miss;
 *  - both faces: no culling (Manta's test culls nothing either).
 * Prepared data: the raw vertices (9 reals).
 * Flat triangles: an exactly flat one (zero area, found in exact arithmetic at
 * prepare time, see kernels.h) gets an all-NaN record and misses every ray.
 */

#define tb_kensler_shirley_stride 9 /* reals per prepared triangle, either precision */
/* ops per test on the hit path: edges 6, n 9, den 5, 1 / den 1, c 3, n.c 5,
 * t 1, t tests 2, i 9, g.i 5, u 1, u test 1, f.i 5, v 1, v tests 3 */
#define tb_kensler_shirley_ops 57
#define tb_kensler_shirley_flat TB_FLAT_MISS /* exactly flat triangles: NaN records, every ray misses */
#define tb_kensler_shirley_prepare_f32 tb_prepare_vertices_f32
#define tb_kensler_shirley_prepare_f64 tb_prepare_vertices_f64
#define tb_kensler_shirley_ray_f32 tb_ray_plain_f32
#define tb_kensler_shirley_ray_f64 tb_ray_plain_f64

static inline int TB_FN(tb_kensler_shirley_test)(const tb_ray *restrict r, const real *restrict tri,
                                                 real t_max, tb_hit *restrict h)
{
    const real *d = r->d;
    real f[3], g[3], n[3], c[3], i[3];

    /* the edges and the normal, from the vertices */
    TB_FN(sub3)(tri, tri + 3, f);
    TB_FN(sub3)(tri + 6, tri, g);
    TB_FN(cross3)(g, f, n);
    real inv_den = 1 / TB_FN(dot3)(n, d);

    /* depth first */
    TB_FN(sub3)(tri, r->o, c);
    real t = TB_FN(dot3)(n, c) * inv_den;
    if (!(t > 0 && t < t_max))
        return 0;

    /* the barycentrics, from the one cross product c x d */
    TB_FN(cross3)(c, d, i);
    real u = TB_FN(dot3)(g, i) * inv_den;
    if (!(u >= 0))
        return 0;
    real v = TB_FN(dot3)(f, i) * inv_den;
    if (!(v >= 0 && u + v <= 1))
        return 0;
    h->t = t;
    h->u = u;
    h->v = v;
    return 1;
}

/* operations per test by class (fma, mul, add, cmp, div, logic), on the hit path, the split of tb_kensler_shirley_ops; see kernels.h */
#define tb_kensler_shirley_mix {0, 27, 24, 5, 1, 0}
