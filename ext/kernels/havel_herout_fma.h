/* havel_herout_fma: Havel & Herout's three-plane test at the CPU's native
 * width, fused multiply-adds, branchless.
 *
 * Reference: J. Havel, A. Herout, "Yet Faster Ray-Triangle Intersection
 * (Using SSE4)", IEEE TVCG 16(3):434-438, 2010 (as havel_herout.h, whose
 * record, promises and arithmetic this is). A native wide kernel (native.h):
 * 16 float / 8 double lanes with AVX-512, 8 / 4 with AVX2 + FMA, 4 / 2 on the
 * baseline, chosen at run time.
 *
 * Record: havel_herout's (N N_c, N1 N1_c, N2 N2_c: 12 reals, the planes
 * computed in double and rounded once). That is already the fully
 * precomputed layout of this algorithm (the paper's own): nothing per
 * triangle is left to compute, so its prepare is reused.
 *
 * How it differs from havel_herout's arithmetic on every lane (and why):
 *  - det, t' and P' are fused (one multiply, then fused multiply-adds);
 *    u' and v' are not (see below): 38 operations per test and lane, the
 *    loop's division path included, where havel_herout does 52
 *    (moller_trumbore_fma: 38);
 *  - written on negated quantities so that every fused step is one fmadd or
 *    fmsub: T = N.o - N_c = -t', Q = T d - det o = -P', -u' = N1.Q - det N1_c,
 *    -v' likewise; the sign fold then xors in the sign bit of -det (an exact
 *    +-1 multiplication without the multiply);
 *  - why u' and v' are not fused: fused (one multiply, two fmadd, one fmsub
 *    each) they made the cracks of tribench validate (full size) two to four
 *    times havel_herout's: through shared edges 16.1% / 17.6% of rays
 *    (float32 / float64) against 6.5% / 8.8%, at shared vertices 24% / 23%
 *    against 5.3% / 5.7%, misses from inside Embree's far sphere 19.6%
 *    against 9.9% (float32). Plain (three multiplies, two adds, then minus
 *    det N_c): 6.8% / 8.8%, 4.8% / 6.3%, 9.7%, as havel_herout. Neither form
 *    is watertight (the neighbours across an edge test different rounded
 *    planes); the fused one loses more sign agreements between them. Cost:
 *    6 operations per test more;
 *  - det != 0 is not tested: det = 0 gives |det| = 0, and 0 < t' < t_max |det|
 *    then fails (t_max = inf gives NaN, also a fail); the closed edge rule is
 *    u' >= 0, v' >= 0, u' + v' <= |det| (after the fold), every rejection
 *    !(accept), so a NaN is a miss, as havel_herout;
 *  - no early exit: every lane computes v' as well. An exit after u (a
 *    vector none of whose lanes passes the plane and u tests returns) would
 *    be taken by 78% of vectors on the Suzanne camera workload, but it is
 *    unpredictable and resolves at the end of the test's longest dependency
 *    chain, so each mispredict drains the loop: with it the kernel ran at
 *    0.87 ns per test against 0.55 without (Suzanne 968 triangles, 64^2
 *    camera, float32, AVX-512, Zen 4; docs/decisions.md, "How near the
 *    bound");
 *  - the loop, not the kernel, divides: once per vector with a candidate.
 * Not bit-for-bit havel_herout: a fused operation rounds once where the
 * scalar form rounds twice, and t' is N . o - N_c in one fused chain. Error
 * bound, against the float64 reference on the inputs as the kernel sees them:
 *   |t - t_ref| <= 2 eps K_hh t_ref,  K_hh = (|v0| + |o| + |d| t_ref) / (|N . d| t_ref)
 * (N the unit normal): t' is a difference of plane constants of the size of
 * the coordinates, so unlike Moller-Trumbore (whose o - v0 is exact) the
 * error scales with the distance from the coordinate origin, not from the
 * ray's origin. The same holds for u' and v': the hit or miss is the
 * reference's where its barycentric edge margin is at least 1e-3 and at least
 * 64 eps (|v0| + |o| + |d| t_ref) / h (h the triangle's smallest height).
 * tests/test_kernels_fma.py holds every ISA to both on random pairs and on
 * scaled (1e-3..1e3), shifted (to 1e3) and grazing rays, and the plain
 * havel_herout to the same: t measured at 0.81 eps K_hh at most (scalar) and
 * 0.89 (this kernel); wrong decisions at margins up to 7.2 (scalar) and 23.7
 * (this kernel) eps (|v0| + |o| + |d| t_ref) / h, all on float32 triangles of
 * 1e-3 at 1e3 from the origin, where both forms miss or hit wrongly alike.
 * Flat triangles: havel_herout's NaN records (misses).
 */

#if TB_NFIRST
#define tb_havel_herout_fma_algorithm "havel_herout" /* the clean scalar kernel it is a form of */
#define tb_havel_herout_fma_stride tb_havel_herout_stride
#define tb_havel_herout_fma_flat TB_FLAT_MISS
#define tb_havel_herout_fma_ray_f32 tb_ray_plain_f32
#define tb_havel_herout_fma_ray_f64 tb_ray_plain_f64
#define tb_havel_herout_fma_prepare_f32 tb_havel_herout_prepare_f32
#define tb_havel_herout_fma_prepare_f64 tb_havel_herout_prepare_f64
/* per lane and test (rules in kernels.h; an FMA counts 1), on the path that
 * does everything: det 3, t' 3, t_max |det| 1, plane tests 2, P' 6, u' 7,
 * u tests 2, v' 7, u' + v' 1, v tests 2; the loop's division path: 1 / |det|
 * 1, t 1, 0 < t < t_max 2 */
#define tb_havel_herout_fma_ops 38
#endif

TB_NWIDE nmask TB_NFN(tb_havel_herout_fma_test)(const tb_nray *restrict r, const real *restrict lanes,
                                                nreal t_max, tb_nhit *restrict h)
{
    const nreal *o = r->o, *d = r->d;
    nreal plane[4];
    for (int k = 0; k < 4; ++k)
        plane[k] = nv_load(lanes + TB_NBLOCK * k);
    const nreal zero = nv_set1(0);
    const nbits sign_bit = (nbits)nv_set1((real)-0.0);
    nreal det = nv_fmadd(plane[0], d[0], nv_fmadd(plane[1], d[1], plane[2] * d[2]));
    nreal neg_t = nv_fmadd(plane[0], o[0], nv_fmadd(plane[1], o[1], nv_fmsub(plane[2], o[2], plane[3])));
    nbits sign = (nbits)det & sign_bit;
    nbits flip = sign ^ sign_bit; /* the sign of -det: folds it into the negated quantities */
    nreal abs_det = (nreal)((nbits)det ^ sign);
    nreal t = (nreal)((nbits)neg_t ^ flip);
    nmask front = nm_and(nv_gt(t, zero), nv_lt(t, t_max * abs_det));
    nreal q[3], plane_u[4];
    for (int k = 0; k < 3; ++k)
        q[k] = nv_fmsub(neg_t, d[k], det * o[k]);
    for (int k = 0; k < 4; ++k)
        plane_u[k] = nv_load(lanes + TB_NBLOCK * (4 + k));
    nreal u = (nreal)((nbits)(plane_u[0] * q[0] + plane_u[1] * q[1] + plane_u[2] * q[2] - det * plane_u[3]) ^ flip);
    nmask first = nm_and(front, nm_and(nv_ge(u, zero), nv_le(u, abs_det)));
    nreal plane_v[4];
    for (int k = 0; k < 4; ++k)
        plane_v[k] = nv_load(lanes + TB_NBLOCK * (8 + k));
    nreal v = (nreal)((nbits)(plane_v[0] * q[0] + plane_v[1] * q[1] + plane_v[2] * q[2] - det * plane_v[3]) ^ flip);
    nmask hit = nm_and(first, nm_and(nv_ge(v, zero), nv_le(u + v, abs_det)));
    h->t = t;
    h->u = u;
    h->v = v;
    h->den = abs_det;
    return hit;
}

/* operations per test by class (fma, mul, add, cmp, div, logic), per lane, counted in the compiled
 * AVX-512 block loop (tests/test_ext_build.py); see kernels.h */
#define tb_havel_herout_fma_mix {8, 14, 7, 8, 1, 8}
