/* y = s1 k1 u1 + s2 k2 u2 + s3 u3 + ... element by element: SUM_N inputs of SUM_W elements
 * each, one after the other, SUM_SIGNS their signs; direct feedthrough (twmr.blocks.Sum). */
#include "kernel.h"

static const double SIGN[SUM_N] = SUM_SIGNS;

void kernel_eval(Model *m) {
    double *v = m->v, g[SUM_N];
    int i, j;
    for (j = 0; j < SUM_N; j++) g[j] = SIGN[j];
    g[0] *= v[V_k1];
    g[1] *= v[V_k2];
    for (i = 0; i < SUM_W; i++) {
        double s = g[0] * v[V_u1 + i];
        for (j = 1; j < SUM_N; j++) s = s + g[j] * v[V_u1 + j * SUM_W + i];
        v[V_y + i] = s;
    }
}

void kernel_init(Model *m) { kernel_eval(m); }
void kernel_step(Model *m, double t, double h) { (void)m; (void)t; (void)h; }
