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

/* Prepared data of the kernels that test raw vertices: the 9 coordinates. */
static void TB_FN(tb_prepare_vertices)(const real *vertices, size_t n, real *out)
{
    memcpy(out, vertices, n * 9 * sizeof(real));
}
