/* y = (u1, u2, ...): MUX_LEN input elements, one port after the other (twmr.blocks.Mux). */
#include "kernel.h"

void kernel_eval(Model *m) {
    int i;
    for (i = 0; i < MUX_LEN; i++) m->v[V_y + i] = m->v[V_u1 + i];
}

void kernel_init(Model *m) { kernel_eval(m); }
void kernel_step(Model *m, double t, double h) { (void)m; (void)t; (void)h; }
