/* curless_seed_object: curless_seed as the seed's program runs it (seed_objects.h: its
 * objects, calls and scene loop; why and how there).
 *
 * Seed: M. Vitse, ULCO 2022 (LR/Src/Triangle.cpp, the branch without MOLLER), g++ -O2.
 * Algorithm and reference: curless_seed.h, whose arithmetic this repeats operation
 * for operation, in the seed's mixed precision (points in double, vectors in
 * `real`). Internal kernel (TB_INTERNAL_KERNEL_LIST): tribench seed times it. */

#define tb_curless_seed_object_stride TB_SO_STRIDE
#define tb_curless_seed_object_flat TB_FLAT_AS_IS
#define tb_curless_seed_object_ops tb_curless_seed_ops /* the twin's arithmetic: the same counts (kernels.h) */
#define tb_curless_seed_object_mix tb_curless_seed_mix

/* Triangle::intersecte and ::coupe without MOLLER: Curless's plane, then
 * edges, every temporary as the seed's code makes and destroys it. */
static inline __attribute__((always_inline)) int
TB_FN(tb_so_curless_body)(const tb_so_triangle *self, const tb_so_ray *r, tb_so_hit *inter, real *t_out)
{
    /* auto origin = r.origine: g++ keeps its three doubles in registers and
     * spills each across the calls with a store of its own, then reads x and y
     * back as one 16-byte pair to compute q. That load spans two stores, which
     * the CPU cannot forward (seed_objects.h): written so, not as a Point copy. */
    double origin[3];
    origin[0] = r->origine.x;
    TB_SO_STORED(origin); /* one 8-byte store each */
    origin[1] = r->origine.y;
    TB_SO_STORED(origin);
    origin[2] = r->origine.z;
    TB_SO_STORED(origin);
    tb_so_point a, b, c, q;
    tb_so_vec direction = r->direction, p, a_vec, ab, aq, bc, bq, ca, cq, side;
    real side_ab, side_bc, side_ca;
    int hit = 0;
    /* p from the values just loaded, as g++ converts them from registers */
    TB_FN(tb_so_vec_make)(&p, (real)r->origine.x, (real)r->origine.y, (real)r->origine.z);
    a = tb_so_point_copy(&self->s[0]);
    TB_FN(tb_so_vec_make)(&a_vec, (real)a.x, (real)a.y, (real)a.z);
    real dist = TB_FN(tb_so_dot)(&self->n, &a_vec);
    TB_FN(tb_so_vec_destroy)(&a_vec);
    real nd = TB_FN(tb_so_dot)(&self->n, &direction);
    if (nd == 0)
        goto destroy_p;
    real t = (dist - TB_FN(tb_so_dot)(&self->n, &p)) / nd;
    if ((double)t < 1e-4)
        goto destroy_p;
    b = tb_so_point_copy(&self->s[1]);
    c = tb_so_point_copy(&self->s[2]);
    tb_so_double_pair origin_xy;
    memcpy(&origin_xy, origin, sizeof origin_xy); /* the 16-byte load over the two stores */
    origin_xy += (tb_so_double_pair){(double)(t * direction.dx), (double)(t * direction.dy)};
    q = (tb_so_point){1, origin_xy[0], origin_xy[1], origin[2] + (double)(t * direction.dz)};
    TB_FN(tb_so_vec_from)(&ab, &a, &b);
    TB_FN(tb_so_vec_from)(&aq, &a, &q);
    TB_FN(tb_so_cross)(&side, &ab, &aq);
    side_ab = TB_FN(tb_so_dot)(&side, &self->n);
    TB_FN(tb_so_vec_destroy)(&side);
    if (side_ab <= 0)
        goto destroy_a;
    TB_FN(tb_so_vec_from)(&bc, &b, &c);
    TB_FN(tb_so_vec_from)(&bq, &b, &q);
    TB_FN(tb_so_cross)(&side, &bc, &bq);
    side_bc = TB_FN(tb_so_dot)(&side, &self->n);
    TB_FN(tb_so_vec_destroy)(&side);
    if (side_bc <= 0)
        goto destroy_b;
    TB_FN(tb_so_vec_from)(&ca, &c, &a);
    TB_FN(tb_so_vec_from)(&cq, &c, &q);
    TB_FN(tb_so_cross)(&side, &ca, &cq);
    side_ca = TB_FN(tb_so_dot)(&side, &self->n);
    TB_FN(tb_so_vec_destroy)(&side);
    if (side_ca <= 0)
        goto destroy_c;
    hit = 1;
    if (inter) {
        tb_so_hit made;
        TB_FN(tb_so_hit_make)(&made, &q, self, &t);
        real sum = side_ab + side_bc + side_ca; /* tribench's u, v: as curless_seed gives them */
        made.u = side_ca / sum;
        made.v = side_ab / sum;
        *inter = made;
    } else {
        *t_out = t;
    }
destroy_c:
    TB_FN(tb_so_vec_destroy)(&cq);
    TB_FN(tb_so_vec_destroy)(&ca);
destroy_b:
    TB_FN(tb_so_vec_destroy)(&bq);
    TB_FN(tb_so_vec_destroy)(&bc);
destroy_a:
    TB_FN(tb_so_vec_destroy)(&aq);
    TB_FN(tb_so_vec_destroy)(&ab);
destroy_p:
    TB_FN(tb_so_vec_destroy)(&p);
    TB_FN(tb_so_vec_destroy)(&direction);
    return hit;
}

TB_SO_METHODS(curless)

static void TB_FN(tb_curless_seed_object_prepare)(const real *vertices, size_t n, real *out)
{
    TB_FN(tb_so_prepare)(TB_SO_CURLESS, vertices, n, out);
}


#if TB_EMIT_SCALAR
TB_SO_INSTANTIATE(curless_seed_object)
#endif
