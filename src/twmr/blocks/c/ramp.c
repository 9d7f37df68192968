/* y(t) = offset + slope max(0, t - time) (twmr.blocks.Ramp). */
#include "kernel.h"

static double at(const double *v, double t) {
    return v[V_offset] + (t > v[V_time] ? v[V_slope] * (t - v[V_time]) : 0.0);
}

void kernel_init(Model *m) { m->v[V_y] = at(m->v, m->time); }
void kernel_eval(Model *m) { (void)m; }
void kernel_step(Model *m, double t, double h) { m->v[V_y] = at(m->v, t + h); }
