/* Native Embree, the peer of tribench's BVH, called through its own C API.
 *
 * A Scene holds one triangle geometry built by Embree (high build quality,
 * one build thread); trace() runs rtcIntersect1 ray by ray or rtcIntersect16
 * over packets of 16 consecutive rays, closest hit, and returns the time of
 * the loop read in C around it, as tribench's own loops are timed
 * (CLOCK_MONOTONIC, the GIL released). Robust scenes set
 * RTC_SCENE_FLAG_ROBUST, Embree's watertight mode.
 *
 * I. Wald, S. Woop, C. Benthin, G. S. Johnson and M. Ernst, "Embree: a
 * kernel framework for efficient CPU ray tracing", ACM Transactions on
 * Graphics 33(4), 2014. Its API is documented with the library (Embree 3).
 *
 * Arrays arrive checked (tribench/ext/embree.py): float32, C-contiguous,
 * finite, of the sizes passed.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <embree3/rtcore.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>
#include <time.h>

#define TB_CAT2(a, b) a##b
#define TB_CAT(a, b) TB_CAT2(a, b)
#define TB_STR2(a) #a
#define TB_STR(a) TB_STR2(a)

/* The same cap as tribench's own BVH loops: a typo, not a design, beyond it. */
#define TB_MAX_TRACE_RAYS 4000000000LL

typedef struct {
    PyObject_HEAD
    RTCDevice device;
    RTCScene scene;
    Py_ssize_t n_triangles;
    long long build_ns;
} Scene;

static int64_t now_ns(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (int64_t)ts.tv_sec * 1000000000 + ts.tv_nsec;
}

/* Embree reports errors through the device; the first since the last check is raised. */
static int device_failed(RTCDevice device, const char *what)
{
    enum RTCError code = rtcGetDeviceError(device);
    if (code == RTC_ERROR_NONE)
        return 0;
    PyErr_Format(PyExc_RuntimeError, "Embree could not %s (RTCError %d)", what, (int)code);
    return 1;
}

static void scene_dealloc(Scene *self)
{
    if (self->scene)
        rtcReleaseScene(self->scene);
    if (self->device)
        rtcReleaseDevice(self->device);
    Py_TYPE(self)->tp_free((PyObject *)self);
}

/* Scene(vertices, n_triangles, robust, max_isa=None): vertices are n_triangles x 3 x 3 floats;
 * max_isa caps the ISA Embree picks (its device's max_isa, e.g. "avx2"), None lets it choose. */
static int scene_init(Scene *self, PyObject *args, PyObject *kwargs)
{
    Py_buffer v = {0};
    Py_ssize_t n;
    int robust;
    const char *max_isa = NULL;
    static char *names[] = {"vertices", "n_triangles", "robust", "max_isa", NULL};
    if (!PyArg_ParseTupleAndKeywords(args, kwargs, "y*np|z:Scene", names, &v, &n, &robust, &max_isa))
        return -1;
    char config[64] = "threads=1";
    const char *isa_letters = "abcdefghijklmnopqrstuvwxyz0123456789.";
    if (max_isa && (strlen(max_isa) > 16 || strspn(max_isa, isa_letters) != strlen(max_isa))) {
        PyErr_SetString(PyExc_ValueError, "max_isa must be a short lower-case ISA name such as avx2");
        PyBuffer_Release(&v);
        return -1;
    }
    if (max_isa)
        snprintf(config, sizeof config, "threads=1,max_isa=%s", max_isa);
    int failed = -1;
    if (self->device) {
        PyErr_SetString(PyExc_RuntimeError, "a Scene is built once");
        goto done;
    }
    if (n < 1 || n > (Py_ssize_t)UINT32_MAX / 3 || v.len != n * 9 * (Py_ssize_t)sizeof(float)) {
        PyErr_SetString(PyExc_ValueError, "vertices must hold n_triangles x 9 floats, n_triangles >= 1");
        goto done;
    }
    int64_t start = now_ns();
    self->device = rtcNewDevice(config);
    if (!self->device) {
        PyErr_Format(PyExc_RuntimeError, "Embree has no device here (RTCError %d)", (int)rtcGetDeviceError(NULL));
        goto done;
    }
    self->scene = rtcNewScene(self->device);
    rtcSetSceneBuildQuality(self->scene, RTC_BUILD_QUALITY_HIGH);
    rtcSetSceneFlags(self->scene, robust ? RTC_SCENE_FLAG_ROBUST : RTC_SCENE_FLAG_NONE);
    RTCGeometry geometry = rtcNewGeometry(self->device, RTC_GEOMETRY_TYPE_TRIANGLE);
    float *vertices = rtcSetNewGeometryBuffer(geometry, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                              3 * sizeof(float), (size_t)(3 * n));
    unsigned *indices = rtcSetNewGeometryBuffer(geometry, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                3 * sizeof(unsigned), (size_t)n);
    if (!vertices || !indices) {
        rtcReleaseGeometry(geometry);
        device_failed(self->device, "allocate the mesh's buffers");
        goto done;
    }
    memcpy(vertices, v.buf, (size_t)v.len);
    for (Py_ssize_t i = 0; i < 3 * n; i++)
        indices[i] = (unsigned)i; /* triangle k is vertices 3k..3k+2: primID is tribench's index */
    rtcCommitGeometry(geometry);
    rtcAttachGeometry(self->scene, geometry);
    rtcReleaseGeometry(geometry);
    Py_BEGIN_ALLOW_THREADS
    rtcCommitScene(self->scene);
    Py_END_ALLOW_THREADS
    if (device_failed(self->device, "build the scene"))
        goto done;
    self->build_ns = (long long)(now_ns() - start);
    self->n_triangles = n;
    failed = 0;
done:
    PyBuffer_Release(&v);
    return failed;
}

/* What one pass over the rays adds up, and where each ray's answer goes (NULL: not kept). */
typedef struct {
    const float *o, *d, *t_max;
    Py_ssize_t n;
    int64_t *index;
    float *t;
    uint64_t hits;
    double t_sum;
} Pass;

static void keep(Pass *p, Py_ssize_t i, unsigned geom, unsigned prim, float t)
{
    int hit = geom != RTC_INVALID_GEOMETRY_ID;
    if (hit) {
        p->hits++;
        p->t_sum += t;
    }
    if (p->index) {
        p->index[i] = hit ? (int64_t)prim : -1;
        p->t[i] = hit ? t : INFINITY;
    }
}

static void trace_single(RTCScene scene, Pass *p)
{
    struct RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    for (Py_ssize_t i = 0; i < p->n; i++) {
        struct RTCRayHit r;
        r.ray.org_x = p->o[3 * i], r.ray.org_y = p->o[3 * i + 1], r.ray.org_z = p->o[3 * i + 2];
        r.ray.dir_x = p->d[3 * i], r.ray.dir_y = p->d[3 * i + 1], r.ray.dir_z = p->d[3 * i + 2];
        r.ray.tnear = 0.0f, r.ray.tfar = p->t_max[i], r.ray.time = 0.0f;
        r.ray.mask = UINT32_MAX, r.ray.id = 0, r.ray.flags = 0;
        r.hit.geomID = RTC_INVALID_GEOMETRY_ID, r.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
        rtcIntersect1(scene, &context, &r);
        keep(p, i, r.hit.geomID, r.hit.primID, r.ray.tfar);
    }
}

/* Packets of 16 consecutive rays; the last one's missing lanes are masked off. */
static void trace_packets(RTCScene scene, Pass *p)
{
    struct RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    struct RTCRayHit16 r;
    RTC_ALIGN(64) int valid[16];
    for (Py_ssize_t base = 0; base < p->n; base += 16) {
        int m = p->n - base < 16 ? (int)(p->n - base) : 16;
        for (int j = 0; j < 16; j++) {
            Py_ssize_t i = base + (j < m ? j : 0); /* a masked lane repeats a real ray */
            valid[j] = j < m ? -1 : 0;
            r.ray.org_x[j] = p->o[3 * i], r.ray.org_y[j] = p->o[3 * i + 1], r.ray.org_z[j] = p->o[3 * i + 2];
            r.ray.dir_x[j] = p->d[3 * i], r.ray.dir_y[j] = p->d[3 * i + 1], r.ray.dir_z[j] = p->d[3 * i + 2];
            r.ray.tnear[j] = 0.0f, r.ray.tfar[j] = p->t_max[i], r.ray.time[j] = 0.0f;
            r.ray.mask[j] = UINT32_MAX, r.ray.id[j] = 0, r.ray.flags[j] = 0;
            r.hit.geomID[j] = RTC_INVALID_GEOMETRY_ID, r.hit.instID[0][j] = RTC_INVALID_GEOMETRY_ID;
        }
        rtcIntersect16(valid, scene, &context, &r);
        for (int j = 0; j < m; j++)
            keep(p, base + j, r.hit.geomID[j], r.hit.primID[j], r.ray.tfar[j]);
    }
}

/* trace(origins, directions, t_max, n_rays, width, loops[, index, t]) -> (elapsed_ns, hits, t_sum):
 * loops passes, timed together; index and t (writable, n_rays each) get the last pass's answers. */
static PyObject *scene_trace(Scene *self, PyObject *args)
{
    Py_buffer o = {0}, d = {0}, t_max = {0}, index = {0}, t = {0};
    Py_ssize_t n;
    int width;
    long long loops;
    PyObject *result = NULL;
    if (!PyArg_ParseTuple(args, "y*y*y*niL|w*w*:trace", &o, &d, &t_max, &n, &width, &loops, &index, &t))
        return NULL;
    Py_ssize_t floats = n * (Py_ssize_t)sizeof(float);
    if (!self->scene) {
        PyErr_SetString(PyExc_RuntimeError, "the Scene was not built");
        goto done;
    }
    if (n < 1 || o.len != 3 * floats || d.len != 3 * floats || t_max.len != floats ||
        (index.buf && (index.len != n * 8 || t.len != floats))) {
        PyErr_SetString(PyExc_ValueError, "origins and directions must hold n_rays x 3 floats, t_max n_rays");
        goto done;
    }
    if ((width != 1 && width != 16) || loops < 1 || (double)loops * (double)n > (double)TB_MAX_TRACE_RAYS) {
        PyErr_Format(PyExc_ValueError, "width must be 1 or 16, loops at least 1 and loops x rays at most %lld",
                     TB_MAX_TRACE_RAYS);
        goto done;
    }
    Pass pass = {o.buf, d.buf, t_max.buf, n, NULL, NULL, 0, 0.0};
    int64_t start, stop;
    Py_BEGIN_ALLOW_THREADS
    start = now_ns();
    for (long long k = 0; k < loops; k++) {
        if (k == loops - 1 && index.buf)
            pass.index = index.buf, pass.t = t.buf;
        if (width == 1)
            trace_single(self->scene, &pass);
        else
            trace_packets(self->scene, &pass);
    }
    stop = now_ns();
    Py_END_ALLOW_THREADS
    if (device_failed(self->device, "trace the rays"))
        goto done;
    result = Py_BuildValue("LKd", (long long)(stop - start), (unsigned long long)pass.hits, pass.t_sum);
done:
    PyBuffer_Release(&o);
    PyBuffer_Release(&d);
    PyBuffer_Release(&t_max);
    if (index.buf)
        PyBuffer_Release(&index);
    if (t.buf)
        PyBuffer_Release(&t);
    return result;
}

static PyMethodDef scene_methods[] = {
    {"trace", (PyCFunction)scene_trace, METH_VARARGS, "Trace rays: (elapsed_ns, hits, t_sum)."},
    {NULL, NULL, 0, NULL},
};

static PyObject *scene_build_ns(Scene *self, void *closure)
{
    (void)closure;
    return PyLong_FromLongLong(self->build_ns);
}

static PyGetSetDef scene_getset[] = {
    {"build_ns", (getter)scene_build_ns, NULL, "The build's wall time, ns.", NULL},
    {NULL, NULL, NULL, NULL, NULL},
};

static PyTypeObject SceneType = {
    PyVarObject_HEAD_INIT(NULL, 0)
    .tp_name = TB_STR(TB_MODULE_NAME) ".Scene",
    .tp_basicsize = sizeof(Scene),
    .tp_flags = Py_TPFLAGS_DEFAULT,
    .tp_doc = "An Embree scene of one triangle mesh.",
    .tp_new = PyType_GenericNew,
    .tp_init = (initproc)scene_init,
    .tp_dealloc = (destructor)scene_dealloc,
    .tp_methods = scene_methods,
    .tp_getset = scene_getset,
};

static struct PyModuleDef module = {
    PyModuleDef_HEAD_INIT, TB_STR(TB_MODULE_NAME), "Native Embree for tribench's peers.", -1, NULL,
};

PyMODINIT_FUNC TB_CAT(PyInit_, TB_MODULE_NAME)(void)
{
    if (PyType_Ready(&SceneType) < 0)
        return NULL;
    PyObject *m = PyModule_Create(&module);
    if (!m)
        return NULL;
    Py_INCREF(&SceneType);
    if (PyModule_AddObject(m, "Scene", (PyObject *)&SceneType) < 0 ||
        PyModule_AddStringConstant(m, "version", RTC_VERSION_STRING) < 0) {
        Py_DECREF(&SceneType);
        Py_DECREF(m);
        return NULL;
    }
    return m;
}
