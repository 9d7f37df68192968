/* y = 0 in [lower, upper], u - upper above, u - lower below, N elements (twmr.blocks.DeadZone). */
#include "kernel.h"

void kernel_eval(Model *m) {
    double *v = m->v, lo = v[V_lower], hi = v[V_upper];
    int i;
    for (i = 0; i < N; i++) {
        double u = v[V_u + i];
        v[V_y + i] = u < lo ? u - lo : (u > hi ? u - hi : 0.0);
    }
}

void kernel_init(Model *m) { kernel_eval(m); }
void kernel_step(Model *m, double t, double h) { (void)m; (void)t; (void)h; }
