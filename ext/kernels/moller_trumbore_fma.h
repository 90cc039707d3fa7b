/* moller_trumbore_fma: Moller-Trumbore at the CPU's native width, fused
 * multiply-adds, stored edges.
 *
 * Reference: Moller & Trumbore 1997 (late division, as moller_trumbore.h);
 * the stored-edge layout is Embree's (v0, e1 = v1 - v0, e2 = v2 - v0).
 * A native wide kernel (native.h): 16 float / 8 double lanes with AVX-512,
 * 8 / 4 with AVX2 + FMA, 4 / 2 on the baseline, chosen at run time; the ISA
 * that ran is recorded with its results. One name for every width: the
 * width is the machine's, not the algorithm's, so results from an AVX-512
 * and an AVX2 machine stay comparable under one name (a _x16 name would be
 * false on AVX2, where the same records run as two 8-lane vectors).
 *
 * How it differs from moller_trumbore's arithmetic on every lane (and why):
 *  - p = d x e2, q = s x e1 and the four dot products are fused
 *    (one multiply, then fused multiply-adds/-subtracts): 27 FMA-pipe
 *    operations instead of 45, the minimal arithmetic;
 *  - edges are prepared once (rounded once, as moller_trumbore rounds them
 *    per test, so the edges themselves are the same numbers);
 *  - the sign of det is folded in with bit operations (xor with its sign
 *    bit, an exact +-1 multiplication without the multiply);
 *  - det != 0 is not tested: det = 0 gives |det| = 0, and 0 < T < t_max |det|
 *    then fails (t_max = inf gives NaN, also a fail);
 *  - the loop, not the kernel, divides: once per vector with a candidate.
 * Not bit-for-bit moller_trumbore: a fused operation rounds once where the
 * scalar form rounds twice. Error bound, against the float64 reference on the
 * inputs as the kernel sees them: where the reference's barycentric edge
 * margin is at least 1e-3, the same hit or miss, and
 *   |t - t_ref| <= 4 eps K t_ref,  K = |e1| |e2| (|d| + |o - v0| / t_ref) / |det|
 * (eps of the precision; K is the conditioning of det and of the scaled t).
 * tests/test_kernels_fma.py holds every ISA to it on random pairs and on
 * scaled (1e-3..1e3), shifted (to 1e3) and grazing rays; measured there at
 * about 1.0 eps K at most, the same as the plain moller_trumbore.
 * Prepared data: v0, e1, e2 (9 reals). Flat triangles: NaN records (misses).
 */

#if TB_NFIRST
#define tb_moller_trumbore_fma_algorithm "moller_trumbore" /* the clean scalar kernel it is a form of */
#define tb_moller_trumbore_fma_stride 9 /* reals per triangle: v0, e1, e2 */
#define tb_moller_trumbore_fma_flat TB_FLAT_MISS
#define tb_moller_trumbore_fma_ray_f32 tb_ray_plain_f32
#define tb_moller_trumbore_fma_ray_f64 tb_ray_plain_f64
/* per lane and test (rules in kernels.h; an FMA counts 1): p 6, det 3, s 3,
 * u 3, q 6, v 3, t 3, u + v 1, t_max |det| 1, tests 5; the loop's division
 * path: 1 / |det| 1, t 1, 0 < t < t_max 2 */
#define tb_moller_trumbore_fma_ops 38

/* v0, then the edges, rounded once here */
static void TB_FN(tb_moller_trumbore_fma_prepare)(const real *vertices, size_t n, real *out)
{
    for (size_t i = 0; i < n; ++i) {
        const real *v = vertices + 9 * i;
        real *rec = out + 9 * i;
        for (int k = 0; k < 3; ++k) {
            rec[k] = v[k];
            rec[3 + k] = v[3 + k] - v[k];
            rec[6 + k] = v[6 + k] - v[k];
        }
    }
}
#endif

/* The test, with or without the early exit after u (moller_trumbore_fma_exit),
 * with or without culling (moller_trumbore_cull_fma: det's sign is not folded
 * in, so det <= 0 fails 0 <= u <= det or 0 < t < t_max det). */
TB_NWIDE nmask TB_NFN(tb_mt_fma)(const tb_nray *restrict r, const real *restrict lanes,
                                 nreal t_max, tb_nhit *restrict h, const int early_exit,
                                 const int cull)
{
    const nreal *o = r->o, *d = r->d;
    nreal v0[3], e1[3], e2[3];
    for (int k = 0; k < 3; ++k) {
        v0[k] = nv_load(lanes + TB_NBLOCK * k);
        e1[k] = nv_load(lanes + TB_NBLOCK * (3 + k));
        e2[k] = nv_load(lanes + TB_NBLOCK * (6 + k));
    }
    const nreal zero = nv_set1(0);
    const nbits sign_bit = (nbits)nv_set1((real)-0.0);
    nreal px = nv_fmsub(d[1], e2[2], d[2] * e2[1]);
    nreal py = nv_fmsub(d[2], e2[0], d[0] * e2[2]);
    nreal pz = nv_fmsub(d[0], e2[1], d[1] * e2[0]);
    nreal det = nv_fmadd(e1[0], px, nv_fmadd(e1[1], py, e1[2] * pz));
    nbits sign = cull ? (nbits)zero : (nbits)det & sign_bit;
    nreal abs_det = (nreal)((nbits)det ^ sign);
    nreal sx = o[0] - v0[0], sy = o[1] - v0[1], sz = o[2] - v0[2];
    nreal u = (nreal)((nbits)nv_fmadd(sx, px, nv_fmadd(sy, py, sz * pz)) ^ sign);
    nmask first = nv_ge(u, zero);
    if (early_exit) {
        first = nm_and(first, nv_le(u, abs_det));
        if (!nm_any(first)) {
            h->t = h->u = h->v = u; /* unread (no lane set): defined all the same */
            h->den = abs_det;
            return first;
        }
    }
    nreal qx = nv_fmsub(sy, e1[2], sz * e1[1]);
    nreal qy = nv_fmsub(sz, e1[0], sx * e1[2]);
    nreal qz = nv_fmsub(sx, e1[1], sy * e1[0]);
    nreal v = (nreal)((nbits)nv_fmadd(d[0], qx, nv_fmadd(d[1], qy, d[2] * qz)) ^ sign);
    nreal t = (nreal)((nbits)nv_fmadd(e2[0], qx, nv_fmadd(e2[1], qy, e2[2] * qz)) ^ sign);
    nmask hit = nm_and(nm_and(first, nv_ge(v, zero)),
                       nm_and(nv_le(u + v, abs_det),
                              nm_and(nv_gt(t, zero), nv_lt(t, t_max * abs_det))));
    h->t = t;
    h->u = u;
    h->v = v;
    h->den = abs_det;
    return hit;
}

TB_NWIDE nmask TB_NFN(tb_moller_trumbore_fma_test)(const tb_nray *restrict r, const real *restrict lanes,
                                                   nreal t_max, tb_nhit *restrict h)
{
    return TB_NFN(tb_mt_fma)(r, lanes, t_max, h, 0, 0);
}

/* operations per test by class (fma, mul, add, cmp, div, logic), per lane, counted in the compiled
 * AVX-512 block loop (tests/test_ext_build.py); the AVX2 loop does one more compare and more logic
 * (no mask registers); see kernels.h */
#define tb_moller_trumbore_fma_mix {14, 12, 4, 7, 1, 8}
