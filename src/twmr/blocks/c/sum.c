/* y = k1 u1 + k2 u2, direct feedthrough (twmr.blocks.Sum). */
#include "kernel.h"

void kernel_eval(Model *m) {
    double *v = m->v;
    v[V_y] = v[V_k1] * v[V_u1] + v[V_k2] * v[V_u2];
}

void kernel_init(Model *m) { kernel_eval(m); }
void kernel_step(Model *m, double t, double h) { (void)m; (void)t; (void)h; }
