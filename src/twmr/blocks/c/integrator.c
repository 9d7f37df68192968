/* x' = k u, y = x, exact for an input held over the step (twmr.blocks.Integrator). */
#include "kernel.h"

void kernel_init(Model *m) { m->v[V_y] = m->v[V_x0]; }
void kernel_eval(Model *m) { (void)m; }
void kernel_step(Model *m, double t, double h) {
    (void)t;
    m->v[V_y] = m->v[V_y] + m->v[V_k] * m->v[V_u] * h;
}
