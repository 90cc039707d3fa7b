/* badouel_fma: Badouel's projection test at the CPU's native width, fused
 * multiply-adds, branchless.
 *
 * Reference: D. Badouel, "An Efficient Ray-Polygon Intersection", Graphics
 * Gems, 1990, pp. 390-393 (as badouel.h, whose record, promises and
 * arithmetic this is). A native wide kernel (native.h): 16 float / 8 double
 * lanes with AVX-512, 8 / 4 with AVX2 + FMA, 4 / 2 on the baseline, chosen at
 * run time.
 *
 * Record: badouel's (N N_c, k, the vertices' a and b coordinates: 11 reals),
 * prepared by the same function.
 *
 * The test, without a division (the loop divides): with den = N . d and
 * W = N . o - N_c (= -t den), the hit point's offset from v0 on the plane that
 * drops k, scaled by den: u0' = den (o_a - v0_a) - W d_a, v0' likewise; the
 * edges (u1, v1), (u2, v2) from the stored coordinates, det = u1 v2 - u2 v1;
 * alpha'' = u0' v2 - v0' u2, beta'' = u1 v0' - v1 u0' (den det times alpha and
 * beta); the signs of den and det folded in (xor with sign bits):
 * hit iff 0 < t' < t_max |den| (t' = -W sign(den)), alpha'' >= 0,
 * beta'' >= 0, alpha'' + beta'' <= |den det| and |den det| > 0. t = t' / |den|,
 * and u, v are divided by their own denominator |den det| (h->uv_den, native.h),
 * once, where they are asked for.
 *
 * How it differs from badouel's arithmetic on every lane (and why):
 *  - no division in the kernel: the barycentrics are scaled by den det, so
 *    both the plane's and the 2-D determinant's divisions leave the test;
 *  - the hit point is never formed: o_a - v0_a first (the offset of the ray's
 *    origin from the vertex, as Moller-Trumbore's s = o - v0), then the
 *    scaled step along d, so the coordinates' size cancels before the step
 *    is added (the scalar form's p_a - v0_a cancels after);
 *  - fused: N . d, W, the offsets and every 2 x 2 determinant a multiply and
 *    fused multiply-adds;
 *  - |den det| > 0 is tested: det rounded to 0 (a triangle too small for the
 *    precision) would otherwise pass with alpha'' = beta'' = 0; the scalar
 *    form misses it through a NaN;
 *  - the dropped axis k is per lane, read with two masks and two selects per
 *    used component of o and d (a and b: 8 selects), as baldwin_weber_9_fma;
 *  - no early exit: every lane computes alpha and beta (an exit after the
 *    plane test would be an unpredictable branch at the end of a long chain;
 *    havel_herout_fma measured such an exit costing more than it saved).
 * Not bit for bit badouel. Error bound: havel_herout's (the same rounded unit
 * plane: |t - t_ref| <= 2 eps K_hh t_ref), and the reference's decision where
 * its edge margin is at least 1e-3 and 64 eps (|v0| + |o| + |d| t_ref) / h
 * (h the triangle's smallest height; tests/test_kernels_fma.py, every ISA):
 * t measured there at 0.60 eps K_hh at most in float32 and 0.98 in float64
 * (scalar badouel), 0.52 and 1.08 (this kernel; havel_herout: 0.60, 0.88).
 * Shared edges and vertices (no promise; `tribench validate --quick`, one run):
 * cracks at 1.0% / 3.7% of the edge rays (float32 / float64) and 0 / 8.3% of
 * the vertex rays, against badouel's 0 / 3.1% and 0 / 0 (havel_herout_fma:
 * 6.3% / 3.7%, 8.3% / 4.2%).
 * Flat triangles: badouel's NaN records (misses).
 */

#if TB_NFIRST
#define tb_badouel_fma_algorithm "badouel" /* the clean scalar kernel it is a form of */
#define tb_badouel_fma_stride tb_badouel_stride
#define tb_badouel_fma_flat TB_FLAT_MISS
#define tb_badouel_fma_ray_f32 tb_ray_plain_f32
#define tb_badouel_fma_ray_f64 tb_ray_plain_f64
#define tb_badouel_fma_prepare_f32 tb_badouel_prepare_f32
#define tb_badouel_fma_prepare_f64 tb_badouel_prepare_f64
/* per lane and test (rules in kernels.h; an FMA counts 1), the path that does
 * everything: axis 2, den 3, W 3, o - v0 2, u0' v0' 4, edges 4, det 2,
 * alpha'' 2, beta'' 2, |den det| 1, t_max |den| 1, tests 6, alpha'' + beta'' 1;
 * the loop's division path: 1 / den 1, t 1, 0 < t < t_max 2 */
#define tb_badouel_fma_ops 37
#endif

TB_NWIDE nmask TB_NFN(tb_badouel_fma_test)(const tb_nray *restrict r, const real *restrict lanes, nreal t_max,
                                           tb_nhit *restrict h)
{
    const nreal zero = nv_set1(0);
    const nbits sign_bit = (nbits)nv_set1((real)-0.0);
    /* the plane */
    nreal plane[4];
    for (int j = 0; j < 4; ++j)
        plane[j] = nv_load(lanes + TB_NBLOCK * j);
    const nreal den = nv_fmadd(plane[0], r->d[0], nv_fmadd(plane[1], r->d[1], plane[2] * r->d[2]));
    const nreal w = nv_fmadd(plane[0], r->o[0], nv_fmadd(plane[1], r->o[1], nv_fmsub(plane[2], r->o[2], plane[3])));
    const nbits sign = (nbits)den & sign_bit;
    const nreal abs_den = (nreal)((nbits)den ^ sign);
    const nreal t = (nreal)((nbits)w ^ sign ^ sign_bit);

    /* the ray's a and b components in each lane's projection (a = k + 1, b = k + 2) */
    const nreal axis = nv_load(lanes + TB_NBLOCK * 4);
    const nmask is1 = nv_eq(axis, nv_set1(1)), is2 = nv_eq(axis, nv_set1(2));
    const nreal o_a = nv_select(is1, r->o[2], nv_select(is2, r->o[0], r->o[1]));
    const nreal o_b = nv_select(is1, r->o[0], nv_select(is2, r->o[1], r->o[2]));
    const nreal d_a = nv_select(is1, r->d[2], nv_select(is2, r->d[0], r->d[1]));
    const nreal d_b = nv_select(is1, r->d[0], nv_select(is2, r->d[1], r->d[2]));

    /* the 2-D barycentrics, scaled by den det */
    nreal p[6];
    for (int j = 0; j < 6; ++j)
        p[j] = nv_load(lanes + TB_NBLOCK * (5 + j));
    const nreal u0 = nv_fmsub(den, o_a - p[0], w * d_a), v0 = nv_fmsub(den, o_b - p[1], w * d_b);
    const nreal u1 = p[2] - p[0], v1 = p[3] - p[1], u2 = p[4] - p[0], v2 = p[5] - p[1];
    const nreal det = nv_fmsub(u1, v2, u2 * v1);
    const nbits flip = ((nbits)den ^ (nbits)det) & sign_bit;
    const nreal scale = (nreal)((nbits)(den * det) & ~sign_bit);
    const nreal alpha = (nreal)((nbits)nv_fmsub(u0, v2, v0 * u2) ^ flip);
    const nreal beta = (nreal)((nbits)nv_fmsub(u1, v0, v1 * u0) ^ flip);
    nmask hit = nm_and(nm_and(nv_gt(t, zero), nv_lt(t, t_max * abs_den)), nv_gt(scale, zero));
    hit = nm_and(hit, nm_and(nm_and(nv_ge(alpha, zero), nv_ge(beta, zero)), nv_le(alpha + beta, scale)));
    h->t = t;
    h->u = alpha;
    h->v = beta;
    h->den = abs_den;
    h->uv_den = scale;
    h->uv_den_set = 1;
    return hit;
}

/* operations per test by class (fma, mul, add, cmp, div, logic), per lane, counted in the compiled
 * AVX-512 block loop (tests/test_ext_build.py); see kernels.h */
#define tb_badouel_fma_mix {10, 9, 7, 10, 1, 18}
