/* Sliding-mode tracking controllers of the paper: the law of eqs (9)-(32) with the torque limit,
 * and with ADAPTIVE the ASMC's estimate d_hat' = eta s (eq. 33), held while the torque is limited
 * when HOLD_SATURATED. DRIVE (0 auto, DRIVE_FORWARD, DRIVE_BACKWARD) sets the side of the
 * look-ahead point, SAT_SCALE how the limit applies (0: clip each wheel, 1: scale both). The C twin of
 * components/_tracking.py, asmc.py, smc.py and _model.tracking_law, in the same order of
 * operations. */
#include <math.h>
#include "kernel.h"
#include "inertia.h"

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
    double m11 = m->w[M11], m12 = m->w[M12], m_G = v[V_m_G], r = v[V_r], b = v[V_b];
    double lam = v[V_lam], vth = v[V_vartheta], k = v[V_k], L = m->w[SIDE] * v[V_lookahead];
    double eps = v[V_eps_singular], phi = v[V_phi], lim = v[V_torque_limit];
    double x = v[V_pose], y = v[V_pose + 1], th = v[V_pose + 2];
    double wR = v[V_wheel_speed], wL = v[V_wheel_speed + 1];
    double vxT = v[V_ref_velocity], vyT = v[V_ref_velocity + 1];
#ifdef ADAPTIVE
    double dR = v[V_d_hat], dL = v[V_d_hat + 1];
#else
    double dR = 0.0, dL = 0.0;
#endif
    double c = cos(th), s_ = sin(th);
    double ex = v[V_ref_position] - x, ey = v[V_ref_position + 1] - y;
    double e1 = c * ex + s_ * ey, e2 = -s_ * ex + c * ey;  /* eq. (9) */
    double e1k = fabs(e1) >= eps ? e1 : (e1 >= 0.0 ? eps : -eps);  /* singularity guard */
    double k11 = (e2 / b - 1.0) * r / 2.0, k12 = -(e2 / b + 1.0) * r / 2.0;  /* eq. (15) */
    double k21 = -e1k * r / (2.0 * b), k22 = e1k * r / (2.0 * b);
    double x11 = e1 - L, x12 = e2;  /* x1 and x1' (eq. 16 without the slip part of xi_1) */
    double d11 = k11 * wR + k12 * wL + c * vxT + s_ * vyT;
    double d12 = k21 * wR + k22 * wL - s_ * vxT + c * vyT;
    double x21 = d11 + lam * x11, x22 = d12 + lam * x12;
    double s1 = vth * x11 + x21, s2 = vth * x12 + x22;  /* eq. (25) */
    double det_m = m11 * m11 - m12 * m12, i11 = m11 / det_m, i12 = -m12 / det_m;
    double bc = m_G * r * r / (2.0 * b) * (r * (wR - wL) / (2.0 * b));
    double z11 = k11 * i11 + k12 * i12, z12 = k11 * i12 + k12 * i11;  /* Z, eq. (21) */
    double z21 = k21 * i11 + k22 * i12, z22 = k21 * i12 + k22 * i11;
    double e1_11 = z12 * bc, e1_12 = -z11 * bc, e1_21 = z22 * bc, e1_22 = -z21 * bc;
    double det_k = k11 * k22 - k12 * k21;
    double ki11 = k22 / det_k, ki12 = -k12 / det_k, ki21 = -k21 / det_k, ki22 = k11 / det_k;
    double E11 = e1_11 * ki11 + e1_12 * ki21, E12 = e1_11 * ki12 + e1_12 * ki22;  /* eq. (23) */
    double E21 = e1_21 * ki11 + e1_22 * ki21, E22 = e1_21 * ki12 + e1_22 * ki22;
    double w1 = x21 - lam * x11, w2 = x22 - lam * x12, g1, g2, v1, v2, det_z, tR, tL;
    if (phi > 0.0) {
        g1 = fmin(1.0, fmax(-1.0, s1 / phi));
        g2 = fmin(1.0, fmax(-1.0, s2 / phi));
    } else {
        g1 = sign(s1);
        g2 = sign(s2);
    }
    v1 = (vth + E11) * w1 + E12 * w2 + dR + k * g1;
    v2 = E21 * w1 + (vth + E22) * w2 + dL + k * g2;
    det_z = z11 * z22 - z12 * z21;  /* tau = -Z^-1 v, eq. (32) */
    tR = -(z22 * v1 - z12 * v2) / det_z;
    tL = -(-z21 * v1 + z11 * v2) / det_z;
    m->w[SATURATED] = lim > 0.0 && (fabs(tR) > lim || fabs(tL) > lim);
    if (m->w[SATURATED] != 0.0) {
#if SAT_SCALE
        double f = lim / fmax(fabs(tR), fabs(tL));
        tR = tR * f;
        tL = tL * f;
#else
        tR = fmin(lim, fmax(-lim, tR));
        tL = fmin(lim, fmax(-lim, tL));
#endif
    }
    m->v[V_torque] = tR;
    m->v[V_torque + 1] = tL;
    m->v[V_s] = s1;
    m->v[V_s + 1] = s2;
    m->v[V_error] = e1;
    m->v[V_error + 1] = e2;
}

/* 1 (forward) when the target, one second ahead, lies in front of M along the body axis
 * (e_p1 + v_T1 * 1 s >= 0, eq. 9 with the target's velocity), else -1 (backward) */
static double start_side(const double *v) {
    double x = v[V_pose], y = v[V_pose + 1], th = v[V_pose + 2];
    double c = cos(th), s = sin(th);
    double ahead = c * (v[V_ref_position] - x) + s * (v[V_ref_position + 1] - y)
                   + (c * v[V_ref_velocity] + s * v[V_ref_velocity + 1]) * 1.0;
    return ahead >= 0.0 ? 1.0 : -1.0;
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
