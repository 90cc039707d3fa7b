/* wald: Wald's projection test over a precomputed 48-byte record ("TriAccel").
 *
 * Reference: I. Wald, "Realtime Ray Tracing and Interactive Global
 * Illumination", PhD thesis, Saarland University, 2004, the chapter on fast
 * triangle intersection (the optimised projection method and its 48-byte
 * precomputed record).
 *
 * Per triangle (precomputed): the dropped axis k = argmax |n_i| (n = e1 x e2),
 * u, v = the other two axes in cyclic order (k + 1, k + 2); the plane scaled
 * so that its k component is 1: n_u = n_u / n_k, n_v = n_v / n_k,
 * n_d = (n . v0) / n_k; and the 2-D line equations, on the plane that drops k,
 * of the two barycentrics (b: the weight of v1, from the edge e2 = v2 - v0;
 * c: the weight of v2, from the edge e1 = v1 - v0):
 *   b_nu = e2_v / n_k,  b_nv = -e2_u / n_k,  b_d = (e2_u v0_v - e2_v v0_u) / n_k
 *   c_nu = -e1_v / n_k, c_nv = e1_u / n_k,   c_d = (e1_v v0_u - e1_u v0_v) / n_k
 * Per test:
 *   t = (n_d - o_k - n_u o_u - n_v o_v) / (d_k + n_u d_u + n_v d_v),
 *   h_u = o_u + t d_u, h_v = o_v + t d_v,
 *   beta = b_nu h_u + b_nv h_v + b_d,  gamma = c_nu h_u + c_nv h_v + c_d;
 * hit iff beta >= 0, gamma >= 0, beta + gamma <= 1 (u = beta, v = gamma).
 * Record, the thesis's layout (12 reals: 48 bytes in float32, 96 in float64):
 *   n_u n_v n_d k | b_nu b_nv b_d pad | c_nu c_nv c_d pad
 * (three 16-byte quarters of a float32 record; the pads are 0).
 *
 * How it differs from the thesis (and why):
 *  - the record is computed in double from the vertices and rounded once to
 *    `real`; the line constants are formed from the edges and v0, not from
 *    v1 and v2, whose products cancel far from the origin (measured for the
 *    same constants in baldwin_weber_12.h);
 *  - k is stored as a real (0, 1 or 2), in the slot of the thesis's integer,
 *    and read as 1 or 2 when it equals 1 or 2, else 0 (as baldwin_weber_9),
 *    so no record indexes outside the ray;
 *  - no epsilon: 0 < t < t_max strict (the thesis rejects t < epsilon);
 *    closed triangle: beta >= 0, gamma >= 0, beta + gamma <= 1 (points on an
 *    edge or vertex are inside), as the float64 reference; every rejection
 *    is !(accept), so a NaN (a ray in the plane: 0 / 0) is a miss;
 *  - the thesis's order of early exits: t, then beta, then gamma and the sum;
 *  - t is one division, numerator / denominator: the thesis's code takes the
 *    reciprocal of the denominator first (to start the slow division early)
 *    and multiplies the numerator by it, one rounding and one operation more
 *    (checked against the thesis's code as public renderers reproduce it,
 *    e.g. its modulo table, "nd = 1 / (d_k + n_u d_u + n_v d_v)", then
 *    f = (n_d - o_k - n_u o_u - n_v o_v) * nd);
 *  - a triangle with no usable record (n_k == 0 in double, or anything not
 *    finite, in double or after rounding to `real`) gets the plane 0 and
 *    line equations (0, 0, -1): beta = -1 (or NaN), so every ray misses it.
 * The arithmetic is baldwin_weber_9's, derived differently (Baldwin & Weber
 * 2016 reach the same rows from an affine map): stride 12 against 10 (the
 * thesis pads to three 16-byte quarters), and beta is not tested against 1.
 * Flat triangles: an exactly flat one (zero area, found in exact arithmetic at
 * prepare time, see kernels.h) gets an all-NaN record and misses every ray.
 */

#define tb_wald_stride 12 /* reals per prepared triangle, either precision */
/* ops per test on the hit path: axis 2, denominator 4, numerator 5, t 1,
 * t tests 2, h 4, beta 4, beta test 1, gamma 4, gamma tests 3 */
#define tb_wald_ops 30
#define tb_wald_flat TB_FLAT_MISS /* exactly flat triangles: NaN records, every ray misses */
#define tb_wald_ray_f32 tb_ray_plain_f32
#define tb_wald_ray_f64 tb_ray_plain_f64

/* Wald's record of one triangle, in double: n_u n_v n_d k b_nu b_nv b_d c_nu
 * c_nv c_d (10 values, no pads); 0 if it is usable, -1 if not. */
static int TB_FN(tb_wald_record)(const real *vtx, double out[10])
{
    const tb_frame f = TB_FN(tb_frame_of)(vtx);
    const double *v0 = f.v0, *e1 = f.e1, *e2 = f.e2, *n = f.n;
    const int k = f.k;
    const int u = (k + 1) % 3, v = (k + 2) % 3;
    const double nk = n[k];
    out[0] = n[u] / nk;
    out[1] = n[v] / nk;
    out[2] = v0[k] + out[0] * v0[u] + out[1] * v0[v];
    out[3] = k;
    out[4] = e2[v] / nk;
    out[5] = -e2[u] / nk;
    out[6] = (e2[u] * v0[v] - e2[v] * v0[u]) / nk;
    out[7] = -e1[v] / nk;
    out[8] = e1[u] / nk;
    out[9] = (e1[v] * v0[u] - e1[u] * v0[v]) / nk;
    int usable = nk != 0;
    for (int j = 0; j < 10; ++j)
        usable &= isfinite((real)out[j]) != 0;
    return usable ? 0 : -1;
}

static void TB_FN(tb_wald_prepare)(const real *vertices, size_t n_tris, real *out)
{
    for (size_t i = 0; i < n_tris; ++i) {
        /* the record of a triangle no ray hits: plane 0, line equations (0, 0, -1) */
        static const double miss[10] = {0, 0, 0, 0, 0, 0, -1, 0, 0, -1};
        double m[10];
        real *rec = out + 12 * i;
        if (TB_FN(tb_wald_record)(vertices + 9 * i, m) < 0)
            memcpy(m, miss, sizeof m);
        for (int j = 0; j < 4; ++j)
            rec[j] = (real)m[j];
        for (int j = 0; j < 3; ++j) {
            rec[4 + j] = (real)m[4 + j];
            rec[8 + j] = (real)m[7 + j];
        }
        rec[7] = rec[11] = 0;
    }
}

static inline int TB_FN(tb_wald_test)(const tb_ray *restrict r, const real *restrict m, real t_max,
                                      tb_hit *restrict h)
{
    static const int axis[5] = {0, 1, 2, 0, 1};
    /* arithmetic, not ?: (GCC branches on that, and k changes from triangle to triangle) */
    const int k = (m[3] == 1) + 2 * (m[3] == 2), u = axis[k + 1], v = axis[k + 2];
    const real *o = r->o, *d = r->d;

    /* the plane, its k coefficient 1 */
    real t = (m[2] - o[k] - m[0] * o[u] - m[1] * o[v]) / (d[k] + m[0] * d[u] + m[1] * d[v]);
    if (!(t > 0 && t < t_max))
        return 0;

    /* the hit point on the plane that drops k, and the two line equations */
    real h_u = o[u] + t * d[u], h_v = o[v] + t * d[v];
    real beta = m[4] * h_u + m[5] * h_v + m[6];
    if (!(beta >= 0))
        return 0;
    real gamma = m[8] * h_u + m[9] * h_v + m[10];
    if (!(gamma >= 0 && beta + gamma <= 1))
        return 0;
    h->t = t;
    h->u = beta;
    h->v = gamma;
    return 1;
}

/* operations per test by class (fma, mul, add, cmp, div, logic), on the hit path, the split of tb_wald_ops; see kernels.h */
#define tb_wald_mix {0, 10, 12, 7, 1, 0}
