/* The traversals of bvh.h's trees, one ray at a time (binary and wide), and the batch loop of
 * every walk, with a native kernel's block test at the leaves; packets of rays are bvh_packet.h's.
 * No include guard: native.h includes this file after bvh.h, once per ISA of each precision. */

/* Slab test of the ray against one node's box, within [0, t_max] (Ize 2013,
 * "Robust BVH ray traversal"). inv = 1 / d per axis, so d = +-0 gives +-inf
 * and the slab's entry and exit are +-inf: a ray parallel to a slab is inside
 * it for all t or for none, as it should be (Williams et al. 2005). The one
 * NaN is 0 x inf, the origin exactly on a slab plane with d parallel to it:
 * the comparisons are written so a NaN never replaces the running value
 * (x > t0 ? x : t0 is false for NaN), so that slab is ignored, which keeps
 * the ray (a conservative answer, never a lost hit). Rounding: (b - o) * inv
 * is within 3 rounding errors of the exact entry or exit (the difference, the
 * reciprocal, the product); every exit is computed with inv_far, the
 * reciprocal scaled by 1 + 4 eps per ray (tb_bvh_ray_of; one rounding more,
 * as scaling each exit would take), which is more than Ize's 1 + 2 gamma_3
 * and keeps an exit computed too early from dropping a box the exact ray
 * meets, flat boxes of axis-aligned triangles included. Non-finite rays never
 * get here (they miss). Returns whether the box is met, and its entry
 * distance in *t_in. */
TB_NWIDE int TB_NFN(tb_bvh_box)(const tb_bvh_node *node, const real o[3], const real inv[3],
                                const real inv_far[3], const int near[3], real t_max, real *t_in)
{
    real t0 = 0, t1 = t_max;
    for (int k = 0; k < 3; ++k) {
        real enter = (node->b[near[k]][k] - o[k]) * inv[k];
        real leave = (node->b[1 - near[k]][k] - o[k]) * inv_far[k];
        t0 = enter > t0 ? enter : t0;
        t1 = leave < t1 ? leave : t1;
    }
    *t_in = t0;
    return t0 <= t1;
}

/* Asks for every line of a wide node (four, on 64-byte lines: bvh.py aligns the
 * array), so that a child pushed is in cache when it is popped. */
TB_NWIDE void TB_NFN(tb_bvh_prefetch_wide)(const tb_bvh_wide *w)
{
    for (size_t at = 0; at < sizeof *w; at += 64)
        __builtin_prefetch((const char *)w + at);
}

/* Whether child i of wide node `at` can be entered: a leaf, or an inner
 * node after its parent and inside the tree (so a malformed tree cannot loop
 * or read out of bounds). */
TB_NWIDE int TB_NFN(tb_bvh_child_sound)(const tb_bvh_wide *w, int i, uint32_t at, size_t n_nodes)
{
    return w->n[i] != 0 || (w->a[i] > at && w->a[i] < n_nodes);
}

/* The same slab test on every child of a wide node at once: one 32-byte
 * vector per plane, the same arithmetic and rounding margin as tb_bvh_box,
 * lane by lane. max and min keep the running value when the new one is NaN
 * (the 0 x inf case above): the AVX forms return their second operand on a
 * NaN, and the baseline's select does the same. An empty child's box
 * (+inf, -inf) is missed by every finite ray. rows: the byte offsets of
 * the ray's entry and exit plane per axis (tb_bvh_trace_wide), so that a
 * node's loads need no arithmetic on the ray's signs. Written as
 * (o - b) * -inv, which is (b - o) * inv bit for bit (negation is exact), so
 * that each plane's load folds into the subtraction. Returns the bits of the
 * children met, and their entry distances in *t_in. */
#if (TB_NISA_ID == 1 || TB_NISA_ID == 2) && !TB_REAL_IS_DOUBLE
#define tb_wv_max(a, b) _mm256_max_ps(a, b)
#define tb_wv_min(a, b) _mm256_min_ps(a, b)
#define tb_wv_le_bits(a, b) ((unsigned)_mm256_movemask_ps(_mm256_cmp_ps(a, b, _CMP_LE_OQ)))
#elif TB_NISA_ID == 1 || TB_NISA_ID == 2
#define tb_wv_max(a, b) _mm256_max_pd(a, b)
#define tb_wv_min(a, b) _mm256_min_pd(a, b)
#define tb_wv_le_bits(a, b) ((unsigned)_mm256_movemask_pd(_mm256_cmp_pd(a, b, _CMP_LE_OQ)))
#elif TB_NISA_ID == 3
/* NEON: the 32 bytes as two registers. vmaxnmq and vminnmq return the
 * number when one operand is NaN, so the running value (never NaN) is kept
 * as AVX keeps it; they differ from AVX only on -0 against +0, which
 * compare equal in the test and in the children's order. */
#define tb_wv_max(a, b) TB_NFN(tb_wv_pair)(a, b, 1)
#define tb_wv_min(a, b) TB_NFN(tb_wv_pair)(a, b, 0)
#define tb_wv_le_bits(a, b) TB_NFN(tb_wv_le)(a, b)
TB_NWIDE vreal TB_NFN(tb_wv_pair)(vreal a, vreal b, const int max)
{
    nreal x[2], y[2];
    memcpy(x, &a, sizeof x);
    memcpy(y, &b, sizeof y);
    for (int h = 0; h < 2; ++h)
        x[h] = max ? TB_NV(vmaxnmq)(x[h], y[h]) : TB_NV(vminnmq)(x[h], y[h]);
    memcpy(&a, x, sizeof a);
    return a;
}
TB_NWIDE unsigned TB_NFN(tb_wv_le)(vreal a, vreal b)
{
    nreal x[2], y[2];
    memcpy(x, &a, sizeof x);
    memcpy(y, &b, sizeof y);
    return nm_bits(nv_le(x[0], y[0])) | nm_bits(nv_le(x[1], y[1])) << TB_NL;
}
#else
#define tb_wv_max(a, b) TB_NFN(tb_wv_pick)(a, b, (a) > (b))
#define tb_wv_min(a, b) TB_NFN(tb_wv_pick)(a, b, (a) < (b))
#define tb_wv_le_bits(a, b) TB_NFN(tb_wv_bits)((a) <= (b))
TB_NWIDE vreal TB_NFN(tb_wv_pick)(vreal a, vreal b, vmask m)
{
    return (vreal)((m & (vmask)a) | (~m & (vmask)b));
}
TB_NWIDE unsigned TB_NFN(tb_wv_bits)(vmask m)
{
    mask_elem lanes[TB_BVH_WIDTH];
    memcpy(lanes, &m, sizeof lanes);
    return TB_FN(tb_lane_bits)(lanes, TB_BVH_WIDTH);
}
#endif
TB_NWIDE unsigned TB_NFN(tb_bvh_wide_box)(const tb_bvh_wide *w, const vreal org[3], const vreal ninv[3],
                                          const vreal ninv_far[3], const size_t rows[6], real t_max, vreal *t_in)
{
    vreal t0 = (vreal){0}, t1 = t_max + (vreal){0};
    const char *planes = (const char *)w->b;
    for (int k = 0; k < 3; ++k) {
        vreal enter, leave;
        memcpy(&enter, planes + rows[2 * k], sizeof enter);
        memcpy(&leave, planes + rows[2 * k + 1], sizeof leave);
        t0 = tb_wv_max((org[k] - enter) * ninv[k], t0);
        t1 = tb_wv_min((org[k] - leave) * ninv_far[k], t1);
    }
    *t_in = t0;
    return tb_wv_le_bits(t0, t1);
}

/* A ray as both traversals take it: the kernel's ray in every lane, and
 * the slab test's origin, inverse direction and near side per axis. */
typedef struct {
    tb_nray r;
    real org[3], inv[3], inv_far[3]; /* inv_far: inv scaled by 1 + 4 eps, for the exits (tb_bvh_box) */
    int near[3], finite;
} TB_NFN(tb_bvh_ray);

TB_NWIDE void TB_NFN(tb_bvh_ray_of)(TB_FN(tb_ray_fn) make_ray, const real *o, const real *d, TB_NFN(tb_bvh_ray) * ray)
{
    tb_ray sr;
    make_ray(o, d, &sr);
    ray->r = TB_NFN(tb_nray_of)(&sr);
    ray->finite = 1;
    for (int k = 0; k < 3; ++k) {
        ray->finite &= isfinite(sr.o[k]) && isfinite(sr.d[k]);
        ray->org[k] = sr.o[k];
        ray->inv[k] = 1 / sr.d[k];
        ray->inv_far[k] = ray->inv[k] * ((real)1 + 4 * (TB_REAL_IS_DOUBLE ? DBL_EPSILON : FLT_EPSILON));
        ray->near[k] = signbit(ray->inv[k]) ? 1 : 0;
    }
}

/* The closest hit so far: t starts at the ray's t_max; slot and index -1
 * until a hit; filter is the kernel's t_max, t grown by 1 + 4 eps so that an
 * equal t (coincident triangles) reaches the tie rule. */
typedef struct {
    real t, u, v;
    int64_t slot; /* its input index is job->perm[slot], looked up on a tie and once the ray is done */
    nreal filter;
} TB_NFN(tb_bvh_best);

/* A leaf's triangles through the kernel: each vector's worth of its blocks
 * with the closest hit so far as t_max, dividing as native.h's loop does.
 * The closest hit is the smallest t; equal t goes to the lowest input index,
 * as brute force does; hits with t >= the ray's own t_max never count.
 * Counts the leaf (c[2], c[3]). Returns -1 on a leaf out of range (a
 * malformed tree), 1 when mode any has its hit (the ray is done), else 0. */
TB_NWIDE int TB_NFN(tb_bvh_visit_leaf)(TB_NFN(tb_native_fn) test, size_t stride, const tb_bvh_job *job,
                                       const TB_NFN(tb_bvh_ray) * ray, size_t first, size_t count, int mode,
                                       int timed, int null, nreal iota, TB_NFN(tb_bvh_best) * b, uint64_t c[4])
{
    const real *rec = job->base.records;
    const real grow = (real)1 + 4 * (TB_REAL_IS_DOUBLE ? DBL_EPSILON : FLT_EPSILON);
    const nreal zero = nv_set1(0), one = nv_set1(1);
    if (first % 16 || first > job->n_slots || count > job->n_slots - first)
        return -1;
    ++c[2];
    c[3] += count;
    if (null) {
        __asm__ volatile("" : : "r"(rec + stride * first) : "memory");
        return 0;
    }
    for (size_t at = 0; at < count; at += TB_NL) {
        const size_t slot = first + at;
        tb_nhit h;
        h.uv_den_set = 0;
        nmask m = test(&ray->r, rec + stride * (slot - slot % 16) + slot % 16, b->filter, &h);
        if (!nm_any(m))
            continue;
        if (count - at < (size_t)TB_NL) /* lanes past the leaf's last triangle */
            m = nm_and(m, nv_lt(iota, nv_set1((real)(count - at))));
        nreal inv_den = one / h.den, t = h.t * inv_den;
        m = nm_and(m, nm_and(nv_gt(t, zero), nv_le(t, nv_set1(b->t))));
        if (!nm_any(m))
            continue;
        real ts[TB_NL], us[TB_NL], vs[TB_NL];
        memcpy(ts, &t, sizeof ts);
        if (mode == TB_CLOSEST_UV || !timed) {
            const nreal inv_uv = TB_NFN(tb_nhit_uv_inv)(&h, inv_den);
            const nreal u = h.u * inv_uv, v = h.v * inv_uv;
            memcpy(us, &u, sizeof us);
            memcpy(vs, &v, sizeof vs);
        }
        for (unsigned lanes = nm_bits(m); lanes; lanes &= lanes - 1) { /* the candidates */
            const int l = __builtin_ctz(lanes);
            if (!(ts[l] <= b->t)) /* beaten by an earlier lane */
                continue;
            if (ts[l] < b->t || (b->slot >= 0 && job->perm[slot + l] < job->perm[b->slot])) {
                b->t = ts[l];
                b->slot = (int64_t)(slot + l);
                if (mode == TB_CLOSEST_UV || !timed) {
                    b->u = us[l];
                    b->v = vs[l];
                }
                if (mode == TB_ANY)
                    return 1;
            }
        }
        b->filter = nv_set1(b->t * grow);
    }
    return 0;
}

/* The binary tree, one ray: the root's box, then depth first: at an inner
 * node both children's boxes are tested, the nearer (by entry distance, ties
 * to the left) is entered next and the farther pushed with its entry
 * distance; a popped node whose entry lies beyond the closest hit so far is
 * skipped. Counts: the root's box test, two per inner node. Returns 0 on a
 * malformed tree, else 1. */
TB_NWIDE int TB_NFN(tb_bvh_trace_binary)(TB_NFN(tb_native_fn) test, size_t stride, const tb_bvh_job *job,
                                         const TB_NFN(tb_bvh_ray) * ray, int mode, int timed, int null, nreal iota,
                                         TB_NFN(tb_bvh_best) * b, uint64_t c[4])
{
    const tb_bvh_node *nodes = job->nodes;
    size_t node = 0, sp = 0, stack[TB_BVH_STACK];
    real stack_t[TB_BVH_STACK], t_in;
    c[1] = (uint64_t)ray->finite;
    if (!ray->finite || !TB_NFN(tb_bvh_box)(&nodes[0], ray->org, ray->inv, ray->inv_far, ray->near, b->t, &t_in))
        return 1;
    for (;;) {
        const tb_bvh_node *nd = &nodes[node];
        ++c[0];
        if (nd->n == 0) { /* inner: test both children */
            size_t left = node + 1, right = nd->a;
            if (right <= left || right >= job->n_nodes)
                return 0;
            real t_left, t_right;
            int hit_left = TB_NFN(tb_bvh_box)(&nodes[left], ray->org, ray->inv, ray->inv_far, ray->near, b->t, &t_left);
            int hit_right = TB_NFN(tb_bvh_box)(&nodes[right], ray->org, ray->inv, ray->inv_far, ray->near, b->t, &t_right);
            c[1] += 2;
            if (hit_left && hit_right) {
                if (sp == TB_BVH_STACK)
                    return 0;
                int left_first = t_left <= t_right;
                stack[sp] = left_first ? right : left;
                stack_t[sp++] = left_first ? t_right : t_left;
                node = left_first ? left : right;
                continue;
            }
            if (hit_left || hit_right) {
                node = hit_left ? left : right;
                continue;
            }
        } else {
            int done = TB_NFN(tb_bvh_visit_leaf)(test, stride, job, ray, nd->a, nd->n, mode, timed, null, iota, b, c);
            if (done)
                return done > 0;
        }
        do { /* the next pushed node still in reach */
            if (sp == 0)
                return 1;
            --sp;
        } while (!(stack_t[sp] <= b->t));
        node = stack[sp];
    }
}

/* The order a wide node's children met are entered in, for both walks of the wide tree: child
 * `e`, met after the j children at kids[0 .. j-1] (in lane order), is inserted among them, which
 * stay sorted by entry distance, farthest first, so that the nearest ends on top of the stack; an
 * equal entry goes above the lower lanes', so the lower child is entered first (as the binary
 * walk's left). A macro, as the two walks' entries differ in type; j is moved. */
#define TB_BVH_PUSH_IN_ORDER(kids, j, e)                     \
    do {                                                     \
        for (; (j) > 0 && (kids)[(j) - 1].t <= (e).t; --(j)) \
            (kids)[j] = (kids)[(j) - 1];                     \
        (kids)[j] = (e);                                     \
    } while (0)

/* The wide tree, one ray, in order (Wald et al. 2008; Embree does the
 * same): a wide node's children are tested at once; those met are pushed
 * farthest first, so the nearest is entered next and each popped child is
 * the nearest left; a child whose entry lies beyond the closest hit so far
 * is skipped when popped. Equal entries go to the lower child first, as the
 * binary traversal's left. Counts: TB_BVH_WIDTH box tests per wide node
 * (the lanes tested, empty ones included). Returns 0 on a malformed tree. */
TB_NWIDE int TB_NFN(tb_bvh_trace_wide)(TB_NFN(tb_native_fn) test, size_t stride, const tb_bvh_job *job,
                                       const TB_NFN(tb_bvh_ray) * ray, int mode, int timed, int null, nreal iota,
                                       TB_NFN(tb_bvh_best) * b, uint64_t c[4])
{
    typedef struct {
        uint32_t a, n; /* as a wide node's child */
        real t;        /* its entry distance */
    } entry;
    const tb_bvh_wide *nodes = job->nodes;
    /* the children met are sorted in place on top of the stack, the nearest last, then entered: room
     * for the deepest tree's pushes and one node's children past them */
    entry stack[TB_BVH_STACK * (TB_BVH_WIDTH - 1) + TB_BVH_WIDTH];
    size_t sp = 0;
    if (!ray->finite)
        return 1;
    vreal org[3], ninv[3], ninv_far[3];
    size_t rows[6];
    for (int k = 0; k < 3; ++k) {
        org[k] = ray->org[k] + (vreal){0};
        ninv[k] = -ray->inv[k] + (vreal){0};
        ninv_far[k] = -ray->inv_far[k] + (vreal){0};
        rows[2 * k] = (size_t)(2 * k + ray->near[k]) * sizeof nodes->b[0];
        rows[2 * k + 1] = (size_t)(2 * k + 1 - ray->near[k]) * sizeof nodes->b[0];
    }
    uint32_t a = 0, n = 0; /* the root, wide node 0 */
    for (;;) {
        if (n == 0) {
            const tb_bvh_wide *w = &nodes[a];
            vreal t_in;
            unsigned met = TB_NFN(tb_bvh_wide_box)(w, org, ninv, ninv_far, rows, b->t, &t_in);
            ++c[0];
            c[1] += TB_BVH_WIDTH;
            if (met && !(met & (met - 1))) { /* one child met: entered at once, no sort, no push */
                const int i = __builtin_ctz(met);
                if (!TB_NFN(tb_bvh_child_sound)(w, i, a, job->n_nodes))
                    return 0;
                n = w->n[i];
                a = w->a[i];
                continue;
            }
            if (met) {
                real ts[TB_BVH_WIDTH];
                memcpy(ts, &t_in, sizeof ts);
                if (sp + TB_BVH_WIDTH > sizeof stack / sizeof *stack)
                    return 0;
                entry *kids = &stack[sp];
                int k = 0;
                for (; met; met &= met - 1) { /* insertion by entry, farthest first */
                    int i = __builtin_ctz(met), j = k++;
                    if (!TB_NFN(tb_bvh_child_sound)(w, i, a, job->n_nodes))
                        return 0;
                    entry e = {w->a[i], w->n[i], ts[i]};
                    if (e.n == 0) /* fetched while the nearer children are visited: +3-5% at 1M triangles */
                        TB_NFN(tb_bvh_prefetch_wide)(&nodes[e.a]);
                    else if (e.a < job->n_slots) /* a leaf's first block: a line per field */
                        for (size_t f = 0; f < stride; ++f)
                            __builtin_prefetch((const real *)job->base.records + stride * e.a + 16 * f);
                    TB_BVH_PUSH_IN_ORDER(kids, j, e);
                }
                sp += (size_t)k - 1;
                a = kids[k - 1].a;
                n = kids[k - 1].n;
                continue;
            }
        } else {
            ++c[0];
            int done = TB_NFN(tb_bvh_visit_leaf)(test, stride, job, ray, a, n, mode, timed, null, iota, b, c);
            if (done)
                return done > 0;
        }
        do { /* the nearest pushed child still in reach */
            if (sp == 0)
                return 1;
            --sp;
        } while (!(stack[sp].t <= b->t));
        a = stack[sp].a;
        n = stack[sp].n;
    }
}

#include "bvh_packet.h" /* the wide tree walked by packets of coherent rays */

/* A batch's sums over its timed rays: hits, their t and u + v, and the four counts. */
typedef struct {
    uint64_t hits, counts[4];
    double t_sum, uv_sum;
} TB_NFN(tb_bvh_tally);

/* A traced ray's answer: its outputs (untimed), or the batch's sums. */
TB_NWIDE void TB_NFN(tb_bvh_record)(tb_bvh_job *job, size_t i, const TB_NFN(tb_bvh_best) * b, const uint64_t c[4],
                                    int mode, int timed, TB_NFN(tb_bvh_tally) * sum)
{
    tb_job *base = &job->base;
    if (timed) {
        if (b->slot >= 0) {
            const int64_t index = job->perm[b->slot]; /* what the untimed call returns, loaded as it is */
            __asm__ volatile("" : : "r"(index));
            ++sum->hits;
            sum->t_sum += b->t;
            if (mode == TB_CLOSEST_UV)
                sum->uv_sum += (double)b->u + b->v;
        }
        for (int k = 0; k < 4; ++k)
            sum->counts[k] += c[k];
        return;
    }
    real *t_out = base->t_out, *u_out = base->u_out, *v_out = base->v_out;
    base->index_out[i] = b->slot >= 0 ? job->perm[b->slot] : -1;
    t_out[i] = b->slot >= 0 ? b->t : (real)NAN;
    u_out[i] = b->slot >= 0 ? b->u : (real)NAN;
    v_out[i] = b->slot >= 0 ? b->v : (real)NAN;
    for (int k = 0; k < 4; ++k)
        job->counts_out[4 * i + k] = (int64_t)c[k];
}

/* Rays i .. i + n - 1 of the batch, which share one origin, as a packet: set up, traced
 * (tb_bvh_trace_packet) and recorded into *sum. Returns 0 on a malformed tree. */
TB_NWIDE int TB_NFN(tb_bvh_packet_batch)(TB_NFN(tb_native_fn) test, TB_FN(tb_ray_fn) make_ray, size_t stride,
                                         tb_bvh_job *job, size_t i, int n, int mode, int timed, int null,
                                         nreal iota, TB_NFN(tb_bvh_tally) * sum)
{
    const real *o = job->base.origins, *d = job->base.directions, *t_max = job->base.t_max;
    TB_NFN(tb_bvh_ray) ray[TB_BVH_PACKET];
    TB_NFN(tb_bvh_best) b[TB_BVH_PACKET];
    uint64_t c[TB_BVH_PACKET][4];
    memset(c, 0, (size_t)n * sizeof *c);
    for (int r = 0; r < n; ++r) {
        TB_NFN(tb_bvh_ray_of)(make_ray, o + 3 * (i + r), d + 3 * (i + r), &ray[r]);
        b[r] = (TB_NFN(tb_bvh_best)){t_max[i + r], (real)NAN, (real)NAN, -1, nv_set1(t_max[i + r])};
    }
    if (!TB_NFN(tb_bvh_trace_packet)(test, stride, job, ray, n, mode, timed, null, iota, b, c))
        return 0;
    for (int r = 0; r < n; ++r)
        TB_NFN(tb_bvh_record)(job, i + r, &b[r], c[r], mode, timed, sum);
    return 1;
}

/* A kernel's packets' trace (TB_BVH_ENTRIES): tb_bvh_packet_batch with the kernel compiled in and its
 * mode and flags passed, one out-of-line copy for all six entry points. */
typedef int (*TB_NFN(tb_bvh_packet_fn))(tb_bvh_job *job, size_t i, int n, int mode, int timed, int null, nreal iota,
                                       TB_NFN(tb_bvh_tally) * sum);

/* One batch of BVH traversal with a native kernel's block test at the
 * leaves, on the binary tree (`wide` 0) or the wide one (1, constants in
 * each entry point). On the wide tree with job->packets (layout "packets"),
 * the consecutive rays, up to TB_BVH_PACKET, that share the first one's
 * origin go as a packet (bvh_packet.h) through `trace_packet`, out of line:
 * inlined beside the single ray's walk, or with a ray alone in the packet's
 * arrays, the rays traced alone ran 8-15% slower. A ray alone is traced
 * alone. Non-finite rays (NaN or Inf in o or d) miss at once. Mode any
 * stops at the first hit.
 *
 * Counts per ray: nodes visited (inner nodes and leaves entered), box tests,
 * leaves, triangle tests (the leaf's triangles, not its padding lanes). With
 * `null`, the leaf test is replaced by a compiler barrier on the leaf's
 * records (no load, no arithmetic): the same traversal order, but nothing is
 * ever hit, so no interval shrinks; run it with each ray's t_max at its
 * closest hit to traverse as a ray that found its hit at once (the counts
 * say how the two traversals differ). */
TB_NWIDE void TB_NFN(tb_bvh_loop)(TB_NFN(tb_native_fn) test, TB_FN(tb_ray_fn) make_ray, size_t stride,
                                  tb_bvh_job *job, const int mode, const int timed, const int null, const int wide,
                                  TB_NFN(tb_bvh_packet_fn) trace_packet)
{
    tb_job *base = &job->base;
    const real *o = base->origins, *d = base->directions, *t_max = base->t_max;
    const int packets = wide && job->packets;
    real lane[TB_NL];
    for (int l = 0; l < TB_NL; ++l)
        lane[l] = (real)l;
    const nreal iota = nv_load(lane);
    TB_NFN(tb_bvh_tally) sum = {0, {0, 0, 0, 0}, 0, 0};
    uint64_t rays = 0, poll_at = 1;
    const uint64_t loops = timed ? base->loops : 1;
    for (uint64_t pass = 0; pass < loops; ++pass)
        for (size_t i = 0; i < base->n_rays;) {
            int n = 1; /* the rays from ray i's origin, up to a packet's */
            const size_t left = base->n_rays - i, most = packets && left > TB_BVH_PACKET ? TB_BVH_PACKET : left;
            for (const real *a = o + 3 * i, *x = a + 3; packets && (size_t)n < most; ++n, x += 3)
                if (!(x[0] == a[0] && x[1] == a[1] && x[2] == a[2]))
                    break;
            if ((rays += (uint64_t)n) >= poll_at && !(poll_at = tb_poll(base, rays)))
                goto stop;
            if (n > 1) {
                if (!trace_packet(job, i, n, mode, timed, null, iota, &sum)) {
                    job->bad_tree = 1;
                    goto stop;
                }
                i += (size_t)n;
                continue;
            }
            TB_NFN(tb_bvh_ray) ray;
            TB_NFN(tb_bvh_ray_of)(make_ray, o + 3 * i, d + 3 * i, &ray);
            TB_NFN(tb_bvh_best) b = {t_max[i], (real)NAN, (real)NAN, -1, nv_set1(t_max[i])};
            uint64_t c[4] = {0, 0, 0, 0};
            int sound = wide ? TB_NFN(tb_bvh_trace_wide)(test, stride, job, &ray, mode, timed, null, iota, &b, c)
                             : TB_NFN(tb_bvh_trace_binary)(test, stride, job, &ray, mode, timed, null, iota, &b, c);
            if (!sound) {
                job->bad_tree = 1;
                goto stop;
            }
            TB_NFN(tb_bvh_record)(job, i, &b, c, mode, timed, &sum);
            ++i;
        }
stop:
    base->hits = sum.hits;
    base->tests = sum.counts[3];
    base->t_sum = sum.t_sum;
    base->uv_sum = sum.uv_sum;
    memcpy(job->counts, sum.counts, sizeof sum.counts);
}
#undef tb_wv_max
#undef tb_wv_min
#undef tb_wv_le_bits
#undef TB_BVH_PUSH_IN_ORDER

/* Entry points of one native kernel's BVH traversals for this ISA (the wide
 * tree's, which also walk it by packets, then the binary tree's: bvh.c's
 * table in the same order); only the TB_NATIVE kernels of the public list
 * (one line each, from list.h). The wide tree's four timed walks are each
 * compiled with their mode and flags as constants: with them as arguments
 * one kernel's walk ran 4-7% slower. Each tree's other entry points share one
 * walk compiled for that tree, which takes them as arguments
 * (TB_SHARED_LOOP), as the packets share their trace: the binary tree's timed
 * walks ran faster so than with constants (docs/decisions.md, "One walk per
 * tree"). */
#define TB_BVH_ENTRY(name, fn_mode, mode, timed, null)                                              \
    TB_NTARGET TB_HIDDEN void TB_NFN(tb_##name##_bvh_##fn_mode)(tb_bvh_job *job)                    \
    {                                                                                               \
        TB_NFN(tb_bvh_loop)(TB_NFN(tb_##name##_test), TB_FN(tb_##name##_ray), tb_##name##_stride, job, \
                            mode, timed, null, 1, TB_NFN(tb_##name##_bvh_packet));                  \
    }
#define TB_BVH_SHARED_ENTRY(name, fn_mode, mode, timed, null, tree)                                 \
    TB_NTARGET TB_HIDDEN void TB_NFN(tb_##name##_bvh_##fn_mode)(tb_bvh_job *job)                    \
    {                                                                                               \
        TB_NFN(tb_##name##_bvh_##tree)(job, mode, timed, null);                                     \
    }
#define TB_BVH_WALK(name, tree, wide)                                                               \
    static TB_SHARED_LOOP TB_NTARGET void TB_NFN(tb_##name##_bvh_##tree)(tb_bvh_job *job, int mode, int timed, \
                                                                            int null)              \
    {                                                                                               \
        TB_NFN(tb_bvh_loop)(TB_NFN(tb_##name##_test), TB_FN(tb_##name##_ray), tb_##name##_stride, job, \
                            mode, timed, null, wide, TB_NFN(tb_##name##_bvh_packet));               \
    }
#define TB_BVH_ENTRIES(name)                                                                        \
    static __attribute__((noinline)) TB_NTARGET int TB_NFN(tb_##name##_bvh_packet)(                \
        tb_bvh_job *job, size_t i, int n, int mode, int timed, int null, nreal iota, TB_NFN(tb_bvh_tally) * sum) \
    {                                                                                               \
        return TB_NFN(tb_bvh_packet_batch)(TB_NFN(tb_##name##_test), TB_FN(tb_##name##_ray), tb_##name##_stride, \
                                           job, i, n, mode, timed, null, iota, sum);                \
    }                                                                                               \
    TB_BVH_WALK(name, wide, 1)                                                                      \
    TB_BVH_WALK(name, binary, 0)                                                                    \
    TB_BVH_SHARED_ENTRY(name, run_any, TB_ANY, 0, 0, wide)                                          \
    TB_BVH_SHARED_ENTRY(name, run_closest, TB_CLOSEST_UV, 0, 0, wide)                               \
    TB_BVH_ENTRY(name, time_any, TB_ANY, 1, 0)                                                      \
    TB_BVH_ENTRY(name, time_closest, TB_CLOSEST, 1, 0)                                              \
    TB_BVH_ENTRY(name, time_closest_uv, TB_CLOSEST_UV, 1, 0)                                        \
    TB_BVH_ENTRY(name, time_null, TB_CLOSEST, 1, 1)                                                 \
    TB_BVH_SHARED_ENTRY(name, binary_run_any, TB_ANY, 0, 0, binary)                                 \
    TB_BVH_SHARED_ENTRY(name, binary_run_closest, TB_CLOSEST_UV, 0, 0, binary)                      \
    TB_BVH_SHARED_ENTRY(name, binary_time_any, TB_ANY, 1, 0, binary)                                \
    TB_BVH_SHARED_ENTRY(name, binary_time_closest, TB_CLOSEST, 1, 0, binary)                        \
    TB_BVH_SHARED_ENTRY(name, binary_time_closest_uv, TB_CLOSEST_UV, 1, 0, binary)                  \
    TB_BVH_SHARED_ENTRY(name, binary_time_null, TB_CLOSEST, 1, 1, binary)
#define TB_BVH_INSTANTIATE(name, faces, watertight, promised_by, origin, wide) \
    TB_BVH_IF_##wide(TB_BVH_ENTRIES(name))
#define TB_BVH_IF_TB_SCALAR_ONLY(...)
#define TB_BVH_IF_TB_NATIVE(...) __VA_ARGS__
#define TB_BVH_IF_TB_NATIVE_AVX2(...)
#if TB_CAT(TB_EMIT_, TB_NISA) /* as native.h's entry points */
TB_KERNEL_LIST(TB_BVH_INSTANTIATE)
#endif
#undef TB_BVH_IF_TB_NATIVE_AVX2
#undef TB_BVH_IF_TB_NATIVE
#undef TB_BVH_IF_TB_SCALAR_ONLY
#undef TB_BVH_INSTANTIATE
#undef TB_BVH_ENTRIES
#undef TB_BVH_ENTRY
#undef TB_BVH_SHARED_ENTRY
#undef TB_BVH_WALK
