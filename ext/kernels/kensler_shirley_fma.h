/* kensler_shirley_fma: Kensler & Shirley's test at the CPU's native width,
 * fused multiply-adds, no division in the test.
 *
 * Reference: A. Kensler, P. Shirley, "Optimizing Ray-Triangle Intersection
 * via Automated Search", IEEE Symposium on Interactive Ray Tracing 2006 (as
 * kensler_shirley.h, whose record, promises and arithmetic this is). A native
 * wide kernel (native.h): 16 float / 8 double lanes with AVX-512, 8 / 4 with
 * AVX2 + FMA, 4 / 2 on the baseline, chosen at run time.
 *
 * Record: the raw vertices (9 reals), as kensler_shirley.
 *
 * The test, without a division (the loop divides): f = v0 - v1, g = v2 - v0,
 * n = g x f, c = v0 - o, i = c x d; den = n . d, and with den's sign folded
 * in t' = n . c, u' = g . i, v' = f . i; hit iff u' >= 0, v' >= 0,
 * u' + v' <= |den| and 0 < t' < t_max |den|. t = t' / |den|, u and v likewise.
 *
 * How it differs from kensler_shirley's arithmetic on every lane (and why):
 *  - no reciprocal in the test: t, u and v are compared scaled by |den|
 *    (the sign folded in with bit operations, an exact +-1), and the loop
 *    divides once per vector with a candidate;
 *  - fused: both cross products and the four dot products are a multiply
 *    and fused multiply-adds;
 *  - den == 0 needs no test: |den| = 0 fails 0 < t' < t_max |den|;
 *  - no early exit: the scalar form's order (t, then u, then v) would be
 *    branches in the middle of a short chain.
 * Not bit for bit kensler_shirley. Error bound: Moller-Trumbore's (the same
 * edges, determinant and triple products, grouped otherwise:
 * |t - t_ref| <= 4 eps K t_ref, K = |e1| |e2| (|d| + |o - v0| / t_ref) / |det|;
 * tests/test_kernels_fma.py, every ISA).
 * Flat triangles: NaN records (misses).
 */

#if TB_NFIRST
#define tb_kensler_shirley_fma_algorithm "kensler_shirley" /* the clean scalar kernel it is a form of */
#define tb_kensler_shirley_fma_stride 9 /* reals per triangle: v0 v1 v2 */
#define tb_kensler_shirley_fma_flat TB_FLAT_MISS
#define tb_kensler_shirley_fma_ray_f32 tb_ray_plain_f32
#define tb_kensler_shirley_fma_ray_f64 tb_ray_plain_f64
#define tb_kensler_shirley_fma_prepare_f32 tb_prepare_vertices_f32
#define tb_kensler_shirley_fma_prepare_f64 tb_prepare_vertices_f64
/* per lane and test (rules in kernels.h; an FMA counts 1): edges 6, n 6,
 * den 3, c 3, i 6, t' 3, u' 3, v' 3, u' + v' 1, t_max |den| 1, tests 5; the
 * loop's division path: 1 / |den| 1, t 1, 0 < t < t_max 2 */
#define tb_kensler_shirley_fma_ops 44
#endif

TB_NWIDE nmask TB_NFN(tb_kensler_shirley_fma_test)(const tb_nray *restrict r, const real *restrict lanes,
                                                   nreal t_max, tb_nhit *restrict h)
{
    const nreal *o = r->o, *d = r->d;
    nreal f[3], g[3], c[3];
    for (int k = 0; k < 3; ++k) {
        const nreal v0 = nv_load(lanes + TB_NBLOCK * k);
        f[k] = v0 - nv_load(lanes + TB_NBLOCK * (3 + k));
        g[k] = nv_load(lanes + TB_NBLOCK * (6 + k)) - v0;
        c[k] = v0 - o[k];
    }
    const nreal zero = nv_set1(0);
    const nbits sign_bit = (nbits)nv_set1((real)-0.0);

    /* the two shared cross products */
    const nreal n0 = nv_fmsub(g[1], f[2], g[2] * f[1]);
    const nreal n1 = nv_fmsub(g[2], f[0], g[0] * f[2]);
    const nreal n2 = nv_fmsub(g[0], f[1], g[1] * f[0]);
    const nreal i0 = nv_fmsub(c[1], d[2], c[2] * d[1]);
    const nreal i1 = nv_fmsub(c[2], d[0], c[0] * d[2]);
    const nreal i2 = nv_fmsub(c[0], d[1], c[1] * d[0]);

    /* one dot product each, den's sign folded in */
    const nreal den = nv_fmadd(n0, d[0], nv_fmadd(n1, d[1], n2 * d[2]));
    const nbits sign = (nbits)den & sign_bit;
    const nreal abs_den = (nreal)((nbits)den ^ sign);
    const nreal t = (nreal)((nbits)nv_fmadd(n0, c[0], nv_fmadd(n1, c[1], n2 * c[2])) ^ sign);
    const nreal u = (nreal)((nbits)nv_fmadd(g[0], i0, nv_fmadd(g[1], i1, g[2] * i2)) ^ sign);
    const nreal v = (nreal)((nbits)nv_fmadd(f[0], i0, nv_fmadd(f[1], i1, f[2] * i2)) ^ sign);
    const nmask hit = nm_and(nm_and(nv_ge(u, zero), nv_ge(v, zero)),
                             nm_and(nv_le(u + v, abs_den), nm_and(nv_gt(t, zero), nv_lt(t, t_max * abs_den))));
    h->t = t;
    h->u = u;
    h->v = v;
    h->den = abs_den;
    return hit;
}

/* operations per test by class (fma, mul, add, cmp, div, logic), per lane, counted in the compiled
 * AVX-512 block loop (tests/test_ext_build.py); see kernels.h */
#define tb_kensler_shirley_fma_mix {14, 12, 10, 7, 1, 8}
