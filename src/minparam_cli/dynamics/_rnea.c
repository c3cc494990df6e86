/*
 * Compiled kernel for the inertial part of the Newton-Euler regressor.
 *
 * Same algorithm, frames and parameter order as the numpy version in
 * regressor.py (which stays the reference and the fallback):
 *   forward pass  V_j = V_p + S_j qd_j,  A_j = A_p + S_j qdd_j + (V_j x_m S_j) qd_j,  A_0 = (0, -g),
 *   per link      the wrench about the link origin in link coordinates, K_j (6 x 10), linear in phi_j,
 *   projection    Y[k, 10 j + c] = S_k . (K_j moved to the base origin, base coordinates), k an ancestor of j.
 * One sample at a time, no allocation inside the loop; the GIL is released while it runs.
 * Two layouts of the result: inertial_regressor fills Y (N, n, P) sample-major, as regressor()
 * returns it; inertial_columns writes chosen columns joint-major, out[k, dest[c], s] (a strided
 * block: the rows identify's accumulators take), with no full regressor in between.
 * Only the buffer protocol is used (no numpy headers), so it builds with nothing but a C compiler.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

static inline void cross3(const double *a, const double *b, double *out)
{
    out[0] = a[1] * b[2] - a[2] * b[1];
    out[1] = a[2] * b[0] - a[0] * b[2];
    out[2] = a[0] * b[1] - a[1] * b[0];
}

/* x in base coordinates -> R^T x (R row-major in the 4x4 T). */
static inline void to_local(const double *T, const double *x, double *out)
{
    for (int c = 0; c < 3; c++)
        out[c] = T[c] * x[0] + T[4 + c] * x[1] + T[8 + c] * x[2];
}

/* Wrench regressor about the link origin, link coordinates: rows (moment; force), 10 columns
 * XX XY XZ YY YZ ZZ MX MY MZ M. */
static void link_wrench(const double *w, const double *d, const double *a, double *K)
{
    const double w11 = w[0] * w[0], w22 = w[1] * w[1], w33 = w[2] * w[2];
    const double w12 = w[0] * w[1], w13 = w[0] * w[2], w23 = w[1] * w[2];
    const double k[60] = {
        d[0], d[1] - w13, d[2] + w12, -w23, w22 - w33, w23, 0.0, a[2], -a[1], 0.0,
        w13, d[0] + w23, w33 - w11, d[1], d[2] - w12, -w13, -a[2], 0.0, a[0], 0.0,
        -w12, w11 - w22, d[0] - w23, w12, d[1] + w13, d[2], a[1], -a[0], 0.0, 0.0,
        0.0, 0.0, 0.0, 0.0, 0.0, 0.0, -w22 - w33, w12 - d[2], w13 + d[1], a[0],
        0.0, 0.0, 0.0, 0.0, 0.0, 0.0, w12 + d[2], -w11 - w33, w23 - d[0], a[1],
        0.0, 0.0, 0.0, 0.0, 0.0, 0.0, w13 - d[1], w23 + d[0], -w11 - w22, a[2],
    };
    memcpy(K, k, sizeof k);
}

/* Where the kernel writes: sample-major Y (N, n, P) when dest is NULL, else joint-major:
 * column c of joint k's row at sample s goes to out[k * joint_stride + dest[c] * row_stride + s]
 * (dest[c] < 0: column not wanted). */
typedef struct {
    double *Y;
    Py_ssize_t P;
    const long long *dest;
    Py_ssize_t joint_stride, row_stride;
} Store;

static void regress(const Store *st, Py_ssize_t N, Py_ssize_t n,
                    const double *q, const double *qd, const double *qdd,
                    const double *terms, const double *axor, const long long *parents,
                    const unsigned char *revolute, const double *g, double *work)
{
    double *T = work;      /* n x 16, row-major 4x4 link frames */
    double *S = T + 16 * n; /* n x 6 joint screws at the base origin */
    double *V = S + 6 * n;  /* n x 6 spatial velocities */
    double *A = V + 6 * n;  /* n x 6 spatial accelerations (gravity included) */
    const double zero6[6] = {0, 0, 0, 0, 0, 0};
    const double a0[6] = {0, 0, 0, -g[0], -g[1], -g[2]};

    for (Py_ssize_t s = 0; s < N; s++) {
        const double *qs = q + s * n, *qds = qd + s * n, *qdds = qdd + s * n;
        double *Ys = st->dest == NULL ? st->Y + s * n * st->P : NULL;
        for (Py_ssize_t j = 0; j < n; j++) {
            const double *C0 = terms + 48 * j, *C1 = C0 + 16, *C2 = C0 + 32;
            const double *ax = axor + 6 * j, *org = ax + 3;
            const long long p = parents[j];
            double L[16], z[3], o[3];
            double *Tj = T + 16 * j;
            if (revolute[j]) {
                const double sn = sin(qs[j]), vc = 1.0 - cos(qs[j]);
                for (int i = 0; i < 16; i++)
                    L[i] = C0[i] + sn * C1[i] + vc * C2[i];
            } else {
                for (int i = 0; i < 16; i++)
                    L[i] = C0[i] + qs[j] * C1[i];
            }
            if (p < 0) {
                memcpy(Tj, L, sizeof L);
                memcpy(z, ax, sizeof z);
                memcpy(o, org, sizeof o);
            } else {
                const double *Tp = T + 16 * p;
                for (int r = 0; r < 3; r++) {
                    for (int c = 0; c < 4; c++)
                        Tj[4 * r + c] = Tp[4 * r] * L[c] + Tp[4 * r + 1] * L[4 + c] + Tp[4 * r + 2] * L[8 + c]
                                        + Tp[4 * r + 3] * L[12 + c];
                    z[r] = Tp[4 * r] * ax[0] + Tp[4 * r + 1] * ax[1] + Tp[4 * r + 2] * ax[2];
                    o[r] = Tp[4 * r] * org[0] + Tp[4 * r + 1] * org[1] + Tp[4 * r + 2] * org[2] + Tp[4 * r + 3];
                }
                Tj[12] = 0.0, Tj[13] = 0.0, Tj[14] = 0.0, Tj[15] = 1.0;
            }
            double *Sj = S + 6 * j, *Vj = V + 6 * j, *Aj = A + 6 * j;
            if (revolute[j]) {
                memcpy(Sj, z, sizeof z);
                cross3(o, z, Sj + 3);
            } else {
                Sj[0] = Sj[1] = Sj[2] = 0.0;
                memcpy(Sj + 3, z, sizeof z);
            }
            const double *Vp = p < 0 ? zero6 : V + 6 * p, *Ap = p < 0 ? a0 : A + 6 * p;
            for (int i = 0; i < 6; i++)
                Vj[i] = Vp[i] + Sj[i] * qds[j];
            double c1[3], c2[3], c3[3];
            cross3(Vj, Sj, c1);
            cross3(Vj, Sj + 3, c2);
            cross3(Vj + 3, Sj, c3);
            for (int i = 0; i < 3; i++) {
                Aj[i] = Ap[i] + Sj[i] * qdds[j] + c1[i] * qds[j];
                Aj[3 + i] = Ap[3 + i] + Sj[3 + i] * qdds[j] + (c2[i] + c3[i]) * qds[j];
            }
            /* classical velocity and acceleration of the link origin, then link coordinates */
            const double pos[3] = {Tj[3], Tj[7], Tj[11]};
            double t[3], vo[3], ao[3], wl[3], dwl[3], al[3];
            cross3(Vj, pos, t);
            for (int i = 0; i < 3; i++)
                vo[i] = Vj[3 + i] + t[i];
            cross3(Aj, pos, t);
            for (int i = 0; i < 3; i++)
                ao[i] = Aj[3 + i] + t[i];
            cross3(Vj, vo, t);
            for (int i = 0; i < 3; i++)
                ao[i] += t[i];
            to_local(Tj, Vj, wl);
            to_local(Tj, Aj, dwl);
            to_local(Tj, ao, al);
            double K[60], W[60];
            link_wrench(wl, dwl, al, K);
            /* joint-major: only the columns asked for (a regrouped parameter's are not) */
            const long long *dj = st->dest == NULL ? NULL : st->dest + 10 * j;
            /* to the base origin in base coordinates: f0 = R Kf, n0 = R Kn + pos x f0; the six
             * inertia columns (c < 6) exert no force (K's force rows are zero there) */
            for (int c = 0; c < 6; c++) {
                if (dj != NULL && dj[c] < 0)
                    continue;
                for (int r = 0; r < 3; r++) {
                    const double *R = Tj + 4 * r;
                    W[10 * r + c] = R[0] * K[c] + R[1] * K[10 + c] + R[2] * K[20 + c];
                }
            }
            for (int c = 6; c < 10; c++) {
                if (dj != NULL && dj[c] < 0)
                    continue;
                double f[3], m[3];
                for (int r = 0; r < 3; r++) {
                    const double *R = Tj + 4 * r;
                    f[r] = R[0] * K[30 + c] + R[1] * K[40 + c] + R[2] * K[50 + c];
                    m[r] = R[0] * K[c] + R[1] * K[10 + c] + R[2] * K[20 + c];
                }
                cross3(pos, f, t);
                for (int r = 0; r < 3; r++) {
                    W[10 * r + c] = m[r] + t[r];
                    W[10 * (3 + r) + c] = f[r];
                }
            }
            /* every joint from j back to the root carries link j */
            for (long long k = (long long)j; k >= 0; k = parents[k]) {
                const double *Sk = S + 6 * k;
                /* S_k . W_c; no force in the inertia columns (c < 6) */
                if (Ys != NULL) {
                    double *row = Ys + k * st->P + 10 * j;
                    for (int c = 0; c < 6; c++)
                        row[c] = Sk[0] * W[c] + Sk[1] * W[10 + c] + Sk[2] * W[20 + c];
                    for (int c = 6; c < 10; c++)
                        row[c] = Sk[0] * W[c] + Sk[1] * W[10 + c] + Sk[2] * W[20 + c] + Sk[3] * W[30 + c]
                                 + Sk[4] * W[40 + c] + Sk[5] * W[50 + c];
                } else {
                    double *col = st->Y + k * st->joint_stride + s;
                    for (int c = 0; c < 6; c++)
                        if (dj[c] >= 0)
                            col[dj[c] * st->row_stride] = Sk[0] * W[c] + Sk[1] * W[10 + c] + Sk[2] * W[20 + c];
                    for (int c = 6; c < 10; c++)
                        if (dj[c] >= 0)
                            col[dj[c] * st->row_stride] = Sk[0] * W[c] + Sk[1] * W[10 + c] + Sk[2] * W[20 + c]
                                                          + Sk[3] * W[30 + c] + Sk[4] * W[40 + c] + Sk[5] * W[50 + c];
                }
            }
        }
    }
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
               Py_buffer *terms, Py_buffer *axor, Py_buffer *parents, Py_buffer *revolute, Py_buffer *g)
{
    double *work = (double *)malloc((size_t)(34 * n) * sizeof(double));
    if (work == NULL) {
        PyErr_NoMemory();
        return 0;
    }
    Py_BEGIN_ALLOW_THREADS
    regress(st, N, n, (const double *)q->buf, (const double *)qd->buf, (const double *)qdd->buf,
            (const double *)terms->buf, (const double *)axor->buf, (const long long *)parents->buf,
            (const unsigned char *)revolute->buf, (const double *)g->buf, work);
    Py_END_ALLOW_THREADS
    free(work);
    return 1;
}

static PyObject *inertial_regressor(PyObject *self, PyObject *args)
{
    Py_buffer out, q, qd, qdd, terms, axor, parents, revolute, g;
    Py_ssize_t N, n, P;
    if (!PyArg_ParseTuple(args, "w*y*y*y*y*y*y*y*y*nnn", &out, &q, &qd, &qdd, &terms, &axor, &parents,
                          &revolute, &g, &N, &n, &P))
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
    if (run(&st, N, n, &q, &qd, &qdd, &terms, &axor, &parents, &revolute, &g)) {
        result = Py_None;
        Py_INCREF(result);
    }
done:
    PyBuffer_Release(&out);
    PyBuffer_Release(&q);
    PyBuffer_Release(&qd);
    PyBuffer_Release(&qdd);
    PyBuffer_Release(&terms);
    PyBuffer_Release(&axor);
    PyBuffer_Release(&parents);
    PyBuffer_Release(&revolute);
    PyBuffer_Release(&g);
    return result;
}

static PyObject *inertial_columns(PyObject *self, PyObject *args)
{
    Py_buffer out, q, qd, qdd, terms, axor, parents, revolute, g, dest;
    Py_ssize_t N, n, joint_stride, row_stride;
    if (!PyArg_ParseTuple(args, "w*y*y*y*y*y*y*y*y*y*nnnn", &out, &q, &qd, &qdd, &terms, &axor, &parents,
                          &revolute, &g, &dest, &N, &n, &joint_stride, &row_stride))
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
    /* the columns of links a joint does not carry are zero: their rows are cleared once, whole */
    const long long *par = (const long long *)parents.buf;
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
    if (run(&st, N, n, &q, &qd, &qdd, &terms, &axor, &parents, &revolute, &g)) {
        result = Py_None;
        Py_INCREF(result);
    }
done:
    PyBuffer_Release(&out);
    PyBuffer_Release(&q);
    PyBuffer_Release(&qd);
    PyBuffer_Release(&qdd);
    PyBuffer_Release(&terms);
    PyBuffer_Release(&axor);
    PyBuffer_Release(&parents);
    PyBuffer_Release(&revolute);
    PyBuffer_Release(&g);
    PyBuffer_Release(&dest);
    return result;
}

static PyMethodDef methods[] = {
    {"inertial_regressor", inertial_regressor, METH_VARARGS,
     "inertial_regressor(out, q, qd, qdd, terms, axor, parents, revolute, gravity, N, n, P): fill the "
     "10 n inertial columns of out (N, n, P), C-contiguous float64; other entries are left untouched."},
    {"inertial_columns", inertial_columns, METH_VARARGS,
     "inertial_columns(out, q, qd, qdd, terms, axor, parents, revolute, gravity, dest, N, n, joint_stride, "
     "row_stride): out[k * joint_stride + dest[c] * row_stride + s] = Y[s, k, c] for the 10 n inertial columns c "
     "with dest[c] >= 0 (dest: int64), every joint k and sample s; out float64, C-contiguous."},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef module = {PyModuleDef_HEAD_INIT, "_rnea", "Compiled Newton-Euler regressor kernel.", -1,
                                    methods};

PyMODINIT_FUNC PyInit__rnea(void) { return PyModule_Create(&module); }
