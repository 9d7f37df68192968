/* y = bilinear interpolation of an N_BP1 x N_BP2 grid at (u1, u2), N elements, extrapolation
 * EXTRAP (twmr.blocks.Lookup2D). */
#include "kernel.h"
#include "tables.h"

void kernel_eval(Model *m) {
    double *v = m->v;
    int i;
    for (i = 0; i < N; i++)
        v[V_y + i] = interp2(v + V_breakpoints1, N_BP1, v + V_breakpoints2, N_BP2, v + V_values,
                             v[V_u1 + i], v[V_u2 + i], EXTRAP);
}

void kernel_init(Model *m) { kernel_eval(m); }
void kernel_step(Model *m, double t, double h) { (void)m; (void)t; (void)h; }
