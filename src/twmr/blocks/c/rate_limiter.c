/* y(t + h) = y + clip(u - y, -falling h, rising h), N elements (twmr.blocks.RateLimiter). */
#include "kernel.h"

void kernel_init(Model *m) {
    int i;
    for (i = 0; i < N; i++) m->v[V_y + i] = m->v[V_y0];
}

void kernel_eval(Model *m) { (void)m; }

void kernel_step(Model *m, double t, double h) {
    double *v = m->v, up = v[V_rising] * h, down = -v[V_falling] * h;
    int i;
    (void)t;
    for (i = 0; i < N; i++) {
        double y = v[V_y + i], d = v[V_u + i] - y;
        v[V_y + i] = y + (d > up ? up : (d < down ? down : d));
    }
}
