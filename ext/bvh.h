/* A bounding volume hierarchy over a triangle array: binned SAH build and
 * single-ray traversal with a native kernel's block test at the leaves.
 *
 * No include guard: native.h includes this file at its end, once per ISA of
 * each precision. The build and the node layout belong to the precision
 * (first pass, TB_NFIRST; the build is compiled in bvh.c, where it is
 * called); the traversal is compiled per ISA and kernel (isa_<isa>_<p>.c). The
 * job a traversal runs, tb_bvh_job, is in core.h.
 *
 * Build (Wald 2007, "On fast construction of SAH-based bounding volume
 * hierarchies"): top down, each node's triangles binned by centroid into
 * TB_BVH_BINS bins per axis over the centroids' bounds; the split plane
 * between two bins with the least surface-area cost wins. Leaf cost counts
 * blocks of 16 (one native block test, whatever the ISA), not triangles:
 * a 3-triangle leaf costs one block test as a 16-triangle leaf does, so the
 * heuristic fills blocks. A node of at most max_leaf triangles becomes a leaf
 * when that is no dearer than its best split. When binning cannot split
 * (every centroid in one bin: coincident or tightly packed triangles), or the
 * tree reaches TB_BVH_SAH_DEPTH levels, the node is split at the median of
 * its triangles sorted by input index (log depth from there on, and stacked
 * coincident triangles keep input order across leaves). Sequential and
 * deterministic: the same input gives the same tree, bit for bit.
 *
 * Layout: nodes in one flat array, depth first, the left child right after
 * its parent, 8 reals each (32 bytes in float32, 64 in float64):
 *   b[0] = lower corner, b[1] = upper corner of the box (exact min/max of the
 *   stored vertices: no rounding), then two uint32: for an inner node
 *   a = right child, n = 0; for a leaf a = first slot, n = its triangles.
 * A 2-wide tree: its two child boxes are read from two adjacent-or-near
 * nodes; wide (4/8) nodes are the next step (see the report of issue 19).
 * Slots: each leaf starts on a block boundary (a multiple of 16) and takes
 * whole blocks, so its records are the kernel's prepared blocks as brute force
 * uses them, tested with the kernel's own block test. The build writes the
 * input indices in leaf order (order_out); Python maps slots to them.
 *
 * Traversal: see TB_NFN(tb_bvh_loop) below. */

#if TB_NFIRST
#ifndef TB_BVH_BUILD_VERSION
/* Bump when the tree tb_bvh_build makes for the same input changes (the BVH
 * cache, tribench.workloads.bvh_cache, names its files by it). */
#define TB_BVH_BUILD_VERSION 1
#endif
#define TB_BVH_BINS 16
#define TB_BVH_SAH_DEPTH 40 /* then median splits: depth < 40 + 32 for 2^32 triangles */
#define TB_BVH_STACK 80     /* at least the deepest tree the build makes */
#define TB_BVH_NODE_REALS 8
#define tb_bvh_node TB_FN(tb_bvh_node)
typedef struct {
    real b[2][3];
    uint32_t a, n;
#if TB_REAL_IS_DOUBLE
    uint32_t pad[2]; /* 64 bytes: a node never straddles two cache lines */
#endif
} tb_bvh_node;
_Static_assert(sizeof(tb_bvh_node) == TB_BVH_NODE_REALS * sizeof(real), "node size");

/* one triangle during the build: its box and input index */
typedef struct {
    real lo[3], hi[3];
    uint32_t index;
} TB_FN(tb_bvh_item);

typedef struct {
    TB_FN(tb_bvh_item) * items;
    tb_bvh_node *nodes;
    size_t n_nodes, n_slots;
    int max_leaf;
} TB_FN(tb_bvh_builder);

/* SAH costs, in units of one block test: an inner node (two box tests) and
 * a leaf of n triangles */
#define TB_BVH_NODE_COST 1.0
static double TB_FN(tb_bvh_leaf_cost)(size_t n)
{
    return (double)((n + 15) / 16);
}

static double TB_FN(tb_bvh_area)(const double lo[3], const double hi[3])
{
    double x = hi[0] - lo[0], y = hi[1] - lo[1], z = hi[2] - lo[2];
    return x * y + y * z + z * x;
}

/* centroid on an axis, in double: halves first, so no sum overflows */
static inline double TB_FN(tb_bvh_centre)(const TB_FN(tb_bvh_item) * it, int k)
{
    return 0.5 * (double)it->lo[k] + 0.5 * (double)it->hi[k];
}

static inline int TB_FN(tb_bvh_bin)(double c, double c_lo, double scale)
{
    double x = (c - c_lo) * scale; /* >= 0: c >= c_lo, computed alike */
    return x < TB_BVH_BINS - 1 ? (int)x : TB_BVH_BINS - 1;
}

static int TB_FN(tb_bvh_by_index)(const void *a, const void *b)
{
    uint32_t i = ((const TB_FN(tb_bvh_item) *)a)->index, j = ((const TB_FN(tb_bvh_item) *)b)->index;
    return (i > j) - (i < j);
}

/* Builds the subtree of items [begin, end) into node `at`. */
static void TB_FN(tb_bvh_build_node)(TB_FN(tb_bvh_builder) * bld, size_t at, size_t begin, size_t end, int depth)
{
    TB_FN(tb_bvh_item) *items = bld->items;
    tb_bvh_node *node = &bld->nodes[at];
    size_t n = end - begin;
    memset(node, 0, sizeof *node); /* the padding too: the same tree, bit for bit */
    double c_lo[3] = {INFINITY, INFINITY, INFINITY}, c_hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (int k = 0; k < 3; ++k) {
        node->b[0][k] = items[begin].lo[k];
        node->b[1][k] = items[begin].hi[k];
    }
    for (size_t i = begin; i < end; ++i)
        for (int k = 0; k < 3; ++k) {
            node->b[0][k] = items[i].lo[k] < node->b[0][k] ? items[i].lo[k] : node->b[0][k];
            node->b[1][k] = items[i].hi[k] > node->b[1][k] ? items[i].hi[k] : node->b[1][k];
            double c = TB_FN(tb_bvh_centre)(&items[i], k);
            c_lo[k] = c < c_lo[k] ? c : c_lo[k];
            c_hi[k] = c > c_hi[k] ? c : c_hi[k];
        }

    /* the best binned split: axis, and the first bin of the right side */
    int best_axis = -1, best_bin = 0;
    double best_cost = INFINITY, scale[3] = {0, 0, 0};
    if (n > 1 && depth < TB_BVH_SAH_DEPTH) {
        size_t count[3][TB_BVH_BINS] = {{0}};
        double lo[3][TB_BVH_BINS][3], hi[3][TB_BVH_BINS][3];
        for (int k = 0; k < 3; ++k) {
            double extent = c_hi[k] - c_lo[k];
            if (extent > 0 && isfinite(TB_BVH_BINS * (1 - 1e-9) / extent))
                scale[k] = TB_BVH_BINS * (1 - 1e-9) / extent;
            for (int b = 0; b < TB_BVH_BINS; ++b)
                for (int j = 0; j < 3; ++j) {
                    lo[k][b][j] = INFINITY;
                    hi[k][b][j] = -INFINITY;
                }
        }
        for (size_t i = begin; i < end; ++i)
            for (int k = 0; k < 3; ++k) {
                if (scale[k] == 0)
                    continue;
                int b = TB_FN(tb_bvh_bin)(TB_FN(tb_bvh_centre)(&items[i], k), c_lo[k], scale[k]);
                ++count[k][b];
                for (int j = 0; j < 3; ++j) {
                    lo[k][b][j] = items[i].lo[j] < lo[k][b][j] ? items[i].lo[j] : lo[k][b][j];
                    hi[k][b][j] = items[i].hi[j] > hi[k][b][j] ? items[i].hi[j] : hi[k][b][j];
                }
            }
        for (int k = 0; k < 3; ++k) {
            if (scale[k] == 0)
                continue;
            /* sweep from the right: area and count of bins b.. */
            double right_area[TB_BVH_BINS];
            size_t right_count[TB_BVH_BINS];
            double r_lo[3] = {INFINITY, INFINITY, INFINITY}, r_hi[3] = {-INFINITY, -INFINITY, -INFINITY};
            size_t r_n = 0;
            for (int b = TB_BVH_BINS - 1; b > 0; --b) {
                for (int j = 0; j < 3; ++j) {
                    r_lo[j] = lo[k][b][j] < r_lo[j] ? lo[k][b][j] : r_lo[j];
                    r_hi[j] = hi[k][b][j] > r_hi[j] ? hi[k][b][j] : r_hi[j];
                }
                r_n += count[k][b];
                right_area[b] = r_n ? TB_FN(tb_bvh_area)(r_lo, r_hi) : 0;
                right_count[b] = r_n;
            }
            double l_lo[3] = {INFINITY, INFINITY, INFINITY}, l_hi[3] = {-INFINITY, -INFINITY, -INFINITY};
            size_t l_n = 0;
            for (int b = 1; b < TB_BVH_BINS; ++b) {
                for (int j = 0; j < 3; ++j) {
                    l_lo[j] = lo[k][b - 1][j] < l_lo[j] ? lo[k][b - 1][j] : l_lo[j];
                    l_hi[j] = hi[k][b - 1][j] > l_hi[j] ? hi[k][b - 1][j] : l_hi[j];
                }
                l_n += count[k][b - 1];
                if (l_n == 0 || right_count[b] == 0)
                    continue;
                double cost = TB_FN(tb_bvh_area)(l_lo, l_hi) * TB_FN(tb_bvh_leaf_cost)(l_n) +
                              right_area[b] * TB_FN(tb_bvh_leaf_cost)(right_count[b]);
                if (cost < best_cost) { /* strict: ties to the lower axis and bin */
                    best_cost = cost;
                    best_axis = k;
                    best_bin = b;
                }
            }
        }
    }

    /* a leaf: small enough and no dearer than splitting (areas relative to the node's) */
    double lo_d[3], hi_d[3];
    for (int k = 0; k < 3; ++k) {
        lo_d[k] = node->b[0][k];
        hi_d[k] = node->b[1][k];
    }
    double area = TB_FN(tb_bvh_area)(lo_d, hi_d);
    int make_leaf = n <= (size_t)bld->max_leaf &&
                    (best_axis < 0 || !(area > 0) ||
                     TB_FN(tb_bvh_leaf_cost)(n) <= TB_BVH_NODE_COST + best_cost / area);
    if (make_leaf) {
        node->a = (uint32_t)bld->n_slots;
        node->n = (uint32_t)n;
        bld->n_slots += (n + 15) / 16 * 16;
        return;
    }
    size_t mid;
    if (best_axis >= 0) { /* partition by bin: the same arithmetic as the binning */
        size_t i = begin, j = end;
        while (i < j) {
            if (TB_FN(tb_bvh_bin)(TB_FN(tb_bvh_centre)(&items[i], best_axis), c_lo[best_axis],
                                  scale[best_axis]) < best_bin)
                ++i;
            else {
                TB_FN(tb_bvh_item) tmp = items[i];
                items[i] = items[--j];
                items[j] = tmp;
            }
        }
        mid = i;
    } else { /* no binned split: the median by input index */
        qsort(items + begin, n, sizeof *items, TB_FN(tb_bvh_by_index));
        mid = begin + n / 2;
    }
    size_t left = bld->n_nodes++; /* at + 1: depth first, left child next */
    TB_FN(tb_bvh_build_node)(bld, left, begin, mid, depth + 1);
    size_t right = bld->n_nodes++; /* after the whole left subtree */
    node->a = (uint32_t)right;
    node->n = 0;
    TB_FN(tb_bvh_build_node)(bld, right, mid, end, depth + 1);
}
#endif /* TB_NFIRST */

#if TB_NFIRST
/* The tree of n triangles (9 reals each, finite; n < 2^32): nodes (room for
 * 2n - 1), and order_out, the n input indices in leaf order. Returns 0, or -1
 * when out of memory. */
static int TB_FN(tb_bvh_build)(const real *vertices, size_t n, int max_leaf, tb_bvh_node *nodes,
                               int64_t *order_out, size_t *n_nodes, size_t *n_slots)
{
    TB_FN(tb_bvh_item) *items = malloc(n * sizeof *items);
    if (!items)
        return -1;
    for (size_t i = 0; i < n; ++i) {
        const real *v = vertices + 9 * i;
        for (int k = 0; k < 3; ++k) {
            real lo = v[k], hi = v[k];
            for (int j = 1; j < 3; ++j) {
                lo = v[3 * j + k] < lo ? v[3 * j + k] : lo;
                hi = v[3 * j + k] > hi ? v[3 * j + k] : hi;
            }
            items[i].lo[k] = lo;
            items[i].hi[k] = hi;
        }
        items[i].index = (uint32_t)i;
    }
    TB_FN(tb_bvh_builder) bld = {items, nodes, 1, 0, max_leaf};
    TB_FN(tb_bvh_build_node)(&bld, 0, 0, n, 0);
    for (size_t i = 0; i < n; ++i)
        order_out[i] = items[i].index;
    free(items);
    *n_nodes = bld.n_nodes;
    *n_slots = bld.n_slots;
    return 0;
}

static int TB_FN(tb_bvh_box_in)(const tb_bvh_node *inner, const tb_bvh_node *outer)
{
    for (int k = 0; k < 3; ++k)
        if (!(inner->b[0][k] >= outer->b[0][k] && inner->b[1][k] <= outer->b[1][k]))
            return 0;
    return 1;
}

/* Checks a tree that comes from outside (the cache) before any traversal
 * may follow it: every invariant tb_bvh_build gives, so that a tree this
 * accepts is one the build could have made over these n triangles, up to
 * the SAH's choices. Nodes in depth-first order, the left child next and the
 * right child after the left subtree, every node reached once; no inner node
 * as deep as the traversal's stack; boxes finite, lower <= upper, each inside
 * its parent's; leaves of 1..max_leaf triangles on consecutive whole blocks
 * of 16 slots covering n_slots; each slot of a leaf names a triangle (every
 * triangle exactly once) whose vertices lie in the leaf's box; padding slots
 * -1. Returns NULL when the tree is sound, else the first fault found, with
 * the node (or slot) it was found at in *where; "" when out of memory. */
static const char *TB_FN(tb_bvh_check)(const tb_bvh_node *nodes, size_t n_nodes, const int64_t *perm,
                                       size_t n_slots, const real *vertices, size_t n, int max_leaf, size_t *where)
{
    unsigned char *seen = calloc(n, 1);
    if (!seen)
        return "";
    const char *fault = NULL;
    size_t next = 0, slot_end = 0, placed = 0, sp = 0, node = 0, depth = 0;
    size_t stack[TB_BVH_STACK], stack_depth[TB_BVH_STACK];
    for (;;) {
        const tb_bvh_node *nd = &nodes[node];
        *where = node;
        if (node != next) {
            fault = "nodes are not in depth-first order (a right child must follow its left subtree)";
            break;
        }
        ++next;
        for (int k = 0; k < 3 && !fault; ++k)
            if (!(isfinite(nd->b[0][k]) && isfinite(nd->b[1][k]) && nd->b[0][k] <= nd->b[1][k]))
                fault = "a box is not finite with its lower corner below its upper";
        if (fault)
            break;
        if (nd->n == 0) { /* inner */
            size_t left = node + 1, right = nd->a;
            if (left >= n_nodes || right <= left || right >= n_nodes) {
                fault = "an inner node's children are out of range";
                break;
            }
            if (depth + 1 >= TB_BVH_STACK) {
                fault = "the tree is deeper than the traversal's stack";
                break;
            }
            if (!TB_FN(tb_bvh_box_in)(&nodes[left], nd) || !TB_FN(tb_bvh_box_in)(&nodes[right], nd)) {
                fault = "a child's box is not inside its parent's";
                break;
            }
            stack[sp] = right;
            stack_depth[sp++] = depth + 1;
            node = left;
            ++depth;
            continue;
        }
        /* a leaf */
        size_t first = nd->a, count = nd->n, end = first + (count + 15) / 16 * 16;
        if (count > (size_t)max_leaf) {
            fault = "a leaf holds more triangles than max_leaf";
            break;
        }
        if (first != slot_end || first > n_slots || end > n_slots) {
            fault = "leaves are not on consecutive whole blocks of 16 slots";
            break;
        }
        for (size_t s = first; s < end && !fault; ++s) {
            int64_t index = perm[s];
            *where = s;
            if (s >= first + count) {
                if (index != -1)
                    fault = "a padding slot names a triangle (it must be -1)";
                continue;
            }
            if (index < 0 || (uint64_t)index >= n)
                fault = "a slot names no triangle";
            else if (seen[index])
                fault = "a triangle is in two slots";
            else {
                seen[index] = 1;
                ++placed;
                const real *v = vertices + 9 * (size_t)index;
                for (int j = 0; j < 9 && !fault; ++j)
                    if (!(v[j] >= nd->b[0][j % 3] && v[j] <= nd->b[1][j % 3]))
                        fault = "a triangle lies outside its leaf's box";
            }
        }
        if (fault)
            break;
        slot_end = end;
        if (sp == 0)
            break;
        node = stack[--sp];
        depth = stack_depth[sp];
    }
    if (!fault && next != n_nodes) {
        *where = next;
        fault = "nodes are left over after the tree";
    }
    if (!fault && (slot_end != n_slots || placed != n)) {
        *where = slot_end;
        fault = "the leaves do not hold every triangle in exactly n_slots slots";
    }
    free(seen);
    return fault;
}

#endif /* TB_NFIRST */

/* Slab test of the ray against one node's box, within [0, t_max] (Ize 2013,
 * "Robust BVH ray traversal"). inv = 1 / d per axis, so d = +-0 gives +-inf
 * and the slab's entry and exit are +-inf: a ray parallel to a slab is inside
 * it for all t or for none, as it should be (Williams et al. 2005). The one
 * NaN is 0 x inf, the origin exactly on a slab plane with d parallel to it:
 * the comparisons are written so a NaN never replaces the running value
 * (x > t0 ? x : t0 is false for NaN), so that slab is ignored, which keeps
 * the ray (a conservative answer, never a lost hit). Rounding: (b - o) * inv
 * is within 2 rounding errors of the exact entry or exit; scaling every exit
 * by 1 + 4 eps (more than Ize's 1 + 2 gamma_3) keeps an exit computed too
 * early from dropping a box the exact ray meets, flat boxes of axis-aligned
 * triangles included. Non-finite rays never get here (they miss). Returns
 * whether the box is met, and its entry distance in *t_in. */
TB_NWIDE int TB_NFN(tb_bvh_box)(const tb_bvh_node *node, const real o[3], const real inv[3],
                                const int near[3], real t_max, real *t_in)
{
    const real grow = (real)1 + 4 * (TB_REAL_IS_DOUBLE ? DBL_EPSILON : FLT_EPSILON);
    real t0 = 0, t1 = t_max;
    for (int k = 0; k < 3; ++k) {
        real enter = (node->b[near[k]][k] - o[k]) * inv[k];
        real leave = (node->b[1 - near[k]][k] - o[k]) * inv[k] * grow;
        t0 = enter > t0 ? enter : t0;
        t1 = leave < t1 ? leave : t1;
    }
    *t_in = t0;
    return t0 <= t1;
}

/* One batch of BVH traversal with a native kernel's block test at the leaves.
 *
 * Per ray: the root's box, then depth first from the root: at an inner node
 * both children's boxes are tested, the nearer (by entry distance, ties to
 * the left) is entered next and the farther pushed with its entry distance;
 * a popped node whose entry lies beyond the closest hit so far is skipped.
 * At a leaf, each vector's worth of its blocks goes through the kernel's test
 * with the closest hit so far as t_max, and the loop divides as native.h's
 * does. The closest hit is the smallest t; equal t (coincident triangles)
 * goes to the lowest input index, as brute force does. The kernel is told
 * t_max slightly above the best t (1 + 4 eps) so an equal t reaches that
 * comparison; hits with t >= the ray's own t_max never count. Mode any stops
 * at the first hit. Non-finite rays (NaN or Inf in o or d) miss at once.
 *
 * Counts: nodes visited (inner nodes and leaves entered), box tests (the
 * root's, none for a non-finite ray, and two per inner node), leaves, triangle tests (the leaf's
 * triangles, not its padding lanes). With `null`, the leaf test is replaced
 * by a compiler barrier on the leaf's records (no load, no arithmetic): the
 * same traversal order, but nothing is ever hit, so no interval shrinks; run
 * it with each ray's t_max at its closest hit to traverse as a ray that found
 * its hit at once (the counts say how the two traversals differ). */
TB_NWIDE void TB_NFN(tb_bvh_loop)(TB_NFN(tb_native_fn) test, TB_FN(tb_ray_fn) make_ray, size_t stride,
                                  tb_bvh_job *job, const int mode, const int timed, const int null)
{
    tb_job *base = &job->base;
    const real *o = base->origins, *d = base->directions, *rec = base->records, *t_max = base->t_max;
    const tb_bvh_node *nodes = job->nodes;
    const int64_t *perm = job->perm;
    const size_t n_nodes = job->n_nodes, n_slots = job->n_slots;
    const real grow = (real)1 + 4 * (TB_REAL_IS_DOUBLE ? DBL_EPSILON : FLT_EPSILON);
    real lane[TB_NL];
    for (int l = 0; l < TB_NL; ++l)
        lane[l] = (real)l;
    const nreal iota = nv_load(lane), zero = nv_set1(0), one = nv_set1(1), nan = nv_set1((real)NAN);
    uint64_t hits = 0, rays = 0, poll_at = 1, sums[4] = {0, 0, 0, 0};
    double t_sum = 0, uv_sum = 0;
    const uint64_t loops = timed ? base->loops : 1;
    for (uint64_t pass = 0; pass < loops; ++pass)
        for (size_t i = 0; i < base->n_rays; ++i) {
            if (++rays == poll_at && !(poll_at = tb_poll(base, rays)))
                goto stop;
            tb_ray sr;
            make_ray(o + 3 * i, d + 3 * i, &sr);
            const tb_nray r = TB_NFN(tb_nray_of)(&sr);
            real org[3], inv[3];
            int near[3], finite = 1;
            for (int k = 0; k < 3; ++k) {
                finite &= isfinite(sr.o[k]) && isfinite(sr.d[k]);
                org[k] = sr.o[k];
                inv[k] = 1 / sr.d[k];
                near[k] = signbit(inv[k]) ? 1 : 0;
            }
            real best_t = t_max[i], best_u = (real)NAN, best_v = (real)NAN, t_in;
            int64_t best_slot = -1, best_index = -1;
            nreal filter = nv_set1(best_t); /* the kernel's t_max */
            uint64_t visited = 0, boxes = finite, leaves = 0, tris = 0;
            size_t node = 0, sp = 0, stack[TB_BVH_STACK];
            real stack_t[TB_BVH_STACK];
            if (!finite || !TB_NFN(tb_bvh_box)(&nodes[0], org, inv, near, best_t, &t_in))
                goto ray_done;
            for (;;) {
                const tb_bvh_node *nd = &nodes[node];
                ++visited;
                if (nd->n == 0) { /* inner: test both children */
                    size_t left = node + 1, right = nd->a;
                    if (right <= left || right >= n_nodes) {
                        job->bad_tree = 1;
                        goto stop;
                    }
                    real t_left, t_right;
                    int hit_left = TB_NFN(tb_bvh_box)(&nodes[left], org, inv, near, best_t, &t_left);
                    int hit_right = TB_NFN(tb_bvh_box)(&nodes[right], org, inv, near, best_t, &t_right);
                    boxes += 2;
                    if (hit_left && hit_right) {
                        if (sp == TB_BVH_STACK) {
                            job->bad_tree = 1;
                            goto stop;
                        }
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
                } else { /* a leaf: its blocks through the kernel */
                    const size_t first = nd->a, count = nd->n;
                    if (first % 16 || first > n_slots || count > n_slots - first) {
                        job->bad_tree = 1;
                        goto stop;
                    }
                    ++leaves;
                    tris += count;
                    if (null) {
                        __asm__ volatile("" : : "r"(rec + stride * first) : "memory");
                    } else {
                        for (size_t at = 0; at < count; at += TB_NL) {
                            const size_t slot = first + at;
                            tb_nhit h;
                            h.uv_den_set = 0;
                            nmask m = test(&r, rec + stride * (slot - slot % 16) + slot % 16, filter, &h);
                            if (!nm_any(m))
                                continue;
                            if (count - at < (size_t)TB_NL) /* lanes past the leaf's last triangle */
                                m = nm_and(m, nv_lt(iota, nv_set1((real)(count - at))));
                            nreal inv_den = one / h.den, t = h.t * inv_den;
                            m = nm_and(m, nm_and(nv_gt(t, zero), nv_le(t, nv_set1(best_t))));
                            if (!nm_any(m))
                                continue;
                            real ts[TB_NL], us[TB_NL], vs[TB_NL];
                            nreal t_sel = nv_select(m, t, nan);
                            memcpy(ts, &t_sel, sizeof ts);
                            if (mode == TB_CLOSEST_UV || !timed) {
                                const nreal inv_uv = TB_NFN(tb_nhit_uv_inv)(&h, inv_den);
                                const nreal u = h.u * inv_uv, v = h.v * inv_uv;
                                memcpy(us, &u, sizeof us);
                                memcpy(vs, &v, sizeof vs);
                            }
                            for (int l = 0; l < TB_NL; ++l) {
                                if (!(ts[l] <= best_t)) /* not a candidate (NaN), or beaten by an earlier lane */
                                    continue;
                                int64_t index = perm[slot + l];
                                if (ts[l] < best_t || (best_slot >= 0 && index < best_index)) {
                                    best_t = ts[l];
                                    best_slot = (int64_t)(slot + l);
                                    best_index = index;
                                    if (mode == TB_CLOSEST_UV || !timed) {
                                        best_u = us[l];
                                        best_v = vs[l];
                                    }
                                    if (mode == TB_ANY)
                                        break;
                                }
                            }
                            if (mode == TB_ANY && best_slot >= 0)
                                break;
                            filter = nv_set1(best_t * grow);
                        }
                        if (mode == TB_ANY && best_slot >= 0)
                            goto ray_done;
                    }
                }
                do { /* the next pushed node still in reach */
                    if (sp == 0)
                        goto ray_done;
                    --sp;
                } while (!(stack_t[sp] <= best_t));
                node = stack[sp];
            }
        ray_done:
            if (timed) {
                if (best_slot >= 0) {
                    ++hits;
                    t_sum += best_t;
                    if (mode == TB_CLOSEST_UV)
                        uv_sum += (double)best_u + best_v;
                }
                sums[0] += visited;
                sums[1] += boxes;
                sums[2] += leaves;
                sums[3] += tris;
            } else {
                real *t_out = base->t_out, *u_out = base->u_out, *v_out = base->v_out;
                int64_t *c = job->counts_out + 4 * i;
                base->index_out[i] = best_index;
                t_out[i] = best_slot >= 0 ? best_t : (real)NAN;
                u_out[i] = best_slot >= 0 ? best_u : (real)NAN;
                v_out[i] = best_slot >= 0 ? best_v : (real)NAN;
                c[0] = (int64_t)visited;
                c[1] = (int64_t)boxes;
                c[2] = (int64_t)leaves;
                c[3] = (int64_t)tris;
            }
        }
stop:
    base->hits = hits;
    base->tests = sums[3];
    base->t_sum = t_sum;
    base->uv_sum = uv_sum;
    memcpy(job->counts, sums, sizeof sums);
}

/* Entry points of one native kernel's BVH traversal for this ISA; only the
 * TB_NATIVE kernels of the public list (one line each, from list.h). */
#define TB_BVH_ENTRY(name, fn_mode, mode, timed, null)                                              \
    TB_NTARGET TB_HIDDEN void TB_NFN(tb_##name##_bvh_##fn_mode)(tb_bvh_job *job)                    \
    {                                                                                               \
        TB_NFN(tb_bvh_loop)(TB_NFN(tb_##name##_test), TB_FN(tb_##name##_ray), tb_##name##_stride, job, \
                            mode, timed, null);                                                     \
    }
#define TB_BVH_ENTRIES(name)                                  \
    TB_BVH_ENTRY(name, run_any, TB_ANY, 0, 0)                 \
    TB_BVH_ENTRY(name, run_closest, TB_CLOSEST_UV, 0, 0)      \
    TB_BVH_ENTRY(name, time_any, TB_ANY, 1, 0)                \
    TB_BVH_ENTRY(name, time_closest, TB_CLOSEST, 1, 0)        \
    TB_BVH_ENTRY(name, time_closest_uv, TB_CLOSEST_UV, 1, 0)  \
    TB_BVH_ENTRY(name, time_null, TB_CLOSEST, 1, 1)
#define TB_BVH_INSTANTIATE(name, faces, watertight, promised_by, origin, wide) \
    TB_BVH_IF_##wide(TB_BVH_ENTRIES(name))
#define TB_BVH_IF_TB_SCALAR_ONLY(...)
#define TB_BVH_IF_TB_X8(...)
#define TB_BVH_IF_TB_NATIVE(...) __VA_ARGS__
#define TB_BVH_IF_TB_NATIVE_AVX2(...)
#if TB_CAT(TB_EMIT_, TB_NISA) /* as native.h's entry points */
TB_KERNEL_LIST(TB_BVH_INSTANTIATE)
#endif
#undef TB_BVH_IF_TB_NATIVE_AVX2
#undef TB_BVH_IF_TB_NATIVE
#undef TB_BVH_IF_TB_X8
#undef TB_BVH_IF_TB_SCALAR_ONLY
#undef TB_BVH_INSTANTIATE
#undef TB_BVH_ENTRIES
#undef TB_BVH_ENTRY
