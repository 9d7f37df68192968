/* (y1, y2, ...) = u: MUX_LEN elements, one output port after the other (twmr.blocks.Demux). */
#include "kernel.h"

void kernel_eval(Model *m) {
    int i;
    for (i = 0; i < MUX_LEN; i++) m->v[V_y1 + i] = m->v[V_u + i];
}

void kernel_init(Model *m) { kernel_eval(m); }
void kernel_step(Model *m, double t, double h) { (void)m; (void)t; (void)h; }
