/* Small 3-vector helpers over `real`, instantiated once per precision.
 * No include guard: kernels.h includes this file once for float, once for
 * double. Everything is static inline so the kernels inline into the loops. */

static inline void TB_FN(sub3)(const real *a, const real *b, real *out)
{
    out[0] = a[0] - b[0];
    out[1] = a[1] - b[1];
    out[2] = a[2] - b[2];
}

static inline void TB_FN(cross3)(const real *a, const real *b, real *out)
{
    out[0] = a[1] * b[2] - a[2] * b[1];
    out[1] = a[2] * b[0] - a[0] * b[2];
    out[2] = a[0] * b[1] - a[1] * b[0];
}

static inline real TB_FN(dot3)(const real *a, const real *b)
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

/* Which side of the edge a->b the point q lies on, seen along n:
 * ((b - a) x (q - a)) . n, positive inside a counter-clockwise triangle. */
static inline real TB_FN(edge_side)(const real *a, const real *b, const real *q, const real *n)
{
    real edge[3], toq[3], side[3];
    TB_FN(sub3)(b, a, edge);
    TB_FN(sub3)(q, a, toq);
    TB_FN(cross3)(edge, toq, side);
    return TB_FN(dot3)(side, n);
}

/* The end of a late-division test: one division, then 0 < t < t_max on the
 * divided t (an infinite or tiny denominator can round t to 0 or to t_max),
 * and t, u, v of the hit. The scaled values and denominator share a sign. */
static inline int TB_FN(tb_divide_hit)(real scaled_t, real scaled_u, real scaled_v, real det,
                                       real t_max, tb_hit *h)
{
    real inv_det = 1 / det;
    real t = scaled_t * inv_det;
    if (!(t > 0 && t < t_max))
        return 0;
    h->t = t;
    h->u = scaled_u * inv_det;
    h->v = scaled_v * inv_det;
    return 1;
}

/* What the plane-based tests precompute from, in double (a small triangle far from the origin
 * loses its normal in float): the first vertex v0, the edges e1 = v1 - v0 and e2 = v2 - v0, the
 * normal n = e1 x e2 and k, the axis of n's largest component (ties to the lower axis). */
#ifndef TB_FRAME_DEFINED
#define TB_FRAME_DEFINED
typedef struct tb_frame {
    double v0[3], e1[3], e2[3], n[3];
    int k;
} tb_frame;
#endif
static inline tb_frame TB_FN(tb_frame_of)(const real *vtx)
{
    tb_frame f;
    for (int j = 0; j < 3; ++j) {
        f.v0[j] = vtx[j];
        f.e1[j] = (double)vtx[3 + j] - f.v0[j];
        f.e2[j] = (double)vtx[6 + j] - f.v0[j];
    }
    f.n[0] = f.e1[1] * f.e2[2] - f.e1[2] * f.e2[1];
    f.n[1] = f.e1[2] * f.e2[0] - f.e1[0] * f.e2[2];
    f.n[2] = f.e1[0] * f.e2[1] - f.e1[1] * f.e2[0];
    f.k = fabs(f.n[1]) > fabs(f.n[0]) ? 1 : 0;
    if (fabs(f.n[2]) > fabs(f.n[f.k]))
        f.k = 2;
    return f;
}

/* Prepared data of the kernels that test raw vertices: the 9 coordinates. */
static void TB_FN(tb_prepare_vertices)(const real *vertices, size_t n, real *out)
{
    memcpy(out, vertices, n * 9 * sizeof(real));
}

/* Per-ray data of the kernels without a per-ray precomputation. */
static inline void TB_FN(tb_ray_plain)(const real *o, const real *d, tb_ray *r)
{
    memset(r, 0, sizeof *r);
    for (int k = 0; k < 3; ++k) {
        r->o[k] = o[k];
        r->d[k] = d[k];
    }
}
