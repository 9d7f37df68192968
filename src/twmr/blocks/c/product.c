/* y = ((1 op1 u1) op2 u2) ... element by element, op '*' (PROD_OPS 1) or '/' (-1): PROD_N
 * inputs of PROD_W elements each, one after the other (twmr.blocks.Product). */
#include "kernel.h"

static const double OP[PROD_N] = PROD_OPS;

void kernel_eval(Model *m) {
    double *v = m->v;
    int i, j;
    for (i = 0; i < PROD_W; i++) {
        double s = 1.0;
        for (j = 0; j < PROD_N; j++) {
            double u = v[V_u1 + j * PROD_W + i];
            s = OP[j] > 0.0 ? s * u : s / u;
        }
        v[V_y + i] = s;
    }
}

void kernel_init(Model *m) { kernel_eval(m); }
void kernel_step(Model *m, double t, double h) { (void)m; (void)t; (void)h; }
