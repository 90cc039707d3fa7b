/* my_moller.c: an example kernel file for tribench (docs/own-kernel.md walks
 * through it). Copy it, rename the kernel, change the test, and rank it:
 *
 *     tribench sweep --kernel-file my_moller.c --kernels my_moller,moller_trumbore
 *
 * Reference: T. Moller, B. Trumbore, "Fast, Minimum Storage Ray-Triangle
 * Intersection", Journal of Graphics Tools 2(1):21-28, 1997 (the second
 * listing: scaled barycentrics tested against the determinant, one division
 * on a hit), both faces.
 *
 * The file is read three ways. First with neither TB_SCALAR_PART nor
 * TB_NATIVE_PART defined: its declarations alone (the two macros just
 * below, which must read the same every time). Then, with TB_SCALAR_PART, once
 * per precision, where `real` is float or double and every name made with
 * TB_FN gets the precision's suffix. A native-width kernel's code would go
 * under TB_NATIVE_PART (ext/native.h: once per ISA and precision). */

#define TB_FILE_CITATION "Moller & Trumbore, Fast, Minimum Storage Ray-Triangle Intersection, JGT 2(1), 1997"
/* one registration line per kernel: name, faces, watertight promise, the
 * paper that promises it, origin, form (the columns of ext/kernels/list.h) */
#define TB_FILE_KERNELS(X) X(my_moller, TB_BOTH_FACES, TB_OPEN, "", TB_CLEAN, TB_SCALAR_ONLY)

#ifdef TB_SCALAR_PART
#define tb_my_moller_stride 9 /* reals per prepared triangle: the three vertices */
/* operations per test on a hit's path (the rules in ext/kernels.h), and by
 * class: fma, mul, add, cmp, div, logic */
#define tb_my_moller_ops 65
#define tb_my_moller_mix {0, 30, 24, 10, 1, 0}
#define tb_my_moller_flat TB_FLAT_MISS /* an exactly flat triangle: a NaN record, missed by every ray */
#define tb_my_moller_prepare_f32 tb_prepare_vertices_f32 /* the vertices as they are */
#define tb_my_moller_prepare_f64 tb_prepare_vertices_f64
#define tb_my_moller_ray_f32 tb_ray_plain_f32 /* nothing precomputed per ray */
#define tb_my_moller_ray_f64 tb_ray_plain_f64

/* 1 on a hit with 0 < t < t_max, writing t, u and v; 0 otherwise. Every
 * rejection is written as !(accept), so a NaN anywhere is a miss. */
static inline int TB_FN(tb_my_moller_test)(const tb_ray *restrict r, const real *restrict tri, real t_max,
                                           tb_hit *restrict h)
{
    real e1[3], e2[3], p[3], s[3], q[3];
    TB_FN(sub3)(tri + 3, tri, e1);
    TB_FN(sub3)(tri + 6, tri, e2);
    TB_FN(cross3)(r->d, e2, p);
    real det = TB_FN(dot3)(e1, p);
    if (det == 0) /* the ray lies in the triangle's plane */
        return 0;
    real sign = det < 0 ? -1 : 1; /* both faces: fold det's sign into u, v and t */
    real abs_det = sign * det;
    TB_FN(sub3)(r->o, tri, s);
    real u = sign * TB_FN(dot3)(s, p);
    if (!(u >= 0 && u <= abs_det))
        return 0;
    TB_FN(cross3)(s, e1, q);
    real v = sign * TB_FN(dot3)(r->d, q);
    if (!(v >= 0 && u + v <= abs_det))
        return 0;
    real t = sign * TB_FN(dot3)(e2, q);
    if (!(t > 0 && t < t_max * abs_det)) /* a farther hit costs no division */
        return 0;
    return TB_FN(tb_divide_hit)(t, u, v, abs_det, t_max, h);
}
#endif
