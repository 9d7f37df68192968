/* y(t) from N_TABLE time-value pairs, linear or held between them, the end values outside
 * (twmr.blocks.Table); INTERP_HOLD: zero-order hold. */
#include "kernel.h"
#include "tables.h"

static double at(const double *v, double t) {
    const double *times = v + V_times, *values = v + V_values;
    if (t < times[0]) return values[0];
    if (t >= times[N_TABLE - 1]) return values[N_TABLE - 1];
#if INTERP_HOLD
    return values[interval(times, N_TABLE, t)];
#else
    return interp1(times, values, N_TABLE, t, EXTRAP_HOLD);
#endif
}

void kernel_init(Model *m) { m->v[V_y] = at(m->v, m->time); }
void kernel_eval(Model *m) { (void)m; }
void kernel_step(Model *m, double t, double h) { m->v[V_y] = at(m->v, t + h); }
