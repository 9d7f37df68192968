/* Wheel slip and disturbance generator (Sec. IV-A): profiles paper, none, constant, step, mud
 * (PROFILE in config.h: one of the codes SLIP_* of components/_model.py). The C twin of
 * components/slip.py (the random profile is not exported). */
#include <math.h>
#include "kernel.h"

void kernel_eval(Model *m) {
    double *v = m->v, t = m->time, rate[3] = {0.0, 0.0, 0.0}, accel[3] = {0.0, 0.0, 0.0};
    double dist[2] = {0.0, 0.0}, g = v[V_slip_gain], gd = v[V_disturbance_gain];
    int i;
#if PROFILE == SLIP_PAPER
    double tp = t + v[V_phase];
    rate[0] = 1.0 + cos(tp); rate[1] = 1.0 + sin(tp); rate[2] = cos(tp);
    accel[0] = -sin(tp); accel[1] = cos(tp); accel[2] = -sin(tp);
    dist[0] = 2.0 * sin(3.0 * tp); dist[1] = 2.0 * cos(3.0 * tp);
#elif PROFILE != SLIP_NO_SLIP
#if PROFILE == SLIP_CONSTANT
    int on = 1;
#elif PROFILE == SLIP_STEP
    int on = t >= v[V_step_time];
#else
    int on = hypot(v[V_pose] - v[V_mud_center], v[V_pose + 1] - v[V_mud_center + 1])
             <= v[V_mud_radius];
#endif
    if (on) {
        for (i = 0; i < 3; i++) rate[i] = v[V_slip_value + i];
        dist[0] = v[V_disturbance_value];
        dist[1] = v[V_disturbance_value + 1];
    }
#endif
    (void)t;
    for (i = 0; i < 3; i++) {
        v[V_slip_rate + i] = g * rate[i];
        v[V_slip_accel + i] = g * accel[i];
    }
    v[V_disturbance] = gd * dist[0];
    v[V_disturbance + 1] = gd * dist[1];
}

/* the descriptor of components/_model.DESCRIPTOR, for the plant to evaluate the profile itself */
void kernel_init(Model *m) {
    double *v = m->v, *d = v + V_model;
    int i;
    d[0] = PROFILE;
    d[1] = v[V_slip_gain];
    d[2] = v[V_disturbance_gain];
    for (i = 0; i < 3; i++) d[3 + i] = v[V_slip_value + i];
    d[6] = v[V_disturbance_value];
    d[7] = v[V_disturbance_value + 1];
    d[8] = v[V_step_time];
    d[9] = v[V_mud_center];
    d[10] = v[V_mud_center + 1];
    d[11] = v[V_mud_radius];
    d[12] = v[V_phase];
    kernel_eval(m);
}

void kernel_step(Model *m, double t, double h) { (void)m; (void)t; (void)h; }
