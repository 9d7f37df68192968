/* y = min(max(u, lower), upper) for each of N elements (twmr.blocks.Saturation). */
#include "kernel.h"

void kernel_eval(Model *m) {
    double *v = m->v, lo = v[V_lower], hi = v[V_upper];
    int i;
    for (i = 0; i < N; i++) {
        double u = v[V_u + i];
        v[V_y + i] = u < lo ? lo : (u > hi ? hi : u);
    }
}

void kernel_init(Model *m) { kernel_eval(m); }
void kernel_step(Model *m, double t, double h) { (void)m; (void)t; (void)h; }
