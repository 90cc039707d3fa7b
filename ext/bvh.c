/* The BVH: its build and check (bvh.h, compiled here where they are called),
 * the table of the kernels a BVH takes as its leaf test, and the glue:
 * bvh_kernels, bvh_build, bvh_check, bvh_run and bvh_time. The traversal
 * loops are compiled per ISA (isa_<isa>.c). */

#include "core.h"

#include "declarations.h"

TB_HIDDEN const long long tb_bvh_build_version = TB_BVH_BUILD_VERSION;

/* The tree is built here (bvh.h) and lives in Python-owned arrays between
 * calls: nodes (8 reals each), perm (slot -> input index) and the kernel's
 * records in slot order. Traversal checks every node it follows against the
 * counts it is given, so a malformed tree raises instead of reading out of
 * bounds. */

enum { TB_BVH_RUN_ANY, TB_BVH_RUN_CLOSEST, TB_BVH_TIME_ANY, TB_BVH_TIME_CLOSEST, TB_BVH_TIME_CLOSEST_UV,
       TB_BVH_TIME_NULL, TB_BVH_N_FNS };
enum { TB_BVH_WIDE, TB_BVH_BINARY, TB_BVH_PACKETS, TB_BVH_N_LAYOUTS }; /* bvh.py's LAYOUTS, in order */
enum { TB_BVH_N_TREES = 2 }; /* the wide tree's entry points (which also walk it by packets), the binary's */
typedef struct {
    const char *name;
    tb_bvh_fn f32[TB_MAX_ISAS][TB_BVH_N_TREES][TB_BVH_N_FNS], f64[TB_MAX_ISAS][TB_BVH_N_TREES][TB_BVH_N_FNS];
} tb_bvh_kernel;
#define TB_BVH_TREE_FNS(name, tree, isa, sfx)                                                      \
    {TB_CAT(tb_##name##_bvh_##tree##run_any_##isa, sfx), TB_CAT(tb_##name##_bvh_##tree##run_closest_##isa, sfx), \
     TB_CAT(tb_##name##_bvh_##tree##time_any_##isa, sfx), TB_CAT(tb_##name##_bvh_##tree##time_closest_##isa, sfx), \
     TB_CAT(tb_##name##_bvh_##tree##time_closest_uv_##isa, sfx), TB_CAT(tb_##name##_bvh_##tree##time_null_##isa, sfx)}
#define TB_BVH_FNS(name, isa, sfx)                                                                 \
    {TB_BVH_TREE_FNS(name, , isa, sfx), TB_BVH_TREE_FNS(name, binary_, isa, sfx)},
#define TB_BVH_FNS_F32(name, isa) TB_BVH_FNS(name, isa, _f32)
#define TB_BVH_FNS_F64(name, isa) TB_BVH_FNS(name, isa, _f64)
#define TB_BVH_KERNEL(name, faces, watertight, promised_by, origin, wide) TB_BVH_KERNEL_##wide(name)
#define TB_BVH_KERNEL_TB_SCALAR_ONLY(name)
#define TB_BVH_KERNEL_TB_NATIVE_AVX2(name)
#define TB_BVH_KERNEL_TB_NATIVE(name) \
    {#name, {TB_NATIVE_ISA_LIST(TB_BVH_FNS_F32, name)}, {TB_NATIVE_ISA_LIST(TB_BVH_FNS_F64, name)}},
static const tb_bvh_kernel tb_bvh_kernels[] = {TB_KERNEL_LIST(TB_BVH_KERNEL)};
/* a variable, not the constant: a kernel file's build may have no native kernel (an empty table) */
static const size_t tb_n_bvh_kernels = sizeof tb_bvh_kernels / sizeof *tb_bvh_kernels;

/* bvh_kernels() -> the kernels a BVH can take as its leaf test, registry order */
TB_HIDDEN PyObject *py_bvh_kernels(PyObject *Py_UNUSED(self), PyObject *Py_UNUSED(unused))
{
    size_t n = tb_n_bvh_kernels;
    PyObject *out = PyTuple_New((Py_ssize_t)n);
    for (size_t i = 0; out && i < n; ++i) {
        PyObject *s = PyUnicode_FromString(tb_bvh_kernels[i].name);
        if (!s)
            Py_CLEAR(out);
        else
            PyTuple_SET_ITEM(out, (Py_ssize_t)i, s);
    }
    return out;
}

/* bvh_build(itemsize, vertices, n, max_leaf, nodes_out, order_out) -> (n_nodes, n_slots):
 * nodes_out has room for 2n - 1 nodes (8 reals each), order_out for n int64 */
TB_HIDDEN PyObject *py_bvh_build(PyObject *Py_UNUSED(self), PyObject *args)
{
    Py_ssize_t itemsize, n;
    int max_leaf;
    Py_buffer vertices = {0}, nodes = {0}, order = {0};
    PyObject *result = NULL;
    if (!PyArg_ParseTuple(args, "ny*niw*w*:bvh_build", &itemsize, &vertices, &n, &max_leaf, &nodes, &order))
        return NULL;
    if (tb_check_itemsize(itemsize) || tb_check_count("n", n, 64))
        goto done;
    if (n > TB_MAX_BVH_TRIANGLES || max_leaf < 1 || max_leaf > 1024) {
        PyErr_Format(PyExc_ValueError, "bvh_build: n must be at most %lld and max_leaf 1..1024, got %zd and %d",
                     TB_MAX_BVH_TRIANGLES, n, max_leaf);
        goto done;
    }
    if (tb_check_buffer(&vertices, "vertices", 9 * n, itemsize) ||
        tb_check_buffer(&nodes, "nodes_out", TB_BVH_NODE_REALS * (2 * n - 1), itemsize) ||
        tb_check_buffer(&order, "order_out", n, 8))
        goto done;
    size_t n_nodes = 0, n_slots = 0;
    int failed;
    Py_BEGIN_ALLOW_THREADS
    failed = itemsize == 4 ? tb_bvh_build_f32(vertices.buf, (size_t)n, max_leaf, nodes.buf, order.buf, &n_nodes, &n_slots)
                           : tb_bvh_build_f64(vertices.buf, (size_t)n, max_leaf, nodes.buf, order.buf, &n_nodes, &n_slots);
    Py_END_ALLOW_THREADS
    if (failed)
        PyErr_NoMemory();
    else
        result = Py_BuildValue("nn", (Py_ssize_t)n_nodes, (Py_ssize_t)n_slots);
done:
    PyBuffer_Release(&vertices);
    PyBuffer_Release(&nodes);
    PyBuffer_Release(&order);
    return result;
}

/* bvh_check(itemsize, nodes, n_nodes, perm, n_slots, vertices, n, max_leaf): raises
 * ValueError naming the first broken invariant of a tree made outside this
 * process (bvh.h's tb_bvh_check), so a malformed tree is never traversed. */
TB_HIDDEN PyObject *py_bvh_check(PyObject *Py_UNUSED(self), PyObject *args)
{
    Py_ssize_t itemsize, n_nodes, n_slots, n;
    int max_leaf;
    Py_buffer nodes = {0}, perm = {0}, vertices = {0};
    PyObject *result = NULL;
    if (!PyArg_ParseTuple(args, "ny*ny*ny*ni:bvh_check", &itemsize, &nodes, &n_nodes, &perm, &n_slots, &vertices, &n,
                          &max_leaf))
        return NULL;
    if (tb_check_itemsize(itemsize) || tb_check_count("n", n, 64) || tb_check_count("n_nodes", n_nodes, 64) ||
        tb_check_count("n_slots", n_slots, 64) || tb_check_buffer(&nodes, "nodes", TB_BVH_NODE_REALS * n_nodes, itemsize) ||
        tb_check_buffer(&perm, "perm", n_slots, 8) || tb_check_buffer(&vertices, "vertices", 9 * n, itemsize))
        goto done;
    if (n > TB_MAX_BVH_TRIANGLES || max_leaf < 1 || max_leaf > 1024) {
        PyErr_Format(PyExc_ValueError, "bvh_check: n must be at most %lld and max_leaf 1..1024, got %zd and %d",
                     TB_MAX_BVH_TRIANGLES, n, max_leaf);
        goto done;
    }
    size_t where = 0;
    const char *fault;
    Py_BEGIN_ALLOW_THREADS
    fault = itemsize == 4 ? tb_bvh_check_f32(nodes.buf, (size_t)n_nodes, perm.buf, (size_t)n_slots, vertices.buf,
                                             (size_t)n, max_leaf, &where)
                          : tb_bvh_check_f64(nodes.buf, (size_t)n_nodes, perm.buf, (size_t)n_slots, vertices.buf,
                                             (size_t)n, max_leaf, &where);
    Py_END_ALLOW_THREADS
    if (fault && !*fault)
        PyErr_NoMemory();
    else if (fault)
        PyErr_Format(PyExc_ValueError, "malformed BVH: %s (at node or slot %zu)", fault, where);
    else
        result = Py_NewRef(Py_None);
done:
    PyBuffer_Release(&nodes);
    PyBuffer_Release(&perm);
    PyBuffer_Release(&vertices);
    return result;
}

/* bvh_widen(itemsize, nodes, n_nodes, wide_out) -> n_wide: the wide tree
 * (bvh.h) of a binary tree that bvh_build made or bvh_check passed; wide_out
 * has room for (n_nodes - 1) / 2 + 1 nodes of 256 bytes. */
TB_HIDDEN PyObject *py_bvh_widen(PyObject *Py_UNUSED(self), PyObject *args)
{
    Py_ssize_t itemsize, n_nodes;
    Py_buffer nodes = {0}, wide = {0};
    PyObject *result = NULL;
    if (!PyArg_ParseTuple(args, "ny*nw*:bvh_widen", &itemsize, &nodes, &n_nodes, &wide))
        return NULL;
    if (tb_check_itemsize(itemsize) || tb_check_count("n_nodes", n_nodes, 64) ||
        tb_check_buffer(&nodes, "nodes", TB_BVH_NODE_REALS * n_nodes, itemsize) ||
        tb_check_buffer(&wide, "wide_out", TB_BVH_WIDE_BYTES / itemsize * ((n_nodes - 1) / 2 + 1), itemsize))
        goto done;
    size_t cap = (size_t)(n_nodes - 1) / 2 + 1, n_wide;
    Py_BEGIN_ALLOW_THREADS
    n_wide = itemsize == 4 ? tb_bvh_widen_f32(nodes.buf, (size_t)n_nodes, wide.buf, cap)
                           : tb_bvh_widen_f64(nodes.buf, (size_t)n_nodes, wide.buf, cap);
    Py_END_ALLOW_THREADS
    if (n_wide == 0)
        PyErr_SetString(PyExc_ValueError, "malformed BVH: the binary tree cannot be widened (check it first)");
    else
        result = PyLong_FromSize_t(n_wide);
done:
    PyBuffer_Release(&nodes);
    PyBuffer_Release(&wide);
    return result;
}

/* Checks a BVH call (the brute-force job's checks, with the slots as the
 * records, then the tree's buffers) and fills `job`; returns the traversal
 * to call, or NULL with a Python exception set. */
static tb_bvh_fn tb_parse_bvh_job(const char *name, Py_ssize_t itemsize, int mode, const char *isa, int layout,
                                  int timed, int null, Py_buffer *o, Py_buffer *d, Py_ssize_t n_rays, Py_buffer *t_max,
                                  Py_buffer *nodes, Py_ssize_t n_nodes, Py_buffer *perm, Py_ssize_t n_slots,
                                  Py_buffer *rec, tb_bvh_job *job)
{
    if (mode == TB_PAIRS) {
        PyErr_SetString(PyExc_ValueError, "a BVH has no 'pairs' mode");
        return NULL;
    }
    if (!tb_parse_job(name, itemsize, mode, isa, timed, o, d, n_rays, t_max, rec, n_slots, &job->base))
        return NULL;
    const tb_bvh_kernel *bk = NULL;
    for (size_t i = 0; i < tb_n_bvh_kernels; ++i)
        if (strcmp(tb_bvh_kernels[i].name, name) == 0)
            bk = &tb_bvh_kernels[i];
    if (!bk) {
        PyErr_Format(PyExc_ValueError, "kernel '%s' has no BVH traversal (native kernels only)", name);
        return NULL;
    }
    if (layout < 0 || layout >= TB_BVH_N_LAYOUTS) {
        PyErr_Format(PyExc_ValueError, "layout must be 0 (wide), 1 (binary) or 2 (packets), got %d", layout);
        return NULL;
    }
    Py_ssize_t node_reals = layout == TB_BVH_BINARY ? TB_BVH_NODE_REALS : TB_BVH_WIDE_BYTES / itemsize;
    if (n_slots % 16 || tb_check_count("n_nodes", n_nodes, 64) ||
        tb_check_buffer(nodes, "nodes", node_reals * n_nodes, itemsize) ||
        tb_check_buffer(perm, "perm", n_slots, 8)) {
        if (!PyErr_Occurred())
            PyErr_Format(PyExc_ValueError, "n_slots must be a multiple of 16, got %zd", n_slots);
        return NULL;
    }
    int i = tb_isa_index(name, isa); /* found: tb_parse_job checked it */
    job->nodes = nodes->buf;
    job->perm = perm->buf;
    job->n_nodes = (size_t)n_nodes;
    job->n_slots = (size_t)n_slots;
    job->counts_out = NULL;
    memset(job->counts, 0, sizeof job->counts);
    job->packets = layout == TB_BVH_PACKETS;
    job->bad_tree = 0;
    if (n_nodes == 0) {
        PyErr_SetString(PyExc_ValueError, "malformed BVH: no nodes");
        return NULL;
    }
    const int tree = layout == TB_BVH_BINARY ? 1 : 0;
    const tb_bvh_fn *fns = itemsize == 4 ? bk->f32[i][tree] : bk->f64[i][tree];
    if (!timed)
        return fns[mode == TB_ANY ? TB_BVH_RUN_ANY : TB_BVH_RUN_CLOSEST];
    if (null)
        return fns[TB_BVH_TIME_NULL];
    return fns[mode == TB_ANY ? TB_BVH_TIME_ANY : mode == TB_CLOSEST ? TB_BVH_TIME_CLOSEST : TB_BVH_TIME_CLOSEST_UV];
}

/* Runs a traversal as tb_run_loop runs a loop; -1 with an exception set on a
 * signal or a malformed tree. */
static int tb_run_bvh(tb_bvh_fn fn, tb_bvh_job *job)
{
    job->base.start_ns = job->base.polled_ns = tb_now_ns();
    job->base.thread = PyEval_SaveThread();
    fn(job);
    PyEval_RestoreThread(job->base.thread);
    if (job->base.interrupted)
        return -1;
    if (job->bad_tree) {
        PyErr_SetString(PyExc_ValueError, "malformed BVH: a node points out of range or the tree is too deep");
        return -1;
    }
    return 0;
}

/* bvh_run(name, itemsize, mode, isa, layout, o, d, n_rays, t_max, nodes, n_nodes, perm, n_slots,
 *         records, index_out, t_out, u_out, v_out, counts_out) */
TB_HIDDEN PyObject *py_bvh_run(PyObject *Py_UNUSED(self), PyObject *args)
{
    const char *name, *isa;
    Py_ssize_t itemsize, n_rays, n_nodes, n_slots;
    int mode, layout;
    Py_buffer o = {0}, d = {0}, t_max = {0}, nodes = {0}, perm = {0}, rec = {0}, index = {0}, t = {0}, u = {0},
              v = {0}, counts = {0};
    PyObject *result = NULL;
    tb_bvh_job job;
    if (!PyArg_ParseTuple(args, "snisiy*y*ny*y*ny*ny*w*w*w*w*w*:bvh_run", &name, &itemsize, &mode, &isa, &layout, &o, &d,
                          &n_rays, &t_max, &nodes, &n_nodes, &perm, &n_slots, &rec, &index, &t, &u, &v, &counts))
        return NULL;
    tb_bvh_fn fn = tb_parse_bvh_job(name, itemsize, mode, isa, layout, 0, 0, &o, &d, n_rays, &t_max, &nodes, n_nodes, &perm,
                                    n_slots, &rec, &job);
    if (!fn || tb_check_buffer(&index, "index_out", n_rays, 8) || tb_check_buffer(&t, "t_out", n_rays, itemsize) ||
        tb_check_buffer(&u, "u_out", n_rays, itemsize) || tb_check_buffer(&v, "v_out", n_rays, itemsize) ||
        tb_check_buffer(&counts, "counts_out", 4 * n_rays, 8))
        goto done;
    job.base.index_out = index.buf;
    job.base.t_out = t.buf;
    job.base.u_out = u.buf;
    job.base.v_out = v.buf;
    job.counts_out = counts.buf;
    if (tb_run_bvh(fn, &job) == 0)
        result = Py_NewRef(Py_None);
done:
    PyBuffer_Release(&o);
    PyBuffer_Release(&d);
    PyBuffer_Release(&t_max);
    PyBuffer_Release(&nodes);
    PyBuffer_Release(&perm);
    PyBuffer_Release(&rec);
    PyBuffer_Release(&index);
    PyBuffer_Release(&t);
    PyBuffer_Release(&u);
    PyBuffer_Release(&v);
    PyBuffer_Release(&counts);
    return result;
}

/* bvh_time(name, itemsize, mode, isa, layout, o, d, n_rays, t_max, nodes, n_nodes, perm, n_slots,
 *          records, loops, null) -> (elapsed_ns, hits, triangle_tests, t_sum, uv_sum,
 *          nodes_visited, box_tests, leaves) */
TB_HIDDEN PyObject *py_bvh_time(PyObject *Py_UNUSED(self), PyObject *args)
{
    const char *name, *isa;
    Py_ssize_t itemsize, n_rays, n_nodes, n_slots;
    long long loops;
    int mode, layout, null;
    Py_buffer o = {0}, d = {0}, t_max = {0}, nodes = {0}, perm = {0}, rec = {0};
    PyObject *result = NULL;
    tb_bvh_job job;
    if (!PyArg_ParseTuple(args, "snisiy*y*ny*y*ny*ny*Lp:bvh_time", &name, &itemsize, &mode, &isa, &layout, &o, &d, &n_rays,
                          &t_max, &nodes, &n_nodes, &perm, &n_slots, &rec, &loops, &null))
        return NULL;
    tb_bvh_fn fn = tb_parse_bvh_job(name, itemsize, mode, isa, layout, 1, null, &o, &d, n_rays, &t_max, &nodes, n_nodes,
                                    &perm, n_slots, &rec, &job);
    if (!fn)
        goto done;
    if (loops < 1 || (double)loops * (double)n_rays > (double)TB_MAX_BVH_BATCH_RAYS) {
        PyErr_Format(PyExc_ValueError, "loops must be at least 1 and loops x rays at most %lld, got %lld loops",
                     TB_MAX_BVH_BATCH_RAYS, loops);
        goto done;
    }
    job.base.loops = (uint64_t)loops;
    int64_t start = tb_now_ns();
    if (tb_run_bvh(fn, &job) < 0)
        goto done;
    int64_t stop = tb_now_ns();
    result = Py_BuildValue("LKKddKKK", (long long)(stop - start), (unsigned long long)job.base.hits,
                           (unsigned long long)job.base.tests, job.base.t_sum, job.base.uv_sum,
                           (unsigned long long)job.counts[0], (unsigned long long)job.counts[1],
                           (unsigned long long)job.counts[2]);
done:
    PyBuffer_Release(&o);
    PyBuffer_Release(&d);
    PyBuffer_Release(&t_max);
    PyBuffer_Release(&nodes);
    PyBuffer_Release(&perm);
    PyBuffer_Release(&rec);
    return result;
}
