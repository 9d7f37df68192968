/* y = value (twmr.blocks.Constant). */
#include "kernel.h"

void kernel_init(Model *m) { m->v[V_y] = m->v[V_value]; }
void kernel_eval(Model *m) { (void)m; }
void kernel_step(Model *m, double t, double h) { (void)m; (void)t; (void)h; }
