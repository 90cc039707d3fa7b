/* segura_feito_fma: Segura & Feito's determinant-sign test at the CPU's native
 * width, fused multiply-adds, an early exit before the plane.
 *
 * Reference: R. J. Segura, F. R. Feito, "Algorithms to test ray-triangle
 * intersection. Comparative study", Journal of WSCG 9(3), 2001 (as
 * segura_feito.h, whose record, promises and arithmetic this is). A native
 * wide kernel (native.h): 16 float / 8 double lanes with AVX-512, 8 / 4 with
 * AVX2 + FMA, 4 / 2 on the baseline, chosen at run time.
 *
 * Record: the raw vertices (9 reals), as segura_feito.
 *
 * The test, without a division (the loop divides): a, b, c = the vertices
 * shifted by -o, the edges a -> b -> c -> a; the three edge determinants
 * w2 = (a x (b - a)) . d, w0 = (b x (c - b)) . d, w1 = (c x (a - c)) . d,
 * sum = w0 + w1 + w2; hit iff every w_i, its sign folded with sum's, is
 * >= 0 and |sum| > 0; then n = (b - a) x (c - a), den = n . d, t' = n . a
 * with den's sign folded in, 0 < t' < t_max |den|. t = t' / |den|, and u, v
 * = w1, w2 over |sum| (h->uv_den, native.h), divided where they are asked for.
 *
 * How it differs from segura_feito's arithmetic on every lane (and why):
 *  - three cross products, one per determinant: two shared ones (c x d,
 *    b x d, expanding along the ray's column) save 12 operations but lose
 *    the edge-length rounding of segura_feito's form, and missed a third
 *    of `tribench validate --quick`'s tiny triangles in float32;
 *  - fused: every cross and dot product is a multiply and fused multiply-adds;
 *  - the signs are folded with sum's (xor with its sign bit) and tested
 *    against 0 once each, not both ways;
 *  - one early exit: a vector leaves as soon as no lane crosses all three
 *    edges (the paper's point: the plane only for a crossing), before n and
 *    t; the partial-sum test of the scalar form becomes the test on the sum;
 *  - the loop, not the kernel, divides.
 * Not bit for bit segura_feito. Error bound: plucker's (the same shifted
 * triple products and the same n . a / n . d: |t - t_ref| <= 2 eps K t_ref,
 * K = |e1| |e2| (|d| + |o - v0| / t_ref) / |det|; tests/test_kernels_fma.py,
 * every ISA).
 * Flat triangles: NaN records (misses).
 */

#if TB_NFIRST
#define tb_segura_feito_fma_algorithm "segura_feito" /* the clean scalar kernel it is a form of */
#define tb_segura_feito_fma_stride 9 /* reals per triangle: v0 v1 v2 */
#define tb_segura_feito_fma_flat TB_FLAT_MISS
#define tb_segura_feito_fma_ray_f32 tb_ray_plain_f32
#define tb_segura_feito_fma_ray_f64 tb_ray_plain_f64
#define tb_segura_feito_fma_prepare_f32 tb_prepare_vertices_f32
#define tb_segura_feito_fma_prepare_f64 tb_prepare_vertices_f64
/* per lane and test (rules in kernels.h; an FMA counts 1), on the path that
 * does everything: shift 9, edges 9, three volumes 27, sum 2, sign tests 3,
 * |sum| > 0 1, n 6, n . d 3, n . a 3, t_max |den| 1, t tests 2; the loop's
 * division path: 1 / |den| 1, t 1, 0 < t < t_max 2 */
#define tb_segura_feito_fma_ops 70
#endif

/* (x x e) . d, the cross product and the dot product fused */
TB_NWIDE nreal TB_NFN(tb_segura_feito_fma_volume)(const nreal *x, const nreal *e, const nreal *d)
{
    const nreal m0 = nv_fmsub(x[1], e[2], x[2] * e[1]);
    const nreal m1 = nv_fmsub(x[2], e[0], x[0] * e[2]);
    const nreal m2 = nv_fmsub(x[0], e[1], x[1] * e[0]);
    return nv_fmadd(m0, d[0], nv_fmadd(m1, d[1], m2 * d[2]));
}

TB_NWIDE nmask TB_NFN(tb_segura_feito_fma_test)(const tb_nray *restrict r, const real *restrict lanes,
                                                nreal t_max, tb_nhit *restrict h)
{
    const nreal *o = r->o, *d = r->d;
    nreal a[3], b[3], c[3], ab[3], bc[3], ca[3];
    for (int k = 0; k < 3; ++k) {
        a[k] = nv_load(lanes + TB_NBLOCK * k) - o[k];
        b[k] = nv_load(lanes + TB_NBLOCK * (3 + k)) - o[k];
        c[k] = nv_load(lanes + TB_NBLOCK * (6 + k)) - o[k];
    }
    for (int k = 0; k < 3; ++k) {
        ab[k] = b[k] - a[k];
        bc[k] = c[k] - b[k];
        ca[k] = a[k] - c[k];
    }
    const nreal zero = nv_set1(0);
    const nbits sign_bit = (nbits)nv_set1((real)-0.0);

    /* the edge determinants (x x (y - x)) . d, as segura_feito */
    const nreal w2 = TB_NFN(tb_segura_feito_fma_volume)(a, ab, d);
    const nreal w0 = TB_NFN(tb_segura_feito_fma_volume)(b, bc, d);
    const nreal w1 = TB_NFN(tb_segura_feito_fma_volume)(c, ca, d);
    const nreal sum = w0 + w1 + w2;
    const nbits sum_sign = (nbits)sum & sign_bit;
    const nreal abs_sum = (nreal)((nbits)sum ^ sum_sign);
    const nreal u = (nreal)((nbits)w1 ^ sum_sign), v = (nreal)((nbits)w2 ^ sum_sign);
    const nmask crosses = nm_and(nm_and(nv_ge((nreal)((nbits)w0 ^ sum_sign), zero), nv_ge(u, zero)),
                                 nm_and(nv_ge(v, zero), nv_gt(abs_sum, zero)));
    if (!nm_any(crosses)) {
        h->t = h->u = h->v = sum; /* unread (no lane set): defined all the same */
        h->den = h->uv_den = abs_sum;
        return crosses;
    }

    /* the plane: t' = n . a over n . d, sign folded in */
    const nreal n0 = nv_fmsub(ca[1], ab[2], ca[2] * ab[1]); /* (a - c) x (b - a) */
    const nreal n1 = nv_fmsub(ca[2], ab[0], ca[0] * ab[2]);
    const nreal n2 = nv_fmsub(ca[0], ab[1], ca[1] * ab[0]);
    const nreal den = nv_fmadd(n0, d[0], nv_fmadd(n1, d[1], n2 * d[2]));
    const nbits sign = (nbits)den & sign_bit;
    const nreal abs_den = (nreal)((nbits)den ^ sign);
    const nreal t = (nreal)((nbits)nv_fmadd(n0, a[0], nv_fmadd(n1, a[1], n2 * a[2])) ^ sign);
    const nmask hit = nm_and(crosses, nm_and(nv_gt(t, zero), nv_lt(t, t_max * abs_den)));
    h->t = t;
    h->den = abs_den;
    h->u = u;
    h->v = v;
    h->uv_den = abs_sum;
    h->uv_den_set = 1;
    return hit;
}

/* operations per test by class (fma, mul, add, cmp, div, logic), per lane, counted in the compiled
 * AVX-512 block loop (tests/test_ext_build.py); see kernels.h */
#define tb_segura_feito_fma_mix {22, 19, 20, 8, 1, 10}
