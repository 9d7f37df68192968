/* y = u at the sample instants start + k Ts, held between them, N_EL elements; w[0] counts the
 * steps since the last sample (twmr.blocks.ZeroOrderHold). */
#include <math.h>
#include "kernel.h"

void kernel_eval(Model *m) {
    int i;
    if (m->w[0] == 0.0)
        for (i = 0; i < N_EL; i++) m->v[V_y + i] = m->v[V_u + i];
}

void kernel_init(Model *m) {
    m->w[0] = 0.0;
    kernel_eval(m);
}

void kernel_step(Model *m, double t, double h) {
    double steps = h > 0.0 ? fmax(1.0, floor(m->v[V_sample_period] / h + 0.5)) : 1.0;
    double n = m->w[0] + 1.0;
    (void)t;
    m->w[0] = n >= steps ? 0.0 : n;
}
