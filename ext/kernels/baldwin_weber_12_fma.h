/* baldwin_weber_12_fma: Baldwin & Weber's coordinate transformation (12-real
 * form) at the CPU's native width, fused multiply-adds, branchless.
 *
 * Reference: D. Baldwin, M. Weber, "Fast Ray-Triangle Intersections by
 * Coordinate Transformation", JCGT 5(3):39-49, 2016; the map M (rows U, V,
 * W) and its record are baldwin_weber_12's (baldwin_weber_12.h), prepared by
 * the same function. A native wide kernel (native.h): 16 float / 8 double
 * lanes with AVX-512, 8 / 4 with AVX2 + FMA, 4 / 2 on the baseline.
 *
 * The paper transforms the ray into the triangle's frame, where the triangle
 * is the unit one in z = 0: o' = M o (affine), d' = M d (linear), then
 * t = -W(o) / W(d) and (u, v) = (U(o), V(o)) + t (U(d), V(d)). Without the
 * division (the loop divides), scaled by den = |W(d)| with the sign s of
 * W(d) folded in (xor with its sign bit, as moller_trumbore_fma does):
 *   t' = -W(o) s,  u' = (U(o) W(d) - W(o) U(d)) s,  v' = (V(o) W(d) - W(o) V(d)) s
 * and the hit tests 0 < t' < t_max den, u' >= 0, v' >= 0, u' + v' <= den.
 * The shared test below serves baldwin_weber_9_fma too (layout = 9: the
 * ray permuted per lane to the record's axis order; see that file).
 *
 * How it differs from baldwin_weber_12's arithmetic on every lane (and why):
 *  - the plane and the barycentrics are fused (each row on o: three fused
 *    multiply-adds; on d: a multiply and two; u' and v': a multiply and a
 *    fused multiply-subtract each): 22 FMA-pipe operations for t', u', v'
 *    against baldwin_weber_12's 30 (its divide, hit point and dots unfused);
 *  - no hit point p = o + t d and no division in the kernel: u and v come
 *    from the transformed ray (the 2 x 2 determinants above), which needs
 *    U(o) and U(d) (6 operations) where the paper's homogeneous hit point
 *    P = o W(d) - d W(o) would need 6 for P and 4 for u' = U . P + U_c W(d);
 *    the determinant form is 2 operations more in all (V too); it was
 *    chosen when the kernel exited early after u, where it is 2 fewer before
 *    the exit. The hit-point form, tried then, cracked as often (below);
 *  - no early exit. After u, a vector none of whose lanes has
 *    0 <= u' <= den could return (V and the t test skipped: 14 of the 22),
 *    and 74% of the vectors could on issue #18's camera workload (Suzanne,
 *    1,280 triangles, 128 x 128 rays); but the branch is unpredictable and
 *    resolves at the end of a long dependency chain, so each mispredict
 *    drains the loop. Without it: 0.66 ns per test against 0.91 with it
 *    (Suzanne 968 triangles, 64^2 camera, float32, AVX-512, Zen 4), and
 *    0.63 against 0.91 on AVX2; docs/decisions.md, "How near the bound";
 *  - W(d) == 0 (a parallel ray, or a degenerate triangle's miss record)
 *    gives den = 0, and 0 < t' < t_max den then fails (NaN for t_max = inf);
 *    a NaN anywhere fails a comparison: a miss, as in the scalar form.
 *    A ray exactly in the triangle's plane is another matter, for every
 *    Baldwin-Weber form: W is rounded when the record is made, so the stored
 *    plane is tilted by about eps from the triangle's, W(d) is not 0, and the
 *    ray crosses the stored plane somewhere; where that is inside the
 *    triangle, it hits. `tribench validate`'s parallel rays (full size, three
 *    seeds): baldwin_weber_12 and _9 hit 0.4-1.2% of them, these forms
 *    0.9-3% (the unfused arithmetic rounds W(o) or W(d) to an exact 0 more
 *    often, which misses); havel_herout, whose planes are rounded the same
 *    way, 1-3%. Only a tolerance on |W(d)| would miss them all, and it would
 *    lose the grazing rays (slopes to 1e-6) the algorithm now hits.
 * Shared edges and vertices (no promise, measured by `tribench validate
 * --quick`): cracks at 8-15% of the edge rays and 4-29% of the vertex rays,
 * against the plain forms' 2-3% and 0: on validate's exact (dyadic) rays the
 * plain forms' t = -W(o) / W(d) often rounds to the exact t, and then
 * p = o + t d is the exact edge or vertex point; without the division the
 * error of W(o) reaches u and v (the homogeneous hit point P, tried, cracks
 * as often).
 * Not bit for bit baldwin_weber_12: a fused operation rounds once where the
 * scalar form rounds twice, and u, v are computed from the transformed ray,
 * not from the rounded hit point. Error bound, against the float64 reference
 * on the inputs as the kernel sees them: where the reference's barycentric
 * edge margin is at least 1e-3 and 4 eps K_uv (below), the same hit or miss,
 * and |t - t_ref| <= 2 eps K t_ref,  K = |n| (|o| + |v0| + t_ref |d|) / (t_ref |n . d|)
 * (n = e1 x e2; eps of the precision). K differs from moller_trumbore's:
 * W(o) sums terms of the size of the coordinates, so this algorithm's error
 * grows with the distance from the origin, not from the triangle (the plain
 * baldwin_weber_12 has the same K). tests/test_kernels_fma.py holds every ISA
 * to it on random pairs and on scaled (1e-3..1e3), shifted (to 1e3) and
 * grazing rays; measured there at 0.81 eps K at most (the plain
 * baldwin_weber_12: 0.82), and u, v within 1.2 eps K_uv of the reference's,
 * K_uv = (|o| + |v0|) max(|e1|, |e2|) |d| / |n . d| (plain: 0.8): so where
 * the edge margin is below a few eps K_uv (float32 triangles of 1e-3 at 1e3
 * from the origin), the decision is the algorithm's guess, plain or fused.
 * Prepared data: baldwin_weber_12's (rows U, V, W: 12 reals). Flat
 * triangles: NaN records (misses).
 */

#if TB_NFIRST
#define tb_baldwin_weber_12_fma_algorithm "baldwin_weber_12" /* the clean scalar kernel it is a form of */
#define tb_baldwin_weber_12_fma_stride tb_baldwin_weber_12_stride
#define tb_baldwin_weber_12_fma_flat TB_FLAT_MISS
#define tb_baldwin_weber_12_fma_ray_f32 tb_ray_plain_f32
#define tb_baldwin_weber_12_fma_ray_f64 tb_ray_plain_f64
#define tb_baldwin_weber_12_fma_prepare_f32 tb_baldwin_weber_12_prepare_f32
#define tb_baldwin_weber_12_fma_prepare_f64 tb_baldwin_weber_12_prepare_f64
/* per lane and test (rules in kernels.h; an FMA counts 1), the path that does
 * everything: W(o) 3, W(d) 3, U(o) 3, U(d) 3, u' 2, u tests 2, V(o) 3,
 * V(d) 3, v' 2, u' + v' 1, t_max den 1, tests 4; the loop's division path:
 * 1 / den 1, t 1, 0 < t < t_max 2 */
#define tb_baldwin_weber_12_fma_ops 34
#endif

/* One row R of a record on a point (affine: R . x + R_c) or a direction
 * (R . x). layout 12: the row's 4 fields (x, y, z, constant), x in world
 * order; layout 9: its 3 fields (k1, k2, constant), x in the order k, k1, k2,
 * and the k coefficient, not stored, is 1 for W (row 2) and 0 for U and V. */
TB_NWIDE nreal TB_NFN(tb_bw_row)(const real *restrict lanes, const int layout, const int row,
                                 const nreal x[3], const int affine)
{
    const real *f = lanes + TB_NBLOCK * (layout == 9 ? 3 * row : 4 * row);
    const nreal c_const = nv_load(f + TB_NBLOCK * (layout == 9 ? 2 : 3));
    const nreal c1 = nv_load(f + TB_NBLOCK * (layout == 9 ? 0 : 1));
    const nreal c2 = nv_load(f + TB_NBLOCK * (layout == 9 ? 1 : 2));
    nreal acc;
    if (layout == 9 && row == 2) {
        acc = x[0];
        if (affine)
            acc = acc + c_const;
        acc = nv_fmadd(c2, x[2], acc);
    } else if (affine) {
        acc = nv_fmadd(c2, x[2], c_const);
    } else {
        acc = c2 * x[2];
    }
    acc = nv_fmadd(c1, x[1], acc);
    if (layout == 12)
        acc = nv_fmadd(nv_load(f), x[0], acc);
    return acc;
}

/* The test of both Baldwin-Weber native forms (layout 12 or 9). */
TB_NWIDE nmask TB_NFN(tb_bw_fma)(const tb_nray *restrict r, const real *restrict lanes,
                                 nreal t_max, tb_nhit *restrict h, const int layout)
{
    nreal o[3], d[3];
    if (layout == 9) {
        /* the ray in each lane's axis order k, k1, k2 (k is 1 or 2 where the record says so, else 0) */
        TB_NFN(tb_nray_by_axis)(r, nv_load(lanes + TB_NBLOCK * 9), o, d);
    } else {
        for (int j = 0; j < 3; ++j) {
            o[j] = r->o[j];
            d[j] = r->d[j];
        }
    }
    const nreal zero = nv_set1(0);
    const nbits sign_bit = (nbits)nv_set1((real)-0.0);
    const nreal w_o = TB_NFN(tb_bw_row)(lanes, layout, 2, o, 1);
    const nreal w_d = TB_NFN(tb_bw_row)(lanes, layout, 2, d, 0);
    const nbits sign = (nbits)w_d & sign_bit;
    const nreal den = (nreal)((nbits)w_d ^ sign);
    const nreal u_o = TB_NFN(tb_bw_row)(lanes, layout, 0, o, 1);
    const nreal u_d = TB_NFN(tb_bw_row)(lanes, layout, 0, d, 0);
    const nreal u = (nreal)((nbits)nv_fmsub(u_o, w_d, w_o * u_d) ^ sign);
    nmask hit = nm_and(nv_ge(u, zero), nv_le(u, den));
    const nreal v_o = TB_NFN(tb_bw_row)(lanes, layout, 1, o, 1);
    const nreal v_d = TB_NFN(tb_bw_row)(lanes, layout, 1, d, 0);
    const nreal v = (nreal)((nbits)nv_fmsub(v_o, w_d, w_o * v_d) ^ sign);
    const nreal t = (nreal)((nbits)w_o ^ sign ^ sign_bit); /* -W(o) s */
    hit = nm_and(nm_and(hit, nv_ge(v, zero)),
                 nm_and(nv_le(u + v, den), nm_and(nv_gt(t, zero), nv_lt(t, t_max * den))));
    h->t = t;
    h->u = u;
    h->v = v;
    h->den = den;
    return hit;
}

TB_NWIDE nmask TB_NFN(tb_baldwin_weber_12_fma_test)(const tb_nray *restrict r, const real *restrict lanes,
                                                    nreal t_max, tb_nhit *restrict h)
{
    return TB_NFN(tb_bw_fma)(r, lanes, t_max, h, 12);
}

/* operations per test by class (fma, mul, add, cmp, div, logic), per lane, counted in the compiled
 * AVX-512 block loop (tests/test_ext_build.py); see kernels.h */
#define tb_baldwin_weber_12_fma_mix {17, 7, 1, 8, 1, 9}
