/* The seed's program around its two tests: its objects, its out-of-line
 * Vecteur calls, its scene loop and virtual dispatch, for moller_seed_object
 * and curless_seed_object (one file each, which include this one's loop).
 *
 * Seed: M. Vitse, ULCO 2022 (LR/Src: Scene.cpp, Triangle.cpp, Vecteur.cpp,
 * Point.hpp, Intersection.cpp), built with g++ -O2. References for the
 * algorithms: see moller_seed.h and curless_seed.h, whose arithmetic these
 * forms repeat operation for operation.
 *
 * Why: moller_seed and curless_seed replay the seed's arithmetic, inlined
 * into tribench's loop. The seed's program spends about four times their
 * time per test, on code its arithmetic sits in: every Vecteur operation is
 * a call into another translation unit (g++ inlines none of them), a Vecteur
 * has a user-written destructor, so each is returned through memory and each
 * temporary is destroyed by a call, each triangle is reached through a
 * vector of pointers and a virtual call, and a hit builds an Intersection
 * that is copied twice. These forms do the same, in C, so that `tribench
 * seed` predicts the seed's render times and not only its arithmetic:
 *  - the objects as g++ lays them out on x86-64: a Point is a vtable pointer
 *    and three doubles (it has a virtual destructor), a Vecteur three reals,
 *    a Triangle a vtable pointer, its Materiau (32 bytes), three Points and
 *    its normal; each Triangle in its own heap chunk, as `new` places them
 *    (a 16-byte-aligned, 160-byte chunk), reached through an array of pointers;
 *  - Scene::intersecte (closest hit: an Intersection made by its constructor,
 *    every object asked through its vtable, a closer hit copied out) and
 *    Scene::coupe (the first object that cuts the ray);
 *  - Triangle::intersecte and ::coupe, each Vecteur constructor, product and
 *    cross product a call that returns through a pointer, each temporary's
 *    destructor a call, in the order g++ emits them (read off objdump -d of
 *    the seed's build), with the seed's mixed precision: points in double,
 *    vectors in `real` (float for the faithful float32 form).
 * The calls are kept out of line with noinline and GCC's noipa, which stops
 * every interprocedural shortcut the separate translation units stopped.
 * Deviations, each for tribench's answers and none on a miss's path: the
 * Intersection also carries u and v (written with the hit, as the
 * arithmetic forms give them), coupe returns t through a pointer (the
 * checksum folds it), and a hit must have t < the ray's t_max (the seed's
 * rays have none: t_max is +inf on its workloads). The objects are copied
 * into their heap chunks once per batch (0.01% of a batch on scene03).
 * Internal kernels (TB_INTERNAL_KERNEL_LIST): `tribench seed` times them;
 * they are not algorithms to rank. */

#ifndef TB_SEED_OBJECT_ONCE
#define TB_SEED_OBJECT_ONCE
#if defined(__GNUC__) && !defined(__clang__)
#define TB_OUT_OF_LINE __attribute__((noinline, noipa))
#else
#define TB_OUT_OF_LINE __attribute__((noinline))
#endif
/* Point: a vtable pointer (virtual ~Point) and doubles. The vtable slots
 * hold small numbers, not pointers: the records may be cached on disk. */
typedef struct {
    int64_t vptr;
    double x, y, z;
} tb_so_point;
/* Point's copy constructor: the vptr set, then the fields, so g++ stores x and y
 * with one 16-byte move, as the Vecteur(Point, Point) that reads them loads
 * them. (A struct copy moves (vptr, x) and (y, z): the load then spans two
 * stores, which the CPU cannot forward; that cost Curless a fifth of its time.) */
static inline tb_so_point tb_so_point_copy(const tb_so_point *p)
{
    return (tb_so_point){1, p->x, p->y, p->z};
}
/* Two doubles as one SSE register, as g++ vectorises a Point's x and y. */
typedef double tb_so_double_pair __attribute__((vector_size(2 * sizeof(double))));
/* A store the compiler must make now, to memory, as itself: the object
 * forms reproduce how g++ stores and reloads the seed's temporaries. */
#define TB_SO_STORED(p) __asm__ volatile("" : : "r"(p) : "memory")
#define TB_SO_CHUNK 160 /* bytes malloc gives a 152-byte object: 8 of header, rounded to 16 */
#define TB_SO_STRIDE 40 /* reals per record in either precision (the registry has one stride): 160 bytes of float, room to spare in double */
enum { TB_SO_MOLLER, TB_SO_CURLESS };
#endif

#define tb_so_vec TB_FN(tb_so_vec)
#define tb_so_triangle TB_FN(tb_so_triangle)
#define tb_so_ray TB_FN(tb_so_ray)
#define tb_so_hit TB_FN(tb_so_hit)
#define tb_so_vtable TB_FN(tb_so_vtable)
typedef struct {
    real dx, dy, dz;
} tb_so_vec;
typedef struct {
    int64_t vptr;
    float material[8];
    tb_so_point s[3];
    tb_so_vec n;
} tb_so_triangle;
typedef struct {
    tb_so_point origine;
    tb_so_vec direction;
} tb_so_ray;
typedef struct {
    tb_so_point q;
    const tb_so_triangle *objet;
    real distance, u, v;
} tb_so_hit;
typedef struct {
    int (*intersecte)(const tb_so_triangle *, const tb_so_ray *, tb_so_hit *);
    int (*coupe)(const tb_so_triangle *, const tb_so_ray *, real *);
} tb_so_vtable;

/* Vecteur.cpp and Intersection.cpp: one call each. */
static TB_OUT_OF_LINE void TB_FN(tb_so_vec_make)(tb_so_vec *self, real x, real y, real z)
{
    self->dx = x;
    self->dy = y;
    self->dz = z;
}
static TB_OUT_OF_LINE void TB_FN(tb_so_vec_from)(tb_so_vec *self, const tb_so_point *a, const tb_so_point *b)
{
    self->dx = (real)(b->x - a->x);
    self->dy = (real)(b->y - a->y);
    self->dz = (real)(b->z - a->z);
}
static TB_OUT_OF_LINE void TB_FN(tb_so_vec_destroy)(tb_so_vec *self)
{
    __asm__ volatile("" : : "r"(self) : "memory"); /* ~Vecteur(){}: a call that does nothing */
}
static TB_OUT_OF_LINE real TB_FN(tb_so_dot)(const tb_so_vec *self, const tb_so_vec *v)
{
    return self->dx * v->dx + self->dy * v->dy + self->dz * v->dz;
}
/* produitVectoriel as g++ -O2 vectorises it: (dx, dy) from pairs of lanes,
 * loaded 8 bytes at a time from dy onwards. Those loads span the two stores
 * that just wrote a fresh Vecteur (its dx, dy, then its dz), so the CPU cannot
 * forward them and waits: about a quarter of the seed's Moller render is this
 * function (perf record of its build). */
#define tb_so_pair TB_FN(tb_so_pair)
typedef real tb_so_pair __attribute__((vector_size(2 * sizeof(real))));
static TB_OUT_OF_LINE void TB_FN(tb_so_cross)(tb_so_vec *out, const tb_so_vec *u, const tb_so_vec *v)
{
    tb_so_pair u_yz, v_yz;
    memcpy(&u_yz, &u->dy, sizeof u_yz);
    memcpy(&v_yz, &v->dy, sizeof v_yz);
    tb_so_pair xy = u_yz * (tb_so_pair){v->dz, v->dx} - v_yz * (tb_so_pair){u->dz, u->dx};
    out->dz = u->dx * v->dy - u->dy * v->dx;
    memcpy(&out->dx, &xy, sizeof xy);
}
static TB_OUT_OF_LINE void TB_FN(tb_so_hit_empty)(tb_so_hit *self)
{
    self->q = (tb_so_point){1, 0, 0, 0};
    self->objet = NULL;
    self->distance = 0;
}
static TB_OUT_OF_LINE void TB_FN(tb_so_hit_make)(tb_so_hit *self, const tb_so_point *p, const tb_so_triangle *o,
                                                 const real *t)
{
    self->q = *p;
    self->objet = o;
    self->distance = *t;
}

#define TB_SO_METHODS(alg)                                                                                   \
    static TB_OUT_OF_LINE int TB_FN(tb_so_##alg##_intersecte)(const tb_so_triangle *self, const tb_so_ray *r, \
                                                             tb_so_hit *inter)                              \
    {                                                                                                        \
        return TB_FN(tb_so_##alg##_body)(self, r, inter, NULL);                                              \
    }                                                                                                        \
    static TB_OUT_OF_LINE int TB_FN(tb_so_##alg##_coupe)(const tb_so_triangle *self, const tb_so_ray *r,      \
                                                        real *t_out)                                         \
    {                                                                                                        \
        return TB_FN(tb_so_##alg##_body)(self, r, NULL, t_out);                                              \
    }

/* The Triangle methods, defined in moller_seed_object.h and curless_seed_object.h. */
static int TB_FN(tb_so_moller_intersecte)(const tb_so_triangle *, const tb_so_ray *, tb_so_hit *);
static int TB_FN(tb_so_moller_coupe)(const tb_so_triangle *, const tb_so_ray *, real *);
static int TB_FN(tb_so_curless_intersecte)(const tb_so_triangle *, const tb_so_ray *, tb_so_hit *);
static int TB_FN(tb_so_curless_coupe)(const tb_so_triangle *, const tb_so_ray *, real *);

/* The vtables, indexed by the number a Triangle's vptr slot holds. */
static const tb_so_vtable TB_FN(tb_so_vtables)[] = {
    [TB_SO_MOLLER] = {TB_FN(tb_so_moller_intersecte), TB_FN(tb_so_moller_coupe)},
    [TB_SO_CURLESS] = {TB_FN(tb_so_curless_intersecte), TB_FN(tb_so_curless_coupe)},
};
/* a vtable's address per slot number, as a vptr is one (its load stays in the path) */
static const tb_so_vtable *const TB_FN(tb_so_vptrs)[] = {&TB_FN(tb_so_vtables)[0], &TB_FN(tb_so_vtables)[1]};

/* Scene::intersecte: the closest hit below t_max (ties to the first object). */
static TB_OUT_OF_LINE int TB_FN(tb_so_scene_intersecte)(const tb_so_triangle *const *objets, size_t n,
                                                        const tb_so_ray *r, real t_max, tb_so_hit *inter)
{
    real tmax = t_max;
    tb_so_hit cur;
    int found = 0;
    TB_FN(tb_so_hit_empty)(&cur);
    for (size_t i = 0; i < n; ++i)
        if (TB_FN(tb_so_vptrs)[objets[i]->vptr]->intersecte(objets[i], r, &cur) && cur.distance < tmax) {
            tmax = cur.distance;
            *inter = cur;
            found = 1;
        }
    return found;
}

/* Scene::coupe: the index of the first object that cuts the ray below t_max, or n. */
static TB_OUT_OF_LINE size_t TB_FN(tb_so_scene_coupe)(const tb_so_triangle *const *objets, size_t n,
                                                      const tb_so_ray *r, real t_max, real *t_out)
{
    for (size_t i = 0; i < n; ++i)
        if (TB_FN(tb_so_vptrs)[objets[i]->vptr]->coupe(objets[i], r, t_out) && *t_out < t_max)
            return i;
    return n;
}

/* One prepared record: the Triangle as its constructor leaves it (the unit
 * normal as curless_seed's prepare computes it, as the seed's constructor does). */
_Static_assert(sizeof(tb_so_triangle) <= TB_SO_STRIDE * sizeof(real), "a Triangle fits its record");
_Static_assert(sizeof(tb_so_triangle) <= TB_SO_CHUNK, "a Triangle fits its heap chunk");
static void TB_FN(tb_so_prepare)(int kind, const real *vertices, size_t n, real *out)
{
    for (size_t i = 0; i < n; ++i) {
        real plain[12];
        tb_so_triangle tri = {.vptr = kind};
        TB_FN(tb_curless_seed_prepare)(vertices + 9 * i, 1, plain);
        for (int k = 0; k < 3; ++k)
            tri.s[k] = (tb_so_point){1, plain[3 * k], plain[3 * k + 1], plain[3 * k + 2]};
        tri.n = (tb_so_vec){plain[9], plain[10], plain[11]};
        memset(out + i * TB_SO_STRIDE, 0, TB_SO_STRIDE * sizeof(real)); /* padding too: records are hashed */
        memcpy(out + i * TB_SO_STRIDE, &tri, sizeof tri);
    }
}
/* One batch: the scene built (each record copied into its heap chunk; the
 * records are not 8-byte aligned at every layout offset), then every ray
 * through Scene::intersecte or ::coupe, its answers kept as tb_scalar_loop
 * keeps them. Pairs: ray i asks triangle i alone. */
static inline __attribute__((always_inline)) void TB_FN(tb_so_loop)(tb_job *job, const int mode, const int timed)
{
    const real *o = job->origins, *d = job->directions, *t_max = job->t_max;
    const size_t n = job->n_records;
    unsigned char *heap = aligned_alloc(16, (n ? n : 1) * TB_SO_CHUNK);
    const tb_so_triangle **objets = malloc((n ? n : 1) * sizeof *objets);
    uint64_t hits = 0, tests = 0, rays = 0, poll_at = 1;
    double t_sum = 0, uv_sum = 0;
    if (!heap || !objets) {
        job->out_of_memory = 1;
        goto stop;
    }
    for (size_t j = 0; j < n; ++j) {
        memcpy(heap + j * TB_SO_CHUNK, (const real *)job->records + j * TB_SO_STRIDE, sizeof(tb_so_triangle));
        objets[j] = (const tb_so_triangle *)(heap + j * TB_SO_CHUNK);
    }
    const uint64_t loops = timed ? job->loops : 1;
    for (uint64_t pass = 0; pass < loops; ++pass)
        for (size_t i = 0; i < job->n_rays; ++i) {
            if (++rays == poll_at && !(poll_at = tb_poll(job, rays)))
                goto stop;
            tb_so_ray r = {{1, o[3 * i], o[3 * i + 1], o[3 * i + 2]}, {d[3 * i], d[3 * i + 1], d[3 * i + 2]}};
            tb_so_hit h = {.distance = (real)NAN, .u = (real)NAN, .v = (real)NAN};
            int64_t index = -1;
            if (mode == TB_PAIRS) {
                if (TB_FN(tb_so_scene_intersecte)(objets + i, 1, &r, t_max[i], &h))
                    index = (int64_t)i;
                tests += 1;
            } else if (mode == TB_ANY) {
                size_t j = TB_FN(tb_so_scene_coupe)(objets, n, &r, t_max[i], &h.distance);
                index = j < n ? (int64_t)j : -1;
                tests += j < n ? j + 1 : n;
                if (!timed && index >= 0) /* u and v of that hit, for the answers only */
                    TB_FN(tb_so_scene_intersecte)(objets + j, 1, &r, t_max[i], &h);
            } else {
                if (TB_FN(tb_so_scene_intersecte)(objets, n, &r, t_max[i], &h))
                    index = ((const unsigned char *)h.objet - heap) / TB_SO_CHUNK;
                tests += n;
            }
            if (timed) {
                if (index >= 0) {
                    ++hits;
                    t_sum += h.distance;
                    if (mode == TB_CLOSEST_UV)
                        uv_sum += (double)h.u + h.v;
                }
            } else {
                real *t_out = job->t_out, *u_out = job->u_out, *v_out = job->v_out;
                job->index_out[i] = index;
                t_out[i] = index >= 0 ? h.distance : (real)NAN;
                u_out[i] = index >= 0 ? h.u : (real)NAN;
                v_out[i] = index >= 0 ? h.v : (real)NAN;
            }
        }
stop:
    free(heap);
    free(objets);
    job->hits = hits;
    job->tests = tests;
    job->t_sum = t_sum;
    job->uv_sum = uv_sum;
}

#define TB_SO_ENTRY(name, fn_mode, mode, timed)                              \
    TB_HIDDEN void TB_FN(tb_##name##_##fn_mode)(tb_job *job)                 \
    {                                                                        \
        TB_FN(tb_so_loop)(job, mode, timed);                                 \
    }
/* Both kernels share the loop: the vptr slot of each record picks the test. */
#define TB_SO_INSTANTIATE(name)                                              \
    TB_SO_ENTRY(name, run_pairs, TB_PAIRS, 0)                                \
    TB_SO_ENTRY(name, run_any, TB_ANY, 0)                                    \
    TB_SO_ENTRY(name, run_closest, TB_CLOSEST_UV, 0)                         \
    TB_SO_ENTRY(name, time_pairs, TB_PAIRS, 1)                               \
    TB_SO_ENTRY(name, time_any, TB_ANY, 1)                                   \
    TB_SO_ENTRY(name, time_closest, TB_CLOSEST, 1)                           \
    TB_SO_ENTRY(name, time_closest_uv, TB_CLOSEST_UV, 1)
