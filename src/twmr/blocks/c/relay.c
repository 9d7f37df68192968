/* Relay with hysteresis, N elements (twmr.blocks.Relay): on from u >= on_point, off from
 * u <= off_point, the state (work values, 1 on, 0 off) kept in between; off at the start. */
#include "kernel.h"

static double sw(const double *v, double u, double on) {
    if (u >= v[V_on_point]) return 1.0;
    if (u <= v[V_off_point]) return 0.0;
    return on;
}

static double out(const double *v, double on) { return on == 1.0 ? v[V_on_value] : v[V_off_value]; }

void kernel_eval(Model *m) {
    int i;
    for (i = 0; i < N; i++) m->v[V_y + i] = out(m->v, sw(m->v, m->v[V_u + i], m->w[i]));
}

void kernel_init(Model *m) {
    int i;
    for (i = 0; i < N; i++) m->w[i] = 0.0;
    kernel_eval(m);
}

void kernel_step(Model *m, double t, double h) {
    int i;
    (void)t;
    (void)h;
    for (i = 0; i < N; i++) {
        m->w[i] = sw(m->v, m->v[V_u + i], m->w[i]);
        m->v[V_y + i] = out(m->v, m->w[i]);
    }
}
