/* The LQR / LQI tracking controller: eq. (32)'s computed torque on the look-ahead point's error
 * model (look_ahead.h) with u = k_i z + k_p x1 + k_d x1', the torque limit, the integral z of x1
 * held while the torque is limited. The gains come from the weights as
 * components/lqr.lqr_gains computes them (same operations), again whenever a weight changes.
 * DRIVE and SAT_SCALE as in tracking.c. The C twin of components/lqr.py. */
#include <math.h>
#include "kernel.h"
#include "inertia.h"
#include "look_ahead.h"

enum { M11, M12, SIDE, SATURATED, K_I, K_P, K_D, Q_I, Q_P, Q_V };  /* work values */

/* (k_i, k_p, k_d) into w from the weights (components/lqr.lqr_gains) */
static void gains(double q_i, double q_p, double q_v, double *w) {
    double c = sqrt(q_i), a = sqrt(q_v + 2.0 * sqrt(q_p));
    if (c > 0.0) {
        int i;
        a = fmax(a, 1.0);
        while ((a * a - q_v) * (a * a - q_v) - 4.0 * q_p - 8.0 * c * a <= 0.0) a = 2.0 * a;
        for (i = 0; i < 200; i++) {
            double x = a * a - q_v;
            double step = (x * x - 4.0 * q_p - 8.0 * c * a) / (4.0 * a * x - 8.0 * c);
            if (!(a - step < a)) break;
            a = a - step;
        }
    }
    w[K_I] = c;
    w[K_P] = 0.5 * (a * a - q_v);
    w[K_D] = a;
    w[Q_I] = q_i;
    w[Q_P] = q_p;
    w[Q_V] = q_v;
}

void kernel_eval(Model *m) {
    const double *v = m->v;
    double *w = m->w, L = w[SIDE] * v[V_lookahead], v1, v2, tR, tL;
    LookAhead o;
    if (v[V_q_integral] != w[Q_I] || v[V_q_position] != w[Q_P] || v[V_q_velocity] != w[Q_V])
        gains(v[V_q_integral], v[V_q_position], v[V_q_velocity], w);
    o = look_ahead_model(v[V_pose], v[V_pose + 1], v[V_pose + 2], v[V_wheel_speed],
                         v[V_wheel_speed + 1], v[V_ref_position], v[V_ref_position + 1],
                         v[V_ref_velocity], v[V_ref_velocity + 1], w[M11], w[M12], v[V_m_G],
                         v[V_r], v[V_b], L, v[V_eps_singular]);
    v1 = (w[K_D] + o.E11) * o.d11 + o.E12 * o.d12 + w[K_P] * o.x11 + w[K_I] * v[V_integral];
    v2 = o.E21 * o.d11 + (w[K_D] + o.E22) * o.d12 + w[K_P] * o.x12 + w[K_I] * v[V_integral + 1];
    torque_for(v1, v2, &o, &tR, &tL);
    w[SATURATED] = limit_torque(v[V_torque_limit], SAT_SCALE, &tR, &tL);
    m->v[V_torque] = tR;
    m->v[V_torque + 1] = tL;
    m->v[V_error] = o.e1;
    m->v[V_error + 1] = o.e2;
}

void kernel_init(Model *m) {
    double q[4];
    const double *v = m->v;
    m->v[V_integral] = 0.0;
    m->v[V_integral + 1] = 0.0;
    m->w[SIDE] = DRIVE == DRIVE_FORWARD ? 1.0
                 : (DRIVE == DRIVE_BACKWARD ? -1.0 : start_side(m->v));
    inertia(v[V_a], v[V_I_G], v[V_I_D], v[V_I_W], v[V_r], v[V_b], v[V_m_W], v[V_m_G], q);
    m->w[M11] = q[0];
    m->w[M12] = q[1];
    gains(v[V_q_integral], v[V_q_position], v[V_q_velocity], m->w);
    kernel_eval(m);
}

void kernel_step(Model *m, double t, double h) {
    double *v = m->v;
    (void)t;
    if (m->w[K_I] != 0.0 && m->w[SATURATED] == 0.0) {  /* z += x1 h, held while limited */
        v[V_integral] = v[V_integral] + (v[V_error] - m->w[SIDE] * v[V_lookahead]) * h;
        v[V_integral + 1] = v[V_integral + 1] + v[V_error + 1] * h;
    }
}
