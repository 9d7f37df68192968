/* Parallel PID of the error u, 1/s by forward Euler in the integral and the derivative filter,
 * output limited when PID_LIMIT, anti-windup PID_AW (0 none, 1 clamping, 2 back-calculation)
 * (twmr.blocks.Pid); w = integral term, derivative term, previous error, last step (0 before
 * the first: the derivative term is 0 then). */
#include "kernel.h"

/* the derivative term *d, the unlimited output *v and the limited one, for error e */
static double terms(const Model *m, const double *x, double e, double h, double *d, double *v) {
    const double *p = m->v;
    double y;
    *d = (1.0 - p[V_N] * h) * x[1] + p[V_kd] * p[V_N] * (e - x[2]);
    *v = p[V_kp] * e + x[0] + *d;
    y = *v;
    if (PID_LIMIT) {
        y = p[V_y_min] > y ? p[V_y_min] : y;
        y = p[V_y_max] < y ? p[V_y_max] : y;
    }
    return y;
}

void kernel_init(Model *m) {
    double d, v;
    m->w[0] = m->w[1] = m->w[2] = m->w[3] = 0.0;
    m->v[V_y] = terms(m, m->w, m->v[V_u], 0.0, &d, &v);
}

void kernel_eval(Model *m) {
    double d, v;
    m->v[V_y] = terms(m, m->w, m->v[V_u], m->w[3], &d, &v);
}

void kernel_step(Model *m, double t, double h) {
    double e = m->v[V_u], d, v, y, gain, *w = m->w;
    (void)t;
    y = terms(m, w, e, h, &d, &v);
    gain = m->v[V_ki] * h * e;
    if (PID_AW == 1 && y != v && (v - y) * gain > 0.0) gain = 0.0;
    else if (PID_AW == 2) gain = gain + m->v[V_kb] * h * (y - v);
    w[0] = w[0] + gain;
    w[1] = d;
    w[2] = e;
    w[3] = h;
    m->v[V_y] = terms(m, w, e, h, &d, &v);
}
