/* y = offset + amplitude while fmod(t - delay, period) < width, t >= delay (twmr.blocks.Pulse). */
#include <math.h>
#include "kernel.h"

static double at(const double *v, double t) {
    if (t < v[V_delay]) return v[V_offset];
    return v[V_offset] + (fmod(t - v[V_delay], v[V_period]) < v[V_width] ? v[V_amplitude] : 0.0);
}

void kernel_init(Model *m) { m->v[V_y] = at(m->v, m->time); }
void kernel_eval(Model *m) { (void)m; }
void kernel_step(Model *m, double t, double h) { m->v[V_y] = at(m->v, t + h); }
