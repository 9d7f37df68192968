/* y = offset + amplitude sin(2 pi (f0 tau + (f1 - f0) tau^2 / (2 duration)) + phase),
 * tau = max(0, t - time) (twmr.blocks.Chirp). */
#include <math.h>
#include "kernel.h"

static double at(const double *v, double t) {
    double tau = t > v[V_time] ? t - v[V_time] : 0.0;
    double cycles = v[V_f0] * tau + (v[V_f1] - v[V_f0]) * tau * tau / (2.0 * v[V_duration]);
    return v[V_offset] + v[V_amplitude] * sin(2.0 * 3.141592653589793 * cycles + v[V_phase]);
}

void kernel_init(Model *m) { m->v[V_y] = at(m->v, m->time); }
void kernel_eval(Model *m) { (void)m; }
void kernel_step(Model *m, double t, double h) { m->v[V_y] = at(m->v, t + h); }
