/* moller_seed_object: moller_seed as the seed's program runs it (seed_objects.h: its
 * objects, calls and scene loop; why and how there).
 *
 * Seed: M. Vitse, ULCO 2022 (LR/Src/Triangle.cpp, the MOLLER branch), g++ -O2.
 * Algorithm and reference: moller_seed.h, whose arithmetic this repeats operation
 * for operation, in the seed's mixed precision (points in double, vectors in
 * `real`). Internal kernel (TB_INTERNAL_KERNEL_LIST): tribench seed times it. */

#define tb_moller_seed_object_stride TB_SO_STRIDE
#define tb_moller_seed_object_flat TB_FLAT_AS_IS
#define tb_moller_seed_object_ops tb_moller_seed_ops /* the twin's arithmetic: the same counts (kernels.h) */
#define tb_moller_seed_object_mix tb_moller_seed_mix

/* Triangle::intersecte and ::coupe, MOLLER branch: one body, compiled into
 * each as g++ compiles the seed's two copies of it. intersecte records the
 * hit into `inter`; coupe, with inter NULL, only says so (and gives t). */
static inline __attribute__((always_inline)) int
TB_FN(tb_so_moller_body)(const tb_so_triangle *self, const tb_so_ray *r, tb_so_hit *inter, real *t_out)
{
    tb_so_vec edge1, edge2, pvec, tvec, qvec;
    int hit = 0;
    TB_FN(tb_so_vec_from)(&edge1, &self->s[0], &self->s[1]);
    TB_FN(tb_so_vec_from)(&edge2, &self->s[0], &self->s[2]);
    TB_FN(tb_so_cross)(&pvec, &r->direction, &edge2);
    real det = TB_FN(tb_so_dot)(&edge1, &pvec);
    if ((double)det > -1e-4 && (double)det < 1e-4)
        goto destroy_p;
    real inv_det = (real)(1.0 / det);
    TB_FN(tb_so_vec_from)(&tvec, &self->s[0], &r->origine);
    real u = TB_FN(tb_so_dot)(&tvec, &pvec) * inv_det;
    if (u < 0 || u > 1)
        goto destroy_t;
    TB_FN(tb_so_cross)(&qvec, &tvec, &edge1);
    real v = TB_FN(tb_so_dot)(&qvec, &r->direction) * inv_det;
    if (v < 0 || u + v > 1)
        goto destroy_q;
    real t = TB_FN(tb_so_dot)(&edge2, &qvec) * inv_det;
    if ((double)t > 1e-4) {
        hit = 1;
        if (!inter) {
            *t_out = t;
            goto destroy_q;
        }
        const tb_so_point *o = &r->origine;
        const tb_so_vec *d = &r->direction;
        tb_so_point q = {1, o->x + (double)(t * d->dx), o->y + (double)(t * d->dy), o->z + (double)(t * d->dz)};
        tb_so_hit made;
        TB_FN(tb_so_hit_make)(&made, &q, self, &t);
        made.u = u;
        made.v = v;
        *inter = made;
    }
destroy_q:
    TB_FN(tb_so_vec_destroy)(&qvec);
destroy_t:
    TB_FN(tb_so_vec_destroy)(&tvec);
destroy_p:
    TB_FN(tb_so_vec_destroy)(&pvec);
    TB_FN(tb_so_vec_destroy)(&edge2);
    TB_FN(tb_so_vec_destroy)(&edge1);
    return hit;
}

TB_SO_METHODS(moller)

static void TB_FN(tb_moller_seed_object_prepare)(const real *vertices, size_t n, real *out)
{
    TB_FN(tb_so_prepare)(TB_SO_MOLLER, vertices, n, out);
}

#if TB_EMIT_SCALAR
TB_SO_INSTANTIATE(moller_seed_object)
#endif
