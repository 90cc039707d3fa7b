/* shevtsov_fma: Shevtsov, Soupikov & Kapustin's projection test at the CPU's
 * native width, fused multiply-adds, branchless.
 *
 * Reference: M. Shevtsov, A. Soupikov, A. Kapustin, "Ray-Triangle
 * Intersection Algorithm for Modern CPU Architectures", GraphiCon 2007 (as
 * shevtsov.h, whose record, promises and arithmetic this is). A native wide
 * kernel (native.h): 16 float / 8 double lanes with AVX-512, 8 / 4 with
 * AVX2 + FMA, 4 / 2 on the baseline, chosen at run time.
 *
 * Record: shevtsov's 10 reals (n_u' n_v' n_d k p_u p_v U_u U_v V_u V_v), prepared
 * by the same function, in blocks of 16 lanes: 16 triangles against one ray
 * (the paper vectorises the other way, over ray packets: one triangle's
 * record against several rays).
 *
 * The test, without a division (the loop divides): the ray's components in
 * each lane's axis order k, u, v (selects on the stored k); det =
 * d_k + n_u' d_u + n_v' d_v, W = o_k + n_u' o_u + n_v' o_v - n_d (= -t det),
 * D_u = det (o_u - p_u) - W d_u (= det (hit_u - p_u)), D_v likewise,
 * U' = U_u D_u + U_v D_v, V' = V_u D_u + V_v D_v, det's sign folded in:
 * hit iff U' >= 0, V' >= 0, U' + V' <= |det| and 0 < t' < t_max |det|
 * (t' = -W sign(det)). t = t' / |det|, u and v likewise.
 *
 * How it differs from shevtsov's arithmetic on every lane (and why):
 *  - fused: det, W, the offsets and the two edge equations are a multiply
 *    and fused multiply-adds;
 *  - the sign of det folded in with bit operations (xor with its sign bit);
 *  - the dropped axis is per lane, read with two masks and two selects per
 *    component of o and d, as wald_fma;
 *  - no early exit; the loop, not the kernel, divides.
 * Not bit for bit shevtsov. Error bound: Baldwin-Weber's (the same plane
 * scaled to n_k = 1 as baldwin_weber_9 and wald; tests/test_kernels_fma.py,
 * every ISA).
 * Shared edges and vertices (no promise; `tribench validate --quick`, one run):
 * cracks at 6.8% / 4.2% of the edge rays (float32 / float64) and 2.1% / 0 of
 * the vertex rays, against shevtsov's 1.0% / 0 and 0 / 0 (wald_fma: 10.4% /
 * 14.6%, 10.4% / 16.7%); shevtsov in float64, as wald, badouel and
 * baldwin_weber_9, hit 1 of 32 rays lying in a triangle's plane.
 * Flat triangles: shevtsov's NaN records (misses).
 */

#if TB_NFIRST
#define tb_shevtsov_fma_algorithm "shevtsov" /* the clean scalar kernel it is a form of */
#define tb_shevtsov_fma_stride tb_shevtsov_stride
#define tb_shevtsov_fma_flat TB_FLAT_MISS
#define tb_shevtsov_fma_ray_f32 tb_ray_plain_f32
#define tb_shevtsov_fma_ray_f64 tb_ray_plain_f64
#define tb_shevtsov_fma_prepare_f32 tb_shevtsov_prepare_f32
#define tb_shevtsov_fma_prepare_f64 tb_shevtsov_prepare_f64
/* per lane and test (rules in kernels.h; an FMA counts 1), the path that does
 * everything: axis 2, det 2, W 3, D_u 3, D_v 3, U' 2, V' 2, t_max |det| 1,
 * tests 5, U' + V' 1; the loop's division path: 1 / det 1, t 1,
 * 0 < t < t_max 2 */
#define tb_shevtsov_fma_ops 28
#endif

TB_NWIDE nmask TB_NFN(tb_shevtsov_fma_test)(const tb_nray *restrict r, const real *restrict lanes, nreal t_max,
                                            tb_nhit *restrict h)
{
    /* the ray in each lane's axis order k, u, v */
    nreal o[3], d[3];
    TB_NFN(tb_nray_by_axis)(r, nv_load(lanes + TB_NBLOCK * 3), o, d);
    const nreal zero = nv_set1(0);
    const nbits sign_bit = (nbits)nv_set1((real)-0.0);

    /* the plane, its k coefficient 1 */
    const nreal n_u = nv_load(lanes), n_v = nv_load(lanes + TB_NBLOCK), n_d = nv_load(lanes + TB_NBLOCK * 2);
    const nreal det = nv_fmadd(n_v, d[2], nv_fmadd(n_u, d[1], d[0]));
    const nreal w = nv_fmadd(n_v, o[2], nv_fmadd(n_u, o[1], o[0] - n_d));
    const nbits sign = (nbits)det & sign_bit;
    const nreal abs_det = (nreal)((nbits)det ^ sign);
    const nreal t = (nreal)((nbits)w ^ sign ^ sign_bit);

    /* the hit point's offset from v0, times det, and the edge equations */
    const nreal p_u = nv_load(lanes + TB_NBLOCK * 4), p_v = nv_load(lanes + TB_NBLOCK * 5);
    const nreal du = nv_fmsub(det, o[1] - p_u, w * d[1]), dv = nv_fmsub(det, o[2] - p_v, w * d[2]);
    const real *eu = lanes + TB_NBLOCK * 6, *ev = lanes + TB_NBLOCK * 8;
    const nreal su = (nreal)((nbits)nv_fmadd(nv_load(eu), du, nv_load(eu + TB_NBLOCK) * dv) ^ sign);
    const nreal sv = (nreal)((nbits)nv_fmadd(nv_load(ev), du, nv_load(ev + TB_NBLOCK) * dv) ^ sign);
    nmask hit = nm_and(nm_and(nv_gt(t, zero), nv_lt(t, t_max * abs_det)), nv_ge(su, zero));
    hit = nm_and(hit, nm_and(nv_ge(sv, zero), nv_le(su + sv, abs_det)));
    h->t = t;
    h->u = su;
    h->v = sv;
    h->den = abs_det;
    return hit;
}

/* operations per test by class (fma, mul, add, cmp, div, logic), per lane, counted in the compiled
 * AVX-512 block loop (tests/test_ext_build.py); see kernels.h */
#define tb_shevtsov_fma_mix {8, 6, 4, 9, 1, 21}
