/* baldwin_weber_9_fma: Baldwin & Weber's coordinate transformation (9-real
 * form plus the dropped axis) at the CPU's native width, fused multiply-adds,
 * branchless.
 *
 * Reference: D. Baldwin, M. Weber, "Fast Ray-Triangle Intersections by
 * Coordinate Transformation", JCGT 5(3):39-49, 2016 (the 9-float variant);
 * the record is baldwin_weber_9's (baldwin_weber_9.h: U_k1 U_k2 U_c,
 * V_k1 V_k2 V_c, W_k1 W_k2 W_c, k), prepared by the same function. The test
 * is baldwin_weber_12_fma's (its file explains the arithmetic, and why it
 * has no early exit), on the 9-real layout: W's k coefficient is 1 and U's and
 * V's are 0, so W(o) = o_k + W_k1 o_k1 + W_k2 o_k2 + W_c (an add and two fused
 * multiply-adds), U(o) two, U(d) and W(d) two each: 15 FMA-pipe operations
 * for t', u', v' against baldwin_weber_12_fma's 22.
 *
 * The dropped axis k differs from lane to lane, and a record block cannot be
 * sorted by k (the records are the caller's triangles in the caller's order,
 * and a triangle's index is its position: baldwin_weber_9.h), so each lane
 * gets the ray in its own axis order k, k1, k2 from two masks (k == 1,
 * k == 2; anything else reads as 0, as in the scalar form) and two selects
 * per component of o and d: 2 compares and 12 selects per vector. A gather (of o and d by a per-lane index) would replace
 * 12 selects, which run on two ports, by 6 gathers of 16 loads each; an
 * AVX-512 permute (vpermps by k + j) by 6 permutes on one port plus the index
 * arithmetic, for this ISA only. The selects are the cheapest portable choice.
 *
 * How it differs from baldwin_weber_9's arithmetic on every lane: as
 * baldwin_weber_12_fma from baldwin_weber_12's (fused, no division and no hit
 * point in the kernel, u and v from the transformed ray, no early exit).
 * Not bit for bit baldwin_weber_9. Error bound: baldwin_weber_12_fma's, with
 * the same K (the map is the same numbers), held by tests/test_kernels_fma.py
 * on every ISA; measured there at 0.81 eps K at most (the plain
 * baldwin_weber_9: 0.79), u and v within 1.2 eps K_uv (plain: 0.8).
 * Prepared data: baldwin_weber_9's (10 reals). Flat triangles: NaN records
 * (misses).
 */

#if TB_NFIRST
#define tb_baldwin_weber_9_fma_algorithm "baldwin_weber_9" /* the clean scalar kernel it is a form of */
#define tb_baldwin_weber_9_fma_stride tb_baldwin_weber_9_stride
#define tb_baldwin_weber_9_fma_flat TB_FLAT_MISS
#define tb_baldwin_weber_9_fma_ray_f32 tb_ray_plain_f32
#define tb_baldwin_weber_9_fma_ray_f64 tb_ray_plain_f64
#define tb_baldwin_weber_9_fma_prepare_f32 tb_baldwin_weber_9_prepare_f32
#define tb_baldwin_weber_9_fma_prepare_f64 tb_baldwin_weber_9_prepare_f64
/* per lane and test (rules in kernels.h; an FMA counts 1), the path that does
 * everything: axis 2, W(o) 3, W(d) 2, U(o) 2, U(d) 2, u' 2, u tests 2,
 * V(o) 2, V(d) 2, v' 2, u' + v' 1, t_max den 1, tests 4; the loop's division
 * path: 1 / den 1, t 1, 0 < t < t_max 2 */
#define tb_baldwin_weber_9_fma_ops 31
#endif

TB_NWIDE nmask TB_NFN(tb_baldwin_weber_9_fma_test)(const tb_nray *restrict r, const real *restrict lanes,
                                                   nreal t_max, tb_nhit *restrict h)
{
    return TB_NFN(tb_bw_fma)(r, lanes, t_max, h, 9);
}

/* operations per test by class (fma, mul, add, cmp, div, logic), per lane, counted in the compiled
 * AVX-512 block loop (tests/test_ext_build.py); see kernels.h */
#define tb_baldwin_weber_9_fma_mix {12, 6, 2, 10, 1, 21}
