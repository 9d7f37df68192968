/* T y' + y = K u element by element (N_EL elements), exact for u held over the step:
 * y(t + h) = a y + K (1 - a) u, a = exp(-h/T) (twmr.blocks.FirstOrder). */
#include <math.h>
#include "kernel.h"

void kernel_init(Model *m) {
    int i;
    for (i = 0; i < N_EL; i++) m->v[V_y + i] = m->v[V_y0];
}

void kernel_eval(Model *m) { (void)m; }

void kernel_step(Model *m, double t, double h) {
    double *v = m->v, a = v[V_T] > 0.0 ? exp(-h / v[V_T]) : 0.0, b = v[V_K] * (1.0 - a);
    int i;
    (void)t;
    for (i = 0; i < N_EL; i++) v[V_y + i] = a * v[V_y + i] + b * v[V_u + i];
}
