/* A bounding volume hierarchy over a triangle array: binned SAH build, its check
 * and its collapse into a wide tree. Their traversals, with a native kernel's
 * block test at the leaves, are in bvh_trace.h (single rays, and the batch
 * loop) and bvh_packet.h (packets of rays).
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
 * Traversal: TB_NFN(tb_bvh_loop) in bvh_trace.h; the wide tree's is 1.3-1.5x
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
