/* The FMA peak probe (fma_peak.h) and the throughput probes (probes.h), and
 * their glue: fma_peak, op_probe, probe_isas, op_classes. */

#include "core.h"

#include "fma_peak.h"
#include "probes.h"

/* fma_peak(iterations, force_scalar) -> (flops, elapsed_ns, isa, sink) */
TB_HIDDEN PyObject *py_fma_peak(PyObject *Py_UNUSED(self), PyObject *args)
{
    long long iterations;
    int force_scalar = 0;
    if (!PyArg_ParseTuple(args, "L|p:fma_peak", &iterations, &force_scalar))
        return NULL;
    if (iterations < 1 || iterations > TB_MAX_PEAK_ITERATIONS) {
        PyErr_Format(PyExc_ValueError, "iterations must be between 1 and %lld, got %lld",
                     TB_MAX_PEAK_ITERATIONS, iterations);
        return NULL;
    }
    tb_peak r;
    Py_BEGIN_ALLOW_THREADS
    r = tb_fma_peak((uint64_t)iterations, force_scalar);
    Py_END_ALLOW_THREADS
    return Py_BuildValue("dLsd", r.flops, (long long)r.elapsed_ns, r.isa, r.sink);
}

/* op_probe(isa, itemsize, op, steps) -> (lane_ops, elapsed_ns, sink): one
 * throughput probe (probes.h), timed here with the GIL released */
TB_HIDDEN PyObject *py_op_probe(PyObject *Py_UNUSED(self), PyObject *args)
{
    const char *isa, *op;
    Py_ssize_t itemsize;
    long long steps;
    if (!PyArg_ParseTuple(args, "snsL:op_probe", &isa, &itemsize, &op, &steps))
        return NULL;
    int i = 0, o = 0;
    while (i < TB_N_PROBE_ISAS && strcmp(tb_probe_isas[i], isa) != 0)
        ++i;
    while (o < TB_N_OPS && strcmp(tb_op_names[o], op) != 0)
        ++o;
    if (i == TB_N_PROBE_ISAS || !tb_probe_runnable(i)) {
        PyErr_Format(PyExc_ValueError, "probe ISA '%s' is not built or not runnable on this CPU", isa);
        return NULL;
    }
    if (o == TB_N_OPS) {
        PyErr_Format(PyExc_ValueError, "unknown operation class '%s'", op);
        return NULL;
    }
    if (tb_check_itemsize(itemsize))
        return NULL;
    if (steps < 1 || steps > TB_MAX_PEAK_ITERATIONS) {
        PyErr_Format(PyExc_ValueError, "steps must be between 1 and %lld, got %lld", TB_MAX_PEAK_ITERATIONS, steps);
        return NULL;
    }
    static const tb_probe_fn fns[][2] = TB_PROBE_FNS;
    tb_probe_fn fn = fns[i][itemsize == 8];
    const void *c = tb_probe_constants((int)itemsize);
    double lane_ops = 0, sink;
    int64_t start, stop;
    Py_BEGIN_ALLOW_THREADS
    start = tb_now_ns();
    sink = fn(o, (uint64_t)steps, c, &lane_ops);
    stop = tb_now_ns();
    Py_END_ALLOW_THREADS
    return Py_BuildValue("dLd", lane_ops, (long long)(stop - start), sink);
}

/* probe_isas() -> ((name, runnable), ...) best first; op_classes() -> names */
TB_HIDDEN PyObject *py_probe_isas(PyObject *Py_UNUSED(self), PyObject *Py_UNUSED(unused))
{
    PyObject *out = PyTuple_New(TB_N_PROBE_ISAS);
    for (int i = 0; out && i < TB_N_PROBE_ISAS; ++i) {
        PyObject *item = Py_BuildValue("(sO)", tb_probe_isas[i], tb_probe_runnable(i) ? Py_True : Py_False);
        if (!item)
            Py_CLEAR(out);
        else
            PyTuple_SET_ITEM(out, i, item);
    }
    return out;
}

TB_HIDDEN PyObject *py_op_classes(PyObject *Py_UNUSED(self), PyObject *Py_UNUSED(unused))
{
    PyObject *out = PyTuple_New(TB_N_OPS);
    for (int o = 0; out && o < TB_N_OPS; ++o) {
        PyObject *s = PyUnicode_FromString(tb_op_names[o]);
        if (!s)
            Py_CLEAR(out);
        else
            PyTuple_SET_ITEM(out, o, s);
    }
    return out;
}
