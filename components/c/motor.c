/* Motor driver of each wheel: ideal torque source (limited to torque_max when > 0), or (MODE_DC in
 * config.h) a geared DC motor with
 * a PI current loop. The C twin of components/motor.py; the armature is discretised exactly for a
 * voltage and speed held over the step (zero-order hold of the scalar system
 * L di/dt = V - R i - K_e N omega): a = exp(-R h / L), b_V = (1 - a) / R, b_w = -K_e N b_V. */
#include <math.h>
#include <stdio.h>
#include "kernel.h"

enum { CUR, INTEG = 2, H_LAST = 4, A_D, B_V, B_W, IMPLAUSIBLE };  /* work values */

static double kt(const double *v) { return v[V_efficiency] * v[V_gear] * v[V_K_t]; }

void kernel_eval(Model *m) {
    double *v = m->v, *c = v + V_torque_command;
    if (fabs(c[0]) > m->w[IMPLAUSIBLE] || fabs(c[1]) > m->w[IMPLAUSIBLE]) {
        snprintf(m->warning, sizeof m->warning, "torque command (%.4g, %.4g) N.m at t = %.6g s "
                 "is far beyond the drive's limit of %.4g N.m%s (given once)", c[0], c[1],
                 m->time, m->w[IMPLAUSIBLE] / 2.0,
                 MODE_DC ? "" : "; it is applied as is (mode ideal)");
        m->w[IMPLAUSIBLE] = INFINITY;
    }
    if (MODE_DC) {
        v[V_torque] = kt(v) * m->w[CUR];
        v[V_torque + 1] = kt(v) * m->w[CUR + 1];
    } else if (v[V_torque_max] > 0.0) {
        double lim = v[V_torque_max];
        v[V_torque] = fmin(lim, fmax(-lim, c[0]));
        v[V_torque + 1] = fmin(lim, fmax(-lim, c[1]));
    } else {
        v[V_torque] = c[0];
        v[V_torque + 1] = c[1];
    }
}

void kernel_init(Model *m) {
    double limit = MODE_DC ? kt(m->v) * m->v[V_I_max]
                           : (m->v[V_torque_max] != 0.0 ? m->v[V_torque_max] : m->v[V_rated_torque]);
    int j;
    for (j = 0; j < IMPLAUSIBLE; j++) m->w[j] = 0.0;
    m->w[IMPLAUSIBLE] = limit > 0.0 ? 2.0 * limit : INFINITY;
    kernel_eval(m);
}

void kernel_step(Model *m, double t, double h) {
    double *v = m->v, *w = m->w, *ws = v + V_wheel_speed;
    double k, kp, ki;
    int j;
    (void)t;
    v[V_angle] = v[V_angle] + ws[0] * h;
    v[V_angle + 1] = v[V_angle + 1] + ws[1] * h;
    v[V_measured_speed] = ws[0];
    v[V_measured_speed + 1] = ws[1];
    if (!MODE_DC) return;
    if (h != w[H_LAST]) {
        w[A_D] = exp(-v[V_R] * h / v[V_L]);
        w[B_V] = -expm1(-v[V_R] * h / v[V_L]) / v[V_R];
        w[B_W] = -v[V_K_e] * v[V_gear] * w[B_V];
        w[H_LAST] = h;
    }
    k = kt(v);
    kp = v[V_L] * v[V_bandwidth];
    ki = v[V_R] * v[V_bandwidth];
    for (j = 0; j < 2; j++) {
        double i_ref = fmin(fmax(v[V_torque_command + j] / k, -v[V_I_max]), v[V_I_max]);
        double err = i_ref - w[CUR + j], v_raw = kp * err + ki * w[INTEG + j];
        double volt = fmin(v[V_V_max], fmax(-v[V_V_max], v_raw));
        if (volt == v_raw) w[INTEG + j] += err * h;  /* anti-windup: hold while saturated */
        w[CUR + j] = w[A_D] * w[CUR + j] + w[B_V] * volt + w[B_W] * ws[j];
    }
    v[V_torque] = k * w[CUR];
    v[V_torque + 1] = k * w[CUR + 1];
}
