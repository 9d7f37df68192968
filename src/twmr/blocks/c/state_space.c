/* x' = A x + B u, y = C x + D u with N_SS states, N_IN inputs and N_OUT outputs
 * (twmr.blocks.StateSpace), discretised exactly for an input held over the step:
 * exp([[A, B], [0, 0]] h) = [[A_d, B_d], [0, I]], computed by scaling and squaring of a Taylor
 * series (expm.h). Matrices row by row. */
#include <math.h>
#include <string.h>
#include "kernel.h"

#define N1 (N_SS + N_IN)
#define EXPM_N N1
#include "expm.h"

enum { AD = 0, BD = N_SS * N_SS, X = BD + N_SS * N_IN, H_LAST = X + N_SS };  /* work values */

static void output(Model *m) {
    int i, j;
    for (i = 0; i < N_OUT; i++) {
        double y = 0.0, du = 0.0;
        for (j = 0; j < N_SS; j++) y += m->v[V_C + i * N_SS + j] * m->w[X + j];
        for (j = 0; j < N_IN; j++) du += m->v[V_D + i * N_IN + j] * m->v[V_u + j];
        m->v[V_y + i] = N_IN == 1 ? y + m->v[V_D + i] * m->v[V_u] : y + du;
    }
}

void kernel_init(Model *m) {
    memcpy(m->w + X, m->v + V_x0, N_SS * sizeof(double));
    m->w[H_LAST] = NAN;
    output(m);
}

void kernel_eval(Model *m) { output(m); }

void kernel_step(Model *m, double t, double h) {
    double *w = m->w, x[N_SS];
    int i, j;
    (void)t;
    if (h != w[H_LAST]) {
        double M[N1 * N1], E[N1 * N1];
        memset(M, 0, sizeof M);
        for (i = 0; i < N_SS; i++) {
            for (j = 0; j < N_SS; j++) M[i * N1 + j] = m->v[V_A + i * N_SS + j] * h;
            for (j = 0; j < N_IN; j++) M[i * N1 + N_SS + j] = m->v[V_B + i * N_IN + j] * h;
        }
        expm(M, E);
        for (i = 0; i < N_SS; i++) {
            for (j = 0; j < N_SS; j++) w[AD + i * N_SS + j] = E[i * N1 + j];
            for (j = 0; j < N_IN; j++) w[BD + i * N_IN + j] = E[i * N1 + N_SS + j];
        }
        w[H_LAST] = h;
    }
    for (i = 0; i < N_SS; i++) {
        x[i] = 0.0;
        for (j = 0; j < N_IN; j++) x[i] += w[BD + i * N_IN + j] * m->v[V_u + j];
        for (j = 0; j < N_SS; j++) x[i] += w[AD + i * N_SS + j] * w[X + j];
    }
    memcpy(w + X, x, sizeof x);
    output(m);
}
