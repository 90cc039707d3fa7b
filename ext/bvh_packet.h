/* The wide tree walked by packets of coherent rays (layout "packets": bvh_trace.h's tb_bvh_loop).
 *
 * A packet is up to TB_BVH_PACKET consecutive rays of the input that share
 * one origin (tb_bvh_loop; a ray whose origin no neighbour shares, such as a
 * bounce, is traced alone as the wide walk traces it). Where they also share,
 * per axis, the sign of their directions (a camera's rays, in a tile or a row
 * of the image), the packet is traversed as one: each wide node's children
 * are tested once, against the interval of the packet's inverse directions
 * (interval arithmetic: Boulos et al. 2007, "Packet-based Whitted and
 * distribution ray tracing"; Wald et al. 2007, "SIMD ray stream tracing";
 * Reshetov et al. 2005, "Multi-level ray tracing algorithm"), so a node costs
 * one box test for the whole packet, not one per ray. A child is entered when
 * some ray of the packet may meet it: its box's entry over the interval is
 * the smallest a ray of the packet can have, the exit the largest, and the
 * nearest child by that entry goes first. At a leaf each ray is tested
 * against the leaf's box on its own, the rays met run the kernel's leaf test
 * one by one (tb_bvh_visit_leaf, the single-ray traversal's), and each keeps
 * its own closest hit; a node is skipped once its entry lies beyond every
 * ray's closest hit. A packet with mixed signs or a non-finite ray is traced
 * ray by ray by tb_bvh_trace_wide. The closest hits are the single-ray
 * traversal's: every ray meets every leaf it would meet alone (the interval
 * test is conservative, its exits scaled by the same 1 + 4 eps) and tests it
 * as it would.
 *
 * Counts: a packet's node visits and box tests (one per child lane of each
 * wide node it tests) go to its first ray; each ray counts its own leaf box
 * test, leaves and triangle tests. */

#define TB_BVH_PACKET 16 /* at most 32: a packet's rays are the bits of an unsigned */
#define TB_BVH_GROUPS (TB_BVH_PACKET / TB_BVH_WIDTH) /* vectors of TB_BVH_WIDTH rays */

/* The rays of a packet as the leaf box test takes them: one vector of rays per group. */
typedef struct {
    vreal inv[3][TB_BVH_GROUPS], inv_far[3][TB_BVH_GROUPS];
} TB_NFN(tb_bvh_packet_soa);

/* Whether the packet can be traced as one: every ray finite with finite inverse directions (no
 * 0 x inf in the interval test), one origin, one sign per axis. Then its rays' inverse directions
 * in *soa, and their intervals, lo and hi (inv, then inv_far), per axis. */
TB_NWIDE int TB_NFN(tb_bvh_packet_coherent)(const TB_NFN(tb_bvh_ray) * ray, int n, TB_NFN(tb_bvh_packet_soa) * soa,
                                            real lo[2][3], real hi[2][3])
{
    real inv[3][TB_BVH_PACKET], inv_far[3][TB_BVH_PACKET];
    for (int k = 0; k < 3; ++k) {
        lo[0][k] = hi[0][k] = ray[0].inv[k];
        lo[1][k] = hi[1][k] = ray[0].inv_far[k];
    }
    for (int r = 0; r < TB_BVH_PACKET; ++r) {
        const TB_NFN(tb_bvh_ray) *x = &ray[r < n ? r : 0]; /* lanes past the last ray repeat the first */
        if (!x->finite || !isfinite(x->inv[0]) || !isfinite(x->inv[1]) || !isfinite(x->inv[2]))
            return 0;
        for (int k = 0; k < 3; ++k) {
            if (x->org[k] != ray[0].org[k] || x->near[k] != ray[0].near[k])
                return 0;
            inv[k][r] = x->inv[k];
            inv_far[k][r] = x->inv_far[k];
            lo[0][k] = x->inv[k] < lo[0][k] ? x->inv[k] : lo[0][k];
            hi[0][k] = x->inv[k] > hi[0][k] ? x->inv[k] : hi[0][k];
            lo[1][k] = x->inv_far[k] < lo[1][k] ? x->inv_far[k] : lo[1][k];
            hi[1][k] = x->inv_far[k] > hi[1][k] ? x->inv_far[k] : hi[1][k];
        }
    }
    memcpy(soa->inv, inv, sizeof inv);
    memcpy(soa->inv_far, inv_far, sizeof inv_far);
    return 1;
}

/* The farthest any live ray of the packet still looks (its closest hit so far); -inf once all are done. */
TB_NWIDE real TB_NFN(tb_bvh_packet_reach)(const TB_NFN(tb_bvh_best) * b, int n, unsigned live)
{
    real reach = -(real)INFINITY;
    for (int r = 0; r < n; ++r)
        if (live >> r & 1 && b[r].t > reach)
            reach = b[r].t;
    return reach;
}

/* The rays (bits) of the packet whose own slab test meets lane i of wide node w within their closest
 * hit so far: tb_bvh_wide_box's arithmetic with the rays, not the children, across the lanes. */
TB_NWIDE unsigned TB_NFN(tb_bvh_packet_leaf_rays)(const tb_bvh_wide *w, int i, const vreal *org,
                                                  const TB_NFN(tb_bvh_packet_soa) * soa, const int rows[6],
                                                  const TB_NFN(tb_bvh_best) * b, int n, unsigned live)
{
    real reach[TB_BVH_PACKET];
    for (int r = 0; r < TB_BVH_PACKET; ++r)
        reach[r] = r < n ? b[r].t : 0;
    unsigned met = 0;
    for (int g = 0; g < TB_BVH_GROUPS; ++g) {
        vreal t0 = (vreal){0}, t1;
        memcpy(&t1, reach + g * TB_BVH_WIDTH, sizeof t1);
        for (int k = 0; k < 3; ++k) {
            const vreal enter = w->b[rows[2 * k]][i] - org[k], leave = w->b[rows[2 * k + 1]][i] - org[k];
            t0 = tb_wv_max(enter * soa->inv[k][g], t0);
            t1 = tb_wv_min(leave * soa->inv_far[k][g], t1);
        }
        met |= tb_wv_le_bits(t0, t1) << (g * TB_BVH_WIDTH);
    }
    return met & live;
}

/* One packet of n rays through the wide tree (see above). Returns 0 on a malformed tree. */
TB_NWIDE int TB_NFN(tb_bvh_trace_packet)(TB_NFN(tb_native_fn) test, size_t stride, const tb_bvh_job *job,
                                         const TB_NFN(tb_bvh_ray) * ray, int n, int mode, int timed, int null,
                                         nreal iota, TB_NFN(tb_bvh_best) * b, uint64_t (*c)[4])
{
    typedef struct {
        const tb_bvh_wide *parent; /* the child's box: lane i of its parent */
        int i;
        real t; /* the packet's entry */
    } entry;
    TB_NFN(tb_bvh_packet_soa) soa;
    real lo[2][3], hi[2][3];
    if (!TB_NFN(tb_bvh_packet_coherent)(ray, n, &soa, lo, hi)) {
        for (int r = 0; r < n; ++r)
            if (!TB_NFN(tb_bvh_trace_wide)(test, stride, job, &ray[r], mode, timed, null, iota, &b[r], c[r]))
                return 0;
        return 1;
    }
    const tb_bvh_wide *nodes = job->nodes;
    entry stack[TB_BVH_STACK * (TB_BVH_WIDTH - 1) + TB_BVH_WIDTH];
    size_t sp = 0;
    vreal org[3], inv_lo[3], inv_hi[3], far_lo[3], far_hi[3];
    int rows[6];
    for (int k = 0; k < 3; ++k) {
        org[k] = ray[0].org[k] + (vreal){0};
        inv_lo[k] = lo[0][k] + (vreal){0};
        inv_hi[k] = hi[0][k] + (vreal){0};
        far_lo[k] = lo[1][k] + (vreal){0};
        far_hi[k] = hi[1][k] + (vreal){0};
        rows[2 * k] = 2 * k + ray[0].near[k];
        rows[2 * k + 1] = 2 * k + 1 - ray[0].near[k];
    }
    unsigned live = n >= 32 ? ~0u : (1u << n) - 1;
    real reach = TB_NFN(tb_bvh_packet_reach)(b, n, live);
    uint32_t a = 0; /* the root, wide node 0 */
    for (;;) {
        const tb_bvh_wide *w = &nodes[a];
        /* the interval slab test: the packet's entry is the least of (plane - o) x inv at the
         * interval's two ends, its exit the greatest; rounding is monotone in inv, so these are
         * the least entry and the greatest exit any of its rays computes alone (no NaN: every
         * inv is finite and nonzero) */
        vreal t0 = (vreal){0}, t1 = reach + (vreal){0};
        for (int k = 0; k < 3; ++k) {
            vreal enter, leave;
            memcpy(&enter, w->b[rows[2 * k]], sizeof enter);
            memcpy(&leave, w->b[rows[2 * k + 1]], sizeof leave);
            enter -= org[k];
            leave -= org[k];
            t0 = tb_wv_max(tb_wv_min(enter * inv_lo[k], enter * inv_hi[k]), t0);
            t1 = tb_wv_min(tb_wv_max(leave * far_lo[k], leave * far_hi[k]), t1);
        }
        unsigned met = tb_wv_le_bits(t0, t1);
        ++c[0][0];
        c[0][1] += TB_BVH_WIDTH;
        if (met) {
            real ts[TB_BVH_WIDTH];
            memcpy(ts, &t0, sizeof ts);
            if (sp + TB_BVH_WIDTH > sizeof stack / sizeof *stack)
                return 0;
            entry *kids = &stack[sp];
            int k = 0;
            for (; met; met &= met - 1) { /* insertion by entry, farthest first */
                int i = __builtin_ctz(met), j = k++;
                if (!TB_NFN(tb_bvh_child_sound)(w, i, a, job->n_nodes))
                    return 0;
                entry e = {w, i, ts[i]};
                if (w->n[i] == 0)
                    TB_NFN(tb_bvh_prefetch_wide)(&nodes[w->a[i]]);
                TB_BVH_PUSH_IN_ORDER(kids, j, e);
            }
            sp += (size_t)k;
        }
        for (;;) { /* the nearest pushed child still in reach: a leaf is visited here, an inner node entered */
            do {
                if (sp == 0)
                    return 1;
                --sp;
            } while (!(stack[sp].t <= reach));
            const entry e = stack[sp];
            if (e.parent->n[e.i] == 0) {
                a = e.parent->a[e.i];
                break;
            }
            unsigned rays = TB_NFN(tb_bvh_packet_leaf_rays)(e.parent, e.i, org, &soa, rows, b, n, live);
            for (; rays; rays &= rays - 1) {
                const int r = __builtin_ctz(rays);
                ++c[r][0];
                ++c[r][1];
                int done = TB_NFN(tb_bvh_visit_leaf)(test, stride, job, &ray[r], e.parent->a[e.i], e.parent->n[e.i],
                                                     mode, timed, null, iota, &b[r], c[r]);
                if (done < 0)
                    return 0;
                if (done)
                    live &= ~(1u << r);
            }
            reach = TB_NFN(tb_bvh_packet_reach)(b, n, live);
        }
    }
}
