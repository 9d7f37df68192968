/* y(t) = offset + amplitude sin(2 pi f t + phase) (twmr.blocks.Sine). */
#include <math.h>
#include "kernel.h"

static double at(const double *v, double t) {
    return v[V_offset] + v[V_amplitude] * sin(2.0 * 3.141592653589793 * v[V_frequency] * t + v[V_phase]);
}

void kernel_init(Model *m) { m->v[V_y] = at(m->v, m->time); }
void kernel_eval(Model *m) { (void)m; }
void kernel_step(Model *m, double t, double h) { m->v[V_y] = at(m->v, t + h); }
