/* wald_fma: Wald's projection test at the CPU's native width, fused
 * multiply-adds, branchless.
 *
 * Reference: I. Wald, "Realtime Ray Tracing and Interactive Global
 * Illumination", PhD thesis, Saarland University, 2004 (as wald.h, whose
 * record values, promises and arithmetic this is). A native wide kernel
 * (native.h): 16 float / 8 double lanes with AVX-512, 8 / 4 with AVX2 + FMA,
 * 4 / 2 on the baseline, chosen at run time.
 *
 * Record: wald's values without the thesis's two pads: n_u n_v n_d k, b_nu
 * b_nv b_d, c_nu c_nv c_d (10 reals, 40 bytes in float32). The pads align a
 * record's quarters to 16 bytes for one triangle's loads; in blocks stored
 * structure of arrays (native.h) each field is its own aligned line, so a pad
 * would be a whole line of zeros per block read for nothing.
 *
 * The test, without the division (the loop divides), everything scaled by
 * den = |d_k + n_u d_u + n_v d_v| with its sign s folded in (xor with the
 * sign bit):
 *   W = o_k - n_d + n_u o_u + n_v o_v  (= -t' den s),  t' = -W s,
 *   H_u = den o_u - W d_u, H_v likewise (den times the hit point's u and v),
 *   beta' = (b_nu H_u + b_nv H_v + b_d den) s, gamma' likewise;
 * hit iff 0 < t' < t_max |den|, beta' >= 0, gamma' >= 0,
 * beta' + gamma' <= |den|.
 *
 * How it differs from wald's arithmetic on every lane (and why):
 *  - fused: the denominator, W, H and the line equations are each a multiply
 *    and fused multiply-adds (or fused only); no division in the kernel;
 *  - the hit point is the homogeneous one (den times it), as the thesis's
 *    projected h_u, h_v: the line equations then read it as the scalar form
 *    does, scaled by den, their constant b_d times den;
 *  - the dropped axis k differs from lane to lane (a block cannot be sorted by
 *    k: the records are the caller's triangles in the caller's order), so each
 *    lane takes the ray in its own axis order k, u, v from two masks (k == 1,
 *    k == 2; anything else reads as 0, as the scalar form) and two selects per
 *    component of o and d (baldwin_weber_9_fma does the same and says why
 *    selects, not gathers or permutes);
 *  - no early exit: every lane computes gamma as well (the thesis's SIMD form
 *    tests one triangle against four rays, so its exits are per triangle;
 *    across triangles, an exit after beta would be an unpredictable branch at
 *    the end of the longest chain, which cost havel_herout_fma and
 *    baldwin_weber_12_fma more than it saved: their headers);
 *  - den == 0 gives |den| = 0, and 0 < t' < t_max |den| fails (NaN for
 *    t_max = inf); a NaN anywhere fails a comparison: a miss, as wald.
 * Not bit for bit wald: a fused operation rounds once where the scalar form
 * rounds twice, and the hit point is not divided. Error bound, against the
 * float64 reference on the inputs as the kernel sees them: baldwin_weber_9's
 * (the same plane and line equations): |t - t_ref| <= 2 eps K t_ref, K =
 * |n| (|o| + |v0| + t_ref |d|) / (t_ref |n . d|), and the reference's decision
 * where its edge margin is at least 1e-3 and 4 eps K_uv
 * (tests/test_kernels_fma.py, every ISA): t measured there at 0.55 eps K at
 * most in float32 and 1.18 in float64, as the scalar wald (baldwin_weber_9:
 * 0.54, 1.08).
 * Shared edges and vertices (no promise; `tribench validate --quick`, one run):
 * cracks at 10% / 15% of the edge rays (float32 / float64) and 10% / 17% of
 * the vertex rays, against wald's 3.1% / 2.1% and 0 / 0; baldwin_weber_9_fma,
 * the same numbers by the determinant form, 13% / 13% and 4.2% / 23%: without
 * the division, the error of the plane's W reaches beta and gamma
 * (baldwin_weber_12_fma's header measured the same).
 * Flat triangles: NaN records (misses); unusable ones wald's miss record.
 */

#if TB_NFIRST
#define tb_wald_fma_algorithm "wald" /* the clean scalar kernel it is a form of */
#define tb_wald_fma_stride 10 /* reals per triangle: wald's record without its two pads */
#define tb_wald_fma_flat TB_FLAT_MISS
#define tb_wald_fma_ray_f32 tb_ray_plain_f32
#define tb_wald_fma_ray_f64 tb_ray_plain_f64
/* per lane and test (rules in kernels.h; an FMA counts 1), the path that does
 * everything: axis 2, den 2, W 3, H 4, beta' 3, gamma' 3, t_max |den| 1,
 * tests 5, beta' + gamma' 1; the loop's division path: 1 / den 1, t 1,
 * 0 < t < t_max 2 */
#define tb_wald_fma_ops 28

/* wald's record values (wald.h), rounded once, without the pads */
static void TB_FN(tb_wald_fma_prepare)(const real *vertices, size_t n_tris, real *out)
{
    static const double miss[10] = {0, 0, 0, 0, 0, 0, -1, 0, 0, -1};
    for (size_t i = 0; i < n_tris; ++i) {
        double m[10];
        if (TB_FN(tb_wald_record)(vertices + 9 * i, m) < 0)
            memcpy(m, miss, sizeof m);
        for (int j = 0; j < 10; ++j)
            out[10 * i + j] = (real)m[j];
    }
}
#endif

TB_NWIDE nmask TB_NFN(tb_wald_fma_test)(const tb_nray *restrict r, const real *restrict lanes, nreal t_max,
                                        tb_nhit *restrict h)
{
    /* the ray in each lane's axis order k, u, v */
    nreal o[3], d[3];
    TB_NFN(tb_nray_by_axis)(r, nv_load(lanes + TB_NBLOCK * 3), o, d);
    const nreal zero = nv_set1(0);
    const nbits sign_bit = (nbits)nv_set1((real)-0.0);
    const nreal n_u = nv_load(lanes), n_v = nv_load(lanes + TB_NBLOCK), n_d = nv_load(lanes + TB_NBLOCK * 2);
    const nreal den = nv_fmadd(n_v, d[2], nv_fmadd(n_u, d[1], d[0]));
    const nreal w = nv_fmadd(n_v, o[2], nv_fmadd(n_u, o[1], o[0] - n_d));
    const nbits sign = (nbits)den & sign_bit;
    const nreal abs_den = (nreal)((nbits)den ^ sign);
    const nreal t = (nreal)((nbits)w ^ sign ^ sign_bit);
    const nreal h_u = nv_fmsub(den, o[1], w * d[1]), h_v = nv_fmsub(den, o[2], w * d[2]);
    const real *b = lanes + TB_NBLOCK * 4, *c = lanes + TB_NBLOCK * 7;
    const nreal beta = (nreal)((nbits)nv_fmadd(nv_load(b), h_u, nv_fmadd(nv_load(b + TB_NBLOCK), h_v,
                                                                          nv_load(b + 2 * TB_NBLOCK) * den)) ^ sign);
    const nreal gamma = (nreal)((nbits)nv_fmadd(nv_load(c), h_u, nv_fmadd(nv_load(c + TB_NBLOCK), h_v,
                                                                           nv_load(c + 2 * TB_NBLOCK) * den)) ^ sign);
    nmask hit = nm_and(nm_and(nv_gt(t, zero), nv_lt(t, t_max * abs_den)), nv_ge(beta, zero));
    hit = nm_and(hit, nm_and(nv_ge(gamma, zero), nv_le(beta + gamma, abs_den)));
    h->t = t;
    h->u = beta;
    h->v = gamma;
    h->den = abs_den;
    return hit;
}

/* operations per test by class (fma, mul, add, cmp, div, logic), per lane, counted in the compiled
 * AVX-512 block loop (tests/test_ext_build.py); see kernels.h */
#define tb_wald_fma_mix {10, 6, 2, 9, 1, 21}
