/* y_i = u[SEL_INDEX_i] (0-based here), SEL_M output elements (twmr.blocks.Selector). */
#include "kernel.h"

static const int INDEX[SEL_M] = SEL_INDEX;

void kernel_eval(Model *m) {
    int i;
    for (i = 0; i < SEL_M; i++) m->v[V_y + i] = m->v[V_u + INDEX[i]];
}

void kernel_init(Model *m) { kernel_eval(m); }
void kernel_step(Model *m, double t, double h) { (void)m; (void)t; (void)h; }
