/* moller_trumbore_fma_exit: moller_trumbore_fma with an early exit.
 *
 * Reference and arithmetic: as moller_trumbore_fma.h, whose test this is,
 * with one branch: after u, a vector none of whose lanes has 0 <= u <= |det|
 * returns at once (q, v and t are skipped; 2 of the 5 dot-product-sized
 * steps done). The answers are moller_trumbore_fma's bit for bit; only the
 * work differs, and whether it pays depends on how many vectors have a
 * surviving lane (bench/yardstick.py measures it per hit rate).
 * Prepared data: moller_trumbore_fma's (v0, e1, e2: 9 reals).
 */

#if TB_NFIRST
#define tb_moller_trumbore_fma_exit_algorithm "moller_trumbore" /* the clean scalar kernel it is a form of */
#define tb_moller_trumbore_fma_exit_stride tb_moller_trumbore_fma_stride
#define tb_moller_trumbore_fma_exit_flat TB_FLAT_MISS
#define tb_moller_trumbore_fma_exit_ray_f32 tb_ray_plain_f32
#define tb_moller_trumbore_fma_exit_ray_f64 tb_ray_plain_f64
#define tb_moller_trumbore_fma_exit_prepare_f32 tb_moller_trumbore_fma_prepare_f32
#define tb_moller_trumbore_fma_exit_prepare_f64 tb_moller_trumbore_fma_prepare_f64
/* moller_trumbore_fma's 38 and the exit's u <= |det| (counted on the path
 * that does everything) */
#define tb_moller_trumbore_fma_exit_ops 39
#endif

TB_NWIDE nmask TB_NFN(tb_moller_trumbore_fma_exit_test)(const tb_nray *restrict r,
                                                        const real *restrict lanes, nreal t_max,
                                                        tb_nhit *restrict h)
{
    return TB_NFN(tb_mt_fma)(r, lanes, t_max, h, 1, 0);
}

/* operations per test by class (fma, mul, add, cmp, div, logic), per lane, counted in the compiled
 * AVX-512 block loop (tests/test_ext_build.py); the AVX2 loop does one more compare and more logic
 * (no mask registers); see kernels.h */
#define tb_moller_trumbore_fma_exit_mix {14, 12, 4, 8, 1, 9}
