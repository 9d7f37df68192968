/* y = num(s)/den(s) u with TF_N states (twmr.blocks.TransferFunction): the controllable
 * canonical realisation of twmr.blocks.discrete.realise, discretised for the step h by zero-order
 * hold (TF_METHOD 0: exp([[A, B], [0, 0]] h) = [[A_d, B_d], [0, 1]], expm.h) or taken as it is
 * (TF_METHOD 2: coefficients in z). NUM_LEN numerator coefficients. */
#include <math.h>
#include <string.h>
#include "kernel.h"

#define N1 (TF_N + 1)
#define EXPM_N N1
#include "expm.h"

enum { A = 0, B = A + TF_N * TF_N, C = B + TF_N, D = C + TF_N, AD = D + 1, BD = AD + TF_N * TF_N,
       X = BD + TF_N, H_LAST = X + TF_N };  /* work values */

static void realise(Model *m) {
    double *w = m->w, a[N1], b[N1], d0 = m->v[V_den];
    int i, off = NUM_LEN - N1;
    for (i = 0; i < N1; i++) {
        a[i] = m->v[V_den + i] / d0;
        b[i] = i + off >= 0 ? m->v[V_num + i + off] / d0 : 0.0;
    }
    memset(w, 0, (size_t)AD * sizeof(double));
    for (i = 0; i < TF_N; i++) {
        w[A + i] = -a[i + 1];
        if (i > 0) w[A + i * TF_N + i - 1] = 1.0;
        w[C + i] = b[i + 1] - a[i + 1] * b[0];
    }
    w[B] = 1.0;
    w[D] = b[0];
}

static void output(Model *m) {
    double y = 0.0;
    int i;
    for (i = 0; i < TF_N; i++) y += m->w[C + i] * m->w[X + i];
    m->v[V_y] = y + m->w[D] * m->v[V_u];
}

void kernel_init(Model *m) {
    realise(m);
    memset(m->w + X, 0, TF_N * sizeof(double));
    m->w[H_LAST] = NAN;
    output(m);
}

void kernel_eval(Model *m) { output(m); }

static void discretise(double *w, double h) {
    int i, j;
    if (TF_METHOD == 2) {
        memcpy(w + AD, w + A, (TF_N * TF_N + TF_N) * sizeof(double));
        return;
    }
    {
        double M[N1 * N1], E[N1 * N1];
        memset(M, 0, sizeof M);
        for (i = 0; i < TF_N; i++) {
            for (j = 0; j < TF_N; j++) M[i * N1 + j] = w[A + i * TF_N + j] * h;
            M[i * N1 + TF_N] = w[B + i] * h;
        }
        expm(M, E);
        for (i = 0; i < TF_N; i++) {
            for (j = 0; j < TF_N; j++) w[AD + i * TF_N + j] = E[i * N1 + j];
            w[BD + i] = E[i * N1 + TF_N];
        }
    }
}

void kernel_step(Model *m, double t, double h) {
    double *w = m->w, x[TF_N];
    int i, j;
    (void)t;
    if (h != w[H_LAST]) {
        discretise(w, h);
        w[H_LAST] = h;
    }
    for (i = 0; i < TF_N; i++) {
        x[i] = w[BD + i] * m->v[V_u];
        for (j = 0; j < TF_N; j++) x[i] += w[AD + i * TF_N + j] * w[X + j];
    }
    memcpy(w + X, x, sizeof x);
    output(m);
}
