/* TWMR plant with wheel slip: eqs (1)-(8), (11), classical RK4 with ceil(h / internal_step)
 * substeps. The C twin of components/plant.py and components/_model.py (derivative, rk4; the
 * inertia and slip_at in inertia.h and slip_profile.h), in the same order of operations. */
#include <math.h>
#include <stdio.h>
#include "kernel.h"
#include "inertia.h"
#include "slip_profile.h"

#define MAX_SUBSTEPS 1e8  /* substeps of one doStep: more is a step size gone wrong */
enum { M11, M12, Q1, Q2, MG, H_LAST, N_SUB, H_SUB };  /* work values */

/* State derivative d = (x_M', y_M', theta', phi_R'', phi_L'') at z = (x, y, theta, wR, wL). */
static void derivative(const double *z, double tR, double tL, const double *u, const double *w,
                       double a, double r, double b, double *d) {
    double muR = u[0], muL = u[1], dl = u[2], muR2 = u[3], muL2 = u[4];
    double dl2 = u[5], tdR = u[6], tdL = u[7], m_G = w[MG];
    double beta = r * (z[3] + z[4]) / 2.0 + (muR + muL) / 2.0;             /* eq. (2) */
    double varpi = r * (z[3] - z[4]) / (2.0 * b) + (muR - muL) / (2.0 * b);  /* eq. (3) */
    double c = cos(z[2]), s = sin(z[2]);
    double bc = m_G * r * r / (2.0 * b) * varpi, cc = m_G * r / 2.0 * varpi;
    double gc = m_G * a * r / (2.0 * b);
    double fR = tR - bc * z[4] - (w[Q1] * muR2 + w[Q2] * muL2) - cc * dl - gc * dl2 - tdR;
    double fL = tL + bc * z[3] - (w[Q2] * muR2 + w[Q1] * muL2) - cc * dl + gc * dl2 - tdL;
    double det = w[M11] * w[M11] - w[M12] * w[M12];
    d[0] = beta * c - dl * s;  /* eq. (11) */
    d[1] = beta * s + dl * c;
    d[2] = varpi;
    d[3] = (w[M11] * fR - w[M12] * fL) / det;  /* eq. (8) solved for nu' */
    d[4] = (w[M11] * fL - w[M12] * fR) / det;
}

static void com(Model *m) {
    double *v = m->v;
    v[V_com] = v[V_pose] + v[V_a] * cos(v[V_pose + 2]);
    v[V_com + 1] = v[V_pose + 1] + v[V_a] * sin(v[V_pose + 2]);
}

void kernel_init(Model *m) {
    double *v = m->v, k = v[V_scale];
    inertia(v[V_a], k * v[V_I_G], k * v[V_I_D], k * v[V_I_W], v[V_r], v[V_b], k * v[V_m_W],
            k * v[V_m_G], m->w + M11);
    m->w[MG] = k * v[V_m_G];
    m->w[H_LAST] = 0.0;
    com(m);
}

void kernel_eval(Model *m) { (void)m; }

void kernel_step(Model *m, double t0, double h) {
    double *v = m->v, *w = m->w, z[5], y[5], k1[5], k2[5], k3[5], k4[5];
    double a = v[V_a], r = v[V_r], b = v[V_b], hs, tR = v[V_torque], tL = v[V_torque + 1];
    const double *p = v + V_slip_model;
    int live = p[D_CODE] != SLIP_HELD, i, j, n;
    double u[8];  /* slip rates, accelerations [m/s, m/s2], disturbance [N.m] */
    if (h != w[H_LAST]) {  /* substeps for this step size */
        double sub = ceil(h / v[V_internal_step] - 1e-9);
        if (!(sub <= MAX_SUBSTEPS)) {
            snprintf(m->error, sizeof m->error, "%.3g RK4 substeps of internal_step = %g s "
                     "(at most %.0f). Fix: a smaller step or a larger internal_step", sub,
                     v[V_internal_step], MAX_SUBSTEPS);
            return;
        }
        w[N_SUB] = sub > 1.0 ? sub : 1.0;
        w[H_SUB] = h / w[N_SUB];
        w[H_LAST] = h;
    }
    n = (int)w[N_SUB];
    hs = w[H_SUB];
    for (j = 0; j < 3; j++) {
        u[j] = v[V_slip_rate + j];
        u[3 + j] = v[V_slip_accel + j];
    }
    u[6] = v[V_disturbance];
    u[7] = v[V_disturbance + 1];
    for (j = 0; j < 3; j++) z[j] = v[V_pose + j];
    z[3] = v[V_wheel_speed];
    z[4] = v[V_wheel_speed + 1];
    for (i = 0; i < n; i++) {
        double t = t0 + i * hs;
        if (live) slip_at(p, t, z[0], z[1], u);
        derivative(z, tR, tL, u, w, a, r, b, k1);
        for (j = 0; j < 5; j++) y[j] = z[j] + hs / 2 * k1[j];
        if (live) slip_at(p, t + hs / 2, y[0], y[1], u);
        derivative(y, tR, tL, u, w, a, r, b, k2);
        for (j = 0; j < 5; j++) y[j] = z[j] + hs / 2 * k2[j];
        if (live) slip_at(p, t + hs / 2, y[0], y[1], u);
        derivative(y, tR, tL, u, w, a, r, b, k3);
        for (j = 0; j < 5; j++) y[j] = z[j] + hs * k3[j];
        if (live) slip_at(p, t + hs, y[0], y[1], u);
        derivative(y, tR, tL, u, w, a, r, b, k4);
        for (j = 0; j < 5; j++) z[j] += hs / 6 * (k1[j] + 2 * k2[j] + 2 * k3[j] + k4[j]);
    }
    for (j = 0; j < 3; j++) v[V_pose + j] = z[j];
    v[V_wheel_speed] = z[3];
    v[V_wheel_speed + 1] = z[4];
    com(m);
}
