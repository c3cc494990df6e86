/* The regressor kernel's loop for one lane width, included by _rnea.c once per width with
 *   vd         the type of LANES doubles (double itself when LANES is 1),
 *   LANES      the samples computed at a time,
 *   LANE(v, l) lane l of a vd,
 *   NAME(f)    f with the width in its name, ATTR the functions' target attribute (or nothing).
 * Every lane does the scalar arithmetic in the same order (no fused multiply-add is enabled),
 * so each lane's numbers are those of one sample computed on its own, whatever the width. */

ATTR static inline void NAME(cross3)(const vd *a, const vd *b, vd *out)
{
    out[0] = a[1] * b[2] - a[2] * b[1];
    out[1] = a[2] * b[0] - a[0] * b[2];
    out[2] = a[0] * b[1] - a[1] * b[0];
}

/* x in base coordinates -> R^T x (R row-major in the 4x4 T). */
ATTR static inline void NAME(to_local)(const vd *T, const vd *x, vd *out)
{
    for (int c = 0; c < 3; c++)
        out[c] = T[c] * x[0] + T[4 + c] * x[1] + T[8 + c] * x[2];
}

/* Wrench regressor about the link origin, link coordinates: rows (moment; force), 10 columns
 * XX XY XZ YY YZ ZZ MX MY MZ M. */
ATTR static void NAME(link_wrench)(const vd *w, const vd *d, const vd *a, vd *K)
{
    const vd w11 = w[0] * w[0], w22 = w[1] * w[1], w33 = w[2] * w[2];
    const vd w12 = w[0] * w[1], w13 = w[0] * w[2], w23 = w[1] * w[2];
    const vd zero = {0.0};
    const vd k[60] = {
        d[0], d[1] - w13, d[2] + w12, -w23, w22 - w33, w23, zero, a[2], -a[1], zero,
        w13, d[0] + w23, w33 - w11, d[1], d[2] - w12, -w13, -a[2], zero, a[0], zero,
        -w12, w11 - w22, d[0] - w23, w12, d[1] + w13, d[2], a[1], -a[0], zero, zero,
        zero, zero, zero, zero, zero, zero, -w22 - w33, w12 - d[2], w13 + d[1], a[0],
        zero, zero, zero, zero, zero, zero, w12 + d[2], -w11 - w33, w23 - d[0], a[1],
        zero, zero, zero, zero, zero, zero, w13 - d[1], w23 + d[0], -w11 - w22, a[2],
    };
    memcpy(K, k, sizeof k);
}

/* lanes [0, m) of v to the m samples from s on: consecutive doubles at out (joint-major), or one
 * entry per sample P·n apart (sample-major) */
ATTR static inline void NAME(put)(const vd v, double *out, Py_ssize_t step, int m)
{
    for (int l = 0; l < m; l++)
        out[l * step] = LANE(v, l);
}

ATTR static void NAME(regress)(const Store *st, Py_ssize_t N, Py_ssize_t n,
                    const double *q, const double *qd, const double *qdd,
                    const double *terms, const double *axor, const long long *parents,
                    const unsigned char *revolute, const double *g, void *workv)
{
    vd *work = (vd *)workv;
    vd *T = work;          /* n x 16, row-major 4x4 link frames */
    vd *S = T + 16 * n;    /* n x 6 joint screws at the base origin */
    vd *V = S + 6 * n;     /* n x 6 spatial velocities */
    vd *A = V + 6 * n;     /* n x 6 spatial accelerations (gravity included) */
    vd *Q = A + 6 * n;     /* n x 3: q, qd, qdd of the lanes */
    const vd zero = {0.0};
    vd a0[6] = {zero, zero, zero, zero, zero, zero};
    for (int i = 0; i < 3; i++)
        a0[3 + i] = zero - g[i];
    const vd zero6[6] = {zero, zero, zero, zero, zero, zero};

    for (Py_ssize_t s = 0; s < N; s += LANES) {
        const int m = N - s < LANES ? (int)(N - s) : LANES; /* lanes past the end compute q = 0, unused */
        for (Py_ssize_t j = 0; j < n; j++)
            for (int l = 0; l < LANES; l++) {
                const int in = l < m;
                LANE(Q[3 * j], l) = in ? q[(s + l) * n + j] : 0.0;
                LANE(Q[3 * j + 1], l) = in ? qd[(s + l) * n + j] : 0.0;
                LANE(Q[3 * j + 2], l) = in ? qdd[(s + l) * n + j] : 0.0;
            }
        for (Py_ssize_t j = 0; j < n; j++) {
            const double *C0 = terms + 48 * j, *C1 = C0 + 16, *C2 = C0 + 32;
            const double *ax = axor + 6 * j, *org = ax + 3;
            const long long p = parents[j];
            const vd qj = Q[3 * j], qdj = Q[3 * j + 1], qddj = Q[3 * j + 2];
            vd L[16], z[3], o[3];
            vd *Tj = T + 16 * j;
            if (revolute[j]) {
                vd sn, vc;
                for (int l = 0; l < LANES; l++) {
                    LANE(sn, l) = sin(LANE(qj, l));
                    LANE(vc, l) = 1.0 - cos(LANE(qj, l));
                }
                for (int i = 0; i < 16; i++)
                    L[i] = C0[i] + sn * C1[i] + vc * C2[i];
            } else {
                for (int i = 0; i < 16; i++)
                    L[i] = C0[i] + qj * C1[i];
            }
            if (p < 0) {
                memcpy(Tj, L, sizeof L);
                for (int i = 0; i < 3; i++) {
                    z[i] = zero + ax[i];
                    o[i] = zero + org[i];
                }
            } else {
                const vd *Tp = T + 16 * p;
                for (int r = 0; r < 3; r++) {
                    for (int c = 0; c < 4; c++)
                        Tj[4 * r + c] = Tp[4 * r] * L[c] + Tp[4 * r + 1] * L[4 + c] + Tp[4 * r + 2] * L[8 + c]
                                        + Tp[4 * r + 3] * L[12 + c];
                    z[r] = Tp[4 * r] * ax[0] + Tp[4 * r + 1] * ax[1] + Tp[4 * r + 2] * ax[2];
                    o[r] = Tp[4 * r] * org[0] + Tp[4 * r + 1] * org[1] + Tp[4 * r + 2] * org[2] + Tp[4 * r + 3];
                }
                Tj[12] = zero, Tj[13] = zero, Tj[14] = zero, Tj[15] = zero + 1.0;
            }
            vd *Sj = S + 6 * j, *Vj = V + 6 * j, *Aj = A + 6 * j;
            if (revolute[j]) {
                memcpy(Sj, z, sizeof z);
                NAME(cross3)(o, z, Sj + 3);
            } else {
                Sj[0] = Sj[1] = Sj[2] = zero;
                memcpy(Sj + 3, z, sizeof z);
            }
            const vd *Vp = p < 0 ? zero6 : V + 6 * p, *Ap = p < 0 ? a0 : A + 6 * p;
            for (int i = 0; i < 6; i++)
                Vj[i] = Vp[i] + Sj[i] * qdj;
            vd c1[3], c2[3], c3[3];
            NAME(cross3)(Vj, Sj, c1);
            NAME(cross3)(Vj, Sj + 3, c2);
            NAME(cross3)(Vj + 3, Sj, c3);
            for (int i = 0; i < 3; i++) {
                Aj[i] = Ap[i] + Sj[i] * qddj + c1[i] * qdj;
                Aj[3 + i] = Ap[3 + i] + Sj[3 + i] * qddj + (c2[i] + c3[i]) * qdj;
            }
            /* classical velocity and acceleration of the link origin, then link coordinates */
            const vd pos[3] = {Tj[3], Tj[7], Tj[11]};
            vd t[3], vo[3], ao[3], wl[3], dwl[3], al[3];
            NAME(cross3)(Vj, pos, t);
            for (int i = 0; i < 3; i++)
                vo[i] = Vj[3 + i] + t[i];
            NAME(cross3)(Aj, pos, t);
            for (int i = 0; i < 3; i++)
                ao[i] = Aj[3 + i] + t[i];
            NAME(cross3)(Vj, vo, t);
            for (int i = 0; i < 3; i++)
                ao[i] += t[i];
            NAME(to_local)(Tj, Vj, wl);
            NAME(to_local)(Tj, Aj, dwl);
            NAME(to_local)(Tj, ao, al);
            vd K[60], W[60];
            NAME(link_wrench)(wl, dwl, al, K);
            /* joint-major: only the columns asked for (a regrouped parameter's are not) */
            const long long *dj = st->dest == NULL ? NULL : st->dest + 10 * j;
            /* to the base origin in base coordinates: f0 = R Kf, n0 = R Kn + pos x f0; the six
             * inertia columns (c < 6) exert no force (K's force rows are zero there) */
            for (int c = 0; c < 6; c++) {
                if (dj != NULL && dj[c] < 0)
                    continue;
                for (int r = 0; r < 3; r++) {
                    const vd *R = Tj + 4 * r;
                    W[10 * r + c] = R[0] * K[c] + R[1] * K[10 + c] + R[2] * K[20 + c];
                }
            }
            for (int c = 6; c < 10; c++) {
                if (dj != NULL && dj[c] < 0)
                    continue;
                vd f[3], mo[3];
                for (int r = 0; r < 3; r++) {
                    const vd *R = Tj + 4 * r;
                    f[r] = R[0] * K[30 + c] + R[1] * K[40 + c] + R[2] * K[50 + c];
                    mo[r] = R[0] * K[c] + R[1] * K[10 + c] + R[2] * K[20 + c];
                }
                NAME(cross3)(pos, f, t);
                for (int r = 0; r < 3; r++) {
                    W[10 * r + c] = mo[r] + t[r];
                    W[10 * (3 + r) + c] = f[r];
                }
            }
            /* every joint from j back to the root carries link j: S_k . W_c (no force for c < 6) */
            for (long long k = (long long)j; k >= 0; k = parents[k]) {
                const vd *Sk = S + 6 * k;
                double *base;
                Py_ssize_t step;
                if (dj == NULL) {
                    base = st->Y + s * n * st->P + k * st->P + 10 * j;
                    step = n * st->P;
                } else {
                    base = st->Y + k * st->joint_stride + s;
                    step = 1;
                }
                for (int c = 0; c < 10; c++) {
                    if (dj != NULL && dj[c] < 0)
                        continue;
                    vd v = Sk[0] * W[c] + Sk[1] * W[10 + c] + Sk[2] * W[20 + c];
                    if (c >= 6)
                        v = v + Sk[3] * W[30 + c] + Sk[4] * W[40 + c] + Sk[5] * W[50 + c];
                    NAME(put)(v, dj == NULL ? base + c : base + dj[c] * st->row_stride, step, m);
                }
            }
        }
    }
}

