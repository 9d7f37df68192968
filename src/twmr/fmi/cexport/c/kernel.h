/* What a block kernel and the FMI wrappers share (twmr-cosim C export).
 *
 * config.h is generated at export: NV variable elements (FMI 2.0 value reference = index),
 * V_<port> the index of each port's first element, NW work values, the block's options. */
#ifndef TWMR_KERNEL_H
#define TWMR_KERNEL_H

#include "config.h"

typedef struct {
    double v[NV];        /* every variable element: parameters, inputs, outputs, states */
    double w[NW];        /* the kernel's own state and derived constants */
    double time;         /* [s] the present communication point */
    char warning[256];   /* a kernel's message, logged by the wrapper, then cleared */
    char error[256];     /* set by kernel_step when it refuses the step (state unchanged) */
} Model;

/* Derived constants and the outputs at the start time m->time (Component.initialize). */
void kernel_init(Model *m);
/* Direct-feedthrough outputs from the inputs at m->time (Component.evaluate). */
void kernel_eval(Model *m);
/* Advance from t to t + h [s] with the inputs held (Component.do_step); a step it cannot take
 * leaves the state as it was and says why in m->error. */
void kernel_step(Model *m, double t, double h);

#endif
