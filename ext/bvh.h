/* A bounding volume hierarchy over a triangle array: binned SAH build, its
 * collapse into a wide tree, and single-ray traversal of either with a native
 * kernel's block test at the leaves.
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
 * This binary tree is what is built, cached and checked; the traversal
 * the library runs by default walks the wide tree collapsed from it (below).
 * Slots: each leaf starts on a block boundary (a multiple of 16) and takes
 * whole blocks, so its records are the kernel's prepared blocks as brute force
 * uses them, tested with the kernel's own block test. The build writes the
 * input indices in leaf order (order_out); Python maps slots to them.
 *
 * Traversal: see TB_NFN(tb_bvh_loop) below; the wide tree's is 1.3-1.5x
 * faster than the binary one's (docs/decisions.md, "Wide BVH"). */

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

/* The wide tree (Wald et al. 2008, "Getting rid of packets: efficient SIMD
 * single-ray traversal using multi-branching BVHs"; Dammertz et al. 2008,
 * "Shallow bounding volume hierarchies for fast SIMD ray tracing of
 * incoherent rays"), derived from the binary tree above, which stays what is
 * built, cached and checked: the wide tree is a pure function of a sound
 * binary tree, so it needs no check of its own. TB_BVH_WIDTH children per
 * node, one 32-byte vector per box plane (8 floats, 4 doubles: one AVX
 * register), 256 bytes a node. b[2k] and b[2k + 1] are the children's lower
 * and upper planes on axis k; a child is inner (a = its wide node, n = 0), a
 * leaf (a = first slot, n = its triangles, as in the binary tree) or empty
 * (a = n = 0 with an empty box, lower +inf and upper -inf, which no finite
 * ray enters). Nodes depth first, every child after its parent. */
#define TB_BVH_WIDTH ((int)(32 / sizeof(real)))
#define TB_BVH_WIDE_BYTES 256
#define tb_bvh_wide TB_FN(tb_bvh_wide)
typedef struct {
    real b[6][32 / sizeof(real)];
    uint32_t a[32 / sizeof(real)], n[32 / sizeof(real)];
#if TB_REAL_IS_DOUBLE
    uint32_t pad[8];
#endif
} tb_bvh_wide;
_Static_assert(sizeof(tb_bvh_wide) == TB_BVH_WIDE_BYTES, "wide node size");

static double TB_FN(tb_bvh_node_area)(const tb_bvh_node *nd)
{
    double lo[3], hi[3];
    for (int k = 0; k < 3; ++k) {
        lo[k] = nd->b[0][k];
        hi[k] = nd->b[1][k];
    }
    return TB_FN(tb_bvh_area)(lo, hi);
}

/* Collapses binary node `at` and the inner nodes below it into one wide
 * node: its children start as the binary node's two, and the inner child of
 * the largest surface area is opened (replaced by its two children, in
 * place, so siblings stay in the binary tree's order) until there are
 * TB_BVH_WIDTH or only leaves; then each inner child becomes a wide node of
 * its own. The greedy rule is Wald's and Embree's: the largest boxes are the
 * likeliest to be entered, so they are the ones worth testing side by side.
 * Returns the wide node's index, or (size_t)-1 if the binary tree is
 * malformed or deeper than the stack (the caller raises). */
static size_t TB_FN(tb_bvh_widen_node)(const tb_bvh_node *bin, size_t n_bin, size_t at, int depth,
                                       tb_bvh_wide *wide, size_t cap, size_t *n_wide)
{
    if (*n_wide >= cap || depth >= TB_BVH_STACK)
        return (size_t)-1;
    size_t me = (*n_wide)++, kids[32 / sizeof(real)];
    int n_kids = 1;
    kids[0] = at;
    for (;;) {
        int open = -1;
        double open_area = -1;
        for (int i = 0; i < n_kids; ++i)
            if (bin[kids[i]].n == 0 && TB_FN(tb_bvh_node_area)(&bin[kids[i]]) > open_area) {
                open = i;
                open_area = TB_FN(tb_bvh_node_area)(&bin[kids[i]]);
            }
        if (open < 0)
            break;
        size_t node = kids[open], left = node + 1, right = bin[node].a;
        if (right <= left || right >= n_bin)
            return (size_t)-1;
        memmove(&kids[open + 2], &kids[open + 1], (size_t)(n_kids - open - 1) * sizeof *kids);
        kids[open] = left;
        kids[open + 1] = right;
        if (++n_kids == TB_BVH_WIDTH)
            break;
    }
    tb_bvh_wide *w = &wide[me];
    memset(w, 0, sizeof *w);
    for (int i = 0; i < TB_BVH_WIDTH; ++i)
        for (int k = 0; k < 3; ++k) {
            w->b[2 * k][i] = i < n_kids ? bin[kids[i]].b[0][k] : (real)INFINITY;
            w->b[2 * k + 1][i] = i < n_kids ? bin[kids[i]].b[1][k] : -(real)INFINITY;
        }
    for (int i = 0; i < n_kids; ++i) {
        const tb_bvh_node *kid = &bin[kids[i]];
        if (kid->n) { /* a leaf: the binary tree's own */
            w->a[i] = kid->a;
            w->n[i] = kid->n;
            continue;
        }
        size_t sub = TB_FN(tb_bvh_widen_node)(bin, n_bin, kids[i], depth + 1, wide, cap, n_wide);
        if (sub == (size_t)-1)
            return sub;
        w->a[i] = (uint32_t)sub;
    }
    return me;
}

/* The wide tree of a sound binary tree of n_bin nodes into `wide` (room for
 * cap nodes: (n_bin - 1) / 2 + 1 always suffice, as every wide node but a
 * lone leaf's consumes an inner node). Returns the wide nodes' count, or 0
 * when the binary tree is malformed. */
static size_t TB_FN(tb_bvh_widen)(const tb_bvh_node *bin, size_t n_bin, tb_bvh_wide *wide, size_t cap)
{
    size_t n_wide = 0;
    if (n_bin == 0 || TB_FN(tb_bvh_widen_node)(bin, n_bin, 0, 0, wide, cap, &n_wide) == (size_t)-1)
        return 0;
    return n_wide;
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
 * (+inf, -inf) is missed by every finite ray. rows: the ray's entry and
 * exit plane per axis (tb_bvh_trace_wide), so that a node's loads need no
 * arithmetic on the ray's signs. Returns the bits of the
 * children met, and their entry distances in *t_in. */
#if TB_NISA_ID >= 1 && !TB_REAL_IS_DOUBLE
#define tb_wv_max(a, b) _mm256_max_ps(a, b)
#define tb_wv_min(a, b) _mm256_min_ps(a, b)
#define tb_wv_le_bits(a, b) ((unsigned)_mm256_movemask_ps(_mm256_cmp_ps(a, b, _CMP_LE_OQ)))
#elif TB_NISA_ID >= 1
#define tb_wv_max(a, b) _mm256_max_pd(a, b)
#define tb_wv_min(a, b) _mm256_min_pd(a, b)
#define tb_wv_le_bits(a, b) ((unsigned)_mm256_movemask_pd(_mm256_cmp_pd(a, b, _CMP_LE_OQ)))
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
TB_NWIDE unsigned TB_NFN(tb_bvh_wide_box)(const tb_bvh_wide *w, const vreal org[3], const vreal inv[3],
                                          const vreal inv_far[3], const int rows[6], real t_max, vreal *t_in)
{
    vreal t0 = (vreal){0}, t1 = t_max + (vreal){0};
    for (int k = 0; k < 3; ++k) {
        vreal enter, leave;
        memcpy(&enter, w->b[rows[2 * k]], sizeof enter);
        memcpy(&leave, w->b[rows[2 * k + 1]], sizeof leave);
        t0 = tb_wv_max((enter - org[k]) * inv[k], t0);
        t1 = tb_wv_min((leave - org[k]) * inv_far[k], t1);
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
    vreal org[3], inv[3], inv_far[3];
    int rows[6];
    for (int k = 0; k < 3; ++k) {
        org[k] = ray->org[k] + (vreal){0};
        inv[k] = ray->inv[k] + (vreal){0};
        inv_far[k] = ray->inv_far[k] + (vreal){0};
        rows[2 * k] = 2 * k + ray->near[k];
        rows[2 * k + 1] = 2 * k + 1 - ray->near[k];
    }
    uint32_t a = 0, n = 0; /* the root, wide node 0 */
    for (;;) {
        if (n == 0) {
            const tb_bvh_wide *w = &nodes[a];
            vreal t_in;
            unsigned met = TB_NFN(tb_bvh_wide_box)(w, org, inv, inv_far, rows, b->t, &t_in);
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
                        __builtin_prefetch(&nodes[e.a]);
                    else if (e.a < job->n_slots) /* a leaf's first block: a line per field */
                        for (size_t f = 0; f < stride; ++f)
                            __builtin_prefetch((const real *)job->base.records + stride * e.a + 16 * f);
                    for (; j > 0 && kids[j - 1].t <= e.t; --j)
                        kids[j] = kids[j - 1];
                    kids[j] = e;
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

/* A traced ray's answer: its outputs (untimed), or the batch's sums. */
TB_NWIDE void TB_NFN(tb_bvh_record)(tb_bvh_job *job, size_t i, const TB_NFN(tb_bvh_best) * b, const uint64_t c[4],
                                    int mode, int timed, uint64_t *hits, double *t_sum, double *uv_sum, uint64_t sums[4])
{
    tb_job *base = &job->base;
    if (timed) {
        if (b->slot >= 0) {
            const int64_t index = job->perm[b->slot]; /* what the untimed call returns, loaded as it is */
            __asm__ volatile("" : : "r"(index));
            ++*hits;
            *t_sum += b->t;
            if (mode == TB_CLOSEST_UV)
                *uv_sum += (double)b->u + b->v;
        }
        for (int k = 0; k < 4; ++k)
            sums[k] += c[k];
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

/* One batch of BVH traversal with a native kernel's block test at the
 * leaves, on the binary tree, the wide one, or the wide one by packets
 * (`walk`: 0, 1, 2, a constant in each entry point): a packet is the
 * consecutive rays, up to TB_BVH_PACKET, that share the first one's origin
 * (bvh_packet.h); a ray alone is traced alone. Non-finite rays (NaN or Inf
 * in o or d) miss at once. Mode any stops at the first hit.
 *
 * Counts per ray: nodes visited (inner nodes and leaves entered), box tests,
 * leaves, triangle tests (the leaf's triangles, not its padding lanes). With
 * `null`, the leaf test is replaced by a compiler barrier on the leaf's
 * records (no load, no arithmetic): the same traversal order, but nothing is
 * ever hit, so no interval shrinks; run it with each ray's t_max at its
 * closest hit to traverse as a ray that found its hit at once (the counts
 * say how the two traversals differ). */
TB_NWIDE void TB_NFN(tb_bvh_loop)(TB_NFN(tb_native_fn) test, TB_FN(tb_ray_fn) make_ray, size_t stride,
                                  tb_bvh_job *job, const int mode, const int timed, const int null, const int walk,
                                  TB_NFN(tb_bvh_packet_fn) trace_packet)
{
    tb_job *base = &job->base;
    const real *o = base->origins, *d = base->directions, *t_max = base->t_max;
    real lane[TB_NL];
    for (int l = 0; l < TB_NL; ++l)
        lane[l] = (real)l;
    const nreal iota = nv_load(lane);
    uint64_t hits = 0, rays = 0, poll_at = 1, sums[4] = {0, 0, 0, 0};
    double t_sum = 0, uv_sum = 0;
    const uint64_t loops = timed ? base->loops : 1;
    for (uint64_t pass = 0; pass < loops; ++pass)
        for (size_t i = 0; i < base->n_rays;) {
            /* a packet: up to TB_BVH_PACKET rays from one origin, traced out of line; else one ray */
            int n = 1;
            const size_t left = base->n_rays - i, most = walk == 2 && left > TB_BVH_PACKET ? TB_BVH_PACKET : left;
            for (const real *a = o + 3 * i, *x = a + 3; walk == 2 && (size_t)n < most; ++n, x += 3)
                if (!(x[0] == a[0] && x[1] == a[1] && x[2] == a[2]))
                    break;
            if ((rays += (uint64_t)n) >= poll_at && !(poll_at = tb_poll(base, rays)))
                goto stop;
            if (n > 1) {
                TB_NFN(tb_bvh_ray) ray[TB_BVH_PACKET];
                TB_NFN(tb_bvh_best) b[TB_BVH_PACKET];
                uint64_t c[TB_BVH_PACKET][4];
                memset(c, 0, (size_t)n * sizeof *c);
                for (int r = 0; r < n; ++r) {
                    TB_NFN(tb_bvh_ray_of)(make_ray, o + 3 * (i + r), d + 3 * (i + r), &ray[r]);
                    b[r] = (TB_NFN(tb_bvh_best)){t_max[i + r], (real)NAN, (real)NAN, -1, nv_set1(t_max[i + r])};
                }
                if (!trace_packet(job, ray, n, iota, b, c)) {
                    job->bad_tree = 1;
                    goto stop;
                }
                for (int r = 0; r < n; ++r)
                    TB_NFN(tb_bvh_record)(job, i + r, &b[r], c[r], mode, timed, &hits, &t_sum, &uv_sum, sums);
                i += (size_t)n;
                continue;
            }
            TB_NFN(tb_bvh_ray) ray;
            TB_NFN(tb_bvh_ray_of)(make_ray, o + 3 * i, d + 3 * i, &ray);
            TB_NFN(tb_bvh_best) b = {t_max[i], (real)NAN, (real)NAN, -1, nv_set1(t_max[i])};
            uint64_t c[4] = {0, 0, 0, 0};
            int sound = walk ? TB_NFN(tb_bvh_trace_wide)(test, stride, job, &ray, mode, timed, null, iota, &b, c)
                             : TB_NFN(tb_bvh_trace_binary)(test, stride, job, &ray, mode, timed, null, iota, &b, c);
            if (!sound) {
                job->bad_tree = 1;
                goto stop;
            }
            TB_NFN(tb_bvh_record)(job, i, &b, c, mode, timed, &hits, &t_sum, &uv_sum, sums);
            ++i;
        }
stop:
    base->hits = hits;
    base->tests = sums[3];
    base->t_sum = t_sum;
    base->uv_sum = uv_sum;
    memcpy(job->counts, sums, sizeof sums);
}
#undef tb_wv_max
#undef tb_wv_min
#undef tb_wv_le_bits

/* Entry points of one native kernel's BVH traversals for this ISA (the wide
 * tree's, then the binary tree's: bvh.c's table in the same order); only the
 * TB_NATIVE kernels of the public list (one line each, from list.h). */
#define TB_BVH_ENTRY(name, fn_mode, mode, timed, null, walk)                                        \
    TB_NTARGET TB_HIDDEN void TB_NFN(tb_##name##_bvh_##fn_mode)(tb_bvh_job *job)                    \
    {                                                                                               \
        TB_NFN(tb_bvh_loop)(TB_NFN(tb_##name##_test), TB_FN(tb_##name##_ray), tb_##name##_stride, job, \
                            mode, timed, null, walk, NULL);                                         \
    }
/* a packet entry point traces its packets out of line, and a ray alone as the wide entry point does:
 * with both inlined, or the ray in the packet's arrays, the rays traced alone ran 8-15% slower */
#define TB_BVH_PACKET_ENTRY(name, fn_mode, mode, timed, null)                                          \
    static __attribute__((noinline)) TB_NTARGET int TB_NFN(tb_##name##_bvh_##fn_mode##_trace)(        \
        const tb_bvh_job *job, const TB_NFN(tb_bvh_ray) * ray, int n, nreal iota, TB_NFN(tb_bvh_best) * b, \
        uint64_t (*c)[4])                                                                              \
    {                                                                                                  \
        return TB_NFN(tb_bvh_trace_packet)(TB_NFN(tb_##name##_test), tb_##name##_stride, job, ray, n, mode, \
                                           timed, null, iota, b, c);                                   \
    }                                                                                                  \
    TB_NTARGET TB_HIDDEN void TB_NFN(tb_##name##_bvh_##fn_mode)(tb_bvh_job *job)                       \
    {                                                                                                  \
        TB_NFN(tb_bvh_loop)(TB_NFN(tb_##name##_test), TB_FN(tb_##name##_ray), tb_##name##_stride, job,    \
                            mode, timed, null, 2, TB_NFN(tb_##name##_bvh_##fn_mode##_trace));          \
    }
#define TB_BVH_ENTRIES(name)                                            \
    TB_BVH_ENTRY(name, run_any, TB_ANY, 0, 0, 1)                        \
    TB_BVH_ENTRY(name, run_closest, TB_CLOSEST_UV, 0, 0, 1)             \
    TB_BVH_ENTRY(name, time_any, TB_ANY, 1, 0, 1)                       \
    TB_BVH_ENTRY(name, time_closest, TB_CLOSEST, 1, 0, 1)               \
    TB_BVH_ENTRY(name, time_closest_uv, TB_CLOSEST_UV, 1, 0, 1)         \
    TB_BVH_ENTRY(name, time_null, TB_CLOSEST, 1, 1, 1)                  \
    TB_BVH_ENTRY(name, binary_run_any, TB_ANY, 0, 0, 0)                 \
    TB_BVH_ENTRY(name, binary_run_closest, TB_CLOSEST_UV, 0, 0, 0)      \
    TB_BVH_ENTRY(name, binary_time_any, TB_ANY, 1, 0, 0)                \
    TB_BVH_ENTRY(name, binary_time_closest, TB_CLOSEST, 1, 0, 0)        \
    TB_BVH_ENTRY(name, binary_time_closest_uv, TB_CLOSEST_UV, 1, 0, 0)  \
    TB_BVH_ENTRY(name, binary_time_null, TB_CLOSEST, 1, 1, 0)           \
    TB_BVH_PACKET_ENTRY(name, packet_run_any, TB_ANY, 0, 0)                \
    TB_BVH_PACKET_ENTRY(name, packet_run_closest, TB_CLOSEST_UV, 0, 0)     \
    TB_BVH_PACKET_ENTRY(name, packet_time_any, TB_ANY, 1, 0)               \
    TB_BVH_PACKET_ENTRY(name, packet_time_closest, TB_CLOSEST, 1, 0)       \
    TB_BVH_PACKET_ENTRY(name, packet_time_closest_uv, TB_CLOSEST_UV, 1, 0) \
    TB_BVH_PACKET_ENTRY(name, packet_time_null, TB_CLOSEST, 1, 1)
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
#undef TB_BVH_PACKET_ENTRY
#undef TB_BVH_ENTRY
