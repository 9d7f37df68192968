/* Unit delay of one step: y(t + h) = u(t) (twmr.blocks.Delay). */
#include "kernel.h"

void kernel_init(Model *m) { m->v[V_y] = m->v[V_y0]; }
void kernel_eval(Model *m) { (void)m; }
void kernel_step(Model *m, double t, double h) { (void)t; (void)h; m->v[V_y] = m->v[V_u]; }
