/* y = f(u) element by element (N_EL elements), f the code MATH_FN of
 * twmr.blocks.routing_kernels.FUNCTIONS; NaN outside f's domain (twmr.blocks.Math). */
#include <math.h>
#include "kernel.h"

static double apply(double v) {
    switch (MATH_FN) {
    case 0: return fabs(v);
    case 1: return v >= 0.0 ? sqrt(v) : NAN;
    case 2: return v <= EXP_MAX ? exp(v) : INFINITY;
    case 3: return v > 0.0 ? log(v) : (v == 0.0 ? -INFINITY : NAN);
    case 4: return v > 0.0 ? log10(v) : (v == 0.0 ? -INFINITY : NAN);
    case 5: return v - v != 0.0 ? NAN : sin(v);
    case 6: return v - v != 0.0 ? NAN : cos(v);
    case 7: return v - v != 0.0 ? NAN : tan(v);
    case 8: return fabs(v) <= 1.0 ? asin(v) : NAN;
    case 9: return fabs(v) <= 1.0 ? acos(v) : NAN;
    case 10: return atan(v);
    case 11: return tanh(v);
    case 12: return v * v;
    case 13: return v != 0.0 ? 1.0 / v : copysign(INFINITY, v);
    default: return v > 0.0 ? 1.0 : (v < 0.0 ? -1.0 : v);
    }
}

void kernel_eval(Model *m) {
    int i;
    for (i = 0; i < N_EL; i++) m->v[V_y + i] = apply(m->v[V_u + i]);
}

void kernel_init(Model *m) { kernel_eval(m); }
void kernel_step(Model *m, double t, double h) { (void)m; (void)t; (void)h; }
