/*
 * Compiled kernel for the inertial part of the Newton-Euler regressor.
 *
 * Same algorithm, frames and parameter order as the numpy version in
 * regressor.py (which stays the reference and the fallback):
 *   forward pass  V_j = V_p + S_j qd_j,  A_j = A_p + S_j qdd_j + (V_j x_m S_j) qd_j,  A_0 = (0, -g),
 *   per link      the wrench about the link origin in link coordinates, K_j (6 x 10), linear in phi_j,
 *   projection    Y[k, 10 j + c] = S_k . (K_j moved to the base origin, base coordinates), k an ancestor of j.
 * Several samples at a time (_rnea_lanes.h, one instance per width: 1, 2 in 16-byte vectors,
 * 4 in AVX2's 32-byte ones when the processor has them), each lane with exactly the scalar
 * arithmetic; no allocation inside the loop; the GIL is released while it runs.
 * Two layouts of the result: inertial_regressor fills Y (N, n, P) sample-major, as regressor()
 * returns it; inertial_columns writes chosen columns joint-major, out[k, dest[c], s] (a strided
 * block: the rows identify's accumulators take), with no full regressor in between.
 * Only the buffer protocol is used (no numpy headers), so it builds with nothing but a C compiler.
 */
#define PY_SSIZE_T_CLEAN
/* no fused multiply-add: a contracted a*b + c rounds once, so a lane width whose instructions have
 * FMA (arm64's NEON, say) would differ from the others in the last bit */
#if defined(__clang__)
#pragma clang fp contract(off)
#elif defined(__GNUC__)
#pragma GCC optimize("fp-contract=off")
#endif
#include <Python.h>
#include <math.h>
#include <stdlib.h>
#include <stdint.h>
#include <string.h>

/* Where the kernel writes: sample-major Y (N, n, P) when dest is NULL, else joint-major:
 * column c of joint k's row at sample s goes to out[k * joint_stride + dest[c] * row_stride + s]
 * (dest[c] < 0: column not wanted). */
typedef struct {
    double *Y;
    Py_ssize_t P;
    const long long *dest;
    Py_ssize_t joint_stride, row_stride;
} Store;

typedef void (*Kernel)(const Store *, Py_ssize_t, Py_ssize_t, const double *, const double *, const double *,
                       const double *, const double *, const long long *, const unsigned char *, const double *,
                       void *);

/* one sample at a time: any C compiler */
#define LANES 1
#define LANE(v, l) (v)
#define NAME(f) f##1
#define ATTR
typedef double vd1;
#define vd vd1
#include "_rnea_lanes.h"
#undef vd
#undef LANES
#undef LANE
#undef NAME
#undef ATTR

#if defined(__GNUC__) || defined(__clang__)
/* two samples at a time in 16-byte vectors (SSE2 on every x86-64, NEON on arm64) */
#define LANES 2
#define LANE(v, l) ((v)[l])
#define NAME(f) f##2
#define ATTR
typedef double vd2 __attribute__((vector_size(16)));
#define vd vd2
#include "_rnea_lanes.h"
#undef vd
#undef LANES
#undef LANE
#undef NAME
#undef ATTR
#define HAVE_LANES2 1
#endif

#if (defined(__GNUC__) || defined(__clang__)) && defined(__x86_64__)
/* four samples at a time in AVX2's 32-byte vectors, used when the processor has them */
#define LANES 4
#define LANE(v, l) ((v)[l])
#define NAME(f) f##4
#define ATTR __attribute__((target("avx2")))
typedef double vd4 __attribute__((vector_size(32)));
#define vd vd4
#include "_rnea_lanes.h"
#undef vd
#undef LANES
#undef LANE
#undef NAME
#undef ATTR
#define HAVE_LANES4 1
#endif

/* The widest width this build and processor have, or ``lanes`` itself when it is one of them
 * (tests compare every width); 0 when ``lanes`` is not available. */
static int pick(int lanes, Kernel *kernel, size_t *vector_bytes)
{
    int best = 1;
#ifdef HAVE_LANES2
    best = 2;
#endif
#ifdef HAVE_LANES4
    if (__builtin_cpu_supports("avx2"))
        best = 4;
#endif
    if (lanes == 0)
        lanes = best;
    if (lanes == 1) {
        *kernel = (Kernel)regress1, *vector_bytes = sizeof(vd1);
        return 1;
    }
#ifdef HAVE_LANES2
    if (lanes == 2) {
        *kernel = (Kernel)regress2, *vector_bytes = sizeof(vd2);
        return 2;
    }
#endif
#ifdef HAVE_LANES4
    if (lanes == 4 && best == 4) {
        *kernel = (Kernel)regress4, *vector_bytes = sizeof(vd4);
        return 4;
    }
#endif
    return 0;
}

static int need(Py_buffer *b, Py_ssize_t bytes, const char *what)
{
    if (b->len != bytes) {
        PyErr_Format(PyExc_ValueError, "_rnea: %s has %zd bytes, expected %zd", what, b->len, bytes);
        return 0;
    }
    return 1;
}

static int check_chain(Py_ssize_t N, Py_ssize_t n, Py_buffer *q, Py_buffer *qd, Py_buffer *qdd, Py_buffer *terms,
                       Py_buffer *axor, Py_buffer *parents, Py_buffer *revolute, Py_buffer *g)
{
    const Py_ssize_t d = (Py_ssize_t)sizeof(double);
    if (N < 0 || n < 1) {
        PyErr_SetString(PyExc_ValueError, "_rnea: bad sizes");
        return 0;
    }
    if (!need(q, N * n * d, "q") || !need(qd, N * n * d, "qd") || !need(qdd, N * n * d, "qdd")
        || !need(terms, 48 * n * d, "terms") || !need(axor, 6 * n * d, "axor")
        || !need(parents, n * (Py_ssize_t)sizeof(long long), "parents") || !need(revolute, n, "revolute")
        || !need(g, 3 * d, "gravity"))
        return 0;
    for (Py_ssize_t j = 0; j < n; j++) {
        const long long pj = ((const long long *)parents->buf)[j];
        if (pj >= j || pj < -1) {
            PyErr_SetString(PyExc_ValueError, "_rnea: parents must precede their children");
            return 0;
        }
    }
    return 1;
}

static int run(const Store *st, Py_ssize_t N, Py_ssize_t n, Py_buffer *q, Py_buffer *qd, Py_buffer *qdd,
               Py_buffer *terms, Py_buffer *axor, Py_buffer *parents, Py_buffer *revolute, Py_buffer *g, int lanes)
{
    Kernel kernel;
    size_t bytes;
    if (!pick(lanes, &kernel, &bytes)) {
        PyErr_Format(PyExc_ValueError, "_rnea: no kernel %d samples wide here", lanes);
        return 0;
    }
    /* T, S, V, A and the lanes' states: 37 n vectors, aligned for them (malloc's alignment may be less) */
    char *raw = (char *)malloc((size_t)(37 * n) * bytes + 32);
    if (raw == NULL) {
        PyErr_NoMemory();
        return 0;
    }
    void *work = raw + (32 - (size_t)((uintptr_t)raw % 32)) % 32;
    Py_BEGIN_ALLOW_THREADS
    kernel(st, N, n, (const double *)q->buf, (const double *)qd->buf, (const double *)qdd->buf,
           (const double *)terms->buf, (const double *)axor->buf, (const long long *)parents->buf,
           (const unsigned char *)revolute->buf, (const double *)g->buf, work);
    Py_END_ALLOW_THREADS
    free(raw);
    return 1;
}

static PyObject *lane_widths(PyObject *self, PyObject *args)
{
    PyObject *out = PyList_New(0);
    Kernel kernel;
    size_t bytes;
    for (int lanes = 1; out != NULL && lanes <= 4; lanes *= 2) {
        if (pick(lanes, &kernel, &bytes)) {
            PyObject *v = PyLong_FromLong(lanes);
            if (v == NULL || PyList_Append(out, v) < 0) {
                Py_XDECREF(v);
                Py_DECREF(out);
                return NULL;
            }
            Py_DECREF(v);
        }
    }
    return out;
}

/* the buffers an entry point took; the last may be NULL (inertial_regressor has no dest) */
static void release(Py_buffer *out, Py_buffer *q, Py_buffer *qd, Py_buffer *qdd, Py_buffer *terms, Py_buffer *axor,
                    Py_buffer *parents, Py_buffer *revolute, Py_buffer *g, Py_buffer *dest)
{
    Py_buffer *all[] = {out, q, qd, qdd, terms, axor, parents, revolute, g, dest};
    for (int i = 0; i < 10; i++)
        if (all[i] != NULL)
            PyBuffer_Release(all[i]);
}

static PyObject *inertial_regressor(PyObject *self, PyObject *args)
{
    Py_buffer out, q, qd, qdd, terms, axor, parents, revolute, g;
    Py_ssize_t N, n, P;
    int lanes = 0;
    if (!PyArg_ParseTuple(args, "w*y*y*y*y*y*y*y*y*nnn|i", &out, &q, &qd, &qdd, &terms, &axor, &parents,
                          &revolute, &g, &N, &n, &P, &lanes))
        return NULL;
    PyObject *result = NULL;
    Store st = {(double *)out.buf, P, NULL, 0, 0};
    if (!check_chain(N, n, &q, &qd, &qdd, &terms, &axor, &parents, &revolute, &g))
        goto done;
    if (P < 10 * n) {
        PyErr_SetString(PyExc_ValueError, "_rnea: bad sizes");
        goto done;
    }
    if (!need(&out, N * n * P * (Py_ssize_t)sizeof(double), "out"))
        goto done;
    if (run(&st, N, n, &q, &qd, &qdd, &terms, &axor, &parents, &revolute, &g, lanes)) {
        result = Py_None;
        Py_INCREF(result);
    }
done:
    release(&out, &q, &qd, &qdd, &terms, &axor, &parents, &revolute, &g, NULL);
    return result;
}

static PyObject *inertial_columns(PyObject *self, PyObject *args)
{
    Py_buffer out, q, qd, qdd, terms, axor, parents, revolute, g, dest;
    Py_ssize_t N, n, joint_stride, row_stride;
    int lanes = 0;
    if (!PyArg_ParseTuple(args, "w*y*y*y*y*y*y*y*y*y*nnnn|i", &out, &q, &qd, &qdd, &terms, &axor, &parents,
                          &revolute, &g, &dest, &N, &n, &joint_stride, &row_stride, &lanes))
        return NULL;
    PyObject *result = NULL;
    const long long *dst = (const long long *)dest.buf;
    Store st = {(double *)out.buf, 0, dst, joint_stride, row_stride};
    if (!check_chain(N, n, &q, &qd, &qdd, &terms, &axor, &parents, &revolute, &g)
        || !need(&dest, 10 * n * (Py_ssize_t)sizeof(long long), "dest"))
        goto done;
    /* every address written must lie in out: the largest is (n-1) joint_stride + max dest row_stride + N-1 */
    long long top = -1;
    for (Py_ssize_t c = 0; c < 10 * n; c++)
        top = dst[c] > top ? dst[c] : top;
    if (joint_stride < 0 || row_stride < N
        || (top >= 0 && (n - 1) * joint_stride + top * row_stride + N > out.len / (Py_ssize_t)sizeof(double))) {
        PyErr_SetString(PyExc_ValueError, "_rnea: out is too small for the strides and rows asked");
        goto done;
    }
    /* the columns of links a joint does not carry are zero: their rows are cleared once, whole (3 MB
       a 4,096-sample block of the Panda: without the GIL, as the kernel runs) */
    const long long *par = (const long long *)parents.buf;
    Py_BEGIN_ALLOW_THREADS
    for (Py_ssize_t k = 0; k < n; k++)
        for (Py_ssize_t j = 0; j < n; j++) {
            long long a = (long long)j;
            while (a > (long long)k)
                a = par[a];
            if (a == (long long)k)
                continue; /* k carries j */
            for (int c = 0; c < 10; c++)
                if (dst[10 * j + c] >= 0)
                    memset(st.Y + k * joint_stride + dst[10 * j + c] * row_stride, 0, (size_t)N * sizeof(double));
        }
    Py_END_ALLOW_THREADS
    if (run(&st, N, n, &q, &qd, &qdd, &terms, &axor, &parents, &revolute, &g, lanes)) {
        result = Py_None;
        Py_INCREF(result);
    }
done:
    release(&out, &q, &qd, &qdd, &terms, &axor, &parents, &revolute, &g, &dest);
    return result;
}

static PyMethodDef methods[] = {
    {"inertial_regressor", inertial_regressor, METH_VARARGS,
     "inertial_regressor(out, q, qd, qdd, terms, axor, parents, revolute, gravity, N, n, P): fill the "
     "10 n inertial columns of out (N, n, P), C-contiguous float64; other entries are left untouched. "
     "lanes (optional): samples computed at a time, one of lane_widths() (0: the widest)."},
    {"inertial_columns", inertial_columns, METH_VARARGS,
     "inertial_columns(out, q, qd, qdd, terms, axor, parents, revolute, gravity, dest, N, n, joint_stride, "
     "row_stride): out[k * joint_stride + dest[c] * row_stride + s] = Y[s, k, c] for the 10 n inertial columns c "
     "with dest[c] >= 0 (dest: int64), every joint k and sample s; out float64, C-contiguous; lanes as above."},
    {"lane_widths", lane_widths, METH_NOARGS,
     "lane_widths(): the numbers of samples this build computes at a time on this processor (1, 2, 4); every "
     "width gives the same numbers, bit for bit."},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef module = {PyModuleDef_HEAD_INIT, "_rnea", "Compiled Newton-Euler regressor kernel.", -1,
                                    methods};

PyMODINIT_FUNC PyInit__rnea(void) { return PyModule_Create(&module); }
