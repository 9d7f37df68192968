/* Sliding-mode tracking controllers of the paper: the law of eqs (9)-(32) with the torque limit,
 * and with ADAPTIVE the ASMC's estimate d_hat' = eta s (eq. 33), held while the torque is limited
 * when HOLD_SATURATED. DRIVE (0 auto, DRIVE_FORWARD, DRIVE_BACKWARD) sets the side of the
 * look-ahead point, SAT_SCALE how the limit applies (0: clip each wheel, 1: scale both). The C twin of
 * components/_tracking.py, asmc.py, smc.py and _model.tracking_law (the error model in
 * look_ahead.h), in the same order of operations. */
#include <math.h>
#include "kernel.h"
#include "inertia.h"
#include "look_ahead.h"

enum { M11, M12, SIDE, SATURATED };  /* work values: inertia of eq. (8), sign of L, limited */

/* (m11, m12) of eq. (8) (inertia.h) */
static void nominal_inertia(const double *v, double *w) {
    double q[4];
    inertia(v[V_a], v[V_I_G], v[V_I_D], v[V_I_W], v[V_r], v[V_b], v[V_m_W], v[V_m_G], q);
    w[M11] = q[0];
    w[M12] = q[1];
}

static double sign(double s) { return s > 0 ? 1.0 : (s < 0 ? -1.0 : 0.0); }

void kernel_eval(Model *m) {
    const double *v = m->v;
    double lam = v[V_lam], vth = v[V_vartheta], k = v[V_k], L = m->w[SIDE] * v[V_lookahead];
    double phi = v[V_phi];
#ifdef ADAPTIVE
    double dR = v[V_d_hat], dL = v[V_d_hat + 1];
#else
    double dR = 0.0, dL = 0.0;
#endif
    LookAhead o = look_ahead_model(v[V_pose], v[V_pose + 1], v[V_pose + 2], v[V_wheel_speed],
                                   v[V_wheel_speed + 1], v[V_ref_position],
                                   v[V_ref_position + 1], v[V_ref_velocity],
                                   v[V_ref_velocity + 1], m->w[M11], m->w[M12], v[V_m_G],
                                   v[V_r], v[V_b], L, v[V_eps_singular]);
    double x21 = o.d11 + lam * o.x11, x22 = o.d12 + lam * o.x12;
    double s1 = vth * o.x11 + x21, s2 = vth * o.x12 + x22;  /* eq. (25) */
    double w1 = x21 - lam * o.x11, w2 = x22 - lam * o.x12, g1, g2, v1, v2, tR, tL;
    if (phi > 0.0) {
        g1 = fmin(1.0, fmax(-1.0, s1 / phi));
        g2 = fmin(1.0, fmax(-1.0, s2 / phi));
    } else {
        g1 = sign(s1);
        g2 = sign(s2);
    }
    v1 = (vth + o.E11) * w1 + o.E12 * w2 + dR + k * g1;
    v2 = o.E21 * w1 + (vth + o.E22) * w2 + dL + k * g2;
    torque_for(v1, v2, &o, &tR, &tL);
    m->w[SATURATED] = limit_torque(v[V_torque_limit], SAT_SCALE, &tR, &tL);
    m->v[V_torque] = tR;
    m->v[V_torque + 1] = tL;
    m->v[V_s] = s1;
    m->v[V_s + 1] = s2;
    m->v[V_error] = o.e1;
    m->v[V_error + 1] = o.e2;
}

void kernel_init(Model *m) {
#ifdef ADAPTIVE
    m->v[V_d_hat] = m->v[V_d_hat0];
    m->v[V_d_hat + 1] = m->v[V_d_hat0 + 1];
#endif
    m->w[SIDE] = DRIVE == DRIVE_FORWARD ? 1.0
                 : (DRIVE == DRIVE_BACKWARD ? -1.0 : start_side(m->v));
    nominal_inertia(m->v, m->w);
    kernel_eval(m);
}

void kernel_step(Model *m, double t, double h) {
#ifdef ADAPTIVE
    double *v = m->v, d1, d2, lim = v[V_d_hat_limit];
    if (HOLD_SATURATED && m->w[SATURATED] != 0.0) return;
    d1 = v[V_d_hat] + v[V_eta] * v[V_s] * h;  /* eq. (33) */
    d2 = v[V_d_hat + 1] + v[V_eta] * v[V_s + 1] * h;
    if (lim > 0.0) {
        d1 = fmin(lim, fmax(-lim, d1));
        d2 = fmin(lim, fmax(-lim, d2));
    }
    v[V_d_hat] = d1;
    v[V_d_hat + 1] = d2;
#else
    (void)m; (void)h;
#endif
    (void)t;
}
