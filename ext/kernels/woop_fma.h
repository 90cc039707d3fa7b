/* woop_fma: Woop, Benthin & Wald's watertight test at the CPU's native width,
 * fused where fusing keeps the promise, with an early exit.
 *
 * Reference: S. Woop, C. Benthin, I. Wald, "Watertight Ray/Triangle
 * Intersection", JCGT 2(1):65-82, 2013 (as woop.h, whose rules this keeps:
 * no culling, edges closed, a 0 edge function recomputed exactly, det = 0
 * misses, 0 < t < t_max, NaN anywhere a miss). A native wide kernel
 * (native.h): 16 float / 8 double lanes with AVX-512, 8 / 4 with AVX2 + FMA,
 * 4 / 2 on the baseline. The ray's axes kx, ky, kz and shear sx, sy, sz are
 * woop's per-ray data (tb_woop_ray), in every lane (tb_nray); the
 * permutation is per ray, so for a block it is only which fields are loaded.
 *
 * Where it fuses, and where it must not. The promise rests on two facts:
 * each vertex is transformed the same way in every triangle that holds it,
 * and each 2-D edge function's sign is exact for the transformed vertices.
 *  - The shear x = X - sx Z, y = Y - sy Z is fused (one rounding, not two):
 *    the same operation on the same inputs (the vertex relative to the
 *    origin, the ray's sx, sy) in every triangle, so every triangle still
 *    sees the same transformed vertex, which is all the first fact needs.
 *  - The edge functions are NOT fused: U = fl(cx by) - fl(cy bx), products
 *    rounded, then subtracted (vector-extension operators, and setup.py
 *    builds with -ffp-contract=off, so the compiler fuses nothing). Rounding
 *    is monotonic, so fl(a b) > fl(c d) implies a b > c d: a nonzero U has
 *    the exact sign, and a 0 is recomputed. A fused fma(a, b, -fl(c d))
 *    rounds a b - fl(c d), whose sign can differ from a b - c d's (fl(c d) is
 *    off by up to half an ulp), so it may claim a ray is outside an edge that
 *    it is inside of, on both triangles of the edge: a crack. Measured with
 *    the edge functions fused that way: 402 of the 34,848 rays through shared
 *    edges of tests/test_kernels_watertight.py's grids hit nothing in float32,
 *    436 in float64 (AVX-512 and AVX2); unfused, none.
 *  - The scaled t, sz (U az + V bz + W cz), is fused: t only orders hits and
 *    bounds them, it decides no edge.
 * The paper's fallback is kept, lane by lane: a lane with a 0 edge function
 * gets woop's exact rule (tb_woop_edge_exact: float32 in double, float64 by
 * Dekker's two-product) for its three edge functions. It is off the common
 * path: it is checked only in a vector that has a lane inside all three
 * edges, and only lanes inside can need it (a lane with two nonzero edge
 * functions of opposite signs misses whatever its 0 becomes), so the branch
 * is taken only when such a lane has a 0; the recomputation is an out-of-line
 * cold function.
 *
 * How else it differs from woop's arithmetic on every lane (and why):
 *  - 43 operations per lane instead of woop's 57: the shear and
 *    the scaled t fused (6 + 2 FMAs), sz applied once to the scaled t instead
 *    of to each vertex's z, no division in the kernel (the loop divides once
 *    per vector with a candidate);
 *  - the sign test: det = U + V + W first, its sign bit xored into U, V, W
 *    (an exact flip), then one test per edge, >= 0: 3 compares instead of 6,
 *    zeros still accepted with either sign. det = 0 needs no test: with all
 *    three accepted it means all three are 0, so the scaled t is 0 (or NaN)
 *    and 0 < t fails;
 *  - early exit after the sign test: a vector none of whose lanes is inside
 *    all three edges returns at once (the zero check, the scaled t and the
 *    depth tests skipped: 10 of 39 operations). It comes after the third
 *    edge function, not after the first: one edge function alone rejects
 *    nothing (both windings are accepted), and two keep a lane inside a
 *    double wedge at their common vertex, about a third of the directions.
 *    Measured in float64 on issue #18's camera workload (1,280 triangles,
 *    128 x 128 rays): after two edge functions 35% of the lanes survive and
 *    99.98% of the 16-triangle vectors keep a lane, so an exit there is
 *    never taken; after three, 0.03% of the lanes and 0.5% of the vectors
 *    (Moller's u test, the exit of moller_trumbore_fma_exit: 2.1% and 26%).
 *    And the branch costs nothing extra: without the exit, the fallback's
 *    check would need a branch on every vector all the same;
 *  - records: woop's own, the raw vertices (9 reals): the transform is per
 *    ray, so nothing per triangle can be computed once, and storing edges
 *    would break the first fact (v0 + e1 need not be v1 exactly).
 * Not bit for bit woop: the fused shear and t round once where woop rounds
 * twice. Error bound against the float64 reference on the inputs as the
 * kernel sees them: where the reference's barycentric edge margin is at least
 * 1e-3, the same hit or miss, and |t - t_ref| <= B eps K t_ref with
 * moller_trumbore_fma's K = |e1| |e2| (|d| + |o - v0| / t_ref) / |det|;
 * tests/test_kernels_fma.py holds every ISA to it (B and what woop and
 * woop_fma measure there: WOOP_BOUND in that file).
 * Prepared data: the raw vertices (9 reals). Flat triangles: NaN records.
 */

#if TB_NFIRST
#define tb_woop_fma_algorithm "woop" /* the clean scalar kernel it is a form of */
#define tb_woop_fma_stride 9 /* reals per triangle: the raw vertices */
#define tb_woop_fma_flat TB_FLAT_MISS
#define tb_woop_fma_ray_f32 tb_woop_ray_f32
#define tb_woop_fma_ray_f64 tb_woop_ray_f64
#define tb_woop_fma_prepare_f32 tb_prepare_vertices_f32
#define tb_woop_fma_prepare_f64 tb_prepare_vertices_f64
/* per lane and test (rules in kernels.h; an FMA counts 1), on the path that
 * does everything: translate 9, shear 6, edges 9, det 2, signs 3, zero
 * edges 3, scaled t 4, depth tests 3; the loop's division path: 1 / |det|
 * 1, t 1, 0 < t < t_max 2 */
#define tb_woop_fma_ops 43

/* The paper's fallback for n lanes: the three edge functions of each lane by
 * woop's exact rule, from the lanes' sheared vertices xy = {ax, ay, bx, by,
 * cx, cy} (n each); out of line, as it is rarely called. used: each file of
 * loops (isa_<isa>_<p>.c) has a copy of its own, which it calls with one n;
 * as if it had callers unseen, GCC keeps n an argument rather than
 * specializing the copy to that n, and the loops calling it compile as they
 * did when one copy served every ISA. */
static __attribute__((noinline, cold, used)) void TB_FN(tb_woop_fma_exact)(const real *xy, real *edge,
                                                                            int n)
{
    const real *ax = xy, *ay = xy + n, *bx = xy + 2 * n, *by = xy + 3 * n, *cx = xy + 4 * n,
               *cy = xy + 5 * n;
    for (int l = 0; l < n; ++l) {
        edge[l] = TB_FN(tb_woop_edge_exact)(cx[l], by[l], cy[l], bx[l]);
        edge[n + l] = TB_FN(tb_woop_edge_exact)(ax[l], cy[l], ay[l], cx[l]);
        edge[2 * n + l] = TB_FN(tb_woop_edge_exact)(bx[l], ay[l], by[l], ax[l]);
    }
}
#endif

/* det = U + V + W (woop's order), its sign xored into each edge function
 * (side) and removed from det (abs_det); the lanes inside all three edges,
 * zeros accepted with either sign (a NaN lane is outside) */
TB_NWIDE nmask TB_NFN(tb_woop_fma_inside)(const nreal *edge, nreal *side, nreal *abs_det)
{
    const nbits sign_bit = (nbits)nv_set1((real)-0.0);
    const nreal zero = nv_set1(0);
    nreal det = edge[0] + edge[1] + edge[2];
    nbits sign = (nbits)det & sign_bit;
    *abs_det = (nreal)((nbits)det ^ sign);
    for (int k = 0; k < 3; ++k)
        side[k] = (nreal)((nbits)edge[k] ^ sign);
    return nm_and(nm_and(nv_ge(side[0], zero), nv_ge(side[1], zero)), nv_ge(side[2], zero));
}

TB_NWIDE nmask TB_NFN(tb_woop_fma_test)(const tb_nray *restrict r, const real *restrict lanes,
                                        nreal t_max, tb_nhit *restrict h)
{
    const int kx = r->kx, ky = r->ky, kz = r->kz;
    const nreal zero = nv_set1(0);
    /* vertex v's coordinate k is field 3 v + k; relative to the origin, then
     * sheared (fused) so that the ray is the +z axis */
    nreal x[3], y[3], z[3];
    for (int v = 0; v < 3; ++v) {
        const real *f = lanes + TB_NBLOCK * 3 * v;
        z[v] = nv_load(f + TB_NBLOCK * kz) - r->o[kz];
        x[v] = nv_fnmadd(r->sx, z[v], nv_load(f + TB_NBLOCK * kx) - r->o[kx]);
        y[v] = nv_fnmadd(r->sy, z[v], nv_load(f + TB_NBLOCK * ky) - r->o[ky]);
    }
    /* the 2-D edge functions U, V, W, unfused (see above) */
    nreal edge[3] = {x[2] * y[1] - y[2] * x[1], x[0] * y[2] - y[0] * x[2],
                     x[1] * y[0] - y[1] * x[0]};
    nreal side[3], abs_det;
    nmask inside = TB_NFN(tb_woop_fma_inside)(edge, side, &abs_det);
    if (!nm_any(inside)) {
        h->t = h->u = h->v = side[0]; /* unread (no lane set): defined all the same */
        h->den = abs_det;
        return inside;
    }
    /* the paper's fallback, for the lanes inside with a 0 edge function */
    nmask redo = nm_and(inside, nm_or(nm_or(nv_eq(edge[0], zero), nv_eq(edge[1], zero)),
                                      nv_eq(edge[2], zero)));
    if (nm_any(redo)) {
        real xy[6][TB_NL], exact[3][TB_NL];
        for (int v = 0; v < 3; ++v) {
            memcpy(xy[2 * v], &x[v], sizeof x[v]);
            memcpy(xy[2 * v + 1], &y[v], sizeof y[v]);
        }
        TB_FN(tb_woop_fma_exact)(&xy[0][0], &exact[0][0], TB_NL);
        for (int k = 0; k < 3; ++k)
            edge[k] = nv_select(redo, nv_load(exact[k]), edge[k]);
        inside = TB_NFN(tb_woop_fma_inside)(edge, side, &abs_det);
    }
    /* the scaled t (fused), sign of det folded in through the sides */
    nreal t = r->sz * nv_fmadd(side[0], z[0], nv_fmadd(side[1], z[1], side[2] * z[2]));
    nmask hit = nm_and(inside, nm_and(nv_gt(t, zero), nv_lt(t, t_max * abs_det)));
    h->t = t;
    h->u = side[1];
    h->v = side[2];
    h->den = abs_det;
    return hit;
}

/* operations per test by class (fma, mul, add, cmp, div, logic), per lane, counted in the compiled
 * AVX-512 block loop (tests/test_ext_build.py); see kernels.h */
#define tb_woop_fma_mix {8, 10, 14, 10, 1, 8}
