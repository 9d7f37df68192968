/* Yaw-rate gyro (rate-integrating): at each sample k, the heading change since the last sample
 * over the time between them, plus bias and noise_std n_k (n_k: philox.h); held between
 * samples. The C twin of components/imu.py, in the same order of operations. */
#include <math.h>
#include "kernel.h"
#include "sampled.h"
#include "philox.h"

enum { HEADING, T_LAST, K };  /* work values: heading, time and index of the last sample */

void kernel_eval(Model *m) {
    double *v = m->v, *w = m->w;
    if (!sample_due(m->time, w[T_LAST], v[V_sample_period])) return;
    v[V_yaw_rate] = (v[V_heading] - w[HEADING]) / (m->time - w[T_LAST]) + v[V_bias]
                    + v[V_noise_std] * standard_normal((uint64_t)v[V_seed], (int64_t)w[K] + 1, 0);
}

void kernel_init(Model *m) {
    double *v = m->v;
    m->w[HEADING] = m->w[K] = 0.0;
    m->w[T_LAST] = NAN;  /* sample 0's heading: taken by the first step */
    v[V_yaw_rate] = v[V_bias] + v[V_noise_std] * standard_normal((uint64_t)v[V_seed], 0, 0);
}

void kernel_step(Model *m, double t, double h) {
    double *w = m->w;
    int first = isnan(w[T_LAST]);
    (void)h;
    if (!(first || sample_due(t, w[T_LAST], m->v[V_sample_period]))) return;
    m->time = t;
    kernel_eval(m);
    w[HEADING] = m->v[V_heading];
    w[T_LAST] = t;
    if (!first) w[K] += 1.0;
}
