/* y(t) from N_SAMPLES rows of N measured samples, held (INTERP_HOLD) or linear between them, the
 * end rows held, extended or NaN outside them (EXTRAPOLATION), at u = t - time_offset, scaled
 * (twmr.blocks.Data; the same operations as twmr.blocks.data_kernels, SNAP its). */
#include <math.h>
#include "kernel.h"
#include "tables.h"

static double sample(const double *v, double t, int i) {
    const double *times = v + V_times, *values = v + V_values;
    const int last = N_SAMPLES - 1;
    const double below = SNAP * (times[1] - times[0]);
    const double above = SNAP * (times[last] - times[last - 1]);
    double u = t - v[V_time_offset], a, s;
    int k;
    if (u < times[0] - below || u > times[last] + above) {
        if (EXTRAPOLATION == EXTRAP_ERROR) return NAN;
        if (EXTRAPOLATION == EXTRAP_HOLD || INTERP_HOLD)
            return v[V_scale] * values[(u < times[0] ? 0 : last) * N + i];
    } else if (u >= times[last] - above) {
        return v[V_scale] * values[last * N + i];
    } else if (u < times[0]) {
        u = times[0];
    }
    k = interval(times, N_SAMPLES, u);
    if (times[k + 1] - u <= SNAP * (times[k + 1] - times[k])) {
        u = times[k + 1];
        k = interval(times, N_SAMPLES, u);
    } else if (u - times[k] <= SNAP * (times[k + 1] - times[k])) {
        u = times[k];
    }
    if (INTERP_HOLD) return v[V_scale] * values[k * N + i];
    a = values[k * N + i];
    s = (u - times[k]) / (times[k + 1] - times[k]);
    return v[V_scale] * (a + (values[(k + 1) * N + i] - a) * s);
}

static void fill(Model *m, double t) {
    int i;
    for (i = 0; i < N; i++) m->v[V_y + i] = sample(m->v, t, i);
}

void kernel_init(Model *m) { fill(m, m->time); }
void kernel_eval(Model *m) { (void)m; }
void kernel_step(Model *m, double t, double h) { fill(m, t + h); }
