/* The error model of the look-ahead point the tracking laws share, as
 * components/_model.look_ahead_model and torque_for compute it (same order of operations): eqs
 * (9)-(23), x1'' = Z tau + E x1' + (what a law treats as disturbance). */
#ifndef TWMR_LOOK_AHEAD_H
#define TWMR_LOOK_AHEAD_H
#include <math.h>

typedef struct {
    double e1, e2, x11, x12, d11, d12, z11, z12, z21, z22, E11, E12, E21, E22;
} LookAhead;

/* e_p (eq. 9), x1 = e_p - [L, 0], x1' without the slip (eq. 16), Z = kappa M^-1 (eq. 21) and E
 * (eq. 23), with |e_p1| clamped at eps in kappa */
static LookAhead look_ahead_model(double x, double y, double th, double wR, double wL,
                                  double xT, double yT, double vxT, double vyT, double m11,
                                  double m12, double m_G, double r, double b, double L,
                                  double eps) {
    LookAhead o;
    double c = cos(th), s_ = sin(th);
    double ex = xT - x, ey = yT - y;
    double e1k, k11, k12, k21, k22, det_m, i11, i12, bc, e1_11, e1_12, e1_21, e1_22, det_k;
    double ki11, ki12, ki21, ki22;
    o.e1 = c * ex + s_ * ey;  /* eq. (9) */
    o.e2 = -s_ * ex + c * ey;
    e1k = fabs(o.e1) >= eps ? o.e1 : (o.e1 >= 0.0 ? eps : -eps);  /* the clamp */
    k11 = (o.e2 / b - 1.0) * r / 2.0;  /* eq. (15) */
    k12 = -(o.e2 / b + 1.0) * r / 2.0;
    k21 = -e1k * r / (2.0 * b);
    k22 = e1k * r / (2.0 * b);
    o.x11 = o.e1 - L;  /* x1 and x1' (eq. 16 without the slip part of xi_1) */
    o.x12 = o.e2;
    o.d11 = k11 * wR + k12 * wL + c * vxT + s_ * vyT;
    o.d12 = k21 * wR + k22 * wL - s_ * vxT + c * vyT;
    det_m = m11 * m11 - m12 * m12;
    i11 = m11 / det_m;
    i12 = -m12 / det_m;
    bc = m_G * r * r / (2.0 * b) * (r * (wR - wL) / (2.0 * b));
    o.z11 = k11 * i11 + k12 * i12;  /* Z, eq. (21) */
    o.z12 = k11 * i12 + k12 * i11;
    o.z21 = k21 * i11 + k22 * i12;
    o.z22 = k21 * i12 + k22 * i11;
    e1_11 = o.z12 * bc;
    e1_12 = -o.z11 * bc;
    e1_21 = o.z22 * bc;
    e1_22 = -o.z21 * bc;
    det_k = k11 * k22 - k12 * k21;
    ki11 = k22 / det_k;
    ki12 = -k12 / det_k;
    ki21 = -k21 / det_k;
    ki22 = k11 / det_k;
    o.E11 = e1_11 * ki11 + e1_12 * ki21;  /* eq. (23) */
    o.E12 = e1_11 * ki12 + e1_12 * ki22;
    o.E21 = e1_21 * ki11 + e1_22 * ki21;
    o.E22 = e1_21 * ki12 + e1_22 * ki22;
    return o;
}

/* tau = -Z^-1 v (eq. 32) */
static void torque_for(double v1, double v2, const LookAhead *o, double *tR, double *tL) {
    double det_z = o->z11 * o->z22 - o->z12 * o->z21;
    *tR = -(o->z22 * v1 - o->z12 * v2) / det_z;
    *tL = -(-o->z21 * v1 + o->z11 * v2) / det_z;
}

/* the torque limit lim (0: none) by clipping each wheel or, scale, both by one factor;
 * returns 1 when it acted */
static int limit_torque(double lim, int scale, double *tR, double *tL) {
    if (!(lim > 0.0 && (fabs(*tR) > lim || fabs(*tL) > lim))) return 0;
    if (scale) {
        double f = lim / fmax(fabs(*tR), fabs(*tL));
        *tR = *tR * f;
        *tL = *tL * f;
    } else {
        *tR = fmin(lim, fmax(-lim, *tR));
        *tL = fmin(lim, fmax(-lim, *tL));
    }
    return 1;
}

/* the controllers' start side, from their ports (V_pose, V_ref_position, V_ref_velocity of the
 * block that includes this): */
/* 1 (forward) when the target, one second ahead, lies in front of M along the body axis
 * (e_p1 + v_T1 * 1 s >= 0, eq. 9 with the target's velocity), else -1 (backward) */
static double start_side(const double *v) {
    double x = v[V_pose], y = v[V_pose + 1], th = v[V_pose + 2];
    double c = cos(th), s = sin(th);
    double ahead = c * (v[V_ref_position] - x) + s * (v[V_ref_position + 1] - y)
                   + (c * v[V_ref_velocity] + s * v[V_ref_velocity + 1]) * 1.0;
    return ahead >= 0.0 ? 1.0 : -1.0;
}

#endif
