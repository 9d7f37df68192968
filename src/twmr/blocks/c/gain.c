/* y = k u, direct feedthrough (twmr.blocks.Gain). */
#include "kernel.h"

void kernel_eval(Model *m) { m->v[V_y] = m->v[V_k] * m->v[V_u]; }
void kernel_init(Model *m) { kernel_eval(m); }
void kernel_step(Model *m, double t, double h) { (void)m; (void)t; (void)h; }
