/* y = k u element by element (GAIN_MATRIX 0, N_OUT = N_IN), or y = K u, K of N_OUT x N_IN row by
 * row (GAIN_MATRIX 1); direct feedthrough (twmr.blocks.Gain). */
#include "kernel.h"

void kernel_eval(Model *m) {
    double *v = m->v;
    int i, j;
    for (i = 0; i < N_OUT; i++) {
#if GAIN_MATRIX
        double s = v[V_K + i * N_IN] * v[V_u];
        for (j = 1; j < N_IN; j++) s = s + v[V_K + i * N_IN + j] * v[V_u + j];
        v[V_y + i] = s;
#else
        (void)j;
        v[V_y + i] = v[V_k] * v[V_u + i];
#endif
    }
}

void kernel_init(Model *m) { kernel_eval(m); }
void kernel_step(Model *m, double t, double h) { (void)m; (void)t; (void)h; }
