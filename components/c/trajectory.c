/* Reference trajectory of the target point T (SHAPE in config.h: paper1, circle, lemniscate).
 * The C twin of components/trajectory.py (the waypoints shape is not exported). */
#include <math.h>
#include "kernel.h"

/* position, velocity and acceleration of T at time t [s] */
static void sample(double *v, double t) {
    double *p = v + V_position, *d = v + V_velocity, *a = v + V_acceleration;
#if SHAPE == SHAPE_PAPER1
    p[0] = -t; p[1] = sin(0.5 * t) + 0.5 * t + 1.0;
    d[0] = -1.0; d[1] = 0.5 * cos(0.5 * t) + 0.5;
    a[0] = 0.0; a[1] = -0.25 * sin(0.5 * t);
#elif SHAPE == SHAPE_CIRCLE
    double cx = v[V_center], cy = v[V_center + 1], w = v[V_omega], R = v[V_radius];
    double an = w * t + v[V_phase], c = cos(an), s = sin(an);
    p[0] = cx + R * c; p[1] = cy + R * s;
    d[0] = -R * w * s; d[1] = R * w * c;
    a[0] = -R * w * w * c; a[1] = -R * w * w * s;
#else
    double cx = v[V_center], cy = v[V_center + 1], w = v[V_omega], A = v[V_radius];
    double s1 = sin(w * t), c1 = cos(w * t), s2 = sin(2 * w * t), c2 = cos(2 * w * t);
    p[0] = cx + A * s1; p[1] = cy + A / 2 * s2;
    d[0] = A * w * c1; d[1] = A * w * c2;
    a[0] = -A * w * w * s1; a[1] = -2 * A * w * w * s2;
#endif
}

void kernel_init(Model *m) { sample(m->v, m->time); }
void kernel_eval(Model *m) { (void)m; }
void kernel_step(Model *m, double t, double h) { sample(m->v, t + h); }
