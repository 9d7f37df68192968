/* Wheel slip and disturbance generator (Sec. IV-A): profiles paper, none, constant, step, mud
 * (PROFILE in config.h: one of the codes SLIP_* of components/_model.py). The C twin of
 * components/slip.py (the random profile is not exported). */
#include <math.h>
#include "kernel.h"
#include "slip_profile.h"

void kernel_eval(Model *m) {
    double *v = m->v, u[8];
    int i;
    slip_at(v + V_model, m->time, v[V_pose], v[V_pose + 1], u);
    for (i = 0; i < 3; i++) {
        v[V_slip_rate + i] = u[i];
        v[V_slip_accel + i] = u[3 + i];
    }
    v[V_disturbance] = u[6];
    v[V_disturbance + 1] = u[7];
}

/* the descriptor (_model.DESCRIPTOR), which the outputs are evaluated from and the plant can
 * evaluate itself */
void kernel_init(Model *m) {
    double *v = m->v, *d = v + V_model;
    d[D_CODE] = PROFILE;
    d[D_SLIP_GAIN] = v[V_slip_gain];
    d[D_DISTURBANCE_GAIN] = v[V_disturbance_gain];
    d[D_SLIP_R] = v[V_slip_value];
    d[D_SLIP_L] = v[V_slip_value + 1];
    d[D_SLIP_DELTA] = v[V_slip_value + 2];
    d[D_DISTURBANCE_R] = v[V_disturbance_value];
    d[D_DISTURBANCE_L] = v[V_disturbance_value + 1];
    d[D_STEP_TIME] = v[V_step_time];
    d[D_MUD_X] = v[V_mud_center];
    d[D_MUD_Y] = v[V_mud_center + 1];
    d[D_MUD_RADIUS] = v[V_mud_radius];
    d[D_PHASE] = v[V_phase];
    kernel_eval(m);
}

void kernel_step(Model *m, double t, double h) { (void)m; (void)t; (void)h; }
