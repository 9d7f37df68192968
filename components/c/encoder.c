/* Incremental encoders of the two wheels: counts N = floor(phi cpr / (2 pi)), quantised angle
 * N 2 pi / cpr, speed (N - N_last) 2 pi / (cpr (t - t_last)) at each sample, held between. The C
 * twin of components/encoder.py, in the same order of operations. */
#include <math.h>
#include "kernel.h"
#include "sampled.h"

#define TWO_PI (2.0 * 3.141592653589793)
enum { COUNT, T_LAST = 2 };  /* work values: the counts and time of the last sample */

void kernel_eval(Model *m) {
    double *v = m->v, cpr = v[V_cpr];
    int due = sample_due(m->time, m->w[T_LAST], v[V_sample_period]), j;
    for (j = 0; j < 2; j++) {
        double n = floor(v[V_angle + j] * cpr / TWO_PI);
        if (due)
            v[V_speed + j] = (n - m->w[COUNT + j]) * TWO_PI / (cpr * (m->time - m->w[T_LAST]));
        v[V_count + j] = n;
        v[V_measured_angle + j] = n * TWO_PI / cpr;
    }
}

void kernel_init(Model *m) {
    m->w[COUNT] = m->w[COUNT + 1] = 0.0;
    m->w[T_LAST] = NAN;  /* no sample yet: the first step takes it */
    m->v[V_speed] = m->v[V_speed + 1] = 0.0;
    kernel_eval(m);
}

void kernel_step(Model *m, double t, double h) {
    double *w = m->w;
    (void)h;
    if (!(isnan(w[T_LAST]) || sample_due(t, w[T_LAST], m->v[V_sample_period]))) return;
    m->time = t;
    kernel_eval(m);
    w[COUNT] = m->v[V_count];
    w[COUNT + 1] = m->v[V_count + 1];
    w[T_LAST] = t;
}
