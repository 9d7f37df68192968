/* y = interval floor(u / interval + 1/2), N elements (twmr.blocks.Quantizer). */
#include <math.h>
#include "kernel.h"

void kernel_eval(Model *m) {
    double *v = m->v, q = v[V_interval];
    int i;
    for (i = 0; i < N; i++) v[V_y + i] = q * floor(v[V_u + i] / q + 0.5);
}

void kernel_init(Model *m) { kernel_eval(m); }
void kernel_step(Model *m, double t, double h) { (void)m; (void)t; (void)h; }
