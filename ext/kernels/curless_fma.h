/* curless_fma: Curless's plane-then-three-edge test at the CPU's native width,
 * fused multiply-adds, precomputed edge planes, never dividing.
 *
 * Reference: B. Curless, "Ray-triangle intersection", University of
 * Washington CSE 457 lecture notes, 2004 (as curless.h): intersect the ray
 * with the triangle's plane (t first), then test the plane point q against
 * each of the three edges, inside iff ((b - a) x (q - a)) . n >= 0 for every
 * edge a->b. A native wide kernel (native.h: 16 float / 8 double lanes with
 * AVX-512, 8 / 4 with AVX2 + FMA, 4 / 2 on the baseline), the same algorithm
 * and promises as curless: both faces, closed triangle (an edge test rejects
 * only on < 0), NaN = miss, 0 < t < t_max, exactly flat triangles miss.
 *
 * The algorithm, scaled so that nothing is divided (den = |N . d| > 0):
 *   t' = (N . v0 - N . o) sgn(N . d)          t = t' / den
 *   Q  = den o + t' d                         = den q, the plane point times den
 *   side_i = M_i . Q - den C_i                = den (M_i . q - C_i)
 * with N = 2^-x n, n = (v1 - v0) x (v2 - v0) (2^x: n's largest component's
 * binade), and per edge i = (a, b) of ab, bc, ca the in-plane edge normal
 * M_i = N x 2^-x (b - a) and its offset C_i = M_i . a. Since
 * ((b - a) x (q - a)) . n = (n x (b - a)) . (q - a), M_i . q - C_i is
 * curless's edge function of q scaled by 2^-2x (a power of two: a positive
 * constant, exact, so every sign and every exact zero is curless's): the side
 * of q against the line through a along b - a, in the plane. The powers of
 * two keep N and M_i near unit and 1 / height, so a float32 record neither
 * over- nor underflows from tiny to huge triangles, and a ray exactly parallel
 * to a dyadic triangle still has N . d = 0 exactly (validate's parallel rays:
 * a unit normal, rounded, missed that for 12.5% of them). The three edge
 * functions of any point sum to den 2^-x N . n, so u = w side_ca / den and
 * v = w side_ab / den, w = 1 / (2^-x N . n), come out of the loop's one
 * division (curless divides by the sides' sum); w is read only in the modes
 * that report u and v.
 *
 * Record (17 reals: 68 bytes in float32, 136 in float64), computed in double
 * from the vertices and rounded once:
 *   N, N . v0, M_ab, C_ab, M_bc, C_bc, M_ca, C_ca, w.
 * Each C_i is M_i . a with M_i as rounded, N . v0 with N as rounded, and M_i
 * is made from N as rounded, so the stored plane and lines pass through the
 * vertices as closely as `real` allows. A triangle whose n is 0 in double or
 * whose record is not finite (non-finite vertices, overflow) gets an
 * all-zero record: den = 0, t' = 0, a miss. Exactly flat triangles: NaN
 * records (misses), as curless.
 *
 * How it differs from curless's arithmetic on every lane (and why):
 *  - no division in the test: t, u, v are scaled by den, the loop divides
 *    once per vector with a candidate (curless divides t on every test,
 *    and u, v by the sides' sum);
 *  - the edge lines M_i, C_i are stored (12 reals for the three edges,
 *    against curless's 9 vertex coordinates): each edge test is one
 *    multiply and three fused multiply-adds, where curless spends 20
 *    operations (two differences, a cross and a dot product) on it;
 *  - fused multiply-adds everywhere: N . d, N . v0 - N . o, Q and the sides;
 *  - N . d != 0 is not tested: den = 0 makes 0 < t' < t_max den fail (and
 *    t_max = inf gives NaN, a fail too);
 *  - early exit after the plane test (0 < t' < t_max den): a vector with no
 *    lane left returns at once, before the point and the sides. Of the two
 *    places the algorithm allows, the first edge test rejects more lanes of
 *    a camera's rays (Suzanne, 1,280 triangles, 128 x 128 rays, float32,
 *    closest: 12% of lanes fail the plane test, 54.5% plane or edge ab), but
 *    an edge test is a half-plane, which about half of any block's lanes
 *    pass wherever the ray crosses their planes, so it empties a 16-lane
 *    vector almost never (0.5% of vectors; 5% of 8-lane ones). The plane
 *    test empties none on that camera either (most of a mesh's planes are
 *    crossed in front of the camera, and t_max is the lane's own closest
 *    hit, rarely found), but it is the test that empties vectors once lanes
 *    have hits (t < t_max then rejects every plane behind them: a stack of
 *    layers ran twice as fast with it), and it is checked before the 16
 *    operations of the point and sides. On the camera (best of rounds on a
 *    shared 2-core AVX-512 Xeon), the exit after the plane timed as no exit
 *    at all within noise, after edge ab up to 10% slower (AVX2 the most: a
 *    mask test there is a movemask and a branch).
 * Compared with havel_herout: with the edge lines stored, Curless's test is
 * Havel & Herout's with a third stored edge line where HH tests
 * 1 - u - v >= 0 (4 reals fewer, two subtractions for a 4-operation dot
 * product); the third edge test is
 * what keeps this Curless's algorithm.
 *
 * Error bound, against the float64 reference on the inputs as the kernel
 * sees them. K_c is the conditioning of Curless's t: the plane offset N . v0
 * and N . o cancel at the scale of |o| + |v0|, not of |o - v0| as in
 * Moller-Trumbore:
 *   |t - t_ref| <= 4 eps K_c t_ref,  K_c = (|d| + (|o| + |v0|) / t_ref) |n| / |n . d|
 * (eps of the precision), and the same hit or miss where the reference's
 * barycentric edge margin is at least
 * max(1e-3, eps K_c t_ref |d| max|e_i| / |n|) (the plane point's error, mostly
 * t's, over the triangle's smallest height). tests/test_kernels_fma.py holds
 * every ISA to it on random pairs and on scaled (1e-3..1e3), shifted (to 1e3)
 * and grazing rays, beside the plain curless, which needs the same bound:
 * measured on 32,400 such pairs per precision, t within 0.79 (float32) and
 * 0.86 (float64) eps K_c on every ISA (curless: 0.64, 0.84), and every
 * decision against the reference within 0.27 of the margin term (curless
 * too; at 1e-3 alone, 349 of 32,400 float32 pairs, curless 427). Tiny triangles
 * far from the origin are Curless's own limit: at 1e-3 units, 1e3 from the
 * origin, float32 curless and curless_fma both decide about 5% of pairs a
 * thousandth inside or outside an edge against the reference, where
 * Moller-Trumbore decides them all.
 * Not watertight (no promise, as curless): on validate's exactly coplanar
 * dyadic meshes, where curless finds t = 1 exactly and forms the point and
 * its edge functions without rounding (1% cracks at shared edges, float32),
 * the scaled point den q and the stored offsets are rounded at the scale of
 * the coordinates: 17% of the rays through a shared edge find neither
 * triangle (8% without fusion, on the baseline; havel_herout, the same
 * scaled form with two stored edges, 6.5%); float64: none.
 */

#if TB_NFIRST
#define tb_curless_fma_algorithm "curless" /* the clean scalar kernel it is a form of */
#define tb_curless_fma_stride 17 /* reals per triangle: N, N.v0, M and C per edge, w */
#define tb_curless_fma_flat TB_FLAT_MISS
#define tb_curless_fma_ray_f32 tb_ray_plain_f32
#define tb_curless_fma_ray_f64 tb_ray_plain_f64
/* per lane and test (rules in kernels.h; an FMA counts 1): N . d 3,
 * t' 3, t_max den 1, plane tests 2, Q 6, three sides 12, edge tests 3;
 * the loop's division path: 1 / den 1, t 1, 0 < t < t_max 2 */
#define tb_curless_fma_ops 34

/* The record of each triangle, in double, rounded once (see above). */
static void TB_FN(tb_curless_fma_prepare)(const real *vertices, size_t n_tris, real *out)
{
    for (size_t i = 0; i < n_tris; ++i) {
        const real *vtx = vertices + 9 * i;
        real *rec = out + 17 * i;
        double p[3][3], e[3][3]; /* the vertices a, b, c; the edges ab, bc, ca */
        for (int j = 0; j < 3; ++j)
            for (int k = 0; k < 3; ++k)
                p[j][k] = vtx[3 * j + k];
        for (int j = 0; j < 3; ++j)
            for (int k = 0; k < 3; ++k)
                e[j][k] = p[(j + 1) % 3][k] - p[j][k];
        /* n = (v1 - v0) x (v2 - v0) = e_ab x -e_ca, as curless; N = 2^-x n */
        double n[3] = {e[0][2] * e[2][1] - e[0][1] * e[2][2],
                       e[0][0] * e[2][2] - e[0][2] * e[2][0],
                       e[0][1] * e[2][0] - e[0][0] * e[2][1]};
        int x;
        frexp(fmax(fabs(n[0]), fmax(fabs(n[1]), fabs(n[2]))), &x);
        for (int k = 0; k < 3; ++k)
            rec[k] = (real)ldexp(n[k], -x);
        rec[3] = (real)(rec[0] * p[0][0] + rec[1] * p[0][1] + rec[2] * p[0][2]);
        /* M_i = N x 2^-x e_i = 2^-2x (n x e_i), C_i = M_i . a_i */
        for (int j = 0; j < 3; ++j) {
            real *m = rec + 4 + 4 * j;
            const double *a = p[j];
            double ed[3] = {ldexp(e[j][0], -x), ldexp(e[j][1], -x), ldexp(e[j][2], -x)};
            m[0] = (real)(rec[1] * ed[2] - rec[2] * ed[1]);
            m[1] = (real)(rec[2] * ed[0] - rec[0] * ed[2]);
            m[2] = (real)(rec[0] * ed[1] - rec[1] * ed[0]);
            m[3] = (real)(m[0] * a[0] + m[1] * a[1] + m[2] * a[2]);
        }
        /* w: den over the sides' sum, which is den 2^-x N . n for any point (the
         * three edge functions of a point sum to the triangle's) */
        rec[16] = (real)(1 / ldexp(rec[0] * n[0] + rec[1] * n[1] + rec[2] * n[2], -x));
        int usable = n[0] != 0 || n[1] != 0 || n[2] != 0;
        for (int k = 0; k < 17; ++k)
            usable &= isfinite(rec[k]) != 0;
        if (!usable)
            memset(rec, 0, 17 * sizeof(real));
    }
}
#endif

/* den times the side of the plane point against one stored edge plane
 * (M, C at lanes[16 f], f = field..field+3): M . Q - den C */
TB_NWIDE nreal TB_NFN(tb_curless_fma_side)(const real *restrict lanes, int field, const nreal *q,
                                           nreal den)
{
    nreal m0 = nv_load(lanes + TB_NBLOCK * field), m1 = nv_load(lanes + TB_NBLOCK * (field + 1));
    nreal m2 = nv_load(lanes + TB_NBLOCK * (field + 2)), c = nv_load(lanes + TB_NBLOCK * (field + 3));
    return nv_fmadd(m0, q[0], nv_fmadd(m1, q[1], nv_fmsub(m2, q[2], den * c)));
}

TB_NWIDE nmask TB_NFN(tb_curless_fma_test)(const tb_nray *restrict r, const real *restrict lanes,
                                           nreal t_max, tb_nhit *restrict h)
{
    const nreal *o = r->o, *d = r->d;
    nreal n0 = nv_load(lanes), n1 = nv_load(lanes + TB_NBLOCK), n2 = nv_load(lanes + 2 * TB_NBLOCK);
    nreal plane = nv_load(lanes + 3 * TB_NBLOCK);
    const nreal zero = nv_set1(0);
    const nbits sign_bit = (nbits)nv_set1((real)-0.0);

    /* the plane: t' = (N . v0 - N . o) sgn(N . d), t = t' / den */
    nreal nd = nv_fmadd(n0, d[0], nv_fmadd(n1, d[1], n2 * d[2]));
    nbits sign = (nbits)nd & sign_bit;
    nreal den = (nreal)((nbits)nd ^ sign);
    nreal tp = (nreal)((nbits)nv_fnmadd(n0, o[0], nv_fnmadd(n1, o[1], nv_fnmadd(n2, o[2], plane))) ^ sign);
    nmask alive = nm_and(nv_gt(tp, zero), nv_lt(tp, t_max * den));
    h->t = tp;
    h->den = den;
    if (!nm_any(alive)) {
        h->u = h->v = tp; /* unread (no lane set): defined all the same */
        return alive;
    }

    /* den times the plane point, and its three edge tests */
    nreal q[3];
    for (int k = 0; k < 3; ++k)
        q[k] = nv_fmadd(tp, d[k], den * o[k]);
    nreal side_ab = TB_NFN(tb_curless_fma_side)(lanes, 4, q, den);
    nreal side_bc = TB_NFN(tb_curless_fma_side)(lanes, 8, q, den);
    nreal side_ca = TB_NFN(tb_curless_fma_side)(lanes, 12, q, den);
    nreal w = nv_load(lanes + 16 * TB_NBLOCK); /* read in the modes that report u and v only */
    h->u = side_ca * w;
    h->v = side_ab * w;
    return nm_and(alive, nm_and(nv_ge(side_ab, zero), nm_and(nv_ge(side_bc, zero), nv_ge(side_ca, zero))));
}

/* operations per test by class (fma, mul, add, cmp, div, logic), per lane, counted in the compiled
 * AVX-512 block loop (tests/test_ext_build.py); see kernels.h */
#define tb_curless_fma_mix {17, 9, 0, 7, 1, 6}
