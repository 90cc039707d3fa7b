/* moller_trumbore_cull_fma: Moller-Trumbore with back-face culling at the
 * CPU's native width, fused multiply-adds, stored edges, early exit.
 *
 * Reference: Moller & Trumbore 1997, the culling branch (TEST_CULL), late
 * division, as moller_trumbore_cull.h: only det = e1 . (d x e2) > 0 counts
 * (the vertices counter-clockwise seen from the ray's origin), closed
 * triangle, no epsilon, NaN = miss, 0 < t < t_max, flat triangles miss.
 * A native wide kernel (native.h), the arithmetic of moller_trumbore_fma
 * (its test, tb_mt_fma, with the cull parameter: moller_trumbore_fma.h),
 * with the early exit of moller_trumbore_fma_exit (after u).
 *
 * How it differs from moller_trumbore_cull's arithmetic on every lane (and
 * why): as moller_trumbore_fma from moller_trumbore's (fused products, stored
 * edges, no division in the test), and:
 *  - det's sign is not folded in (the paper's culling branch compares the
 *    scaled barycentrics with det itself): 0 <= u <= det, v >= 0,
 *    u + v <= det, 0 < t < t_max det;
 *  - det > 0 is not tested: det < 0 fails 0 <= u <= det, and det = 0 fails
 *    0 < t < t_max det (t_max = inf gives NaN, also a fail), so no back face,
 *    parallel ray or degenerate triangle gets through;
 *  - early exit after 0 <= u <= det, which rejects every back face as well
 *    as the lanes outside the u slab: no lane left, the vector returns;
 *  - the loop, not the kernel, divides: once per vector with a candidate.
 * On a front face (det > 0) every value is moller_trumbore_fma's bit for bit
 * (its fold is then the identity), so the answers are moller_trumbore_fma's
 * where det > 0 and misses elsewhere (tests/test_kernels_fma.py checks it).
 * Error bound: moller_trumbore_fma's, against the float64 reference with
 * culling (the reference's hits with det > 0):
 *   |t - t_ref| <= 4 eps K t_ref,  K = |e1| |e2| (|d| + |o - v0| / t_ref) / |det|
 * and the same hit or miss where the reference's barycentric edge margin is
 * at least 1e-3; measured at about 1.0 eps K at most, as moller_trumbore_cull.
 * Prepared data: moller_trumbore_fma's (v0, e1, e2: 9 reals, 36 bytes in
 * float32, 72 in float64; moller_trumbore_cull stores the vertices and
 * subtracts the edges on every test).
 */

#if TB_NFIRST
#define tb_moller_trumbore_cull_fma_algorithm "moller_trumbore_cull" /* the clean scalar kernel it is a form of */
#define tb_moller_trumbore_cull_fma_stride tb_moller_trumbore_fma_stride
#define tb_moller_trumbore_cull_fma_flat TB_FLAT_MISS
#define tb_moller_trumbore_cull_fma_ray_f32 tb_ray_plain_f32
#define tb_moller_trumbore_cull_fma_ray_f64 tb_ray_plain_f64
#define tb_moller_trumbore_cull_fma_prepare_f32 tb_moller_trumbore_fma_prepare_f32
#define tb_moller_trumbore_cull_fma_prepare_f64 tb_moller_trumbore_fma_prepare_f64
/* moller_trumbore_fma_exit's 39 (counted on the path that does everything) */
#define tb_moller_trumbore_cull_fma_ops 39
#endif

TB_NWIDE nmask TB_NFN(tb_moller_trumbore_cull_fma_test)(const tb_nray *restrict r,
                                                        const real *restrict lanes, nreal t_max,
                                                        tb_nhit *restrict h)
{
    return TB_NFN(tb_mt_fma)(r, lanes, t_max, h, 1, 1);
}

/* operations per test by class (fma, mul, add, cmp, div, logic), per lane, counted in the compiled
 * AVX-512 block loop (tests/test_ext_build.py); see kernels.h */
#define tb_moller_trumbore_cull_fma_mix {14, 12, 4, 8, 1, 4}
