/* Backlash of total width `width`, N elements (twmr.blocks.Backlash): the output kept at the
 * last step (work values) moves only when u leaves the dead band around it. */
#include "kernel.h"

static double engage(double u, double last, double width) {
    double half = 0.5 * width;
    if (u - half > last) return u - half;
    if (u + half < last) return u + half;
    return last;
}

void kernel_eval(Model *m) {
    int i;
    for (i = 0; i < N; i++) m->v[V_y + i] = engage(m->v[V_u + i], m->w[i], m->v[V_width]);
}

void kernel_init(Model *m) {
    int i;
    for (i = 0; i < N; i++) m->w[i] = m->v[V_y0];
    kernel_eval(m);
}

void kernel_step(Model *m, double t, double h) {
    int i;
    (void)t;
    (void)h;
    for (i = 0; i < N; i++) m->w[i] = engage(m->v[V_u + i], m->w[i], m->v[V_width]);
    for (i = 0; i < N; i++) m->v[V_y + i] = m->w[i];
}
