/* plucker_fma: the origin-shifted Plucker test at the CPU's native width,
 * fused multiply-adds, stored edges and normal, with an early exit after the
 * edge tests.
 *
 * References: as plucker.h (Jones 2000, Amanatides & Choi 1997; origin-shifted
 * as in Wald et al., "Embree", ACM TOG 33(4):143, 2014), whose promises,
 * tolerance rule and arithmetic this is. A native wide kernel (native.h):
 * 16 float / 8 double lanes with AVX-512, 8 / 4 with AVX2 + FMA, 4 / 2 on the
 * baseline, chosen at run time.
 *
 * Record (21 reals): v0, v1, v2; the edges v1 - v0, v2 - v1, v0 - v2, each
 * rounded once; the geometric normal n = (v1 - v0) x (v2 - v0), computed in
 * double and rounded once. Embree stores v0, e1, e2 and n for its Plucker
 * form, but the shift by the ray's origin needs every vertex as stored: a
 * vertex rebuilt as v0 + e1 would be rounded differently by each triangle
 * around it, and the exact negation below would be lost. The edges are stored
 * from the unshifted vertices: the neighbour across an edge stores
 * fl(p - q) = -fl(q - p) exactly, so the exact negation holds, and an edge
 * rounded once is closer to the true edge than plucker's difference of two
 * shifted (rounded) vertices. The normal is read only after the early exit.
 *
 * The edge products, ((q - p) x (p + q)) . d for the edge p -> q with p, q
 * shifted by -o: the cross product is fused, three fmsub (x*y - rounded z*w);
 * the dot product is not (three multiplies, two adds). The exact negation of
 * plucker.h is kept: for the shared edge the neighbour has q - p negated
 * exactly and the same p + q (a sum rounds the same in either order); a
 * multiply, an add, an fmadd or an fmsub with each product's operand and the
 * added term negated exactly returns exactly the negated result (round to
 * nearest is symmetric: fl(-x) = -fl(x)), so the moment, then the product,
 * are exactly negated, on every ISA (the baseline's rounded-twice "fused"
 * operations too). Two triangles sharing an edge still see opposite signs or
 * both 0 (tests/test_kernels_watertight.py: 0 cracks through edges).
 * Why the dot product is not fused: at a vertex, where the test is not
 * watertight by construction (plucker.h), a fused dot product (one multiply,
 * two fmadd) made cracks four times as frequent as plucker's on the far fans
 * of tests/test_kernels_watertight.py (rays aimed at a shared vertex from
 * 100-10000 fan sizes away: 802 and 886 cracks in 42,131 rays, float32 and
 * float64, against plucker's 214 and 201); fusing only the cross product
 * gives 167 and 164. Near fans and the grid's vertices: 0 either way. The
 * plain dot product costs 6 operations per test more.
 *
 * How it differs from plucker's arithmetic on every lane (and why):
 *  - stored edges (9 subtractions fewer per test) and normal (6 operations,
 *    and only for vectors that pass the exit); fused cross products: 60
 *    operations before the exit, 74 in all, where plucker does 107;
 *  - the tolerance rule is plucker's: a product may stray to the other sign by
 *    TB_PLUCKER_TOLERANCE machine epsilons of |sum| (sum of the three
 *    products), zeros either way; written as min(products) >= -tolerance or
 *    max(products) <= tolerance (the same sets; a NaN product makes the sum,
 *    so the tolerance, NaN and both comparisons false);
 *  - early exit after the edge tests: a vector with no lane whose products
 *    share a sign returns at once. That is the first test that can reject
 *    (the tolerance needs all three products, and the depth test needs the
 *    normal and its two dot products, 6 FMA-pipe operations, where the edge
 *    tests reject almost every vector of camera rays: 99.5% of the vectors
 *    of the Suzanne camera workload, 1,280 triangles, 128^2 rays, closest,
 *    have no lane whose products share a sign);
 *  - two denominators, as plucker: t = t' / |n . d| (h->den) and u, v =
 *    products / |sum| (h->uv_den, signs folded in); the loop divides by the
 *    second only where u and v are asked for (native.h), so the closest-t
 *    loop still divides once per candidate vector. (One common denominator
 *    |n . d| |sum| would square the range: in float32 it overflowed at
 *    tribench validate's scale 1e8 and lost every hit there);
 *  - det == 0 and sum == 0 miss as in plucker (|n . d| = 0 fails
 *    0 < t' < t_max |n . d|; |sum| > 0 is tested); every rejection is
 *    !(accept), so a NaN is a miss;
 *  - the loop, not the kernel, divides: once per vector with a candidate.
 * Not bit-for-bit plucker. Error bound, against the float64 reference on the
 * inputs as the kernel sees them: where the reference's barycentric edge
 * margin is at least 1e-3, the same hit or miss, and |t - t_ref| <= 2 eps K
 * t_ref with moller_trumbore_fma's K = |e1| |e2| (|d| + |o - v0| / t_ref) /
 * |det| (the origin shift makes the error relative to the ray's origin, as
 * for Moller-Trumbore). tests/test_kernels_fma.py holds every ISA to it on
 * random pairs and on scaled (1e-3..1e3), shifted (to 1e3) and grazing rays,
 * and the plain plucker too: measured at 1.05 eps K at most (plucker) and
 * 0.78 (this kernel), with no wrong decision.
 * Flat triangles: NaN records (misses), as plucker.
 */

#if TB_NFIRST
#define tb_plucker_fma_algorithm "plucker" /* the clean scalar kernel it is a form of */
#define tb_plucker_fma_stride 21 /* reals per triangle: v0 v1 v2, three edges, n */
#define tb_plucker_fma_flat TB_FLAT_MISS
#define tb_plucker_fma_ray_f32 tb_ray_plain_f32
#define tb_plucker_fma_ray_f64 tb_ray_plain_f64
/* per lane and test (rules in kernels.h; an FMA counts 1), on the path that
 * does everything: shift 9, three products 42, sum 2, tolerance 1, min and
 * max 4, sign tests 2, n . d 3, n . (v0 - o) 3, t_max |n . d| 1, depth and
 * sum tests 3; the loop's division path: 1 / |n . d| 1, t 1, 0 < t < t_max 2 */
#define tb_plucker_fma_ops 74

/* the vertices; the edges a -> b, b -> c, c -> a, rounded once in `real`
 * (fl(p - q) = -fl(q - p): a shared edge is stored exactly negated); the
 * normal in double, rounded once */
static void TB_FN(tb_plucker_fma_prepare)(const real *vertices, size_t n, real *out)
{
    for (size_t i = 0; i < n; ++i) {
        const real *v = vertices + 9 * i;
        real *rec = out + 21 * i;
        double e1[3], e2[3];
        for (int k = 0; k < 3; ++k) {
            rec[k] = v[k];
            rec[3 + k] = v[3 + k];
            rec[6 + k] = v[6 + k];
            rec[9 + k] = v[3 + k] - v[k];
            rec[12 + k] = v[6 + k] - v[3 + k];
            rec[15 + k] = v[k] - v[6 + k];
            e1[k] = (double)v[3 + k] - v[k];
            e2[k] = (double)v[6 + k] - v[k];
        }
        rec[18] = (real)(e1[1] * e2[2] - e1[2] * e2[1]);
        rec[19] = (real)(e1[2] * e2[0] - e1[0] * e2[2]);
        rec[20] = (real)(e1[0] * e2[1] - e1[1] * e2[0]);
    }
}
#endif

/* ((q - p) x (p + q)) . d, the cross product fused, the dot product not (see
 * above); exactly negated when edge is */
TB_NWIDE nreal TB_NFN(tb_plucker_fma_side)(const nreal *p, const nreal *q, const nreal *edge, const nreal *d)
{
    nreal s0 = p[0] + q[0], s1 = p[1] + q[1], s2 = p[2] + q[2];
    nreal m0 = nv_fmsub(edge[1], s2, edge[2] * s1);
    nreal m1 = nv_fmsub(edge[2], s0, edge[0] * s2);
    nreal m2 = nv_fmsub(edge[0], s1, edge[1] * s0);
    return m0 * d[0] + m1 * d[1] + m2 * d[2];
}

TB_NWIDE nmask TB_NFN(tb_plucker_fma_test)(const tb_nray *restrict r, const real *restrict lanes, nreal t_max,
                                           tb_nhit *restrict h)
{
    const nreal *o = r->o, *d = r->d;
    nreal a[3], b[3], c[3], ab[3], bc[3], ca[3];
    for (int k = 0; k < 3; ++k) {
        a[k] = nv_load(lanes + TB_NBLOCK * k) - o[k];
        b[k] = nv_load(lanes + TB_NBLOCK * (3 + k)) - o[k];
        c[k] = nv_load(lanes + TB_NBLOCK * (6 + k)) - o[k];
        ab[k] = nv_load(lanes + TB_NBLOCK * (9 + k));
        bc[k] = nv_load(lanes + TB_NBLOCK * (12 + k));
        ca[k] = nv_load(lanes + TB_NBLOCK * (15 + k));
    }
    const nreal zero = nv_set1(0);
    const nbits sign_bit = (nbits)nv_set1((real)-0.0);

    /* edge tests: one sign within the tolerance, zeros either way */
    nreal side_bc = TB_NFN(tb_plucker_fma_side)(b, c, bc, d);
    nreal side_ca = TB_NFN(tb_plucker_fma_side)(c, a, ca, d);
    nreal side_ab = TB_NFN(tb_plucker_fma_side)(a, b, ab, d);
    nreal sum = side_bc + side_ca + side_ab;
    nbits sum_sign = (nbits)sum & sign_bit;
    nreal abs_sum = (nreal)((nbits)sum ^ sum_sign);
    nreal tolerance = nv_set1(TB_FN(tb_plucker_tolerance)) * abs_sum;
    nreal low = nv_min(nv_min(side_bc, side_ca), side_ab), high = nv_max(nv_max(side_bc, side_ca), side_ab);
    nmask same_sign = nm_or(nv_ge(low, (nreal)((nbits)tolerance ^ sign_bit)), nv_le(high, tolerance));
    if (!nm_any(same_sign)) {
        h->t = h->u = h->v = sum; /* unread (no lane set): defined all the same */
        h->den = h->uv_den = abs_sum;
        return same_sign;
    }

    /* depth test on the plane of the stored normal, sign folded in */
    nreal n[3];
    for (int k = 0; k < 3; ++k)
        n[k] = nv_load(lanes + TB_NBLOCK * (18 + k));
    nreal den = nv_fmadd(n[0], d[0], nv_fmadd(n[1], d[1], n[2] * d[2]));
    nreal scaled_t = nv_fmadd(n[0], a[0], nv_fmadd(n[1], a[1], n[2] * a[2]));
    nbits sign = (nbits)den & sign_bit;
    nreal abs_den = (nreal)((nbits)den ^ sign);
    nreal t = (nreal)((nbits)scaled_t ^ sign);
    nmask hit = nm_and(nm_and(same_sign, nv_gt(abs_sum, zero)),
                       nm_and(nv_gt(t, zero), nv_lt(t, t_max * abs_den)));
    /* t = t' / |n . d|, u and v = products / sum: the loop divides */
    h->t = t;
    h->den = abs_den;
    h->u = (nreal)((nbits)side_ca ^ sum_sign);
    h->v = (nreal)((nbits)side_ab ^ sum_sign);
    h->uv_den = abs_sum;
    h->uv_den_set = 1;
    return hit;
}

/* operations per test by class (fma, mul, add, cmp, div, logic), per lane, counted in the compiled
 * AVX-512 block loop (tests/test_ext_build.py); see kernels.h */
#define tb_plucker_fma_mix {13, 23, 30, 7, 1, 8}
