/* y(t) = u(t - delay), linear interpolation between the samples of the last TD_B steps (a ring
 * buffer of TD_N elements each), or a delay of TD_STEPS > 0 steps; y0 until the delay has passed
 * (twmr.blocks.TransportDelay). */
#include <math.h>
#include "kernel.h"

/* work values: the samples row by row, the newest's row, the number stored */
enum { HEAD = TD_B * TD_N, STORED = HEAD + 1 };

void kernel_init(Model *m) {
    int i;
    for (i = 0; i < TD_B * TD_N; i++) m->w[i] = m->v[V_y0];
    m->w[HEAD] = m->w[STORED] = 0.0;
    for (i = 0; i < TD_N; i++) m->v[V_y + i] = m->v[V_y0];
}

void kernel_eval(Model *m) { (void)m; }

void kernel_step(Model *m, double t, double h) {
    double *w = m->w, d, k, frac;
    int i, head, near, far;
    (void)t;
    if (TD_STEPS > 0) {
        d = TD_STEPS;
    } else {
        double r;
        d = h > 0.0 ? m->v[V_delay] / h : 1.0;
        r = floor(d + 0.5);
        if (fabs(d - r) <= 1e-9 * r) d = r;
    }
    d = d < 1.0 ? 1.0 : d;
    d = d > TD_B - 1.0 ? TD_B - 1.0 : d;
    k = floor(d);
    frac = d - k;
    head = ((int)w[HEAD] + 1) % TD_B;
    for (i = 0; i < TD_N; i++) w[head * TD_N + i] = m->v[V_u + i];
    w[HEAD] = head;
    w[STORED] = w[STORED] + 1.0 < TD_B ? w[STORED] + 1.0 : TD_B;
    if (k + frac > w[STORED]) return;  /* t + h - delay before the first sample: y0 */
    near = ((head - (int)k + 1) % TD_B + TD_B) % TD_B;
    far = ((head - (int)k) % TD_B + TD_B) % TD_B;
    for (i = 0; i < TD_N; i++) {
        double y = w[near * TD_N + i];
        if (frac != 0.0) y = (1.0 - frac) * y + frac * w[far * TD_N + i];
        m->v[V_y + i] = y;
    }
}
